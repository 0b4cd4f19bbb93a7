//! Random draws used by the simulator, all from the one seeded generator
//! the simulation owns (`rand_pcg::Pcg64`).

use rand::RngExt;
use rand_pcg::Pcg64;

/// A standard normal draw (Box-Muller; one draw per call keeps the
/// sequence simple to reason about).
pub fn std_normal(rng: &mut Pcg64) -> f64 {
    let u1: f64 = rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    // u1 in [0, 1): map to (0, 1] to avoid ln(0).
    let r = (-2.0 * (1.0 - u1).ln()).sqrt();
    r * (std::f64::consts::TAU * u2).cos()
}

/// A normal draw with mean `mu` and standard deviation `sigma`.
pub fn normal(rng: &mut Pcg64, mu: f64, sigma: f64) -> f64 {
    mu + sigma * std_normal(rng)
}

/// A uniform draw in [lo, hi) (lo when the range is empty).
pub fn uniform(rng: &mut Pcg64, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        lo + (hi - lo) * rng.random::<f64>()
    } else {
        lo
    }
}

/// An exponential draw with the given mean.
pub fn exponential(rng: &mut Pcg64, mean: f64) -> f64 {
    let u: f64 = rng.random::<f64>();
    -mean * (1.0 - u).ln()
}

/// True with probability `p`.
pub fn chance(rng: &mut Pcg64, p: f64) -> bool {
    rng.random::<f64>() < p
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn normal_moments() {
        let mut rng = Pcg64::seed_from_u64(7);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| normal(&mut rng, 2.0, 3.0)).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n as f64;
        assert!((m - 2.0).abs() < 0.03, "{m}");
        assert!((v.sqrt() - 3.0).abs() < 0.03, "{}", v.sqrt());
    }
}
