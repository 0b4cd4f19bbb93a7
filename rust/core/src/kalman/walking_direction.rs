//! Walking direction of the TC paper (eq. 9): the phone's orientation and a
//! heading derived from BLE positions are compared over a short window; when
//! they agree (the walker goes straight) the step takes the BLE heading,
//! otherwise (a turn, a sidestep) the phone's. The BLE heading is the
//! direction of the least-squares line through the BLE positions of the
//! window, oriented from the first to the last one. Eqs. 10-11 (re-basing
//! the phone heading on the BLE heading plus a bias from the regressed
//! track) correspond here to tc-ekf's heading-error state dtheta, which the
//! position updates already estimate; they are not a separate step.

use std::collections::VecDeque;

use crate::Vec2;

use crate::geometry::wrap_pi as wrap;

/// Eq. 9 state: recent BLE positions and phone headings.
#[derive(Debug, Clone)]
pub struct WalkingDirection {
    window_s: f64,
    threshold_rad: f64,
    min_travel_m: f64,
    ble: VecDeque<(f64, Vec2)>,
    phone: VecDeque<(f64, f64)>,
    /// Steps that took the BLE heading.
    pub ble_steps: u64,
}

impl WalkingDirection {
    /// `window_s`: the comparison window (the paper's 3 s); `threshold_rad`:
    /// theta_T, applied to the mean absolute difference over the window;
    /// `min_travel_m`: the BLE positions of the window must span at least this.
    pub fn new(window_s: f64, threshold_rad: f64, min_travel_m: f64) -> Self {
        WalkingDirection {
            window_s,
            threshold_rad,
            min_travel_m,
            ble: VecDeque::new(),
            phone: VecDeque::new(),
            ble_steps: 0,
        }
    }

    fn trim(&mut self, t_s: f64) {
        let from = t_s - self.window_s;
        while self.ble.front().is_some_and(|(t, _)| *t < from) {
            self.ble.pop_front();
        }
        while self.phone.front().is_some_and(|(t, _)| *t < from) {
            self.phone.pop_front();
        }
    }

    /// A BLE position at `t_s` (seconds, non-decreasing).
    pub fn on_ble_position(&mut self, t_s: f64, pos: Vec2) {
        if t_s.is_finite() && pos.x.is_finite() && pos.y.is_finite() {
            self.ble.push_back((t_s, pos));
            self.trim(t_s);
        }
    }

    /// theta_BLE: direction of the principal axis of the window's BLE
    /// positions, oriented first -> last; None with fewer than 3 positions or
    /// less than `min_travel_m` between the first and the last.
    pub fn ble_heading(&self) -> Option<f64> {
        if self.ble.len() < 3 {
            return None;
        }
        let (first, last) = (self.ble.front()?.1, self.ble.back()?.1);
        let travel = last - first;
        if travel.norm() < self.min_travel_m {
            return None;
        }
        let n = self.ble.len() as f64;
        let mean = self.ble.iter().map(|(_, p)| *p).sum::<Vec2>() / n;
        let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
        for (_, p) in &self.ble {
            let d = p - mean;
            sxx += d.x * d.x;
            syy += d.y * d.y;
            sxy += d.x * d.y;
        }
        let axis = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let dir = Vec2::new(axis.cos(), axis.sin());
        Some(if dir.dot(&travel) >= 0.0 {
            axis
        } else {
            wrap(axis + std::f64::consts::PI)
        })
    }

    /// Eq. 9 for one step at `t_s` whose phone heading is `phone_rad`:
    /// the BLE heading when it agrees with the window's phone headings
    /// within theta_T on average, else `phone_rad`.
    pub fn direction(&mut self, t_s: f64, phone_rad: f64) -> f64 {
        if !(t_s.is_finite() && phone_rad.is_finite()) {
            return phone_rad;
        }
        self.phone.push_back((t_s, phone_rad));
        self.trim(t_s);
        let Some(ble) = self.ble_heading() else {
            return phone_rad;
        };
        let mean_abs = self
            .phone
            .iter()
            .map(|(_, h)| wrap(ble - h).abs())
            .sum::<f64>()
            / self.phone.len() as f64;
        if mean_abs < self.threshold_rad {
            self.ble_steps += 1;
            ble
        } else {
            phone_rad
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn east_track(w: &mut WalkingDirection, t0: f64, secs: usize) {
        for k in 0..=secs {
            let t = t0 + k as f64;
            // 1.2 m/s east with +-0.5 m of lateral BLE scatter
            let y = if k % 2 == 0 { 0.5 } else { -0.5 };
            w.on_ble_position(t, Vec2::new(1.2 * t, 10.0 + y));
        }
    }

    #[test]
    fn straight_walk_takes_the_ble_heading() {
        let mut w = WalkingDirection::new(3.0, 20f64.to_radians(), 2.0);
        east_track(&mut w, 0.0, 3);
        let h = w.ble_heading().unwrap();
        assert!(h.abs() < 0.3, "{h}");
        // phone swings +-10 deg around 8 deg: agrees with BLE within 20 deg
        let mut last = f64::NAN;
        for k in 0..6 {
            let phone = (8.0_f64 + if k % 2 == 0 { 10.0 } else { -10.0 }).to_radians();
            last = w.direction(2.0 + 0.2 * k as f64, phone);
        }
        assert_eq!(last, h);
        assert!(w.ble_steps > 0);
    }

    #[test]
    fn a_turn_keeps_the_phone_heading() {
        let mut w = WalkingDirection::new(3.0, 20f64.to_radians(), 2.0);
        east_track(&mut w, 0.0, 3);
        let north = std::f64::consts::FRAC_PI_2;
        for k in 0..6 {
            assert_eq!(w.direction(2.0 + 0.2 * k as f64, north), north);
        }
        assert_eq!(w.ble_steps, 0);
    }

    #[test]
    fn standing_still_or_too_few_fixes_gives_no_ble_heading() {
        let mut w = WalkingDirection::new(3.0, 0.35, 2.0);
        w.on_ble_position(0.0, Vec2::new(0.0, 0.0));
        w.on_ble_position(1.0, Vec2::new(3.0, 0.0));
        assert!(w.ble_heading().is_none(), "two fixes");
        w.on_ble_position(2.0, Vec2::new(0.5, 0.2));
        assert!(w.ble_heading().is_none(), "0.5 m of travel");
        assert_eq!(w.direction(2.0, 1.0), 1.0);
    }

    #[test]
    fn heading_is_oriented_by_the_direction_of_travel() {
        let mut w = WalkingDirection::new(5.0, 0.35, 2.0);
        for k in 0..5 {
            w.on_ble_position(k as f64, Vec2::new(-1.5 * k as f64, 0.2 * (k % 2) as f64));
        }
        let h = w.ble_heading().unwrap();
        assert!((wrap(h - std::f64::consts::PI)).abs() < 0.2, "{h}");
        // old positions leave the window
        w.on_ble_position(20.0, Vec2::new(0.0, 0.0));
        assert!(w.ble_heading().is_none());
    }

    #[test]
    fn bad_input_is_ignored() {
        let mut w = WalkingDirection::new(3.0, 0.35, 2.0);
        w.on_ble_position(f64::NAN, Vec2::new(0.0, 0.0));
        w.on_ble_position(0.0, Vec2::new(f64::NAN, 0.0));
        assert!(w.ble.is_empty());
        assert!(w.direction(f64::NAN, 0.3) == 0.3);
        assert!(w.direction(1.0, f64::NAN).is_nan());
    }
}
