//! Which orientation gives the walking direction (FP-BP eqs. 32-33), and the
//! switch at k0 from the rotation vector to the Madgwick filter.
//!
//! Eq. 32 reads d'_k = R_D [0,1,0]^T for k <= k0 and
//! R_M(omega, a_g, m; theta_k0) R_D [0,1,0]^T after. We read R_M(...; theta_k0)
//! as "the Madgwick orientation, started at k0 from the rotation vector's
//! orientation (whose yaw is theta_k0)": at k0 the filter is set to the
//! rotation-vector quaternion, and from then on the forward axis is rotated
//! by the filter's orientation instead. Both are composed with R_E, so the
//! yaw is in the MCS.
//!
//! Which device axis points where the walker goes ([`ForwardAxis`]): the
//! paper takes the top of the screen (DCS y). That fails when the phone hangs
//! in a swinging hand (top pointing down, screen facing forward): the top's
//! floor projection is then short and flips between forward and backward
//! with every swing. [`ForwardAxis::TiltAware`] keeps the top while the phone
//! is held flat-ish and switches, with hysteresis ([`TiltSwitch`]), to the
//! screen normal when the top is steep: -z with the top up (phone upright in
//! front, screen towards the walker), +z with the top down (hanging hand,
//! screen forward).

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Orientation source of the heading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeadingSource {
    /// FP-BP eq. 32: rotation vector until k0, then Madgwick started from it.
    RotationVectorThenMadgwick,
    /// Rotation vector only (Android's own fusion, magnetic yaw).
    RotationVector,
    /// Madgwick only, initialised from accelerometer + magnetometer.
    Madgwick,
    /// Game rotation vector only (no magnetometer; yaw origin arbitrary, so
    /// headings are relative to where the phone pointed when it started).
    GameRotationVector,
}

/// Which device axis gives the walking direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForwardAxis {
    /// FP-BP eq. 32: the top of the screen, DCS y, always.
    Top,
    /// DCS y while the top is less steep than the upright thresholds; the
    /// screen normal (-z top up, +z top down) while it is steeper.
    TiltAware,
}

/// The upright state of [`ForwardAxis::TiltAware`], with hysteresis: upright
/// once the top's elevation above or below the floor exceeds `enter`, back to
/// the top axis once it falls below `exit` (`exit <= enter`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltSwitch {
    enter_sin: f64,
    exit_sin: f64,
    upright: bool,
}

impl TiltSwitch {
    /// Thresholds as elevations of the top axis, radians.
    pub fn new(enter_rad: f64, exit_rad: f64) -> Self {
        TiltSwitch {
            enter_sin: enter_rad.sin(),
            exit_sin: exit_rad.min(enter_rad).sin(),
            upright: false,
        }
    }

    /// Updates the state with `top_up`, the up component of the unit top
    /// axis (sine of its elevation); returns whether the phone is upright.
    /// Non-finite input leaves the state unchanged.
    pub fn update(&mut self, top_up: f64) -> bool {
        let e = top_up.abs();
        if e.is_finite() {
            if self.upright && e < self.exit_sin {
                self.upright = false;
            } else if !self.upright && e > self.enter_sin {
                self.upright = true;
            }
        }
        self.upright
    }

    /// Whether the last update left the phone upright.
    pub fn upright(&self) -> bool {
        self.upright
    }
}

/// The device axis (in the DCS) that points forward for the orientation
/// `map_from_device`: the top (y), or when `upright` the screen normal signed
/// so that it points away from the walker (-z when the top points up, +z when
/// it points down).
pub fn forward_axis(map_from_device: &Matrix3<f64>, upright: bool) -> Vector3<f64> {
    if upright {
        let top_up = map_from_device[(2, 1)];
        if top_up >= 0.0 {
            -Vector3::z()
        } else {
            Vector3::z()
        }
    } else {
        Vector3::y()
    }
}

/// Tracks the k0 switch of [`HeadingSource::RotationVectorThenMadgwick`].
///
/// Paper: k0 is a time. Optionally ([`SwitchClock::with_calm`]) k0 waits, after
/// that time, until the gyroscope has been calm: the mean angular rate norm
/// over the trailing window at or below a threshold, so that the Madgwick
/// filter does not start from a rotation vector disturbed by deliberate phone
/// motion (the IPIN logs start with a minute of it).
#[derive(Debug, Clone, PartialEq)]
pub struct SwitchClock {
    /// k0 as a time after the first sensor sample, ns; `None`: never switch.
    k0_ns: Option<i64>,
    first_t_ns: Option<i64>,
    switched: bool,
    /// Calm window, ns (0: no calm condition), and its mean-rate threshold.
    calm_window_ns: i64,
    calm_rate: f64,
    /// Gyroscope rate norms in the trailing window, and their sum.
    rates: std::collections::VecDeque<(i64, f64)>,
    rate_sum: f64,
    first_gyro_t_ns: Option<i64>,
}

impl SwitchClock {
    pub fn new(k0_s: Option<f64>) -> Self {
        SwitchClock {
            k0_ns: k0_s.map(|s| (s * 1e9) as i64),
            first_t_ns: None,
            switched: false,
            calm_window_ns: 0,
            calm_rate: f64::INFINITY,
            rates: std::collections::VecDeque::new(),
            rate_sum: 0.0,
            first_gyro_t_ns: None,
        }
    }

    /// Adds the calm condition: a `window_s` (> 0) trailing window of
    /// gyroscope samples whose mean rate norm is at most `max_mean_rad_s`.
    pub fn with_calm(mut self, window_s: f64, max_mean_rad_s: f64) -> Self {
        if window_s > 0.0 {
            self.calm_window_ns = (window_s * 1e9) as i64;
            self.calm_rate = max_mean_rad_s;
        }
        self
    }

    /// Notes a gyroscope sample (rate norm, rad/s) for the calm condition.
    /// Samples out of time order or not finite are ignored.
    pub fn on_gyro(&mut self, t_ns: i64, rate_rad_s: f64) {
        if self.calm_window_ns == 0 || self.switched || !rate_rad_s.is_finite() {
            return;
        }
        if self.rates.back().is_some_and(|&(t, _)| t_ns <= t) {
            return;
        }
        self.first_gyro_t_ns.get_or_insert(t_ns);
        self.rates.push_back((t_ns, rate_rad_s));
        self.rate_sum += rate_rad_s;
        while let Some(&(t, r)) = self.rates.front() {
            if t_ns - t > self.calm_window_ns {
                self.rates.pop_front();
                self.rate_sum -= r;
            } else {
                break;
            }
        }
    }

    /// Whether the calm condition holds (always without one).
    fn calm(&self) -> bool {
        if self.calm_window_ns == 0 {
            return true;
        }
        let (Some(first), Some(&(last, _))) = (self.first_gyro_t_ns, self.rates.back()) else {
            return false;
        };
        last - first >= self.calm_window_ns
            && self.rate_sum.max(0.0) / self.rates.len() as f64 <= self.calm_rate
    }

    /// Notes a sensor time; returns true exactly once, at the first sample at
    /// or after k0 (and, with the calm condition, once it holds).
    pub fn tick(&mut self, t_ns: i64) -> bool {
        let first = *self.first_t_ns.get_or_insert(t_ns);
        if self.switched {
            return false;
        }
        match self.k0_ns {
            Some(k0) if t_ns - first >= k0 && self.calm() => {
                self.switched = true;
                self.rates.clear();
                true
            }
            _ => false,
        }
    }

    /// Whether k0 has passed.
    pub fn switched(&self) -> bool {
        self.switched
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn tilt_switch_has_hysteresis() {
        let mut s = TiltSwitch::new(60f64.to_radians(), 45f64.to_radians());
        let el = |deg: f64| deg.to_radians().sin();
        let seq = [
            30.0, 55.0, 61.0, 50.0, 46.0, 44.0, 55.0, -70.0, -50.0, -40.0,
        ];
        let got: Vec<bool> = seq.iter().map(|&d| s.update(el(d))).collect();
        assert_eq!(
            got,
            [
                false, false, true, true, true, false, false, true, true, false
            ]
        );
        assert!(!s.update(f64::NAN));
    }

    #[test]
    fn forward_axis_points_ahead_for_any_pitch_about_the_right_axis() {
        // Walking north (ENU y); the phone pitched about its x axis (which
        // points east, to the walker's right) by any angle from -100 to +100
        // deg: flat (0), upright in front with the screen towards the walker
        // (+90), hanging with the top down and the screen forward (-90).
        for deg in (-100i32..=100).step_by(5) {
            let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), (deg as f64).to_radians());
            let r = q.to_rotation_matrix().into_inner();
            let mut sw = TiltSwitch::new(60f64.to_radians(), 45f64.to_radians());
            let upright = sw.update(r[(2, 1)]);
            assert_eq!(upright, deg.abs() > 60, "{deg}");
            let d = r * forward_axis(&r, upright);
            let yaw = d.y.atan2(d.x).to_degrees();
            assert!((yaw - 90.0).abs() < 1e-6, "pitch {deg}: yaw {yaw}");
        }
    }

    #[test]
    fn calm_switch_waits_for_a_calm_gyroscope() {
        // k0 = 2 s; the phone is shaken (3 rad/s) until 10 s, then calm
        // (0.3 rad/s). With a 3 s window and 1 rad/s the switch waits until
        // the window's mean drops: (3 * 0.9 + 0.3 * 2.1) / 3 = 1.11 > 1 at
        // 12.1 s, <= 1 a little later; it never fires before 12 s.
        let mut c = SwitchClock::new(Some(2.0)).with_calm(3.0, 1.0);
        let mut plain = SwitchClock::new(Some(2.0));
        let mut fired_at = None;
        for i in 0..1000 {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            c.on_gyro(t_ns, if t < 10.0 { 3.0 } else { 0.3 });
            if c.tick(t_ns) {
                assert!(fired_at.is_none());
                fired_at = Some(t);
            }
            if plain.tick(t_ns) {
                assert!((t - 2.0).abs() < 1e-9);
            }
        }
        let t = fired_at.unwrap();
        assert!((12.1..12.5).contains(&t), "{t}");
        // Calm from the start: fires at k0 if the window is already full.
        let mut c = SwitchClock::new(Some(4.0)).with_calm(3.0, 1.0);
        let mut fired_at = None;
        for i in 0..400 {
            let t_ns = i * 20_000_000;
            c.on_gyro(t_ns, f64::NAN);
            c.on_gyro(t_ns, 0.2);
            if c.tick(t_ns) {
                fired_at = Some(t_ns as f64 * 1e-9);
            }
        }
        assert!((fired_at.unwrap() - 4.0).abs() < 1e-9);
    }

    #[test]
    fn switch_fires_once_at_k0() {
        let mut c = SwitchClock::new(Some(2.0));
        let fired: Vec<bool> = [
            100,
            1_000_000_100,
            2_000_000_099,
            2_000_000_100,
            3_000_000_000,
        ]
        .iter()
        .map(|&t| c.tick(t))
        .collect();
        assert_eq!(fired, [false, false, false, true, false]);
        assert!(c.switched());
        let mut never = SwitchClock::new(None);
        assert!(!never.tick(0) && !never.tick(i64::MAX / 2));
    }
}
