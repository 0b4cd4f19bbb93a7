//! Order statistics shared by the crates: one quantile and one median, so
//! every figure the project prints means the same thing.

/// Quantile `q` (in [0, 1], clamped) of values sorted ascending, linear
/// between order statistics (numpy's default); `None` when empty.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let r = q.clamp(0.0, 1.0) * (n - 1) as f64;
    let (lo, hi) = (r.floor() as usize, r.ceil() as usize);
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * (r - lo as f64))
}

/// [`quantile_sorted`] of `values` in any order (sorted in a copy, by
/// `f64::total_cmp`).
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    quantile_sorted(&sorted(values), q)
}

/// The median of `values` in any order: the middle one, or the mean of the
/// middle two for an even count; `None` when empty.
pub fn median(values: &[f64]) -> Option<f64> {
    let v = sorted(values);
    let m = v.len() / 2;
    match v.len() {
        0 => None,
        n if n % 2 == 1 => Some(v[m]),
        _ => Some(0.5 * (v[m - 1] + v[m])),
    }
}

fn sorted(values: &[f64]) -> Vec<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Guards the definitions the printed figures rest on: interpolation
    /// between order statistics like numpy, the mean of the middle two for
    /// an even median, clamping, and no value for no data.
    #[test]
    fn quantiles_interpolate_like_numpy_and_the_median_is_the_middle() {
        let v = [4.0, 1.0, 3.0, 2.0];
        assert_eq!(quantile(&v, 0.0), Some(1.0));
        assert_eq!(quantile(&v, 1.0), Some(4.0));
        // numpy.percentile([1, 2, 3, 4], 25) = 1.75, 90 -> 3.7
        assert_eq!(quantile(&v, 0.25), Some(1.75));
        assert!((quantile(&v, 0.9).unwrap() - 3.7).abs() < 1e-12);
        assert_eq!(quantile(&v, 2.0), Some(4.0));
        assert_eq!(median(&v), Some(2.5));
        assert_eq!(median(&[5.0, 1.0, 3.0]), Some(3.0));
        assert_eq!(quantile_sorted(&[1.0, 2.0, 3.0], 0.5), Some(2.0));
        assert_eq!((quantile(&[], 0.5), median(&[])), (None, None));
    }
}
