//! Random-number maths of the particle filters: standard normals by
//! Box-Muller (one at a time or batched, the same values), uniform points
//! in a disc, Gaussian points around a centre, uniform indices and
//! symmetric uniform noise. Every function draws from the caller's seeded
//! PCG-64 in a fixed order (the filters' tracks depend on it).

use rand::RngExt;
use rand_pcg::Pcg64;

use super::uniforms::fill_interleaved;
use crate::Vec2;
use crate::radio::fast_ln::ln_normal;

/// One standard normal draw (Box-Muller, one of the pair): the logarithm
/// by [`ln_normal`] (relative 1e-10, u1 is a normal number), the cosine
/// by [`crate::fast_math::cos_turns`] (within 1e-15 of `f64::cos`).
pub fn std_normal(rng: &mut Pcg64) -> f64 {
    let u1: f64 = rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    box_muller(u1, u2)
}

/// [`std_normal`] of the two uniforms `u1`, `u2` (drawn in that order):
/// no branch, so that loops over it vectorise.
#[inline]
pub fn box_muller(u1: f64, u2: f64) -> f64 {
    (-2.0 * ln_normal(u1.max(f64::MIN_POSITIVE))).sqrt() * crate::fast_math::cos_turns(u2)
}

crate::simd::avx2_dispatch! {
    /// `u1[i]` := [`box_muller`]`(u1[i], u2[i])` for every i.
    pub fn box_muller_in_place(u1: &mut [f64], u2: &[f64]) {
        for (a, b) in u1.iter_mut().zip(u2) {
            *a = box_muller(*a, *b);
        }
    }
}

/// Reused buffers of batched normal draws ([`Normals::fill`]).
#[derive(Debug, Clone, Default)]
pub struct Normals {
    /// The second uniform of every pair.
    u2: Vec<f64>,
    /// The uniforms as they come from the RNG ([`fill_interleaved`]).
    raw: Vec<f64>,
}

impl Normals {
    /// `out.len()` standard normal draws into `out`, the same values in
    /// the same order as that many calls of [`std_normal`]: the uniforms
    /// first (the serial chain through the RNG state), then Box-Muller
    /// over the arrays (independent per draw: it vectorises).
    pub fn fill(&mut self, rng: &mut Pcg64, out: &mut [f64]) {
        let n = out.len();
        self.u2.resize(n, 0.0);
        fill_interleaved(rng, &mut self.raw, n, &mut [&mut *out, &mut self.u2[..]]);
        box_muller_in_place(out, &self.u2);
    }
}

/// `buf` resized to `K` * `m` and cut into `K` consecutive rows of `m`
/// (the draw arrays of one batched propagation).
pub fn rows<const K: usize>(buf: &mut Vec<f64>, m: usize) -> [&mut [f64]; K] {
    buf.resize(K * m, 0.0);
    let mut rest = &mut buf[..];
    std::array::from_fn(|_| {
        let (row, tail) = std::mem::take(&mut rest).split_at_mut(m);
        rest = tail;
        row
    })
}

/// A point uniform in the disc of radius `radius` around `centre`: two
/// uniforms, the radius's (sqrt) first, then the angle's.
#[inline]
pub fn in_disc(rng: &mut Pcg64, centre: Vec2, radius: f64) -> Vec2 {
    let r = radius * rng.random::<f64>().sqrt();
    let a = std::f64::consts::TAU * rng.random::<f64>();
    centre + Vec2::new(r * a.cos(), r * a.sin())
}

/// A point of the isotropic Gaussian with standard deviation `sigma`
/// around `centre` (Box-Muller with libm's `ln`, `cos` and `sin`: both
/// normals of one pair of uniforms).
pub fn gaussian_2d(rng: &mut Pcg64, centre: Vec2, sigma: f64) -> Vec2 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    let r = sigma * (-2.0 * u1.ln()).sqrt();
    let a = std::f64::consts::TAU * u2;
    centre + Vec2::new(r * a.cos(), r * a.sin())
}

/// An index uniform in 0..n (n > 0) from one uniform draw.
#[inline]
pub fn uniform_index(rng: &mut Pcg64, n: usize) -> usize {
    ((rng.random::<f64>() * n as f64) as usize).min(n - 1)
}

/// Uniform noise in [-`half_width`, `half_width`) from the uniform `u`
/// in [0, 1).
#[inline(always)]
pub fn symmetric(half_width: f64, u: f64) -> f64 {
    half_width * (2.0 * u - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn batched_normals_are_the_serial_ones() {
        let mut a = Pcg64::seed_from_u64(4);
        let mut b = a.clone();
        let mut normals = Normals::default();
        for n in [0usize, 1, 5, 101] {
            let mut got = vec![0.0; n];
            normals.fill(&mut a, &mut got);
            let want: Vec<f64> = (0..n).map(|_| std_normal(&mut b)).collect();
            assert_eq!(got, want, "{n}");
            assert_eq!(a, b);
        }
    }

    #[test]
    fn disc_and_gaussian_points_lie_where_they_should() {
        let mut rng = Pcg64::seed_from_u64(1);
        let c = Vec2::new(2.0, -1.0);
        for _ in 0..1000 {
            assert!((in_disc(&mut rng, c, 3.0) - c).norm() <= 3.0);
        }
        let n = 4000;
        let sd = (0..n)
            .map(|_| (gaussian_2d(&mut rng, c, 0.5) - c).norm_squared())
            .sum::<f64>()
            / (2 * n) as f64;
        assert!((sd.sqrt() - 0.5).abs() < 0.02, "{sd}");
        for n in [1usize, 2, 7] {
            assert!((0..100).all(|_| uniform_index(&mut rng, n) < n));
        }
        assert_eq!(symmetric(2.0, 0.5), 0.0);
        assert_eq!(symmetric(2.0, 0.0), -2.0);
    }
}
