//! KLD-sampling (Fox, "Adapting the sample size in particle filters
//! through KLD-sampling", IJRR 2003): how many particles a cloud needs so
//! that, with probability 1 - delta, the Kullback-Leibler divergence
//! between its sample-based density and the density it stands for stays
//! below epsilon; from the number of bins the density occupies. A wide
//! cloud (a global start over a floor) occupies many bins and gets many
//! particles, a converged one few.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::Vec2;
use crate::{Error, Result};

/// The adaptive particle count. `max_particles` 0 turns it off: the
/// owner's fixed count holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KldConfig {
    /// At most this many particles (and the count of a global start);
    /// 0 = off.
    pub max_particles: usize,
    /// At least this many particles.
    pub min_particles: usize,
    /// Side of the square bins the occupied count is taken over, m.
    pub bin_m: f64,
    /// The bound on the KL divergence, epsilon.
    pub epsilon: f64,
    /// The upper (1 - delta) quantile of the standard normal (2.33: delta 0.01).
    pub z: f64,
}

impl Default for KldConfig {
    fn default() -> Self {
        KldConfig {
            max_particles: 0,
            min_particles: 500,
            bin_m: 1.0,
            epsilon: 0.05,
            z: 2.33,
        }
    }
}

/// At most this many particles, whatever the configuration says.
pub const MAX_PARTICLES: usize = 100_000;

impl KldConfig {
    /// Whether the count adapts.
    pub fn enabled(&self) -> bool {
        self.max_particles > 0
    }

    /// Checks every field; errors name `PREFIX.<field>` (e.g. `tcpf.adaptive_count`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        for (f, v, lo, hi) in [
            ("bin_m", self.bin_m, 0.05, 100.0),
            ("epsilon", self.epsilon, 1e-4, 10.0),
            ("z", self.z, 0.0, 10.0),
        ] {
            crate::bounds::check_range(&format!("{prefix}.{f}"), v, lo, hi)?;
        }
        if self.max_particles > MAX_PARTICLES
            || (self.enabled() && !(1..=self.max_particles).contains(&self.min_particles))
        {
            return Err(Error::config(
                format!("{prefix}.max_particles"),
                format!(
                    "must be 0 (off) or in min_particles..={MAX_PARTICLES} with min_particles >= 1, got max {} min {}",
                    self.max_particles, self.min_particles
                ),
            ));
        }
        Ok(())
    }

    /// The particle count for a cloud at `positions` with normalised
    /// `weights`: Fox's bound for its occupied bins
    /// ([`expected_occupied_bins`] under `max_particles` draws), within
    /// [`KldConfig::min_particles`, `max_particles`].
    pub fn count(&self, positions: &[Vec2], weights: &[f64]) -> usize {
        let k = expected_occupied_bins(positions, weights, self.bin_m, self.max_particles);
        let n = kld_bound(k, self.epsilon, self.z);
        let n = if n.is_finite() { n.ceil() } else { f64::MAX };
        (n.min(self.max_particles as f64) as usize).max(self.min_particles)
    }
}

/// Fox's bound for `k` occupied bins: (k - 1) / (2 epsilon) x (1 - 2 /
/// (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z)^3 (the Wilson-Hilferty
/// approximation of the chi-square quantile); 1 for k <= 1.
pub fn kld_bound(k: f64, epsilon: f64, z: f64) -> f64 {
    if k <= 1.0 {
        return 1.0;
    }
    let a = 2.0 / (9.0 * (k - 1.0));
    (k - 1.0) / (2.0 * epsilon) * (1.0 - a + a.sqrt() * z).powi(3)
}

/// The number of `bin_m` square bins that `draws` particles drawn from
/// the weighted cloud would be expected to occupy: sum over the bins of
/// 1 - exp(-draws x mass) (a bin of mass p is missed by Poisson(draws x
/// p) draws with probability exp(-draws p)). Smooth and deterministic,
/// unlike counting the bins of one draw. Not-finite positions or weights
/// count nowhere.
pub fn expected_occupied_bins(
    positions: &[Vec2],
    weights: &[f64],
    bin_m: f64,
    draws: usize,
) -> f64 {
    let total: f64 = weights.iter().filter(|w| w.is_finite()).sum();
    if total.is_nan() || total <= 0.0 {
        return 0.0;
    }
    // ordered by key: the sum below is the same whatever the insertion order
    let mut mass: BTreeMap<(i64, i64), f64> = BTreeMap::new();
    for (p, w) in positions.iter().zip(weights) {
        if !(p.x.is_finite() && p.y.is_finite() && w.is_finite()) || *w <= 0.0 {
            continue;
        }
        let key = ((p.x / bin_m).floor() as i64, (p.y / bin_m).floor() as i64);
        *mass.entry(key).or_insert(0.0) += w / total;
    }
    let d = draws as f64;
    mass.values().map(|p| 1.0 - (-d * p).exp()).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fox_bound_matches_the_chi_square_quantile() {
        // chi-square 0.99 quantile with 99 degrees of freedom is 134.64:
        // n = 134.64 / (2 x 0.05) = 1346
        let n = kld_bound(100.0, 0.05, 2.326);
        assert!((n - 1346.0).abs() < 5.0, "{n}");
        assert_eq!(kld_bound(1.0, 0.05, 2.33), 1.0);
    }

    #[test]
    fn a_wide_cloud_gets_many_particles_a_tight_one_few() {
        let cfg = KldConfig {
            max_particles: 5000,
            min_particles: 300,
            ..KldConfig::default()
        };
        // 1000 particles spread over a 60 m x 60 m floor
        let wide: Vec<Vec2> = (0..1000)
            .map(|i| Vec2::new((i % 40) as f64 * 1.5, (i / 40) as f64 * 2.4))
            .collect();
        // the same count within a 1.5 m square
        let tight: Vec<Vec2> = (0..1000)
            .map(|i| Vec2::new((i % 40) as f64 * 0.04, (i / 40) as f64 * 0.06))
            .collect();
        let w = vec![1e-3; 1000];
        assert_eq!(cfg.count(&wide, &w), 5000);
        let n = cfg.count(&tight, &w);
        assert!((300..400).contains(&n), "{n}");
        // particles without weight occupy nothing
        let mut w0 = vec![0.0; 1000];
        w0[0] = 1.0;
        assert_eq!(cfg.count(&wide, &w0), 300);
    }

    #[test]
    fn the_config_is_checked() {
        let ok = KldConfig {
            max_particles: 4000,
            min_particles: 500,
            ..KldConfig::default()
        };
        assert!(ok.validate("tcpf.adaptive_count").is_ok());
        assert!(KldConfig::default().validate("x").is_ok());
        let bad = KldConfig {
            min_particles: 5000,
            ..ok.clone()
        };
        let e = bad.validate("tcpf.adaptive_count").unwrap_err().to_string();
        assert!(e.contains("tcpf.adaptive_count.max_particles"), "{e}");
        let bad = KldConfig {
            max_particles: 1_000_000,
            ..ok.clone()
        };
        assert!(bad.validate("p").is_err());
        let bad = KldConfig { epsilon: 0.0, ..ok };
        assert!(
            bad.validate("p")
                .unwrap_err()
                .to_string()
                .contains("p.epsilon")
        );
    }
}
