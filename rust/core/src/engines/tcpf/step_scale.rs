//! The user's step length, learned online (`tcpf.online_step`; off by
//! default: docs/lab/tcpf-history.md "Stop 32").
//!
//! The PDR's step length comes from one global Weinberg constant fitted on
//! the survey walkers; a user's steps can be a quarter longer or shorter.
//! The per-particle step scales do not learn it: walls kill the particles
//! that travel further, so they select short steps
//! (docs/lab/tcpf-history.md "Stop 31"). This is a cloud-level estimate
//! instead, like the phone's RSSI offset: over windows of `window_m` walked while the cloud stays
//! converged, the scale of the similarity (rotation, scale, shift) that
//! best carries the PDR's raw track onto the track of the cloud's mean;
//! the estimate is the walked-length-weighted mean of the windows' scales
//! with an exponential memory in metres walked, starting at 1. The engine
//! multiplies every step by it, which makes it a fixed-point iteration:
//! while the radio keeps pulling the cloud ahead of its steps the scale
//! grows, until the steps carry the cloud where the radio has it.
//!
//! Measured (docs/lab/tcpf-history.md "Stop 32"): on the real sites the
//! radio pulls the walking cloud back, not ahead (it hears where the
//! walker was), on ILC F1 as on IPIN, so the iteration settles below 1 on
//! both sites and does not find the IPIN walkers' longer steps.

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::Vec2;

/// Settings of the online step-length scale (docs/parameters.md "tcpf").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OnlineStepConfig {
    /// Whether the scale is learned (false: every step as the PDR gives it).
    pub enabled: bool,
    /// A window is scored once the PDR has walked this far in it, m.
    pub window_m: f64,
    /// ... and only when the PDR track's RMS distance from its centroid
    /// is at least this share of `window_m` (not paced on the spot; a
    /// straight walk has 0.29).
    pub min_extent: f64,
    /// ... and only while the cloud's RMS spread stays at most this, m
    /// (and nothing moved the cloud but its steps and the radio).
    pub max_spread_m: f64,
    /// ... and when the walls killed at most this share of the cloud per
    /// step on average over the window (1 = any): a wall stopping an
    /// overshooting cloud is evidence, but only ever toward short steps.
    pub max_wall_kill: f64,
    /// Memory of the estimate, metres walked (exponential forgetting).
    pub memory_m: f64,
    /// The start: scale 1 with the weight of this many metres walked.
    pub prior_m: f64,
    /// One window's scale is clamped to [1 / r, r] before it counts.
    pub max_window_ratio: f64,
    /// The estimate is clamped to [min_scale, max_scale].
    pub min_scale: f64,
    pub max_scale: f64,
}

impl Default for OnlineStepConfig {
    fn default() -> Self {
        OnlineStepConfig {
            enabled: false,
            window_m: 30.0,
            min_extent: 0.1,
            max_spread_m: 4.0,
            max_wall_kill: 1.0,
            memory_m: 150.0,
            prior_m: 30.0,
            max_window_ratio: 1.6,
            min_scale: 0.7,
            max_scale: 1.4,
        }
    }
}

impl OnlineStepConfig {
    /// Checks every field; errors name `tcpf.online_step.<field>`.
    pub fn validate(&self) -> Result<()> {
        for (f, v, lo, hi) in [
            ("window_m", self.window_m, 0.5, 1000.0),
            ("min_extent", self.min_extent, 0.0, 1.0),
            ("max_spread_m", self.max_spread_m, 0.0, 1000.0),
            ("max_wall_kill", self.max_wall_kill, 0.0, 1.0),
            ("memory_m", self.memory_m, 1.0, 1e6),
            ("prior_m", self.prior_m, 0.01, 1e6),
            ("max_window_ratio", self.max_window_ratio, 1.0, 10.0),
            ("min_scale", self.min_scale, 0.1, 1.0),
            ("max_scale", self.max_scale, 1.0, 10.0),
        ] {
            crate::bounds::check_range(&format!("tcpf.online_step.{f}"), v, lo, hi)?;
        }
        Ok(())
    }
}

/// One fusion run of the current window: the cloud's mean and the PDR's
/// raw dead-reckoned position (its steps summed from the window's start).
#[derive(Debug, Clone, Copy)]
struct Pair {
    cloud: Vec2,
    pdr: Vec2,
}

/// The online step-length scale.
#[derive(Debug, Clone, Default)]
pub struct OnlineStep {
    cfg: OnlineStepConfig,
    /// Exponentially weighted sums of the windows' scales times their
    /// walked length, and of their walked lengths, m.
    scaled_m: f64,
    walked_sum_m: f64,
    /// Since the window's start: the PDR's raw position, walked length,
    /// steps and the walls' kills (share of the cloud per step, summed).
    pdr: Vec2,
    walked_m: f64,
    steps: u32,
    kill_sum: f64,
    window: Vec<Pair>,
    /// Windows scored.
    pub windows: u64,
}

impl OnlineStep {
    pub fn new(cfg: &OnlineStepConfig) -> Self {
        OnlineStep {
            cfg: cfg.clone(),
            scaled_m: cfg.prior_m,
            walked_sum_m: cfg.prior_m,
            ..OnlineStep::default()
        }
    }

    /// The factor every PDR step is multiplied by (1 when off).
    pub fn scale(&self) -> f64 {
        if !self.cfg.enabled {
            return 1.0;
        }
        (self.scaled_m / self.walked_sum_m).clamp(self.cfg.min_scale, self.cfg.max_scale)
    }

    /// One raw PDR step (before the scale) and the share of the cloud the
    /// walls killed on it.
    pub fn on_step(&mut self, length_m: f64, yaw_rad: f64, wall_kill: f64) {
        if self.window.is_empty() {
            return;
        }
        self.pdr += Vec2::new(yaw_rad.cos(), yaw_rad.sin()) * length_m;
        self.walked_m += length_m;
        self.steps += 1;
        self.kill_sum += wall_kill;
    }

    /// After a fusion run: the cloud's mean and spread, and whether the
    /// cloud moved other than by its steps and the radio since the last
    /// run (a start, re-seeding, floor change, undone step). Scores the
    /// window once the PDR has walked `window_m` in it and starts the
    /// next; a spread cloud or a jump drops the window.
    pub fn on_fusion(&mut self, mean: Option<Vec2>, spread_m: f64, discontinuity: bool) {
        if !self.cfg.enabled {
            return;
        }
        let Some(mean) = mean.filter(|_| !discontinuity && spread_m <= self.cfg.max_spread_m)
        else {
            self.restart(None);
            return;
        };
        self.window.push(Pair {
            cloud: mean,
            pdr: self.pdr,
        });
        if self.walked_m < self.cfg.window_m {
            return;
        }
        let kill = self.kill_sum / f64::from(self.steps.max(1));
        if let Some((s, extent_m)) = similarity_scale(&self.window)
            && kill <= self.cfg.max_wall_kill
            && extent_m >= self.cfg.min_extent * self.cfg.window_m
        {
            let r = self.cfg.max_window_ratio;
            let keep = (-self.walked_m / self.cfg.memory_m).exp();
            self.scaled_m = keep * self.scaled_m + s.clamp(1.0 / r, r) * self.walked_m;
            self.walked_sum_m = keep * self.walked_sum_m + self.walked_m;
            self.windows += 1;
        }
        self.restart(Some(mean));
    }

    /// Drops the current window (the cloud was put somewhere).
    pub fn drop_window(&mut self) {
        self.restart(None);
    }

    /// A new window, starting at `at` (none: at the next usable run).
    fn restart(&mut self, at: Option<Vec2>) {
        self.window.clear();
        self.window.extend(at.map(|cloud| Pair {
            cloud,
            pdr: Vec2::zeros(),
        }));
        (self.pdr, self.walked_m, self.steps, self.kill_sum) = (Vec2::zeros(), 0.0, 0, 0.0);
    }
}

/// The scale of the least-squares similarity (rotation, scale, shift)
/// that carries the PDR track onto the cloud's (2-D Procrustes: with
/// complex z = cloud - its mean, w = pdr - its mean, a = sum z conj(w) /
/// sum |w|^2, the scale |a|), and the PDR track's RMS extent, m. `None`
/// when the PDR did not move.
fn similarity_scale(pairs: &[Pair]) -> Option<(f64, f64)> {
    let n = pairs.len() as f64;
    let (cm, pm) = pairs
        .iter()
        .fold((Vec2::zeros(), Vec2::zeros()), |(c, p), q| {
            (c + q.cloud / n, p + q.pdr / n)
        });
    let (mut re, mut im, mut ww) = (0.0, 0.0, 0.0);
    for q in pairs {
        let (z, w) = (q.cloud - cm, q.pdr - pm);
        re += z.x * w.x + z.y * w.y;
        im += z.y * w.x - z.x * w.y;
        ww += w.norm_squared();
    }
    (ww > 1e-9).then(|| (re.hypot(im) / ww, (ww / n).sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A walk of straight legs (14 steps, then a right-angle turn) at two
    /// steps a second, one fusion run per step; the PDR's steps are
    /// `pdr_ratio` of the walker's 0.7 m, rotated by 0.1 rad (a heading
    /// bias the fit absorbs). The "cloud" moves by the scaled steps and
    /// then `pull` of the way to the walker (the radio). Returns the scale
    /// after each step.
    fn walk(cfg: &OnlineStepConfig, pdr_ratio: f64, pull: f64, steps: usize) -> Vec<f64> {
        let mut est = OnlineStep::new(cfg);
        let (mut truth, mut cloud) = (Vec2::zeros(), Vec2::zeros());
        let mut out = Vec::new();
        for i in 0..steps {
            // a staircase: east, north, east, south, ...
            let yaw = std::f64::consts::FRAC_PI_2 * [0.0, 1.0, 0.0, -1.0][(i / 14) % 4];
            let (len, pdr_len) = (0.7, 0.7 * pdr_ratio);
            truth += Vec2::new(yaw.cos(), yaw.sin()) * len;
            cloud += Vec2::new(yaw.cos(), yaw.sin()) * (pdr_len * est.scale());
            cloud += (truth - cloud) * pull;
            est.on_step(pdr_len, yaw + 0.1, 0.0);
            est.on_fusion(Some(cloud), 1.0, false);
            out.push(est.scale());
        }
        out
    }

    fn on() -> OnlineStepConfig {
        OnlineStepConfig {
            enabled: true,
            ..OnlineStepConfig::default()
        }
    }

    #[test]
    fn steps_a_quarter_short_converge_near_1_25() {
        // PDR steps 0.8 of the walker's: the scale that makes them true
        // is 1.25; a radio closing 10 % of the gap per step leads there
        let s = walk(&on(), 0.8, 0.1, 1200);
        let (after_5_min, end) = (s[599], s[1199]);
        assert!((after_5_min - 1.25).abs() < 0.05, "5 min: {after_5_min:.3}");
        assert!((end - 1.25).abs() < 0.02, "10 min: {end:.3}");
        // slowly: after 30 s (one window, weighed as much as the prior)
        // about half way
        assert!((1.05..1.15).contains(&s[59]), "30 s: {:.3}", s[59]);
        // true steps stay at 1, long ones go below, and the clamp holds
        let end = |r: f64| *walk(&on(), r, 0.1, 1200).last().unwrap();
        assert!((end(1.0) - 1.0).abs() < 0.01, "{:.3}", end(1.0));
        assert!((end(1.2) - 1.0 / 1.2).abs() < 0.02, "{:.3}", end(1.2));
        assert_eq!(end(0.5), 1.4);
        // off: always 1
        let off = OnlineStepConfig::default();
        assert!(walk(&off, 0.8, 0.1, 600).iter().all(|s| *s == 1.0));
    }

    #[test]
    fn spread_jumps_walls_and_pacing_give_no_window() {
        // 100 m east at 0.5 m per PDR step, the cloud moving 0.9 m a step
        let run = |spread: f64, jump: bool, kill: f64, cfg: OnlineStepConfig| {
            let mut est = OnlineStep::new(&cfg);
            let mut cloud = Vec2::zeros();
            for _ in 0..200 {
                cloud.x += 0.9;
                est.on_step(0.5, 0.0, kill);
                est.on_fusion(Some(cloud), spread, jump);
            }
            (est.windows, est.scale())
        };
        let gate = OnlineStepConfig {
            max_wall_kill: 0.2,
            ..on()
        };
        assert_eq!(run(6.0, false, 0.0, gate.clone()), (0, 1.0));
        assert_eq!(run(1.0, true, 0.0, gate.clone()), (0, 1.0));
        assert_eq!(run(1.0, false, 0.5, gate.clone()), (0, 1.0));
        let (n, s) = run(1.0, false, 0.1, gate);
        assert!(n == 3 && s > 1.3, "{n} windows, scale {s:.3}");
        // pacing back and forth on the spot: the PDR track spans nothing
        let mut est = OnlineStep::new(&on());
        for i in 0..400 {
            let yaw = if i % 2 == 0 {
                0.0
            } else {
                std::f64::consts::PI
            };
            est.on_step(0.5, yaw, 0.0);
            est.on_fusion(Some(Vec2::new(0.1 * f64::from(i % 7), 0.0)), 1.0, false);
        }
        assert_eq!((est.windows, est.scale()), (0, 1.0));
    }
}
