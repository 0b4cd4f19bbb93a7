//! Integrity of the radio against the walk (`tcpf.integrity`; docs/tcpf.md
//! "Radio integrity").
//!
//! A radio map (or the path-loss model) can be wrong over a whole area: a
//! wing the survey never walked, a transmitter moved, a model biased by
//! the walls. There the radio pulls a correct cloud away within seconds,
//! and each update's pull is small beside the cloud, so no single update
//! looks wrong. What gives it away is the sum: the PDR's error grows with
//! the distance walked (a heading bias, a step length a few per cent off),
//! so over a window of the last seconds the corrections the radio makes to
//! the PDR-propagated cloud may add up to a few metres plus a share of the
//! distance walked, plus the cloud's own spread (a broad cloud is allowed
//! to be narrowed down anywhere inside it). Corrections that add up to
//! more than that, in one direction, say that the radio and the steps
//! disagree beyond what either's spread explains.
//!
//! Each radio update's pull is the shift of the cloud's weighted mean that
//! its weights (and any re-seeding) made. The window sums the pulls each
//! divided by the trust they were made with (a pull made at trust t is
//! about t times the pull at full trust, for pulls small beside the
//! cloud), so the sum estimates what the radio would have done at full
//! trust and the trust does not oscillate. The trust is then the allowed
//! correction over that sum, clamped to [`min_trust`, 1]: a radio that
//! keeps to the budget keeps full trust; one that asks for three times the
//! budget gets a third, which holds its actual pull near the budget. The
//! engine multiplies the radio's tempering and the anchors' weight by the
//! trust, re-seeds from the radio only while the trust is at least
//! `reseed_min_trust`, and widens the accuracy radius by the part of the
//! pull it did not follow.
//!
//! A second check reads the fit instead of the pulls (`fit_free_z2`): a
//! model wrong over an area by more than its spread says misfits every
//! reading there wherever the cloud goes (transmitters off in both
//! directions cannot be explained by one phone offset or one place), so
//! the mean squared standardised residual at the cloud, averaged over a
//! few updates, rises well above its level where the model holds. Beyond
//! `fit_free_z2` the radio's trust falls steeply and the steps and the
//! walls carry the track until the fit comes back. Its trust multiplies
//! the pull check's. With a radio map the misfit is read against the
//! survey's own misfit around the cloud (`fit_local_cell_m`,
//! `survey_fit.rs`), and it does not hold the re-seeding
//! (`fit_reseed_min_trust` 0); with the path-loss model it does.
//!
//! [`min_trust`]: IntegrityConfig::min_trust

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::Vec2;

/// Settings of the radio's integrity check (docs/parameters.md "tcpf").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IntegrityConfig {
    /// Whether the radio's trust is checked (false: trust stays 1).
    pub enabled: bool,
    /// Also after a global start (the cloud placed by the radio itself);
    /// false: only after a told start (`InitialPosition`, `set_position`).
    pub after_global_start: bool,
    /// The sliding window the pulls are summed over, s.
    pub window_s: f64,
    /// The correction the steps allow over the window: this many metres
    /// ...
    pub allow_m: f64,
    /// ... plus this share of the distance the steps walked in the window
    /// ...
    pub allow_per_walked: f64,
    /// ... plus this many times the cloud's RMS spread before the update.
    pub allow_spread: f64,
    /// The trust is (allowed / pull)^`trust_exponent` once the pull
    /// exceeds the allowed correction: 1 holds the radio's pull at the
    /// budget (a wrong radio still drags the cloud at the budget's rate),
    /// above 1 the radio loses more of its say the further it asks to go.
    pub trust_exponent: f64,
    /// The trust never falls below this.
    pub min_trust: f64,
    /// Re-seeding from the radio (likelihood surface, anchors) only while
    /// the trust is at least this.
    pub reseed_min_trust: f64,
    /// The accuracy radius gains this share of the pull the engine did
    /// not follow ((1 - trust) x the window's summed pull), in quadrature.
    pub accuracy_share: f64,
    /// The fit check (independent of `enabled`; 0: off): each radio
    /// update's readings against the model at the cloud before it, as
    /// the mean squared standardised residual z^2 (each reading's capped
    /// at `fit_z2_cap`), averaged over updates at `fit_rate`. While the
    /// average stays at most `fit_free_z2` the radio keeps full trust;
    /// beyond, its trust is at most (`fit_free_z2` / average)^`fit_exponent`,
    /// at least `fit_min_trust`. With a radio map; `fit_free_z2_without_map`
    /// applies when the engine weighs with the path-loss model.
    pub fit_free_z2: f64,
    pub fit_free_z2_without_map: f64,
    /// The fit check also after a global start (false: only after a
    /// told start, `InitialPosition` or `set_position`).
    pub fit_after_global_start: bool,
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
    /// the trust (with a radio map, after a global start); the track is
    /// unchanged. With a radio map; the `_without_map` pair applies when
    /// the engine weighs with the path-loss model. 0 = off.
    pub fit_accuracy_m_per_z2: f64,
    pub fit_accuracy_free_z2: f64,
    pub fit_accuracy_m_per_z2_without_map: f64,
    pub fit_accuracy_free_z2_without_map: f64,
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
            enabled: false,
            after_global_start: true,
            window_s: 20.0,
            allow_m: 3.0,
            allow_per_walked: 0.1,
            allow_spread: 1.0,
            trust_exponent: 1.0,
            min_trust: 0.05,
            reseed_min_trust: 0.5,
            accuracy_share: 1.0,
            fit_free_z2: 1.7,
            fit_free_z2_without_map: 1.7,
            fit_after_global_start: false,
            fit_lost_wall_kill: 0.5,
            fit_local_cell_m: 4.0,
            fit_reseed_min_trust: 0.0,
            fit_reseed_min_trust_without_map: 0.5,
            fit_z2_cap: 25.0,
            fit_rate: 0.5,
            fit_exponent: 8.0,
            fit_min_trust: 0.01,
            fit_accuracy_m_per_z2: 48.0,
            fit_accuracy_free_z2: 1.0,
            fit_accuracy_m_per_z2_without_map: 4.0,
            fit_accuracy_free_z2_without_map: 1.0,
            fit_accuracy_rate: 0.1,
            fit_accuracy_max_m: 30.0,
        }
    }
}

impl IntegrityConfig {
    /// Checks every field; errors name `tcpf.integrity.<field>`.
    pub fn validate(&self) -> Result<()> {
        for (f, v, lo, hi) in [
            ("window_s", self.window_s, 0.5, 600.0),
            ("allow_m", self.allow_m, 0.0, 1000.0),
            ("allow_per_walked", self.allow_per_walked, 0.0, 10.0),
            ("allow_spread", self.allow_spread, 0.0, 100.0),
            ("trust_exponent", self.trust_exponent, 0.1, 10.0),
            ("min_trust", self.min_trust, 0.001, 1.0),
            ("reseed_min_trust", self.reseed_min_trust, 0.0, 1.0),
            ("accuracy_share", self.accuracy_share, 0.0, 100.0),
            ("fit_free_z2", self.fit_free_z2, 0.0, 1000.0),
            (
                "fit_free_z2_without_map",
                self.fit_free_z2_without_map,
                0.0,
                1000.0,
            ),
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
            (
                "fit_accuracy_free_z2_without_map",
                self.fit_accuracy_free_z2_without_map,
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

    /// The radius per unit of excess z^2 (0: off) and the free level,
    /// for a path-loss model (`path_loss`) or a radio map.
    pub fn fit_accuracy_for(&self, path_loss: bool) -> (f64, f64) {
        if path_loss {
            (
                self.fit_accuracy_m_per_z2_without_map,
                self.fit_accuracy_free_z2_without_map,
            )
        } else {
            (self.fit_accuracy_m_per_z2, self.fit_accuracy_free_z2)
        }
    }

    /// The fit trust below which the fit check holds the re-seeding, for
    /// a path-loss model (`path_loss`) or a radio map (0: never).
    pub fn fit_reseed_min_for(&self, path_loss: bool) -> f64 {
        if path_loss {
            self.fit_reseed_min_trust_without_map
        } else {
            self.fit_reseed_min_trust
        }
    }

    /// The fit check's free level for a path-loss model (`path_loss`) or
    /// a radio map (0: off).
    pub fn fit_free_for(&self, path_loss: bool) -> f64 {
        if path_loss {
            self.fit_free_z2_without_map
        } else {
            self.fit_free_z2
        }
    }
}

/// One radio update in the window: its time, its pull at full trust and
/// the distance walked since the previous update.
#[derive(Debug, Clone, Copy)]
struct Entry {
    t_ns: i64,
    pull: Vec2,
    walked_m: f64,
}

/// The radio's trust: the window of pulls and the value it gives.
#[derive(Debug, Clone)]
pub struct RadioIntegrity {
    entries: VecDeque<Entry>,
    /// Distance walked since the last radio update, m.
    walked_m: f64,
    trust: f64,
    /// The window's summed pull at full trust, m.
    pull_m: f64,
    /// Whether the current cloud is checked (a told start, or any start
    /// with `after_global_start`).
    active: bool,
    /// Pulls the engine refused (re-seedings beyond the budget) since the
    /// last radio update, at full trust, m.
    refused: Vec2,
    /// The engine weighs with the path-loss model (no radio map): the
    /// fit check's level is `fit_free_z2_without_map`.
    path_loss: bool,
    /// Whether the fit check reads the current cloud (its free level set;
    /// a told start, or any start with `after_global_start`), and the level.
    fit_active: bool,
    fit_free: f64,
    /// The fit check's average z^2 (`None` before the first update) and
    /// the trust it gives.
    fit_z2: Option<f64>,
    fit_trust: f64,
    /// The radius's average z^2 (`fit_accuracy_rate`).
    fit_accuracy_z2: Option<f64>,
}

impl Default for RadioIntegrity {
    fn default() -> Self {
        RadioIntegrity {
            entries: VecDeque::new(),
            walked_m: 0.0,
            trust: 1.0,
            pull_m: 0.0,
            active: false,
            refused: Vec2::zeros(),
            path_loss: false,
            fit_active: false,
            fit_free: 0.0,
            fit_z2: None,
            fit_trust: 1.0,
            fit_accuracy_z2: None,
        }
    }
}

/// At most this many updates in the window (a bound on memory whatever
/// the task periods).
const MAX_ENTRIES: usize = 4096;

impl RadioIntegrity {
    /// Unchecked until the first [`RadioIntegrity::restart`]; `path_loss`
    /// whether the engine weighs with the path-loss model.
    pub fn for_model(path_loss: bool) -> Self {
        RadioIntegrity {
            path_loss,
            ..RadioIntegrity::default()
        }
    }

    /// A new cloud (start, floor change): empty window, full trust;
    /// `told` whether the cloud was placed at a told position.
    pub fn restart(&mut self, cfg: &IntegrityConfig, told: bool) {
        self.entries.clear();
        self.walked_m = 0.0;
        self.trust = 1.0;
        self.pull_m = 0.0;
        self.refused = Vec2::zeros();
        self.active = cfg.enabled && (told || cfg.after_global_start);
        self.fit_free = cfg.fit_free_for(self.path_loss);
        self.fit_active = self.fit_free > 0.0 && (told || cfg.fit_after_global_start);
        self.fit_z2 = None;
        self.fit_trust = 1.0;
        self.fit_accuracy_z2 = None;
    }

    /// The fit check: `z2` the mean squared standardised residuals (each
    /// capped) of one radio update's readings at the cloud before it,
    /// `local` the survey's own relative misfit there (1 when unknown or
    /// not read: `fit_local_cell_m`), which divides the check's z^2 but
    /// not the radius's.
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
        self.fit_trust = if avg > self.fit_free {
            (self.fit_free / avg)
                .powf(cfg.fit_exponent)
                .clamp(cfg.fit_min_trust, 1.0)
        } else {
            1.0
        };
    }

    /// Whether the current cloud's pulls are checked.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// Whether the current cloud's fit is checked.
    pub fn fit_is_active(&self) -> bool {
        self.fit_active
    }

    /// Whether the fit's average is kept ([`RadioIntegrity::on_fit`]):
    /// for the fit check, or for the accuracy radius's
    /// `fit_accuracy_m_per_z2*`.
    pub fn fit_is_watched(&self, cfg: &IntegrityConfig) -> bool {
        self.fit_active || cfg.fit_accuracy_for(self.path_loss).0 > 0.0
    }

    /// The radius the fit adds (`fit_accuracy_m_per_z2*` x the average
    /// z^2 beyond `fit_accuracy_free_z2*`, at most `fit_accuracy_max_m`), m.
    pub fn fit_accuracy_m(&self, cfg: &IntegrityConfig) -> f64 {
        let (slope, free) = cfg.fit_accuracy_for(self.path_loss);
        match self.fit_accuracy_z2 {
            Some(a) if slope > 0.0 => {
                let r = slope * (a - free).max(0.0);
                if cfg.fit_accuracy_max_m > 0.0 {
                    r.min(cfg.fit_accuracy_max_m)
                } else {
                    r
                }
            }
            _ => 0.0,
        }
    }

    /// The correction the walk allows over the window, m: `allow_m` plus
    /// `allow_per_walked` of the distance walked in it (and since the last
    /// update) plus `allow_spread` x `spread_m` (the cloud's RMS spread).
    pub fn allowed_m(&self, cfg: &IntegrityConfig, spread_m: f64) -> f64 {
        let walked = self.entries.iter().skip(1).map(|e| e.walked_m).sum::<f64>() + self.walked_m;
        let spread = if spread_m.is_finite() { spread_m } else { 0.0 };
        cfg.allow_m + cfg.allow_per_walked * walked + cfg.allow_spread * spread
    }

    /// A pull the engine did not make (a re-seeding refused): it counts
    /// in the window at the next radio update as if made at full trust.
    pub fn refuse(&mut self, pull: Vec2) {
        if pull.x.is_finite() && pull.y.is_finite() {
            self.refused += pull;
        }
    }

    /// One step of `length_m` walked.
    pub fn on_step(&mut self, length_m: f64) {
        if length_m.is_finite() && length_m > 0.0 {
            self.walked_m += length_m;
        }
    }

    /// One radio update at `t_ns` moved the cloud's weighted mean by
    /// `pull` (m) with the current trust; `spread_m` is the cloud's RMS
    /// spread before it. Updates the trust.
    pub fn on_radio(&mut self, cfg: &IntegrityConfig, t_ns: i64, pull: Vec2, spread_m: f64) {
        if !self.active {
            return;
        }
        let pull = if pull.x.is_finite() && pull.y.is_finite() {
            pull / self.trust().max(cfg.min_trust.min(cfg.fit_min_trust))
        } else {
            Vec2::zeros()
        } + std::mem::take(&mut self.refused);
        self.entries.push_back(Entry {
            t_ns,
            pull,
            walked_m: self.walked_m,
        });
        self.walked_m = 0.0;
        let oldest = t_ns.saturating_sub((cfg.window_s * 1e9) as i64);
        while self
            .entries
            .front()
            .is_some_and(|e| e.t_ns < oldest || self.entries.len() > MAX_ENTRIES)
        {
            self.entries.pop_front();
        }
        let sum = self.entries.iter().fold(Vec2::zeros(), |s, e| s + e.pull);
        self.pull_m = sum.norm();
        // the first entry's walk happened before the window's first pull
        let allowed = self.allowed_m(cfg, spread_m);
        self.trust = if self.pull_m > allowed {
            (allowed / self.pull_m)
                .powf(cfg.trust_exponent)
                .clamp(cfg.min_trust, 1.0)
        } else {
            1.0
        };
    }

    /// The radio's trust in [`IntegrityConfig::min_trust`, 1] (1 when
    /// unchecked).
    pub fn trust(&self) -> f64 {
        (self.trust * self.fit_trust).max(0.0)
    }

    /// Whether the fit check holds the re-seeding now: its trust below
    /// [`IntegrityConfig::fit_reseed_min_for`] the model.
    pub fn fit_holds_reseed(&self, cfg: &IntegrityConfig) -> bool {
        self.fit_trust < cfg.fit_reseed_min_for(self.path_loss)
    }

    /// The pull check's part of [`RadioIntegrity::trust`].
    pub fn pull_trust(&self) -> f64 {
        self.trust
    }

    /// The fit check's part of [`RadioIntegrity::trust`].
    pub fn fit_trust(&self) -> f64 {
        self.fit_trust
    }

    /// The part of the window's pull the engine did not follow, m.
    pub fn unfollowed_m(&self) -> f64 {
        (1.0 - self.trust) * self.pull_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on() -> IntegrityConfig {
        IntegrityConfig {
            enabled: true,
            ..IntegrityConfig::default()
        }
    }

    /// Guards the budget: pulls that keep within what the steps allow
    /// keep full trust, a steady pull beyond it lowers the trust to about
    /// budget / pull, and the trust comes back once the pulls stop.
    #[test]
    fn a_steady_pull_beyond_the_budget_lowers_the_trust_and_it_recovers() {
        let cfg = on();
        let mut r = RadioIntegrity::default();
        r.restart(&cfg, true);
        let s = 1_000_000_000i64;
        // 1 m/s walked, 0.05 m of pull per second: 20 s -> 1 m < 3 + 2 m
        for k in 0..40 {
            r.on_step(1.0);
            r.on_radio(&cfg, k * s, Vec2::new(0.05, 0.0), 0.5);
        }
        assert_eq!(r.trust(), 1.0);
        // 1 m of pull per second at full trust, in one direction
        for k in 40..100 {
            r.on_step(1.0);
            let p = Vec2::new(0.0, 1.0) * r.trust();
            r.on_radio(&cfg, k * s, p, 0.5);
        }
        // budget 3 + 0.1 x 20 + 0.5 = 5.5 m against ~21 m of pull
        let t = r.trust();
        assert!(t > 0.15 && t < 0.4, "trust {t}");
        assert!(r.unfollowed_m() > 10.0, "{}", r.unfollowed_m());
        for k in 100..130 {
            r.on_step(1.0);
            r.on_radio(&cfg, k * s, Vec2::zeros(), 0.5);
        }
        assert_eq!(r.trust(), 1.0);
    }

    /// Guards the direction: pulls that go back and forth (a radio's noise
    /// around a correct track) cancel in the sum.
    #[test]
    fn pulls_back_and_forth_keep_full_trust() {
        let cfg = on();
        let mut r = RadioIntegrity::default();
        r.restart(&cfg, true);
        for k in 0..100i64 {
            r.on_step(0.7);
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            r.on_radio(&cfg, k * 1_000_000_000, Vec2::new(sign * 2.0, 0.0), 0.5);
            assert!(r.trust() == 1.0, "trust {} at {k}", r.trust());
        }
    }

    /// Off, or a global start without `after_global_start`: trust 1
    /// whatever the pulls.
    #[test]
    fn unchecked_clouds_keep_full_trust() {
        let mut r = RadioIntegrity::default();
        let global_off = IntegrityConfig {
            after_global_start: false,
            ..on()
        };
        for (cfg, told) in [(IntegrityConfig::default(), true), (global_off, false)] {
            r.restart(&cfg, told);
            for k in 0..50i64 {
                r.on_radio(&cfg, k * 1_000_000_000, Vec2::new(5.0, 0.0), 0.1);
            }
            assert_eq!(r.trust(), 1.0);
        }
    }

    /// Guards the fit check: a fit within the free level keeps full
    /// trust, a misfit well beyond it drops the trust to its floor within
    /// a few updates, the fit coming back restores it. The level is
    /// `fit_free_z2_without_map` for a path-loss model, `fit_free_z2`
    /// (0: off) for a radio map; after a global start it reads
    /// nothing unless `fit_after_global_start`.
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
        // a global start: unchecked by default, checked with the flag
        r.restart(&cfg, false);
        for _ in 0..10 {
            r.on_fit(&cfg, 9.0, 1.0);
        }
        assert_eq!(r.trust(), 1.0);
        let global = IntegrityConfig {
            fit_after_global_start: true,
            ..cfg.clone()
        };
        r.restart(&global, false);
        r.on_fit(&global, 9.0, 1.0);
        assert!(r.trust() < 0.05, "trust {}", r.trust());
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
            min_trust: 0.0,
            ..IntegrityConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("tcpf.integrity.min_trust"), "{e}");
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
        p.on_fit(&cfg, cfg.fit_accuracy_free_z2_without_map + 1.0, 1.0);
        let want = cfg.fit_accuracy_m_per_z2_without_map;
        assert!(
            (p.fit_accuracy_m(&cfg) - want).abs() < 1e-9,
            "{}",
            p.fit_accuracy_m(&cfg)
        );
    }
}
