//! A fast natural logarithm for the per-particle likelihood
//! ([`super::likelihood::CloudLikelihood`], [`super::RadioModel::expected_many`]):
//! the exponent from the bits, the mantissa in [sqrt(1/2), sqrt(2)) through
//! the series ln m = 2 atanh(s), s = (m - 1) / (m + 1), to s^11 (|s| <=
//! 0.172, truncation < 2e-11). Within 1e-10 (absolute, or relative above
//! e) of `f64::ln`, checked by the tests; deterministic (no table, no
//! platform libm).

const SQRT2: f64 = std::f64::consts::SQRT_2;
const LN2: f64 = std::f64::consts::LN_2;

/// ln `x`: the series for finite normal positive `x`, `f64::ln` otherwise
/// (0, subnormals, negatives, infinities, NaN).
#[inline]
pub fn fast_ln(x: f64) -> f64 {
    if !(f64::MIN_POSITIVE..=f64::MAX).contains(&x) {
        return x.ln();
    }
    ln_normal(x)
}

/// ln `x` for finite normal positive `x` (anything else gives a wrong
/// finite value): no branch, so that loops over it vectorise.
#[inline]
pub fn ln_normal(x: f64) -> f64 {
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = m > SQRT2;
    let m = if big { 0.5 * m } else { m };
    let e = f64::from(e) + if big { 1.0 } else { 0.0 };
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let p = 1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0 + s2 * (1.0 / 11.0))));
    e * LN2 + (2.0 * s + 2.0 * s * s2 * p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_ln_matches_ln() {
        let mut worst: f64 = 0.0;
        let mut x = 1e-300;
        while x < 1e300 {
            for f in [1.0, 1.000_000_1, 1.1, 1.414, 1.4143, 1.5, 1.9, 1.999_999] {
                let v = x * f;
                let err = (fast_ln(v) - v.ln()).abs() / v.ln().abs().max(1.0);
                worst = worst.max(err);
            }
            x *= 1.37;
        }
        // the range of the likelihood: 1 + z^2 / nu, squared ranges
        for i in 0..200_000 {
            let v = 1.0 + f64::from(i) * 1e-4;
            worst = worst.max((fast_ln(v) - v.ln()).abs());
            let v = 0.25 + f64::from(i) * 0.05;
            worst = worst.max((fast_ln(v) - v.ln()).abs() / v.ln().abs().max(1.0));
        }
        assert!(worst < 1e-10, "{worst}");
        assert_eq!(fast_ln(1.0), 0.0);
        assert!(fast_ln(0.0) == f64::NEG_INFINITY && fast_ln(f64::INFINITY) == f64::INFINITY);
        assert!(fast_ln(-1.0).is_nan() && fast_ln(f64::NAN).is_nan());
        assert!((fast_ln(1e-310) - 1e-310f64.ln()).abs() < 1e-12);
        for v in [f64::MIN_POSITIVE, 1e-200, 0.3, 1.0, 2.0, 1e200, f64::MAX] {
            assert_eq!(ln_normal(v), fast_ln(v));
        }
    }
}
