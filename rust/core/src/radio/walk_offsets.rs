//! Each survey walk's own RSSI offset, learned where walks overlap.
//!
//! Survey walks read the same transmitter at the same place several dB
//! apart even with one phone model (ILC site1/F1 even half, WiFi, each
//! walk against the others' means in shared 3 m cells: sd 2.5 dB, -9 to
//! +7 dB): the phone unit, how it is held, the crowd. A radio map that
//! averages them puts each walk's offset into the places it alone
//! walked. [`estimate`] finds each walk's offset from the bins it shares
//! with other walks (the median of its mean minus the other walks'
//! offset-corrected means, a few rounds; [`BinLevel`]), centred on the
//! readings' weighted mean so the map's level stays that of the survey as a
//! whole; `radio_map.walk_offsets` removes them before smoothing.

use std::collections::BTreeMap;

/// The walks that read one transmitter in one bin: (walk, readings, mean dBm).
#[derive(Debug, Clone, PartialEq)]
pub struct SharedBin {
    pub walks: Vec<(usize, f64, f64)>,
}

/// Rounds of [`estimate`] the radio map builder runs with
/// [`BinLevel::AllWalks`]: enough for a chain of walks each overlapping
/// only the next to settle.
pub const ROUNDS: usize = 30;
/// ... and with [`BinLevel::OtherWalks`] (the default's 5, odd: two walks
/// that share bins end twice their difference apart).
pub const OTHER_WALKS_ROUNDS: usize = 5;

/// What a walk's reading in a bin is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinLevel {
    /// The mean of the other walks' offset-corrected readings there (the
    /// default: `radio_map.walk_offsets_converged` false).
    OtherWalks,
    /// The mean of every walk's, its own included: converges to offsets
    /// whose differences are the walks' (`walk_offsets_converged`).
    AllWalks,
}

/// Offsets per walk (dB, to subtract from its readings) from the bins of
/// one radio kind; a walk with fewer than `min_pairs` shared bins gets
/// none (0). `rounds` >= 1 alternations of the bins' corrected levels
/// (`against`) and the medians.
pub fn estimate(
    bins: &[SharedBin],
    min_pairs: usize,
    rounds: usize,
    against: BinLevel,
) -> BTreeMap<usize, f64> {
    let mut off: BTreeMap<usize, f64> = BTreeMap::new();
    let mut weight: BTreeMap<usize, f64> = BTreeMap::new();
    for b in bins {
        for (w, n, _) in &b.walks {
            *weight.entry(*w).or_default() += n;
        }
    }
    for _ in 0..rounds.max(1) {
        let mut res: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
        for b in bins.iter().filter(|b| b.walks.len() >= 2) {
            let corrected: Vec<f64> = b
                .walks
                .iter()
                .map(|(w, _, m)| m - off.get(w).copied().unwrap_or(0.0))
                .collect();
            let total: f64 = corrected.iter().sum();
            let k = corrected.len() as f64;
            for ((w, _, m), c) in b.walks.iter().zip(&corrected) {
                let level = match against {
                    // the walk's own reading counts in the bin's level:
                    // each walk moves halfway (two walks) or less toward
                    // the others, and the rounds converge
                    BinLevel::AllWalks => total / k,
                    // the others alone: two walks that share a bin each
                    // take the whole difference, and the rounds swing
                    // between twice the difference (odd) and none (even)
                    BinLevel::OtherWalks => (total - c) / (k - 1.0),
                };
                res.entry(*w).or_default().push(m - level);
            }
        }
        let mut next = BTreeMap::new();
        for (w, v) in res {
            if v.len() >= min_pairs.max(1) {
                next.insert(w, crate::ble::calibrate::median(v));
            }
        }
        // centred on the readings of the walks that have one
        let (s, n) = next.iter().fold((0.0, 0.0), |(s, n), (w, o)| {
            let k = weight.get(w).copied().unwrap_or(0.0);
            (s + k * o, n + k)
        });
        let c = if n > 0.0 { s / n } else { 0.0 };
        for o in next.values_mut() {
            *o -= c;
        }
        off = next;
    }
    off
}

/// The reading-weighted standard deviation of the offsets, dB (`None`
/// without any).
pub fn spread_db(off: &BTreeMap<usize, f64>) -> Option<f64> {
    if off.is_empty() {
        return None;
    }
    let n = off.len() as f64;
    let m = off.values().sum::<f64>() / n;
    Some((off.values().map(|o| (o - m).powi(2)).sum::<f64>() / n).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three walks over 30 bins of a field, walk 1 reading 6 dB strong and
    /// walk 2 4 dB weak; each bin walked by two of them.
    fn survey() -> Vec<SharedBin> {
        let truth = [0.0, 6.0, -4.0];
        (0..30)
            .map(|k| {
                let field = -60.0 - k as f64;
                let (a, b) = [(0, 1), (1, 2), (0, 2)][k % 3];
                let noise = if k % 2 == 0 { 0.5 } else { -0.5 };
                SharedBin {
                    walks: vec![
                        (a, 4.0, field + truth[a] + noise),
                        (b, 4.0, field + truth[b] - noise),
                    ],
                }
            })
            .collect()
    }

    #[test]
    fn offsets_of_overlapping_walks_are_found_up_to_their_common_level() {
        let off = estimate(&survey(), 5, 6, BinLevel::OtherWalks);
        // truth 0 / +6 / -4, centred: mean 2/3
        let want = [-2.0 / 3.0, 6.0 - 2.0 / 3.0, -4.0 - 2.0 / 3.0];
        for (w, o) in &off {
            assert!((o - want[*w]).abs() < 0.8, "walk {w}: {o} vs {}", want[*w]);
        }
        assert_eq!(off.len(), 3);
        let sd = spread_db(&off).unwrap();
        assert!((sd - 4.1).abs() < 0.6, "{sd}");
    }

    /// Two phones 8 dB apart, every bin walked once by each: against all
    /// walks the offsets stand 8 dB apart whatever the number of rounds;
    /// against the other walks they swing between 16 dB (odd rounds) and
    /// 0 (even). A chain of walks, each sharing bins with the next only,
    /// converges against all walks too.
    #[test]
    fn two_walks_sharing_every_bin_end_their_difference_apart() {
        let pair: Vec<SharedBin> = (0..20)
            .map(|k| SharedBin {
                walks: vec![
                    (0, 3.0, -60.0 - k as f64 + 4.0),
                    (1, 3.0, -60.0 - k as f64 - 4.0),
                ],
            })
            .collect();
        for rounds in 1..=6 {
            let off = estimate(&pair, 5, rounds, BinLevel::AllWalks);
            assert!((off[&0] - off[&1] - 8.0).abs() < 1e-9, "{rounds}: {off:?}");
            assert!((off[&0] + off[&1]).abs() < 1e-9);
            let swung = estimate(&pair, 5, rounds, BinLevel::OtherWalks);
            let want = if rounds % 2 == 1 { 16.0 } else { 0.0 };
            assert!(
                (swung[&0] - swung[&1] - want).abs() < 1e-9,
                "{rounds}: {swung:?}"
            );
        }
        let truth = [0.0, 5.0, -3.0, 6.0, 1.0, -4.0];
        let chain: Vec<SharedBin> = (0..50)
            .map(|k| {
                let a = k % 5;
                let field = -60.0 - k as f64;
                SharedBin {
                    walks: vec![
                        (a, 2.0, field + truth[a]),
                        (a + 1, 2.0, field + truth[a + 1]),
                    ],
                }
            })
            .collect();
        let off = estimate(&chain, 5, ROUNDS, BinLevel::AllWalks);
        for w in 1..6 {
            let (got, want) = (off[&w] - off[&0], truth[w] - truth[0]);
            assert!((got - want).abs() < 0.3, "walk {w}: {got:.2} vs {want}");
        }
    }

    #[test]
    fn a_walk_with_too_few_shared_bins_gets_no_offset() {
        let mut bins = survey();
        bins.push(SharedBin {
            walks: vec![(0, 3.0, -70.0), (7, 3.0, -50.0)],
        });
        let off = estimate(&bins, 5, 4, BinLevel::OtherWalks);
        assert!(!off.contains_key(&7));
        // a bin walked once says nothing
        let lone = vec![SharedBin {
            walks: vec![(0, 5.0, -70.0)],
        }];
        assert!(estimate(&lone, 1, 3, BinLevel::OtherWalks).is_empty());
    }
}
