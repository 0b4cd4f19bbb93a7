//! The phone's RSSI offset, estimated online while walking.
//!
//! Phones read the same beacon several dB apart (IPIN 2023: the SM-G930F
//! 7.5-9.4 dB weaker than the SM-A520F on all six beacons). The offset o is
//! one scalar state with a Gaussian belief: every radio update gives a
//! robust observation of it (the median over heard transmitters of the
//! residual r_k - mu_k, each averaged over the particle cloud), with a
//! variance that shrinks with the transmitters heard; o random-walks slowly
//! between updates. Transmitters whose expected RSSI at the estimate lies
//! below `min_expected_dbm` are left out: near the receiver's floor only the
//! lucky strong readings are heard (censoring), which would bias o upwards.
//!
//! With per-particle offsets (`per_particle`, and by default wherever the
//! model is the path-loss model, `per_particle_without_map`; with a radio
//! map it cost ILC F1 and IPIN odd 0.1-0.2 m, docs/tcpf.md "Two phones")
//! tcpf does not use this observation:
//! each particle carries its own offset, the likelihood uses it, and the
//! belief here only summarises the particles (weighted mean and sd) for the
//! stats, the anchors' query and (re)initialisations at a point. One offset
//! fed by a possibly wrong cloud settled in a self-consistent wrong mode for
//! a phone 9 dB weaker (docs/tcpf.md "Two phones").

use serde::{Deserialize, Serialize};

use crate::Result;

/// Settings of [`PhoneOffset`] (docs/parameters.md "tcpf").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OffsetConfig {
    /// Whether the offset is estimated (false: fixed at `prior_db`).
    pub enabled: bool,
    /// Prior mean and standard deviation of the offset, dB.
    pub prior_db: f64,
    pub prior_sd_db: f64,
    /// The estimate is clamped to +- this, dB.
    pub max_abs_db: f64,
    /// Random walk of the offset, dB per sqrt(second).
    pub walk_db_per_sqrt_s: f64,
    /// Per-update observation noise: sd_model^2 * noise_scale / m + floor^2.
    pub noise_scale: f64,
    pub noise_floor_db: f64,
    /// Transmitters expected weaker than this at the estimate are not used.
    pub min_expected_dbm: f64,
    /// At least this many usable transmitters per observation.
    pub min_transmitters: usize,
    /// Random walk of each particle's offset, dB per sqrt(second).
    pub particle_walk_db_per_sqrt_s: f64,
    /// A particle drawn from a cell at a start or re-seeding gets the
    /// cell's profiled offset plus this times its posterior sd times
    /// N(0, 1).
    pub particle_start_spread: f64,
    /// With one offset for the whole cloud (a radio map): while the
    /// belief's mean lies more than this many prior sds from the prior's
    /// mean (a belief the prior finds unlikely, as a lost cloud learns
    /// it), a re-seeding profiles the offset under the prior instead, and
    /// the belief becomes the mixture of the old one and the surface's
    /// by the share of particles re-seeded. 0 = never.
    pub reseed_prior_beyond_sd: f64,
}

impl Default for OffsetConfig {
    fn default() -> Self {
        OffsetConfig {
            enabled: true,
            prior_db: 0.0,
            prior_sd_db: 4.0,
            max_abs_db: 15.0,
            walk_db_per_sqrt_s: 0.05,
            noise_scale: 1.5,
            noise_floor_db: 3.0,
            min_expected_dbm: -88.0,
            min_transmitters: 2,
            particle_walk_db_per_sqrt_s: 0.15,
            reseed_prior_beyond_sd: 2.0,
            particle_start_spread: 0.0,
        }
    }
}

impl OffsetConfig {
    /// Checks every field's range; errors name `tcpf.offset.<field>`.
    pub fn validate(&self) -> Result<()> {
        for (f, v, lo, hi) in [
            ("prior_db", self.prior_db, -40.0, 40.0),
            ("prior_sd_db", self.prior_sd_db, 0.01, 40.0),
            ("max_abs_db", self.max_abs_db, 0.0, 60.0),
            ("walk_db_per_sqrt_s", self.walk_db_per_sqrt_s, 0.0, 10.0),
            ("noise_scale", self.noise_scale, 0.0, 100.0),
            ("noise_floor_db", self.noise_floor_db, 0.01, 40.0),
            ("min_expected_dbm", self.min_expected_dbm, -200.0, 0.0),
            (
                "particle_walk_db_per_sqrt_s",
                self.particle_walk_db_per_sqrt_s,
                0.0,
                10.0,
            ),
            (
                "reseed_prior_beyond_sd",
                self.reseed_prior_beyond_sd,
                0.0,
                100.0,
            ),
            (
                "particle_start_spread",
                self.particle_start_spread,
                0.0,
                10.0,
            ),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(crate::Error::config(
                    format!("tcpf.offset.{f}"),
                    format!("must be in [{lo}, {hi}], got {v}"),
                ));
            }
        }
        if !(1..=64).contains(&self.min_transmitters) {
            return Err(crate::Error::config(
                "tcpf.offset.min_transmitters",
                "must be in 1..=64",
            ));
        }
        Ok(())
    }
}

/// The offset belief: mean and variance, dB and dB^2.
#[derive(Debug, Clone, PartialEq)]
pub struct PhoneOffset {
    cfg: OffsetConfig,
    mean_db: f64,
    var_db2: f64,
    last_t_ns: Option<i64>,
    /// Observations absorbed.
    pub updates: u64,
}

impl PhoneOffset {
    /// The prior belief.
    pub fn new(cfg: &OffsetConfig) -> Self {
        PhoneOffset {
            mean_db: cfg.prior_db,
            var_db2: cfg.prior_sd_db * cfg.prior_sd_db,
            cfg: cfg.clone(),
            last_t_ns: None,
            updates: 0,
        }
    }

    /// The current estimate, dB (added to the model's expected RSSI).
    pub fn mean_db(&self) -> f64 {
        self.mean_db
    }

    /// Its standard deviation, dB.
    pub fn sd_db(&self) -> f64 {
        self.var_db2.sqrt()
    }

    /// The settings.
    pub fn config(&self) -> &OffsetConfig {
        &self.cfg
    }

    /// Sets the belief (e.g. the offset profiled at a global start) with
    /// standard deviation `sd_db` (nothing when the estimate is disabled).
    pub fn set(&mut self, mean_db: f64, sd_db: f64) {
        if self.cfg.enabled && mean_db.is_finite() && sd_db.is_finite() {
            let m = self.cfg.max_abs_db;
            self.mean_db = mean_db.clamp(-m, m);
            self.var_db2 = (sd_db * sd_db).min(self.cfg.prior_sd_db.powi(2));
        }
    }

    /// Absorbs one update's residuals `(residual dB, expected dBm, sd dB)`
    /// (residual = heard - expected at the cloud, before any offset) at
    /// `t_ns`. Returns whether it was used.
    pub fn observe(&mut self, t_ns: i64, residuals: &[(f64, f64, f64)]) -> bool {
        if !self.cfg.enabled {
            return false;
        }
        if let Some(t0) = self.last_t_ns {
            let dt = (t_ns - t0).max(0) as f64 * 1e-9;
            self.var_db2 += self.cfg.walk_db_per_sqrt_s.powi(2) * dt;
        }
        self.last_t_ns = Some(t_ns);
        let mut used: Vec<(f64, f64)> = residuals
            .iter()
            .filter(|(r, mu, sd)| {
                r.is_finite() && sd.is_finite() && *mu + self.mean_db >= self.cfg.min_expected_dbm
            })
            .map(|&(r, _, sd)| (r, sd))
            .collect();
        if used.len() < self.cfg.min_transmitters {
            return false;
        }
        used.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n = used.len();
        let med = if n % 2 == 1 {
            used[n / 2].0
        } else {
            0.5 * (used[n / 2 - 1].0 + used[n / 2].0)
        };
        let sd2 = used.iter().map(|u| u.1 * u.1).sum::<f64>() / n as f64;
        let r = sd2 * self.cfg.noise_scale / n as f64 + self.cfg.noise_floor_db.powi(2);
        let k = self.var_db2 / (self.var_db2 + r);
        let m = self.cfg.max_abs_db;
        self.mean_db = (self.mean_db + k * (med - self.mean_db)).clamp(-m, m);
        self.var_db2 *= 1.0 - k;
        self.updates += 1;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converges_to_a_constant_offset_and_ignores_censored_readings() {
        let mut o = PhoneOffset::new(&OffsetConfig::default());
        for k in 0..30 {
            // residuals scattered +-3 dB around -8, plus one NLOS outlier
            let res: Vec<(f64, f64, f64)> = (0..5)
                .map(|i| (-8.0 + [-3.0, -1.0, 0.0, 1.0, 3.0][(i + k) % 5], -70.0, 6.0))
                .chain([(12.0, -70.0, 6.0), (20.0, -120.0, 6.0)])
                .collect();
            o.observe(k as i64 * 1_000_000_000, &res);
        }
        assert!((o.mean_db() + 8.0).abs() < 1.5, "{}", o.mean_db());
        assert!(o.sd_db() < 1.5);
        let mut off = PhoneOffset::new(&OffsetConfig {
            enabled: false,
            ..Default::default()
        });
        assert!(!off.observe(0, &[(5.0, -60.0, 6.0), (5.0, -60.0, 6.0)]));
        assert_eq!(off.mean_db(), 0.0);
    }
}
