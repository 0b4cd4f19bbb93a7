//! Barometric floor tracking (BMW paper Sec. 3.5-3.7): the standard pressure
//! formula (eq. 25) and its height correction (eq. 26), and the stairs rule of
//! Table 2: while the walker is in a staircase, every step moves the height by
//! one stair height up or down when the barometric height rises or drops, and
//! leaves it unchanged otherwise. The floor is the site floor whose `height_m`
//! is nearest to the tracked height.
//!
//! Two modes (`floor.mode`):
//!
//! * `fused` (default): the barometer is trusted only for height *changes*
//!   (when and how many floors), BLE for *which* floor. The unknown per-log
//!   offset c between barometric height z and the walker's height above the
//!   site reference (weather, phone) is tracked by a histogram filter: c
//!   drifts slowly (random walk) and may jump (rare); each BLE floor vote
//!   ([`FloorTracker::on_ble_floor`]) multiplies the cells c whose implied
//!   floor, nearest to z - c, is the voted one by `ble_floor_correct_prob`
//!   and the others by the rest. The floor is the one with the most mass,
//!   with hysteresis. Without any pressure sample the floor is the latest
//!   BLE vote. BLE votes are ignored while the barometer says the walker is
//!   moving vertically (stairs, lifts).
//! * `stairs`: Table 2 as printed (steps and the barometric trend).
//!
//! Any engine can own a [`FloorTracker`]: feed it pressure samples
//! ([`FloorTracker::on_pressure`]), BLE floor votes
//! ([`FloorTracker::on_ble_floor`]) and steps ([`FloorTracker::on_step`], with
//! whether the current position is in a staircase; pass `true` when the map
//! has no staircase annotation) and read [`FloorTracker::floor`].

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Standard sea-level pressure of eq. 25, hPa (101.325 kPa).
pub const SEA_LEVEL_HPA: f64 = 1013.25;
/// Earth radius R of eq. 26, metres.
pub const EARTH_RADIUS_EQ26_M: f64 = 6_356_766.0;

/// Geopotential height H of eq. 25 from pressure `p_hpa`, metres.
/// `None` for non-finite or non-positive pressure.
pub fn pressure_height_m(p_hpa: f64) -> Option<f64> {
    if !p_hpa.is_finite() || p_hpa <= 0.0 {
        return None;
    }
    // eq. 25 takes kPa: Ps / 101.325 == p_hpa / 1013.25
    Some(44_330.76 * (1.0 - (p_hpa / SEA_LEVEL_HPA).powf(0.190_255)))
}

/// Geometric height h = R H / (R - H) of eq. 26, metres.
pub fn geometric_height_m(h_geopotential_m: f64) -> f64 {
    EARTH_RADIUS_EQ26_M * h_geopotential_m / (EARTH_RADIUS_EQ26_M - h_geopotential_m)
}

/// Barometric height from pressure (eqs. 25-26), metres.
pub fn baro_height_m(p_hpa: f64) -> Option<f64> {
    pressure_height_m(p_hpa).map(geometric_height_m)
}

/// How the tracker turns its inputs into a floor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FloorMode {
    /// Barometric height changes fused with BLE floor votes (histogram filter
    /// over the barometric offset).
    Fused,
    /// BMW Table 2 stairs rule alone, started on the first BLE floor.
    Stairs,
}

/// Which floor a BLE scan votes for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FloorVote {
    /// `BleFrontEnd::likely_floor`: the most common floor among the `top_n`
    /// strongest beacons (the engines' BLE floor).
    Likely,
    /// The floor of the strongest filtered beacon.
    Strongest,
}

/// Floor tracker parameters (`floor` in engine configs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FloorConfig {
    /// `fused` or `stairs` (see the module doc). Default `fused`.
    pub mode: FloorMode,
    /// The BLE floor vote handed to the tracker by engines
    /// ([`FloorTracker::vote`]): `likely` or `strongest`. Default `strongest`
    /// (IPIN 2023 even logs, docs/floors.md).
    pub vote: FloorVote,
    /// Fused mode: probability that a BLE floor vote names the true floor
    /// (the rest is shared by the other floors). Default 0.6 (fitted on the
    /// even IPIN 2023 logs, docs/floors.md).
    pub ble_floor_correct_prob: f64,
    /// Fused mode: correlation time of the BLE floor votes, s: a vote's
    /// evidence is raised to the power min(1, time since the previous vote /
    /// this), so that a long run of one wrong vote (a strong beacon from
    /// another floor) counts as a few votes, not as many. Default 10.0.
    pub ble_vote_correlation_s: f64,
    /// Fused mode: while level, the walker is on a floor: each vote also
    /// weighs an offset by a Gaussian of the implied height's distance to the
    /// nearest floor height, with this sigma, m. Default 0.5 (site floor
    /// heights and barometer bias between phones held in the hand or pocket).
    pub floor_height_sigma_m: f64,
    /// Fused mode: random-walk drift of the barometric offset, m / sqrt(s).
    /// Default 0.01 (weather moves the pressure by ~1 hPa = 8 m per several
    /// hours; 0.01 gives 0.17 m in 5 min).
    pub offset_drift_m_per_sqrt_s: f64,
    /// Fused mode: rate of an offset jump to anywhere (a barometer glitch, a
    /// wrong start), 1/s. Default 1e-4.
    pub offset_jump_rate_per_s: f64,
    /// Fused mode: cell size of the offset histogram, m. Default 0.1.
    pub offset_cell_m: f64,
    /// Fused mode: the offset histogram covers the site's floor heights plus
    /// this margin on either side, m. Default 6.0.
    pub offset_margin_m: f64,
    /// Fused mode: another floor replaces the current one only when its mass
    /// exceeds the current floor's by this much (0..1). Default 0.2.
    pub hysteresis: f64,
    /// h_stair of Table 2: height of one stair step, metres. Default 0.17
    /// (typical riser height; building codes allow 0.15-0.19 m).
    pub stair_height_m: f64,
    /// Time constant of the low-pass filter on the barometric height, s. Default 1.0.
    pub smoothing_tau_s: f64,
    /// Window over which "pressure value rises / drops" is judged, s. Default 2.0.
    pub trend_window_s: f64,
    /// Vertical speed of the smoothed barometric height above which it
    /// "rises" (below its negative: "drops"), m/s. Default 0.08 (stair
    /// climbing is about 0.2-0.3 m/s; barometer noise after smoothing is a few cm/s).
    pub min_vertical_speed_mps: f64,
    /// Floor-to-floor height used when every floor of the site has `height_m` 0,
    /// metres (floors then stack in id order). Default 4.0.
    pub default_floor_spacing_m: f64,
}

impl Default for FloorConfig {
    fn default() -> Self {
        FloorConfig {
            mode: FloorMode::Fused,
            vote: FloorVote::Strongest,
            ble_floor_correct_prob: 0.6,
            ble_vote_correlation_s: 10.0,
            floor_height_sigma_m: 0.5,
            offset_drift_m_per_sqrt_s: 0.01,
            offset_jump_rate_per_s: 1e-4,
            offset_cell_m: 0.1,
            offset_margin_m: 6.0,
            hysteresis: 0.2,
            stair_height_m: 0.17,
            smoothing_tau_s: 1.0,
            trend_window_s: 2.0,
            min_vertical_speed_mps: 0.08,
            default_floor_spacing_m: 4.0,
        }
    }
}

impl FloorConfig {
    /// Checks every field's range, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        let pos = |v: f64, f: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("floor.{f}"),
                    "must be finite and > 0",
                ))
            }
        };
        let unit = |v: f64, f: &str| {
            if v.is_finite() && (0.0..1.0).contains(&v) {
                Ok(())
            } else {
                Err(Error::config(format!("floor.{f}"), "must be in [0, 1)"))
            }
        };
        let non_neg = |v: f64, f: &str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("floor.{f}"),
                    "must be finite and >= 0",
                ))
            }
        };
        if !(self.ble_floor_correct_prob.is_finite()
            && self.ble_floor_correct_prob > 0.0
            && self.ble_floor_correct_prob < 1.0)
        {
            return Err(Error::config(
                "floor.ble_floor_correct_prob",
                "must be in (0, 1)",
            ));
        }
        non_neg(self.ble_vote_correlation_s, "ble_vote_correlation_s")?;
        pos(self.floor_height_sigma_m, "floor_height_sigma_m")?;
        non_neg(self.offset_drift_m_per_sqrt_s, "offset_drift_m_per_sqrt_s")?;
        non_neg(self.offset_jump_rate_per_s, "offset_jump_rate_per_s")?;
        pos(self.offset_cell_m, "offset_cell_m")?;
        non_neg(self.offset_margin_m, "offset_margin_m")?;
        unit(self.hysteresis, "hysteresis")?;
        pos(self.stair_height_m, "stair_height_m")?;
        pos(self.smoothing_tau_s, "smoothing_tau_s")?;
        pos(self.trend_window_s, "trend_window_s")?;
        pos(self.min_vertical_speed_mps, "min_vertical_speed_mps")?;
        pos(self.default_floor_spacing_m, "default_floor_spacing_m")
    }
}

/// Vertical movement judged from the barometer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trend {
    Rises,
    Drops,
    Level,
}

/// The fused mode's histogram over the barometric offset c = z - h, where z
/// is the smoothed barometric height and h the walker's height above the
/// site reference. Cell i holds c = base + i * cell.
#[derive(Debug, Clone)]
struct OffsetFilter {
    base: f64,
    cell: f64,
    p: Vec<f64>,
    /// Time of the last prediction.
    t_ns: Option<i64>,
}

impl OffsetFilter {
    /// Uniform over offsets putting the walker anywhere from `margin` below
    /// the lowest to `margin` above the highest floor, at barometric height `z`.
    fn new(cfg: &FloorConfig, floors: &[(i32, f64)], z: f64) -> Self {
        let lo = floors.first().map_or(0.0, |f| f.1) - cfg.offset_margin_m;
        let hi = floors.last().map_or(0.0, |f| f.1) + cfg.offset_margin_m;
        let n = (((hi - lo) / cfg.offset_cell_m).ceil() as usize).clamp(1, 100_000);
        OffsetFilter {
            base: z - hi,
            cell: cfg.offset_cell_m,
            p: vec![1.0 / n as f64; n],
            t_ns: None,
        }
    }

    fn offset(&self, i: usize) -> f64 {
        self.base + (i as f64 + 0.5) * self.cell
    }

    /// Drift (3-tap diffusion, repeated as needed) and jumps over `dt` s.
    fn predict(&mut self, cfg: &FloorConfig, t_ns: i64) {
        let dt = match self.t_ns {
            Some(t0) if t_ns > t0 => (t_ns - t0) as f64 * 1e-9,
            Some(_) => return,
            None => 0.0,
        };
        self.t_ns = Some(t_ns);
        if dt <= 0.0 {
            return;
        }
        let n = self.p.len();
        let var_cells = cfg.offset_drift_m_per_sqrt_s.powi(2) * dt / (self.cell * self.cell);
        if var_cells > 0.0 && n > 1 {
            // each pass of [a, 1 - 2a, a] adds variance 2a cells^2; a <= 0.25
            let passes = (var_cells / 0.5).ceil().min(1000.0) as usize;
            let a = var_cells / (2.0 * passes as f64);
            let mut q = vec![0.0; n];
            for _ in 0..passes {
                for (k, qk) in q.iter_mut().enumerate() {
                    let l = self.p[k.saturating_sub(1)];
                    let r = self.p[(k + 1).min(n - 1)];
                    *qk = (1.0 - 2.0 * a) * self.p[k] + a * (l + r);
                }
                std::mem::swap(&mut self.p, &mut q);
            }
        }
        let jump = 1.0 - (-cfg.offset_jump_rate_per_s * dt).exp();
        let u = 1.0 / n as f64;
        for v in &mut self.p {
            *v = (1.0 - jump) * *v + jump * u;
        }
        self.normalise();
    }

    fn normalise(&mut self) {
        let s: f64 = self.p.iter().sum();
        if s.is_finite() && s > 0.0 {
            for v in &mut self.p {
                *v /= s;
            }
        } else {
            let u = 1.0 / self.p.len() as f64;
            self.p.iter_mut().for_each(|v| *v = u);
        }
    }
}

/// Tracks the walker's height and floor: barometer changes fused with BLE
/// floor votes (`fused`), or the Table 2 stairs rule (`stairs`).
#[derive(Debug, Clone)]
pub struct FloorTracker {
    cfg: FloorConfig,
    /// (floor id, height above the site reference, m), sorted by height.
    floors: Vec<(i32, f64)>,
    /// Smoothed barometric height and the time of the last pressure sample.
    smoothed: Option<(i64, f64)>,
    /// Recent (t_ns, smoothed height) samples inside the trend window.
    history: VecDeque<(i64, f64)>,
    /// h_t of Table 2, metres above the site reference (stairs mode).
    height_m: f64,
    /// Fused mode: offset histogram (built at the first pressure sample).
    offset: Option<OffsetFilter>,
    /// Fused mode: the floor reported (with hysteresis), and the latest BLE vote.
    current: Option<i32>,
    last_ble: Option<i32>,
    /// Time of the last BLE vote used by the fused mode.
    last_vote_t_ns: Option<i64>,
    /// Start floor given at construction or by `reset_to_floor`.
    start: i32,
    /// Whether the start floor came from `reset_to_floor` (stairs mode: the
    /// first BLE vote does not override it).
    start_fixed: bool,
    /// Samples rejected (non-finite, non-positive or out of time order).
    pub rejected: u64,
    /// Steps that moved the height (stairs up or down).
    pub stair_steps: u64,
    /// BLE floor votes used / ignored because the barometer showed vertical motion.
    pub ble_votes: u64,
    pub ble_votes_ignored: u64,
}

impl FloorTracker {
    /// A tracker over `floors` (id, height_m), starting on `start_floor`.
    /// When every height is 0 the floors stack in id order at
    /// `default_floor_spacing_m`.
    pub fn new(cfg: &FloorConfig, floors: &[(i32, f64)], start_floor: i32) -> Self {
        let mut fl: Vec<(i32, f64)> = floors
            .iter()
            .copied()
            .filter(|(_, h)| h.is_finite())
            .collect();
        if fl.iter().all(|(_, h)| *h == 0.0) {
            fl.sort_by_key(|(id, _)| *id);
            for (i, f) in fl.iter_mut().enumerate() {
                f.1 = i as f64 * cfg.default_floor_spacing_m;
            }
        }
        fl.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        let height_m = fl
            .iter()
            .find(|(id, _)| *id == start_floor)
            .map(|(_, h)| *h)
            .unwrap_or(0.0);
        FloorTracker {
            cfg: cfg.clone(),
            floors: fl,
            smoothed: None,
            history: VecDeque::new(),
            height_m,
            offset: None,
            current: None,
            last_ble: None,
            last_vote_t_ns: None,
            start: start_floor,
            start_fixed: false,
            rejected: 0,
            stair_steps: 0,
            ble_votes: 0,
            ble_votes_ignored: 0,
        }
    }

    fn floor_height(&self, floor: i32) -> Option<f64> {
        self.floors.iter().find(|(id, _)| *id == floor).map(|f| f.1)
    }

    /// The floor nearest to height `h` (floors sorted by height).
    fn nearest(&self, h: f64) -> Option<i32> {
        self.floors
            .iter()
            .min_by(|a, b| (a.1 - h).abs().total_cmp(&(b.1 - h).abs()))
            .map(|(id, _)| *id)
    }

    /// Moves the tracked height to `floor` (e.g. when the start position is
    /// known). Fused mode: the offset histogram is concentrated on the
    /// offsets that put the walker on `floor` now.
    pub fn reset_to_floor(&mut self, floor: i32) {
        let Some(h) = self.floor_height(floor) else {
            return;
        };
        self.height_m = h;
        self.start = floor;
        self.start_fixed = true;
        self.current = Some(floor);
        if let (Some(of), Some((_, z))) = (self.offset.as_mut(), self.smoothed) {
            let n = of.p.len();
            // a strong prior, not a certainty: a wrong start (a wrong tap) is
            // voted out by BLE within tens of seconds
            let eps = 0.01;
            for i in 0..n {
                let c = of.offset(i);
                of.p[i] = eps;
                let u = z - c;
                // cells whose nearest floor is `floor`
                let near = self
                    .floors
                    .iter()
                    .min_by(|a, b| (a.1 - u).abs().total_cmp(&(b.1 - u).abs()))
                    .map(|f| f.0);
                if near == Some(floor) {
                    of.p[i] += 1.0;
                }
            }
            of.normalise();
        }
    }

    /// Whether at least one pressure sample has been accepted.
    pub fn has_pressure(&self) -> bool {
        self.smoothed.is_some()
    }

    /// One pressure sample, hPa.
    pub fn on_pressure(&mut self, t_ns: i64, p_hpa: f64) {
        let Some(h) = baro_height_m(p_hpa) else {
            self.rejected += 1;
            return;
        };
        let s = match self.smoothed {
            None => h,
            Some((t0, _)) if t_ns <= t0 => {
                self.rejected += 1;
                return;
            }
            Some((t0, s0)) => {
                let dt = (t_ns - t0) as f64 * 1e-9;
                let a = 1.0 - (-dt / self.cfg.smoothing_tau_s).exp();
                s0 + a * (h - s0)
            }
        };
        self.smoothed = Some((t_ns, s));
        self.history.push_back((t_ns, s));
        let window_ns = (self.cfg.trend_window_s * 1e9) as i64;
        while self
            .history
            .front()
            .is_some_and(|(t, _)| t_ns - *t > window_ns)
        {
            self.history.pop_front();
        }
        if self.cfg.mode == FloorMode::Fused {
            if self.offset.is_none() {
                self.offset = Some(OffsetFilter::new(&self.cfg, &self.floors, s));
                // a floor known before the barometer (start position or BLE) carries over
                if let Some(f) = self.current.or(self.start_fixed.then_some(self.start)) {
                    self.reset_to_floor(f);
                }
            }
            self.refresh();
        }
    }

    /// Fused mode: the mass of each floor at the current barometric height.
    fn floor_masses(&self) -> Vec<(i32, f64)> {
        let mut m: Vec<(i32, f64)> = self.floors.iter().map(|f| (f.0, 0.0)).collect();
        if let (Some(of), Some((_, z))) = (self.offset.as_ref(), self.smoothed) {
            for (i, p) in of.p.iter().enumerate() {
                let u = z - of.offset(i);
                if let Some(f) = self.nearest(u)
                    && let Some(e) = m.iter_mut().find(|e| e.0 == f)
                {
                    e.1 += p;
                }
            }
        }
        m
    }

    /// Fused mode: re-reads the floor with hysteresis.
    fn refresh(&mut self) {
        if self.offset.is_none() {
            return;
        }
        let m = self.floor_masses();
        let Some(best) = m.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1)) else {
            return;
        };
        let cur = self
            .current
            .and_then(|c| m.iter().find(|e| e.0 == c).copied());
        self.current = Some(match cur {
            Some(c) if best.1 <= c.1 + self.cfg.hysteresis => c.0,
            _ => best.0,
        });
    }

    /// The tracker's config (`floor`).
    pub fn config(&self) -> &FloorConfig {
        &self.cfg
    }

    /// One BLE floor vote (e.g. the BLE front end's `floor_vote`) at `t_ns`.
    pub fn on_ble_floor(&mut self, t_ns: i64, floor: i32) {
        if self.floor_height(floor).is_none() {
            return;
        }
        self.last_ble = Some(floor);
        match self.cfg.mode {
            FloorMode::Stairs => {
                if !self.start_fixed {
                    self.reset_to_floor(floor);
                }
            }
            FloorMode::Fused => {
                let Some(z) = self.smoothed.map(|s| s.1) else {
                    return;
                };
                if self.trend() != Trend::Level {
                    self.ble_votes_ignored += 1;
                    return;
                }
                self.ble_votes += 1;
                let w = match self.last_vote_t_ns {
                    Some(t0) if self.cfg.ble_vote_correlation_s > 0.0 => {
                        ((t_ns - t0) as f64 * 1e-9 / self.cfg.ble_vote_correlation_s)
                            .clamp(0.0, 1.0)
                    }
                    _ => 1.0,
                };
                self.last_vote_t_ns = Some(t_ns);
                let n_floors = self.floors.len().max(2) as f64;
                let p_ok = self.cfg.ble_floor_correct_prob.powf(w);
                let p_bad = ((1.0 - self.cfg.ble_floor_correct_prob) / (n_floors - 1.0)).powf(w);
                let cfg = self.cfg.clone();
                let floors = self.floors.clone();
                let Some(of) = self.offset.as_mut() else {
                    return;
                };
                of.predict(&cfg, t_ns);
                let s2 = 2.0 * cfg.floor_height_sigma_m.powi(2);
                for i in 0..of.p.len() {
                    let u = z - of.offset(i);
                    let Some(near) = floors
                        .iter()
                        .min_by(|a, b| (a.1 - u).abs().total_cmp(&(b.1 - u).abs()))
                    else {
                        continue;
                    };
                    let vote = if near.0 == floor { p_ok } else { p_bad };
                    let on_floor = (-(u - near.1).powi(2) / s2 * w).exp();
                    of.p[i] *= vote * on_floor;
                }
                of.normalise();
                self.refresh();
            }
        }
    }

    /// "Pressure value rises / drops" of Table 2, read as the barometric
    /// height's trend over the last `trend_window_s`.
    pub fn trend(&self) -> Trend {
        let (Some(first), Some(last)) = (self.history.front(), self.history.back()) else {
            return Trend::Level;
        };
        let dt = (last.0 - first.0) as f64 * 1e-9;
        if dt < 0.5 * self.cfg.trend_window_s {
            return Trend::Level;
        }
        let v = (last.1 - first.1) / dt;
        if v > self.cfg.min_vertical_speed_mps {
            Trend::Rises
        } else if v < -self.cfg.min_vertical_speed_mps {
            Trend::Drops
        } else {
            Trend::Level
        }
    }

    /// One detected step; `in_staircase` says whether the current position is
    /// in a staircase (Table 2 line 1). Only the stairs mode uses steps.
    pub fn on_step(&mut self, in_staircase: bool) {
        if !in_staircase || self.cfg.mode != FloorMode::Stairs {
            return;
        }
        match self.trend() {
            Trend::Rises => {
                self.height_m += self.cfg.stair_height_m;
                self.stair_steps += 1;
            }
            Trend::Drops => {
                self.height_m -= self.cfg.stair_height_m;
                self.stair_steps += 1;
            }
            Trend::Level => {}
        }
    }

    /// The walker's height above the site reference, m: h_t of Table 2
    /// (stairs mode) or z minus the mean offset (fused mode, once it has pressure).
    pub fn height_m(&self) -> f64 {
        match (self.cfg.mode, self.offset.as_ref(), self.smoothed) {
            (FloorMode::Fused, Some(of), Some((_, z))) => {
                let c: f64 = of.p.iter().enumerate().map(|(i, p)| p * of.offset(i)).sum();
                z - c
            }
            _ => self.height_m,
        }
    }

    /// The tracked floor (`None` for a site without floors). Fused mode:
    /// the floor with the most mass (hysteresis), or without pressure the
    /// latest BLE vote, else the start floor. Stairs mode: the floor nearest
    /// to the tracked height.
    pub fn floor(&self) -> Option<i32> {
        if self.floors.is_empty() {
            return None;
        }
        match self.cfg.mode {
            FloorMode::Stairs => self.nearest(self.height_m),
            FloorMode::Fused => {
                if self.offset.is_some() && (self.ble_votes > 0 || self.start_fixed) {
                    self.current
                } else {
                    self.last_ble
                        .or(self.floor_height(self.start).map(|_| self.start))
                }
                .or_else(|| self.nearest(self.height_m))
            }
        }
    }
}

#[cfg(test)]
mod tests;
