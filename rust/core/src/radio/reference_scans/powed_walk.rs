//! The Bray-Curtis query's postings walk ([`super::ScanMetric::BrayCurtisPowed`]):
//! per scan only the summed min powed level of the transmitters it shares
//! with the query, one f64 a scan (8 bytes read and written per posting,
//! where the walk of both metrics keeps 24). The RMS distance every
//! candidate carries is computed afterwards for the `k` winners alone, by
//! looking the query's transmitters up in each winner's own list in the
//! query's order: the same terms added in the same order as the full
//! walk adds them, so the same bits (unit test).
//!
//! A scan no posting reached keeps -0.0, which no visit leaves (every
//! term is >= 0 and -0.0 + x is x, bit for bit, for x >= 0): the sign
//! says "shares no heard transmitter" without a count.

use super::ReferenceScans;

impl ReferenceScans {
    /// Per scan, the sum over the transmitters it shares with `q` of
    /// min(query level, scan level), in `q`'s order; -0.0 for a scan
    /// that shares none. `q_levels`: the query's powed levels, one per
    /// entry of `q`.
    pub(super) fn powed_sums(&self, q: &[(u32, f64)], q_levels: &[f64]) -> Vec<f64> {
        let mut sums = vec![-0.0; self.scans.len()];
        let lo = i32::from(self.levels_lo);
        for (&(j, _), &pa) in q.iter().zip(q_levels) {
            let (a, b) = (
                self.post_start[j as usize] as usize,
                self.post_start[j as usize + 1] as usize,
            );
            for (&si, &r10) in self.post_scan[a..b].iter().zip(&self.post_r10[a..b]) {
                let l = self.level_powed[(i32::from(r10) - lo) as usize];
                sums[si as usize] += pa.min(l);
            }
        }
        sums
    }

    /// The shared transmitters' correction of the RMS sum and their count
    /// for scan `si`, as [`ReferenceScans::shared_sums`] adds them (the
    /// query's entries in order, each found in the scan's list: by a merge
    /// when `q` is by index, as the engines' windows are, else by a
    /// binary search).
    pub(super) fn shared_of(&self, q: &[(u32, f64)], si: usize) -> (f64, u32) {
        let m = self.cfg.missing_dbm;
        let tx = &self.scans[si].tx;
        let by_index = q.windows(2).all(|w| w[0].0 < w[1].0);
        let (mut corr, mut n, mut p) = (0.0, 0u32, 0usize);
        for &(j, a) in q {
            let hit = if by_index {
                while p < tx.len() && tx[p].0 < j {
                    p += 1;
                }
                (p < tx.len() && tx[p].0 == j).then_some(p)
            } else {
                tx.binary_search_by_key(&j, |e| e.0).ok()
            };
            if let Some(p) = hit {
                let l = &self.levels[(i32::from(tx[p].1) - i32::from(self.levels_lo)) as usize];
                corr += (a - l.r) * (a - l.r) - (a - m) * (a - m) - l.r_m2;
                n += 1;
            }
        }
        (corr, n)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{
        ReferenceScan, ReferenceScanConfig, ReferenceScans, ScanMetric, powed_level,
    };
    use crate::radio::model::TxKind;

    /// The walk both metrics shared before: per scan the RMS correction,
    /// the min-level sum from +0.0 and the count, every posting visited.
    fn full_walk(s: &ReferenceScans, q: &[(u32, f64)]) -> Vec<(f64, f64, u32)> {
        let m = s.cfg.missing_dbm;
        let mut out = vec![(0.0, 0.0, 0u32); s.scans.len()];
        for &(j, a) in q {
            let pa = powed_level(a, m);
            for p in s.post_start[j as usize] as usize..s.post_start[j as usize + 1] as usize {
                let l = &s.levels[(i32::from(s.post_r10[p]) - i32::from(s.levels_lo)) as usize];
                let e = &mut out[s.post_scan[p] as usize];
                e.0 += (a - l.r) * (a - l.r) - (a - m) * (a - m) - l.r_m2;
                e.1 += pa.min(l.powed);
                e.2 += 1;
            }
        }
        out
    }

    #[test]
    fn the_powed_walk_gives_the_full_walks_bits() {
        let mut seed = 777u64;
        let mut next = move |n: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % n
        };
        let kind = |i: u32| {
            if i % 3 == 0 {
                TxKind::Ble
            } else {
                TxKind::Wifi
            }
        };
        let ids: Vec<(TxKind, String)> = (0..40).map(|i| (kind(i), format!("id{i}"))).collect();
        let mut scans: Vec<ReferenceScan> = Vec::new();
        for i in 0..300 {
            // some readings at the floor (-100 dBm: level 0)
            let mut tx: Vec<(u32, i16)> = Vec::new();
            for j in 0..40u32 {
                if next(3) == 0 {
                    tx.push((j, -(300 + next(701) as i16)));
                }
            }
            scans.push(ReferenceScan {
                floor: 0,
                x_m: i as f64,
                y_m: 0.0,
                tx,
            });
        }
        let set = ReferenceScans::new(ReferenceScanConfig::default(), ids, scans).unwrap();
        let m = set.cfg.missing_dbm;
        let mut visited_none = 0;
        for _ in 0..60 {
            // readings down to -110 dBm (floored: level 0)
            let mut q: Vec<(u32, f64)> = Vec::new();
            for j in 0..40u32 {
                if next(4) == 0 {
                    q.push((j, -30.0 - next(80) as f64 - 0.1 * next(10) as f64));
                }
            }
            for (ble, wifi) in [(true, true), (true, false), (false, true)] {
                let used: Vec<(u32, f64)> = q
                    .iter()
                    .filter(|(j, _)| if kind(*j) == TxKind::Ble { ble } else { wifi })
                    .map(|&(j, r)| (j, r.max(m)))
                    .collect();
                let got = set.query_with(&q, ble, wifi, 9, ScanMetric::BrayCurtisPowed);
                let walk = full_walk(&set, &used);
                let q_only: f64 = used.iter().map(|(_, r)| (r - m) * (r - m)).sum();
                let q_powed: f64 = used.iter().map(|&(_, a)| powed_level(a, m)).sum();
                let mut want: Vec<(f64, f64, usize)> = Vec::new();
                for (si, &(corr, min_powed, n)) in walk.iter().enumerate() {
                    if n == 0 {
                        visited_none += 1;
                        continue;
                    }
                    let score = set.powed_score(si, q_powed, min_powed, ble, wifi);
                    let d = set.rms_db(used.len(), q_only, (corr, n), si, ble, wifi);
                    want.push((score, d, si));
                }
                want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
                want.truncate(9);
                assert_eq!(got.len(), want.len());
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!(g.score.to_bits(), w.0.to_bits());
                    assert_eq!(g.dist_db.to_bits(), w.1.to_bits());
                    assert_eq!(g.pos.x, w.2 as f64);
                }
            }
        }
        assert!(visited_none > 0, "some scans share nothing with a query");
        // a query not by index: the same sums through the binary search
        let q = [(7, -61.0), (2, -48.5), (30, -77.0), (11, -90.0)];
        for si in 0..set.scans.len() {
            let (corr, n) = set.shared_of(&q, si);
            let mut sorted = q;
            sorted.sort_by_key(|e| e.0);
            let want = full_walk(&set, &q)[si];
            assert_eq!((corr.to_bits(), n), (want.0.to_bits(), want.2));
            assert_eq!(set.shared_of(&sorted, si).1, n);
        }
    }
}
