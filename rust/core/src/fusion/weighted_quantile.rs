//! The weighted quantile of a cloud's distances (the accuracy radius of a
//! published point) without sorting the whole cloud: quickselect on the
//! side that holds the quantile, O(m) expected instead of O(m log m).

/// Segments at most this long are sorted and scanned.
const SORT_BELOW: usize = 32;

/// The smallest value `v` of `items` ((value, weight) pairs, reordered)
/// at which the weights of the items up to it in increasing value (ties:
/// any order) reach `quantile` of their total: what sorting by value and
/// accumulating gives, up to the rounding of the sums. When the weights
/// never reach it (NaN weights), the largest value of the last segment
/// searched; `None` when `items` is empty.
pub fn weighted_quantile(items: &mut [(f64, f64)], quantile: f64) -> Option<f64> {
    if items.is_empty() {
        return None;
    }
    let target = quantile * items.iter().map(|x| x.1).sum::<f64>();
    // values without a sign bit (distances; NaN included) are in
    // `total_cmp`'s order as their bits are as integers: the cheaper
    // compare gives every comparison the same answer, so the selection
    // reorders the items the same way and the sums are the same
    let unsigned = items
        .iter()
        .fold(true, |ok, x| ok & (x.0.to_bits() >> 63 == 0));
    if unsigned {
        select(items, target, |a, b| a.0.to_bits().cmp(&b.0.to_bits()))
    } else {
        select(items, target, |a, b| a.0.total_cmp(&b.0))
    }
}

/// [`weighted_quantile`]'s search for the weight `target` with the value
/// order `cmp`.
#[inline(always)]
fn select(
    items: &mut [(f64, f64)],
    target: f64,
    cmp: impl Fn(&(f64, f64), &(f64, f64)) -> std::cmp::Ordering + Copy,
) -> Option<f64> {
    // the weight of the items below `lo` (all smaller than those from it)
    let (mut lo, mut hi, mut below) = (0usize, items.len(), 0.0);
    while hi - lo > SORT_BELOW {
        let mid = lo + (hi - lo) / 2;
        items[lo..hi].select_nth_unstable_by(mid - lo, cmp);
        let left: f64 = items[lo..mid].iter().map(|x| x.1).sum();
        if below + left >= target {
            hi = mid;
        } else if below + left + items[mid].1 >= target {
            return Some(items[mid].0);
        } else {
            below += left + items[mid].1;
            lo = mid + 1;
        }
    }
    let seg = &mut items[lo..hi];
    seg.sort_by(cmp);
    let mut acc = below;
    for (v, w) in seg.iter() {
        acc += w;
        if acc >= target {
            return Some(*v);
        }
    }
    seg.last().map(|x| x.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition: sort, accumulate, first value reaching the share.
    fn by_sorting(items: &[(f64, f64)], quantile: f64) -> f64 {
        let mut d = items.to_vec();
        d.sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: f64 = d.iter().map(|x| x.1).sum();
        let mut acc = 0.0;
        for (v, w) in &d {
            acc += w;
            if acc >= quantile * total {
                return *v;
            }
        }
        d.last().unwrap().0
    }

    #[test]
    fn the_quantile_is_the_sorted_one() {
        let mut s: u64 = 7;
        let mut next = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [1usize, 2, 5, 31, 33, 100, 1000, 4000] {
            for q in [0.0, 0.1, 0.5, 0.68, 0.95, 1.0] {
                // weights with exact binary sums (k / 64), values with ties
                let items: Vec<(f64, f64)> = (0..n)
                    .map(|_| {
                        (
                            (next() * 50.0).floor() * 0.5,
                            (next() * 64.0).floor() / 64.0,
                        )
                    })
                    .collect();
                let mut work = items.clone();
                let got = weighted_quantile(&mut work, q).unwrap();
                assert_eq!(got, by_sorting(&items, q), "n {n}, q {q}");
            }
        }
        assert_eq!(weighted_quantile(&mut [], 0.5), None);
        // values without a sign bit compare by their bits: the same
        // reordering and result as `total_cmp` (weights with inexact sums)
        for n in [3usize, 40, 1000, 4000] {
            let mut items: Vec<(f64, f64)> = (0..n).map(|_| (next() * 30.0, next())).collect();
            items[1] = (0.0, 0.3);
            items[2] = (f64::INFINITY, 0.2);
            if n > 3 {
                items[3] = (f64::NAN, 0.1);
            }
            for q in [0.1, 0.68, 0.99] {
                let (mut a, mut b) = (items.clone(), items.clone());
                let target = q * items.iter().map(|x| x.1).sum::<f64>();
                let want = select(&mut a, target, |x, y| x.0.total_cmp(&y.0));
                let got = weighted_quantile(&mut b, q);
                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "n {n}");
                assert!(
                    a.iter()
                        .zip(&b)
                        .all(|(x, y)| x.0.to_bits() == y.0.to_bits())
                );
            }
        }
        let mut nan = vec![(1.0, f64::NAN), (3.0, 1.0), (2.0, 1.0)];
        assert_eq!(weighted_quantile(&mut nan, 0.5), Some(3.0));
    }
}
