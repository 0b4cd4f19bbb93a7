//! Integrity of the radio against its model (`tcpf.integrity`; docs/tcpf.md
//! "Radio integrity").
//!
//! A radio map (or the path-loss model) can be wrong over a whole area: a
//! wing the survey never walked, a transmitter moved, a model biased by
//! the walls. A model wrong over an area by more than its spread says
//! misfits every reading there wherever the cloud goes (transmitters off
//! in both directions cannot be explained by one phone offset or one
//! place), so the mean squared standardised residual at the cloud,
//! averaged over a few updates, rises well above its level where the model
//! holds. Beyond `fit_free_z2` the radio's trust falls steeply and the
//! steps and the walls carry the track until the fit comes back. With a
//! radio map the misfit is read against the survey's own misfit around the
//! cloud (`fit_local_cell_m`, `survey_fit.rs`), and it does not hold the
//! re-seeding (`fit_reseed_min_trust` 0); with the path-loss model it does.
//! The check reads the trust only after a told start (`InitialPosition`,
//! `set_position`); after a global start it keeps the average for the
//! accuracy radius alone.
//!
//! (The pull check that summed the radio's corrections against the walk
//! lost and was deleted: docs/lab/tcpf-deleted-mechanisms.md.)

use serde::{Deserialize, Serialize};

use crate::Result;

/// Settings of the radio's integrity check (docs/parameters.md "tcpf").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IntegrityConfig {
    /// The fit check (0: off): each radio update's readings against the
    /// model at the cloud before it, as the mean squared standardised
    /// residual z^2 (each reading's capped at `fit_z2_cap`), averaged over
    /// updates at `fit_rate`. While the average stays at most
    /// `fit_free_z2` the radio keeps full trust; beyond, its trust is at
    /// most (`fit_free_z2` / average)^`fit_exponent`, at least
    /// `fit_min_trust`.
    pub fit_free_z2: f64,
    /// A fit trust below `fit_reseed_min_trust` holds the re-seeding, unless
    /// the steps' wall kills (moving average, share of the moving
    /// particles) reach this: then the misfit is the cloud's (a wrong
    /// told start), not the model's.
    pub fit_lost_wall_kill: f64,
    /// With a radio map whose survey left reference scans: the fit
    /// check's z^2 (not the radius's) is divided by the survey's own misfit
    /// around the cloud relative to the site's median (at least 1, at most
    /// [`FIT_LOCAL_MAX`]): the mean z^2 of the reference scans in the 3 x 3
    /// cells of this size around the cloud's mean (`survey_fit.rs`), so
    /// that where the survey itself misfits the map, a walk's misfit does
    /// not count as the map being wrong. m; 0 = off.
    pub fit_local_cell_m: f64,
    /// A fit trust below this holds the re-seeding from the radio
    /// (likelihood surface, anchors; see `fit_lost_wall_kill`), with a
    /// radio map; `_without_map` with the path-loss model. 0 = the fit
    /// check never holds it (it still tempers the radio).
    pub fit_reseed_min_trust: f64,
    pub fit_reseed_min_trust_without_map: f64,
    pub fit_z2_cap: f64,
    pub fit_rate: f64,
    pub fit_exponent: f64,
    pub fit_min_trust: f64,
    /// The accuracy radius gains this many metres per unit of the fit
    /// check's average z^2 beyond `fit_accuracy_free_z2`, in quadrature
    /// (the readings misfit the map at the cloud: the cloud may be where
    /// the map is wrong, or the map right where the cloud is not). The
    /// average is kept for this even where the fit check does not touch
    /// the trust (after a global start); the track is unchanged. With a
    /// radio map; `_without_map` with the path-loss model. 0 = off.
    pub fit_accuracy_m_per_z2: f64,
    pub fit_accuracy_m_per_z2_without_map: f64,
    pub fit_accuracy_free_z2: f64,
    /// The radius's z^2 is its own average, at this rate per update
    /// (slower than `fit_rate`: the radius should not flicker with each
    /// update's misfit).
    pub fit_accuracy_rate: f64,
    /// The radius's fit term is at most this, m (a radius beyond a
    /// floor's size says no more than "lost"; 0 = no cap).
    pub fit_accuracy_max_m: f64,
}

/// The most `fit_local_cell_m`'s level divides the fit check's z^2 by.
pub const FIT_LOCAL_MAX: f64 = 5.0;

impl Default for IntegrityConfig {
    fn default() -> Self {
        IntegrityConfig {
            fit_free_z2: 1.7,
            fit_lost_wall_kill: 0.5,
            fit_local_cell_m: 4.0,
            fit_reseed_min_trust: 0.0,
            fit_reseed_min_trust_without_map: 0.5,
            fit_z2_cap: 25.0,
            fit_rate: 0.5,
            fit_exponent: 8.0,
            fit_min_trust: 0.01,
            fit_accuracy_m_per_z2: 48.0,
            fit_accuracy_m_per_z2_without_map: 4.0,
            fit_accuracy_free_z2: 1.0,
            fit_accuracy_rate: 0.1,
            fit_accuracy_max_m: 30.0,
        }
    }
}

impl IntegrityConfig {
    /// Checks every field; errors name `tcpf.integrity.<field>`.
    pub fn validate(&self) -> Result<()> {
        for (f, v, lo, hi) in [
            ("fit_free_z2", self.fit_free_z2, 0.0, 1000.0),
            ("fit_z2_cap", self.fit_z2_cap, 1.0, 10000.0),
            ("fit_rate", self.fit_rate, 0.001, 1.0),
            ("fit_exponent", self.fit_exponent, 0.1, 16.0),
            ("fit_min_trust", self.fit_min_trust, 0.001, 1.0),
            ("fit_lost_wall_kill", self.fit_lost_wall_kill, 0.0, 1.0),
            ("fit_local_cell_m", self.fit_local_cell_m, 0.0, 1000.0),
            ("fit_reseed_min_trust", self.fit_reseed_min_trust, 0.0, 1.0),
            (
                "fit_reseed_min_trust_without_map",
                self.fit_reseed_min_trust_without_map,
                0.0,
                1.0,
            ),
            (
                "fit_accuracy_m_per_z2",
                self.fit_accuracy_m_per_z2,
                0.0,
                100.0,
            ),
            (
                "fit_accuracy_m_per_z2_without_map",
                self.fit_accuracy_m_per_z2_without_map,
                0.0,
                100.0,
            ),
            (
                "fit_accuracy_free_z2",
                self.fit_accuracy_free_z2,
                0.0,
                1000.0,
            ),
            ("fit_accuracy_rate", self.fit_accuracy_rate, 0.001, 1.0),
            ("fit_accuracy_max_m", self.fit_accuracy_max_m, 0.0, 1e6),
        ] {
            crate::bounds::check_range(&format!("tcpf.integrity.{f}"), v, lo, hi)?;
        }
        Ok(())
    }

    /// The radius's slope for the path-loss model or a radio map.
    fn fit_accuracy_slope(&self, path_loss: bool) -> f64 {
        if path_loss {
            self.fit_accuracy_m_per_z2_without_map
        } else {
            self.fit_accuracy_m_per_z2
        }
    }

    /// The re-seeding hold's level for the path-loss model or a radio map.
    fn fit_reseed_min_for(&self, path_loss: bool) -> f64 {
        if path_loss {
            self.fit_reseed_min_trust_without_map
        } else {
            self.fit_reseed_min_trust
        }
    }
}

/// The fit check's state: the averaged misfit, the trust it gives.
#[derive(Debug, Clone)]
pub struct RadioIntegrity {
    /// Whether the engine weighs with the path-loss model (not a radio map).
    path_loss: bool,
    /// Whether the fit sets the trust (after a told start).
    fit_active: bool,
    /// The averaged (locally divided) z^2 of the trust, and the trust.
    fit_z2: Option<f64>,
    fit_trust: f64,
    /// The averaged raw z^2 of the accuracy radius.
    fit_accuracy_z2: Option<f64>,
}

impl RadioIntegrity {
    /// Unchecked until the first [`RadioIntegrity::restart`]; `path_loss`
    /// whether the engine weighs with the path-loss model.
    pub fn for_model(path_loss: bool) -> Self {
        RadioIntegrity {
            path_loss,
            fit_active: false,
            fit_z2: None,
            fit_trust: 1.0,
            fit_accuracy_z2: None,
        }
    }

    /// A new cloud: `told` whether it was placed at a told position (the
    /// fit then sets the trust), else by the radio (a global start).
    pub fn restart(&mut self, cfg: &IntegrityConfig, told: bool) {
        self.fit_active = cfg.fit_free_z2 > 0.0 && told;
        self.fit_z2 = None;
        self.fit_trust = 1.0;
        self.fit_accuracy_z2 = None;
    }

    /// One radio update's mean capped z^2 at the cloud, and the survey's
    /// own misfit level there (`local`, 1 = the site's median).
    pub fn on_fit(&mut self, cfg: &IntegrityConfig, z2: f64, local: f64) {
        if !self.fit_is_watched(cfg) || !z2.is_finite() {
            return;
        }
        let checked = z2 / local.clamp(1.0, FIT_LOCAL_MAX);
        let avg = match self.fit_z2 {
            Some(a) => a + cfg.fit_rate * (checked - a),
            None => checked,
        };
        self.fit_z2 = Some(avg);
        self.fit_accuracy_z2 = Some(match self.fit_accuracy_z2 {
            Some(a) => a + cfg.fit_accuracy_rate * (z2 - a),
            None => z2,
        });
        if !self.fit_active {
            return;
        }
        self.fit_trust = if avg > cfg.fit_free_z2 {
            (cfg.fit_free_z2 / avg)
                .powf(cfg.fit_exponent)
                .clamp(cfg.fit_min_trust, 1.0)
        } else {
            1.0
        };
    }

    /// Whether the fit is read at all (for the trust or the radius).
    pub fn fit_is_watched(&self, cfg: &IntegrityConfig) -> bool {
        self.fit_active || cfg.fit_accuracy_slope(self.path_loss) > 0.0
    }

    /// The accuracy radius's fit term, m.
    pub fn fit_accuracy_m(&self, cfg: &IntegrityConfig) -> f64 {
        let slope = cfg.fit_accuracy_slope(self.path_loss);
        match self.fit_accuracy_z2 {
            Some(a) if slope > 0.0 => {
                let r = slope * (a - cfg.fit_accuracy_free_z2).max(0.0);
                if cfg.fit_accuracy_max_m > 0.0 {
                    r.min(cfg.fit_accuracy_max_m)
                } else {
                    r
                }
            }
            _ => 0.0,
        }
    }

    /// The radio's trust in [`IntegrityConfig::fit_min_trust`, 1].
    pub fn trust(&self) -> f64 {
        self.fit_trust.max(0.0)
    }

    /// Whether the fit's trust holds the re-seeding from the radio.
    pub fn fit_holds_reseed(&self, cfg: &IntegrityConfig) -> bool {
        self.fit_trust < cfg.fit_reseed_min_for(self.path_loss)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Guards the fit check: a fit within the free level keeps full
    /// trust, a misfit well beyond it drops the trust to its floor within
    /// a few updates, the fit coming back restores it (`fit_free_z2`, 0:
    /// off, for either model); after a global start it reads nothing.
    #[test]
    fn a_misfit_beyond_the_free_level_drops_the_trust_and_it_recovers() {
        let cfg = IntegrityConfig::default();
        let mut r = RadioIntegrity::for_model(true);
        r.restart(&cfg, true);
        for _ in 0..20 {
            r.on_fit(&cfg, 1.2, 1.0);
        }
        assert_eq!(r.trust(), 1.0);
        for _ in 0..6 {
            r.on_fit(&cfg, 4.0, 1.0);
        }
        assert!(r.trust() < 0.05, "trust {}", r.trust());
        assert!(r.trust() >= cfg.fit_min_trust);
        for _ in 0..10 {
            r.on_fit(&cfg, 1.0, 1.0);
        }
        assert_eq!(r.trust(), 1.0);
        // a global start: unchecked
        r.restart(&cfg, false);
        for _ in 0..10 {
            r.on_fit(&cfg, 9.0, 1.0);
        }
        assert_eq!(r.trust(), 1.0);
        // a radio map: on by default (`fit_free_z2`), off at 0
        let mut m = RadioIntegrity::for_model(false);
        m.restart(&cfg, true);
        m.on_fit(&cfg, 9.0, 1.0);
        assert!(m.trust() < 0.05, "trust {}", m.trust());
        let off = IntegrityConfig {
            fit_free_z2: 0.0,
            ..cfg
        };
        m.restart(&off, true);
        m.on_fit(&off, 9.0, 1.0);
        assert_eq!(m.trust(), 1.0);
    }

    /// Guards `fit_local_cell_m`'s reading: where the survey itself
    /// misfits the map (a relative level of 3), a walk's z^2 of 4 is read
    /// as 4 / 3 and keeps full trust; the radius reads the raw z^2; a
    /// level below 1 never makes the misfit larger.
    #[test]
    fn the_survey_s_own_misfit_divides_the_check_but_not_the_radius() {
        let cfg = IntegrityConfig {
            fit_free_z2: 1.7,
            ..IntegrityConfig::default()
        };
        let (mut local, mut raw) = (
            RadioIntegrity::for_model(false),
            RadioIntegrity::for_model(false),
        );
        local.restart(&cfg, true);
        raw.restart(&cfg, true);
        for _ in 0..10 {
            local.on_fit(&cfg, 4.0, 3.0);
            raw.on_fit(&cfg, 4.0, 1.0);
        }
        assert_eq!(local.trust(), 1.0);
        assert!(raw.trust() < 0.05, "trust {}", raw.trust());
        assert_eq!(local.fit_accuracy_m(&cfg), raw.fit_accuracy_m(&cfg));
        let mut low = RadioIntegrity::for_model(false);
        low.restart(&cfg, true);
        low.on_fit(&cfg, 4.0, 0.2);
        assert!(low.trust() < 0.05, "trust {}", low.trust());
    }

    #[test]
    fn config_errors_name_the_field() {
        let bad = IntegrityConfig {
            fit_min_trust: 0.0,
            ..IntegrityConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("tcpf.integrity.fit_min_trust"), "{e}");
        let bad = IntegrityConfig {
            fit_accuracy_rate: 0.0,
            ..IntegrityConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("tcpf.integrity.fit_accuracy_rate"), "{e}");
    }

    /// Guards the radius's fit term: with a radio map the fit check
    /// leaves the trust alone (default), yet the average is kept, and the
    /// radius gains `fit_accuracy_m_per_z2` per unit beyond the free
    /// level, after a global start too, smoothed and capped; 0 turns the
    /// term off.
    #[test]
    fn a_misfit_widens_the_radius_without_touching_the_trust() {
        let cfg = IntegrityConfig::default();
        let mut m = RadioIntegrity::for_model(false);
        m.restart(&cfg, false);
        assert_eq!(m.fit_accuracy_m(&cfg), 0.0);
        m.on_fit(&cfg, cfg.fit_accuracy_free_z2 * 0.5, 1.0);
        assert_eq!(m.fit_accuracy_m(&cfg), 0.0);
        m.restart(&cfg, false);
        m.on_fit(&cfg, cfg.fit_accuracy_free_z2 + 0.5, 1.0);
        assert_eq!(m.trust(), 1.0);
        let want = cfg.fit_accuracy_m_per_z2 * 0.5;
        assert!(
            (m.fit_accuracy_m(&cfg) - want).abs() < 1e-9,
            "{}",
            m.fit_accuracy_m(&cfg)
        );
        let off = IntegrityConfig {
            fit_accuracy_m_per_z2: 0.0,
            ..cfg.clone()
        };
        m.restart(&off, false);
        m.on_fit(&off, 9.0, 1.0);
        assert_eq!(m.fit_accuracy_m(&off), 0.0);
        // one update's spike moves the radius by `fit_accuracy_rate` of
        // it, and the term never exceeds `fit_accuracy_max_m`
        m.restart(&cfg, false);
        m.on_fit(&cfg, cfg.fit_accuracy_free_z2, 1.0);
        m.on_fit(&cfg, cfg.fit_accuracy_free_z2 + 10.0, 1.0);
        let want = cfg.fit_accuracy_m_per_z2 * 10.0 * cfg.fit_accuracy_rate;
        assert!((m.fit_accuracy_m(&cfg) - want.min(cfg.fit_accuracy_max_m)).abs() < 1e-9);
        for _ in 0..100 {
            m.on_fit(&cfg, 25.0, 1.0);
        }
        assert_eq!(m.fit_accuracy_m(&cfg), cfg.fit_accuracy_max_m);
        // the path-loss model has its own slope
        let mut p = RadioIntegrity::for_model(true);
        p.restart(&cfg, false);
        p.on_fit(&cfg, cfg.fit_accuracy_free_z2 + 1.0, 1.0);
        let want = cfg.fit_accuracy_m_per_z2_without_map;
        assert!(
            (p.fit_accuracy_m(&cfg) - want).abs() < 1e-9,
            "{}",
            p.fit_accuracy_m(&cfg)
        );
    }
}
