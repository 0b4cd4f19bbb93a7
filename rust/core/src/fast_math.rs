//! Fast exp and cos for the particle loops (the weights of every radio
//! update, the anchors' mixture, the Box-Muller draws of every step):
//! range reduction and a polynomial, no table, no platform libm, within a
//! few ulp of `f64::exp` / `f64::cos` (relative 1e-15, checked by the
//! tests), so results change by float noise only. [`exp_many`] has no
//! branch in its main loop, so it vectorises; inputs outside
//! [`EXP_MIN`, `EXP_MAX`] (tiny results, overflow, NaN) take `f64::exp`.

const LOG2E: f64 = std::f64::consts::LOG2_E;
/// ln 2 split: `LN2_HI` has its low 32 bits zero, so n * LN2_HI is exact.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
/// 1.5 * 2^52: adding it rounds to an integer held in the low bits.
const ROUND: f64 = 6_755_399_441_055_744.0;

/// Below this `exp` goes to `f64::exp` (2^-1021 and less).
pub const EXP_MIN: f64 = -708.0;
/// Above this `exp` goes to `f64::exp` (overflow near 709.78).
pub const EXP_MAX: f64 = 709.0;

/// e^x for x in [`EXP_MIN`, `EXP_MAX`] (anything else: a wrong finite
/// value): x = n ln 2 + r, |r| <= ln 2 / 2, e^r by its Taylor series to
/// r^13 (truncation < 2e-16), times 2^n from the bits.
#[inline]
fn exp_in_range(x: f64) -> f64 {
    let t = x * LOG2E + ROUND;
    let n = t - ROUND;
    let k = t.to_bits().wrapping_sub(ROUND.to_bits());
    let r = (x - n * LN2_HI) - n * LN2_LO;
    // 1 / k!, k = 0..=13
    const C: [f64; 14] = [
        1.0,
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    let p = C.iter().rev().fold(0.0, |acc, c| acc * r + c);
    p * f64::from_bits(k.wrapping_add(1023) << 52)
}

/// e^x: the polynomial in range, `f64::exp` outside (and for NaN).
#[inline]
pub fn fast_exp(x: f64) -> f64 {
    if (EXP_MIN..=EXP_MAX).contains(&x) {
        exp_in_range(x)
    } else {
        x.exp()
    }
}

/// `out[i]` = e^`xs[i]` (same length), [`fast_exp`]'s values: one
/// branch-free pass, then `f64::exp` for the rare inputs out of range.
pub fn exp_many(xs: &[f64], out: &mut [f64]) {
    if exp_clamped_many(xs, out) {
        return;
    }
    for (o, &x) in out.iter_mut().zip(xs) {
        if !(EXP_MIN..=EXP_MAX).contains(&x) {
            *o = x.exp();
        }
    }
}

crate::simd::avx2_dispatch! {
    /// `out[i]` = [`exp_in_range`] of `xs[i]` clamped to the range;
    /// whether every `xs[i]` was in it (NaN is not): the flag in the same
    /// vectorised loop, so the scalar pass for `f64::exp` runs only when
    /// some input needs it.
    fn exp_clamped_many(xs: &[f64], out: &mut [f64]) -> bool {
        let mut all_in = true;
        for (o, &x) in out.iter_mut().zip(xs) {
            all_in &= (EXP_MIN..=EXP_MAX).contains(&x);
            *o = exp_in_range(x.clamp(EXP_MIN, EXP_MAX));
        }
        all_in
    }
}

/// The largest of `f(x)` over `xs` as `fold(NEG_INFINITY, f64::max)`
/// gives it (NaN ignored; `NEG_INFINITY` when `xs` is empty or all NaN),
/// in eight interleaved maxima: the maximum is exact whatever the order,
/// so only the sign of a zero maximum can differ (both zeros there), and
/// the eight chains overlap where one chain waits on each compare (a
/// fold over a cloud is as slow as its 1000 dependent steps).
#[inline]
pub fn max_many(xs: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    let mut acc = [f64::NEG_INFINITY; 8];
    let mut chunks = xs.chunks_exact(8);
    for c in &mut chunks {
        for (a, x) in acc.iter_mut().zip(c) {
            *a = a.max(f(*x));
        }
    }
    for x in chunks.remainder() {
        acc[0] = acc[0].max(f(*x));
    }
    acc.into_iter().fold(f64::NEG_INFINITY, f64::max)
}

/// cos x for |x| <= pi/2 by its Taylor series to x^22 (truncation
/// < 2e-17 there); Horner in x^2.
#[inline]
fn half_pi_cos(x: f64) -> f64 {
    // 1 / (2k)!, k = 0..=11
    const C: [f64; 12] = [
        1.0,
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
        -1.0 / 6_402_373_705_728_000.0,
        1.0 / 2_432_902_008_176_640_000.0,
        -1.0 / 1_124_000_727_777_607_680_000.0,
    ];
    let x2 = x * x;
    C.iter().rev().fold(0.0, |acc, c| acc * x2 + c)
}

/// cos(2 pi `u`) for `u` in [0, 1] (Box-Muller's angle; other `u`: a
/// wrong finite value): with w = |u - round(u)| in [0, 1/2] (exact) and
/// y = min(w, 1/2 - w) in [0, 1/4], it is +-cos(2 pi y); no branch.
#[inline]
pub fn cos_turns(u: f64) -> f64 {
    let w = (u - ((u + ROUND) - ROUND)).abs();
    let far = w > 0.25;
    let y = if far { 0.5 - w } else { w };
    let c = half_pi_cos(std::f64::consts::TAU * y);
    if far { -c } else { c }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_many_is_the_fold() {
        let fold = |xs: &[f64], f: &dyn Fn(f64) -> f64| {
            xs.iter().map(|x| f(*x)).fold(f64::NEG_INFINITY, f64::max)
        };
        let finite = |x: f64| if x.is_finite() { x } else { f64::NEG_INFINITY };
        let mut xs: Vec<f64> = (0..1003)
            .map(|i| (f64::from(i) * 0.77).sin() * 50.0)
            .collect();
        for n in [0, 1, 7, 8, 9, 17, 1003] {
            for f in [&(|x| x) as &dyn Fn(f64) -> f64, &|x| 0.3 * x, &finite] {
                assert_eq!(max_many(&xs[..n], f).to_bits(), fold(&xs[..n], f).to_bits());
            }
        }
        // NaN ignored, infinities kept or dropped by `f`
        xs[5] = f64::NAN;
        xs[600] = f64::INFINITY;
        assert_eq!(max_many(&xs, |x| x), f64::INFINITY);
        assert_eq!(max_many(&xs, finite), fold(&xs, &finite));
        assert_eq!(max_many(&[f64::NAN; 11], |x| x), f64::NEG_INFINITY);
    }

    #[test]
    fn fast_exp_matches_exp() {
        let mut worst: f64 = 0.0;
        let mut x = -760.0;
        while x < 720.0 {
            for d in [0.0, 1e-9, 0.123_456_789, 0.346_6, 0.5, 0.69] {
                let v = x + d;
                let (a, b) = (fast_exp(v), v.exp());
                if b.is_finite() && b > 0.0 {
                    worst = worst.max((a - b).abs() / b);
                } else {
                    assert_eq!(a.to_bits(), b.to_bits(), "{v}");
                }
            }
            x += 0.731;
        }
        // the weights' range: exp(l - max) for l - max in [-50, 0]
        for i in 0..500_000 {
            let v = -50.0 * f64::from(i) / 500_000.0;
            worst = worst.max((fast_exp(v) - v.exp()).abs() / v.exp());
        }
        assert!(worst < 1e-15, "{worst}");
        assert_eq!(fast_exp(0.0), 1.0);
        assert!(fast_exp(f64::NAN).is_nan() && fast_exp(f64::NEG_INFINITY) == 0.0);
        assert_eq!(fast_exp(f64::INFINITY), f64::INFINITY);
        let xs = [-800.0, -708.5, -3.0, 0.0, 1.5, 709.5, 800.0, f64::NAN];
        let mut out = [0.0; 8];
        exp_many(&xs, &mut out);
        for (x, o) in xs.iter().zip(&out) {
            assert!(fast_exp(*x).to_bits() == o.to_bits(), "{x}");
        }
        // all in range (the scalar pass skipped), and one out at the end
        let mut ys: Vec<f64> = (0..37).map(|i| f64::from(i) * 7.3 - 130.0).collect();
        for last in [0.0, -1e4, f64::NEG_INFINITY] {
            ys[36] = last;
            let mut out = vec![0.0; ys.len()];
            exp_many(&ys, &mut out);
            for (y, o) in ys.iter().zip(&out) {
                assert!(fast_exp(*y).to_bits() == o.to_bits(), "{y}");
            }
        }
    }

    #[test]
    fn cos_turns_matches_cos() {
        let mut worst: f64 = 0.0;
        for i in 0..=1_000_000 {
            let u = f64::from(i) / 1_000_000.0;
            let e = (std::f64::consts::TAU * u).cos();
            worst = worst.max((cos_turns(u) - e).abs());
        }
        for u in [0.0, 0.125, 0.25, 0.375, 0.5, 0.75, 1.0 - 1e-16, 1.0] {
            let e = (std::f64::consts::TAU * u).cos();
            worst = worst.max((cos_turns(u) - e).abs());
        }
        assert!(worst < 1e-15, "{worst}");
    }
}
