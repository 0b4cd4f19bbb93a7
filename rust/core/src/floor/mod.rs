//! Barometric floor tracking (BMW paper Sec. 3.5-3.7): the standard pressure
//! formula (eq. 25) and its height correction (eq. 26), and the stairs rule of
//! Table 2: while the walker is in a staircase, every step moves the height by
//! one stair height up or down when the barometric height rises or drops, and
//! leaves it unchanged otherwise. The floor is the site floor whose `height_m`
//! is nearest to the tracked height.
//!
//! Any engine can own a [`FloorTracker`]: feed it pressure samples
//! ([`FloorTracker::on_pressure`]) and steps ([`FloorTracker::on_step`], with
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

/// Floor tracker parameters (`floor` in engine configs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FloorConfig {
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

/// Tracks the walker's height and floor with the Table 2 stairs rule.
#[derive(Debug, Clone)]
pub struct FloorTracker {
    cfg: FloorConfig,
    /// (floor id, height above the site reference, m), sorted by height.
    floors: Vec<(i32, f64)>,
    /// Smoothed barometric height and the time of the last pressure sample.
    smoothed: Option<(i64, f64)>,
    /// Recent (t_ns, smoothed height) samples inside the trend window.
    history: VecDeque<(i64, f64)>,
    /// h_t of Table 2, metres above the site reference.
    height_m: f64,
    /// Samples rejected (non-finite, non-positive or out of time order).
    pub rejected: u64,
    /// Steps that moved the height (stairs up or down).
    pub stair_steps: u64,
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
            rejected: 0,
            stair_steps: 0,
        }
    }

    /// A tracker over the floors of a site.
    pub fn for_site(cfg: &FloorConfig, site: &crate::site::Site, start_floor: i32) -> Self {
        let floors: Vec<(i32, f64)> = site
            .spec
            .floors
            .iter()
            .map(|f| (f.id, f.height_m))
            .collect();
        Self::new(cfg, &floors, start_floor)
    }

    /// Moves the tracked height to `floor` (e.g. when another source, such
    /// as BLE, fixes the floor at start).
    pub fn reset_to_floor(&mut self, floor: i32) {
        if let Some((_, h)) = self.floors.iter().find(|(id, _)| *id == floor) {
            self.height_m = *h;
        }
    }

    /// One pressure sample, hPa.
    /// Whether at least one pressure sample has been accepted.
    pub fn has_pressure(&self) -> bool {
        self.smoothed.is_some()
    }

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
    /// in a staircase (Table 2 line 1).
    pub fn on_step(&mut self, in_staircase: bool) {
        if !in_staircase {
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

    /// h_t, metres above the site reference.
    pub fn height_m(&self) -> f64 {
        self.height_m
    }

    /// The floor nearest to the tracked height (`None` for a site without floors).
    pub fn floor(&self) -> Option<i32> {
        self.floors
            .iter()
            .min_by(|a, b| {
                (a.1 - self.height_m)
                    .abs()
                    .total_cmp(&(b.1 - self.height_m).abs())
            })
            .map(|(id, _)| *id)
    }
}

#[cfg(test)]
mod tests;
