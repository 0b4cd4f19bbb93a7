//! Pedestrian dead reckoning (FP-BP Sec. IV-B): device orientation, step
//! detection, step length and walking heading in the MCS.
//!
//! Feed every sensor sample to [`Pdr::on_sensor`]; collect detected steps
//! with [`Pdr::take_steps`]. Missing streams degrade gracefully: without a
//! rotation vector the orientation comes from the game rotation vector or the
//! Madgwick filter; without a magnetometer Madgwick runs IMU-only.

pub mod heading;
pub mod madgwick;
pub mod orientation;
pub mod steps;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::events::{SensorData, SensorEvent};
use crate::{Error, Result};
pub use heading::{ForwardAxis, HeadingSource};
use heading::{SwitchClock, TiltSwitch};
use madgwick::MadgwickTracker;
use steps::{StepDetector, StepParams};

/// Parameters of the PDR. Defaults and their provenance: docs/parameters.md, "PDR".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PdrConfig {
    /// h of eq. 29: half the peak-search window, seconds. Default 0.2.
    pub half_window_s: f64,
    /// z_th of eq. 29b: minimum peak of the vertical acceleration (gravity
    /// removed, low-passed), m/s^2. Default 0.6.
    pub z_th_mps2: f64,
    /// k_th of eq. 29c: minimum time between two steps, seconds. Default 0.3.
    pub min_step_interval_s: f64,
    /// beta of eq. 31 (s = beta * z_pp^(1/4)), metres / (m/s^2)^(1/4). Default 0.40.
    pub step_length_beta: f64,
    /// Cut-off of the first-order low-pass on the vertical acceleration, Hz;
    /// 0 disables it. Default 3.0.
    pub low_pass_cutoff_hz: f64,
    /// Time constant of the running gravity estimate subtracted from the
    /// vertical acceleration, seconds. Default 2.0.
    pub gravity_tau_s: f64,
    /// Sensor gaps longer than this reset the step window; also the largest
    /// gyroscope dt integrated by Madgwick, seconds. Default 0.5.
    pub max_gap_s: f64,
    /// Which orientation gives the heading. Default `rotation_vector_then_madgwick` (eq. 32).
    pub heading_source: HeadingSource,
    /// k0 of eq. 32: time after the first sensor sample at which the heading
    /// switches from the rotation vector to Madgwick, seconds; `null`: never.
    /// Default 5.0.
    pub switch_to_madgwick_after_s: Option<f64>,
    /// k0 also waits until the gyroscope has been calm over this trailing
    /// window, seconds (a robust k0: not in deliberate phone motion); 0: the
    /// paper's fixed k0. Default 3.0.
    pub switch_calm_window_s: f64,
    /// Calm means a mean angular rate norm over the window at most this,
    /// rad/s. Default 1.5.
    pub switch_calm_rate_rad_s: f64,
    /// Which device axis points forward: `top` (eq. 32, DCS y) or
    /// `tilt_aware` (the screen normal while the phone is upright or hangs
    /// top-down, e.g. in a swinging hand). Default `tilt_aware`.
    pub forward_axis: ForwardAxis,
    /// `tilt_aware`: elevation of the top axis above or below the floor
    /// beyond which the screen normal gives the heading, radians. Default
    /// 1.0472 (60 deg).
    pub upright_enter_rad: f64,
    /// `tilt_aware`: elevation below which the top axis gives the heading
    /// again (hysteresis; at most `upright_enter_rad`), radians. Default
    /// 0.7854 (45 deg).
    pub upright_exit_rad: f64,
    /// Madgwick gain beta, rad/s (the paper's [45] suggests 0.041). Default 0.01.
    pub madgwick_beta: f64,
    /// Whether Madgwick uses the magnetometer (9-axis) or not (6-axis). Default true.
    pub madgwick_use_magnetometer: bool,
    /// `pdr` engine: accuracy radius at the start position, metres. Default 1.0.
    pub start_accuracy_m: f64,
    /// `pdr` engine: accuracy growth per metre walked, metres/metre. Default 0.1.
    pub accuracy_per_walked_m: f64,
}

impl Default for PdrConfig {
    fn default() -> Self {
        PdrConfig {
            half_window_s: 0.2,
            z_th_mps2: 0.6,
            min_step_interval_s: 0.3,
            step_length_beta: 0.40,
            low_pass_cutoff_hz: 3.0,
            gravity_tau_s: 2.0,
            max_gap_s: 0.5,
            heading_source: HeadingSource::RotationVectorThenMadgwick,
            switch_to_madgwick_after_s: Some(5.0),
            switch_calm_window_s: 3.0,
            switch_calm_rate_rad_s: 1.5,
            forward_axis: ForwardAxis::TiltAware,
            upright_enter_rad: 60f64.to_radians(),
            upright_exit_rad: 45f64.to_radians(),
            madgwick_beta: 0.01,
            madgwick_use_magnetometer: true,
            start_accuracy_m: 1.0,
            accuracy_per_walked_m: 0.1,
        }
    }
}

impl PdrConfig {
    /// Checks every field's range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        let positive = |name: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("pdr.{name}"),
                    format!("must be > 0, got {v}"),
                ))
            }
        };
        let non_negative = |name: &str, v: f64| -> Result<()> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("pdr.{name}"),
                    format!("must be >= 0, got {v}"),
                ))
            }
        };
        positive("half_window_s", self.half_window_s)?;
        if !self.z_th_mps2.is_finite() {
            return Err(Error::config("pdr.z_th_mps2", "must be finite"));
        }
        non_negative("min_step_interval_s", self.min_step_interval_s)?;
        positive("step_length_beta", self.step_length_beta)?;
        non_negative("low_pass_cutoff_hz", self.low_pass_cutoff_hz)?;
        positive("gravity_tau_s", self.gravity_tau_s)?;
        positive("max_gap_s", self.max_gap_s)?;
        if let Some(k0) = self.switch_to_madgwick_after_s {
            non_negative("switch_to_madgwick_after_s", k0)?;
        }
        non_negative("switch_calm_window_s", self.switch_calm_window_s)?;
        positive("switch_calm_rate_rad_s", self.switch_calm_rate_rad_s)?;
        if !(self.upright_enter_rad.is_finite()
            && self.upright_enter_rad > 0.0
            && self.upright_enter_rad < std::f64::consts::FRAC_PI_2)
        {
            return Err(Error::config(
                "pdr.upright_enter_rad",
                format!("must be in (0, pi/2), got {}", self.upright_enter_rad),
            ));
        }
        if !(self.upright_exit_rad.is_finite()
            && self.upright_exit_rad > 0.0
            && self.upright_exit_rad <= self.upright_enter_rad)
        {
            return Err(Error::config(
                "pdr.upright_exit_rad",
                format!(
                    "must be in (0, upright_enter_rad = {}], got {}",
                    self.upright_enter_rad, self.upright_exit_rad
                ),
            ));
        }
        non_negative("madgwick_beta", self.madgwick_beta)?;
        non_negative("start_accuracy_m", self.start_accuracy_m)?;
        non_negative("accuracy_per_walked_m", self.accuracy_per_walked_m)?;
        Ok(())
    }

    fn step_params(&self) -> StepParams {
        StepParams {
            half_window_s: self.half_window_s,
            z_th_mps2: self.z_th_mps2,
            min_step_interval_s: self.min_step_interval_s,
            low_pass_cutoff_hz: self.low_pass_cutoff_hz,
            gravity_tau_s: self.gravity_tau_s,
            max_gap_s: self.max_gap_s,
        }
    }
}

/// One detected step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Step {
    /// Time of the step's acceleration peak, ns.
    pub t_ns: i64,
    /// Step length, metres (eq. 31).
    pub length_m: f64,
    /// Walking heading in the MCS, radians, atan2(dy, dx) (eq. 33), at detection.
    pub yaw_rad: f64,
    /// Peak-to-peak vertical acceleration of the step, m/s^2 (eq. 30).
    pub z_pp: f64,
}

/// Counters of the PDR's input.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PdrStats {
    /// Accelerometer samples that could not be used (no orientation yet,
    /// timestamps not advancing, non-finite values).
    pub skipped_accelerometer: u64,
    /// Gyroscope samples skipped (timestamps not advancing).
    pub skipped_gyroscope: u64,
    /// Degenerate quaternions rejected.
    pub bad_quaternions: u64,
    /// Sensor gaps that reset the step window.
    pub gaps: u64,
    /// Steps detected so far.
    pub steps: u64,
    /// Of those, steps whose heading came from the screen normal (phone
    /// upright or hanging; `forward_axis: tilt_aware`).
    pub upright_steps: u64,
}

impl PdrStats {
    /// Sensor inputs the PDR could not use (accelerometer and gyroscope
    /// samples skipped, degenerate quaternions): the PDR's share of an
    /// engine's `rejected_inputs`.
    pub fn rejected(&self) -> u64 {
        self.skipped_accelerometer + self.skipped_gyroscope + self.bad_quaternions
    }
}

/// The PDR pipeline of one walker.
#[derive(Debug, Clone)]
pub struct Pdr {
    cfg: PdrConfig,
    r_e: Matrix3<f64>,
    rv: Option<UnitQuaternion<f64>>,
    grv: Option<UnitQuaternion<f64>>,
    madgwick: MadgwickTracker,
    switch: SwitchClock,
    tilt: TiltSwitch,
    detector: StepDetector,
    pending: Vec<Step>,
    stats: PdrStats,
}

impl Pdr {
    /// A PDR for a site whose MCS is turned `map_from_enu_rad` from ENU.
    /// `cfg` is assumed valid (see [`PdrConfig::validate`]).
    pub fn new(cfg: &PdrConfig, map_from_enu_rad: f64) -> Self {
        let k0 = match cfg.heading_source {
            HeadingSource::RotationVectorThenMadgwick => cfg.switch_to_madgwick_after_s,
            _ => None,
        };
        Pdr {
            cfg: cfg.clone(),
            r_e: orientation::map_from_enu(map_from_enu_rad),
            rv: None,
            grv: None,
            madgwick: MadgwickTracker::new(
                cfg.madgwick_beta,
                cfg.max_gap_s,
                cfg.madgwick_use_magnetometer,
            ),
            switch: SwitchClock::new(k0)
                .with_calm(cfg.switch_calm_window_s, cfg.switch_calm_rate_rad_s),
            tilt: TiltSwitch::new(cfg.upright_enter_rad, cfg.upright_exit_rad),
            detector: StepDetector::new(cfg.step_params()),
            pending: Vec::new(),
            stats: PdrStats::default(),
        }
    }

    /// Feeds one sensor sample. Never fails: unusable samples are counted.
    pub fn on_sensor(&mut self, e: &SensorEvent) {
        if let SensorData::Gyroscope(w) = e.data {
            self.switch.on_gyro(e.t_ns, Vector3::from(w).norm());
        }
        let fired = self.switch.tick(e.t_ns);
        let turned = matches!(
            e.data,
            SensorData::Gyroscope(_)
                | SensorData::RotationVector(_)
                | SensorData::GameRotationVector(_)
        );
        match e.data {
            SensorData::Accelerometer(a) => {
                let a = Vector3::from(a);
                self.madgwick.on_accelerometer(a);
                self.on_accelerometer(e.t_ns, a);
            }
            SensorData::Gyroscope(w) => {
                let before = self.madgwick.skipped_samples;
                self.madgwick.on_gyroscope(e.t_ns, Vector3::from(w));
                self.stats.skipped_gyroscope += self.madgwick.skipped_samples - before;
            }
            SensorData::Magnetometer(m) => self.madgwick.on_magnetometer(Vector3::from(m)),
            SensorData::RotationVector(q) => match orientation::from_android(q) {
                Some(q) => {
                    self.rv = Some(q);
                    if !self.madgwick.is_initialised() {
                        self.madgwick.set_orientation(q);
                    }
                }
                None => self.stats.bad_quaternions += 1,
            },
            SensorData::GameRotationVector(q) => match orientation::from_android(q) {
                Some(q) => self.grv = Some(q),
                None => self.stats.bad_quaternions += 1,
            },
            SensorData::Pressure(_) => {}
        }
        if fired && let Some(rv) = self.rv {
            // k0: Madgwick continues from the rotation vector's orientation (theta_k0).
            self.madgwick.set_orientation(rv);
        }
        if (turned || fired)
            && self.cfg.forward_axis == ForwardAxis::TiltAware
            && let Some(r_d) = self.heading_matrix()
        {
            self.tilt.update(r_d[(2, 1)]);
        }
    }

    fn on_accelerometer(&mut self, t_ns: i64, a: Vector3<f64>) {
        // Tilt for eq. 28: any source will do; prefer Android's fused ones.
        let Some(q) = self.rv.or(self.grv).or_else(|| self.madgwick.orientation()) else {
            self.stats.skipped_accelerometer += 1;
            return;
        };
        let r = q.to_rotation_matrix().into_inner();
        let up = orientation::up_component(&r, &a);
        let before = self.detector.skipped_samples;
        let gaps_before = self.detector.gaps;
        let peak = self.detector.push(t_ns, up);
        self.stats.skipped_accelerometer += self.detector.skipped_samples - before;
        self.stats.gaps += self.detector.gaps - gaps_before;
        if let Some(p) = peak
            && let Some(yaw) = self.yaw_rad()
        {
            self.stats.steps += 1;
            self.stats.upright_steps += u64::from(self.tilt.upright());
            self.pending.push(Step {
                t_ns: p.t_ns,
                length_m: steps::step_length_m(self.cfg.step_length_beta, p.z_pp),
                yaw_rad: yaw,
                z_pp: p.z_pp,
            });
        }
    }

    /// The orientation (device -> ENU) that gives the heading now.
    fn heading_orientation(&self) -> Option<UnitQuaternion<f64>> {
        let mg = self.madgwick.orientation();
        match self.cfg.heading_source {
            HeadingSource::RotationVectorThenMadgwick => {
                if self.switch.switched() {
                    mg.or(self.rv)
                } else {
                    self.rv.or(mg)
                }
            }
            HeadingSource::RotationVector => self.rv.or(mg).or(self.grv),
            HeadingSource::Madgwick => mg.or(self.rv),
            HeadingSource::GameRotationVector => self.grv.or(mg),
        }
    }

    /// Current walking heading in the MCS, radians (eq. 33); `None` before any
    /// orientation is known or while the phone's top points straight up/down.
    pub fn yaw_rad(&self) -> Option<f64> {
        let r_d = self.heading_matrix()?;
        let axis = heading::forward_axis(&r_d, self.tilt.upright());
        orientation::axis_yaw_rad(&r_d, &axis)
    }

    /// R_D (DCS -> MCS) of the heading orientation.
    fn heading_matrix(&self) -> Option<Matrix3<f64>> {
        let q = self.heading_orientation()?;
        Some(orientation::map_from_device(
            &self.r_e,
            &q.to_rotation_matrix().into_inner(),
        ))
    }

    /// Removes and returns the steps detected since the last call, in time order.
    pub fn take_steps(&mut self) -> Vec<Step> {
        std::mem::take(&mut self.pending)
    }

    /// Input counters.
    pub fn stats(&self) -> PdrStats {
        self.stats
    }

    /// The configuration this PDR runs with.
    pub fn config(&self) -> &PdrConfig {
        &self.cfg
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn ev(t_ns: i64, data: SensorData) -> SensorEvent {
        SensorEvent { t_ns, data }
    }

    fn quat_yaw(yaw_enu_rad: f64) -> [f64; 4] {
        // Flat phone whose top points at ENU yaw `yaw_enu_rad` (atan2 from east):
        // rotation about up by yaw - 90 deg from the north-pointing identity.
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_enu_rad - FRAC_PI_2);
        orientation::to_android(&q)
    }

    /// Walks `secs` seconds at 1.8 Hz, 50 Hz sampling, flat phone at ENU yaw
    /// `yaw(t)`; gyro consistent with the yaw rate, magnetometer from the true
    /// attitude rotated by `mag_offset_rad` (a magnetic disturbance).
    fn walk(
        pdr: &mut Pdr,
        secs: f64,
        yaw: impl Fn(f64) -> f64,
        mag_offset_rad: f64,
        with_rv: bool,
    ) -> Vec<Step> {
        let n = (secs * 50.0) as i64;
        let mut out = Vec::new();
        for i in 0..n {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let y = yaw(t);
            let rate = (yaw(t + 1e-3) - yaw(t - 1e-3)) / 2e-3;
            let q = orientation::from_android(quat_yaw(y)).unwrap();
            let acc_enu = Vector3::new(
                0.0,
                0.0,
                9.81 + 2.0 * (std::f64::consts::TAU * 1.8 * t).sin(),
            );
            let mag_enu = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), mag_offset_rad)
                * Vector3::new(0.0, 30.0, -40.0);
            let inv = q.inverse();
            pdr.on_sensor(&ev(t_ns, SensorData::Accelerometer((inv * acc_enu).into())));
            pdr.on_sensor(&ev(t_ns, SensorData::Magnetometer((inv * mag_enu).into())));
            pdr.on_sensor(&ev(t_ns, SensorData::Gyroscope([0.0, 0.0, rate])));
            if with_rv {
                pdr.on_sensor(&ev(t_ns, SensorData::RotationVector(quat_yaw(y))));
            }
            out.extend(pdr.take_steps());
        }
        out
    }

    #[test]
    fn steps_carry_the_map_heading() {
        // Map turned +30 deg from ENU; walking north (ENU yaw 90) -> MCS yaw 120.
        let cfg = PdrConfig {
            heading_source: HeadingSource::RotationVector,
            ..PdrConfig::default()
        };
        let mut pdr = Pdr::new(&cfg, 30f64.to_radians());
        let steps = walk(&mut pdr, 20.0, |_| FRAC_PI_2, 0.0, true);
        assert!((steps.len() as f64 - 36.0).abs() <= 1.0, "{}", steps.len());
        for s in &steps {
            assert!(
                (s.yaw_rad.to_degrees() - 120.0).abs() < 1e-6,
                "{}",
                s.yaw_rad.to_degrees()
            );
            assert!((s.length_m - cfg.step_length_beta * s.z_pp.powf(0.25)).abs() < 1e-12);
        }
    }

    #[test]
    fn yaw_switches_to_madgwick_at_k0() {
        // The rotation vector is wrong by +40 deg from 4 s on (as if Android's
        // fusion were pulled by a disturbed field); the gyro is right. With
        // k0 = 4 s the heading follows the rotation vector before k0 and
        // Madgwick (started from theta_k0, pure gyro with gain 0) after it;
        // with the rotation vector as the only source it goes 40 deg off.
        let cfg = PdrConfig {
            switch_to_madgwick_after_s: Some(4.0),
            madgwick_beta: 0.0,
            ..PdrConfig::default()
        };
        let rv_only = PdrConfig {
            heading_source: HeadingSource::RotationVector,
            ..cfg.clone()
        };
        let mut pdr = Pdr::new(&cfg, 0.0);
        let mut pdr_rv = Pdr::new(&rv_only, 0.0);
        for i in 0..500 {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let true_yaw = 0.3 + 0.1 * t; // turning at 0.1 rad/s
            let rv_yaw = if t >= 4.0 {
                true_yaw + 40f64.to_radians()
            } else {
                true_yaw
            };
            let q = orientation::from_android(quat_yaw(true_yaw)).unwrap();
            for p in [&mut pdr, &mut pdr_rv] {
                p.on_sensor(&ev(
                    t_ns,
                    SensorData::Accelerometer((q.inverse() * Vector3::new(0.0, 0.0, 9.81)).into()),
                ));
                p.on_sensor(&ev(t_ns, SensorData::Gyroscope([0.0, 0.0, 0.1])));
                p.on_sensor(&ev(t_ns, SensorData::RotationVector(quat_yaw(rv_yaw))));
            }
            // k0 fires on the first sample at t >= 4 s, before that instant's
            // rotation vector arrives: Madgwick starts from the last good one.
            let err = crate::geometry::wrap_angle(pdr.yaw_rad().unwrap() - true_yaw).abs();
            assert!(err < 1e-3, "t {t}: err {} deg", err.to_degrees());
            let err_rv = crate::geometry::wrap_angle(pdr_rv.yaw_rad().unwrap() - true_yaw).abs();
            let expect_rv = if t >= 4.0 { 40f64.to_radians() } else { 0.0 };
            assert!(
                (err_rv - expect_rv).abs() < 1e-6,
                "t {t}: rv err {} deg",
                err_rv.to_degrees()
            );
        }
        let mut pdr2 = Pdr::new(&rv_only, 0.0);
        pdr2.on_sensor(&ev(0, SensorData::RotationVector(quat_yaw(PI / 3.0))));
        assert!((pdr2.yaw_rad().unwrap() - PI / 3.0).abs() < 1e-9);
    }

    #[test]
    fn madgwick_after_k0_ignores_a_rotation_vector_jump() {
        // Straight walk north; the rotation vector jumps by 60 deg at 8 s.
        // After k0 = 3 s the 9-axis Madgwick (small gain) keeps the heading.
        let cfg = PdrConfig {
            switch_to_madgwick_after_s: Some(3.0),
            ..PdrConfig::default()
        };
        let mut pdr = Pdr::new(&cfg, 0.0);
        let mut yaws = Vec::new();
        for i in 0..600 {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let q = orientation::from_android(quat_yaw(FRAC_PI_2)).unwrap();
            let rv = if t >= 8.0 {
                quat_yaw(FRAC_PI_2 + PI / 3.0)
            } else {
                quat_yaw(FRAC_PI_2)
            };
            pdr.on_sensor(&ev(
                t_ns,
                SensorData::Accelerometer((q.inverse() * Vector3::new(0.0, 0.0, 9.81)).into()),
            ));
            pdr.on_sensor(&ev(
                t_ns,
                SensorData::Magnetometer((q.inverse() * Vector3::new(0.0, 30.0, -40.0)).into()),
            ));
            pdr.on_sensor(&ev(t_ns, SensorData::Gyroscope([0.0; 3])));
            pdr.on_sensor(&ev(t_ns, SensorData::RotationVector(rv)));
            yaws.push(pdr.yaw_rad().unwrap());
        }
        for y in &yaws[450..] {
            assert!((y - FRAC_PI_2).abs() < 0.01, "{}", y.to_degrees());
        }
    }

    /// A phone hanging in a swinging hand: top down, screen forward, the arm
    /// swinging +-0.35 rad about the walker's right-left axis at half the
    /// step frequency (1.8 steps/s), walking at ENU yaw `walk_yaw`.
    fn swinging_walk(pdr: &mut Pdr, secs: f64, walk_yaw: f64) -> Vec<Step> {
        let n = (secs * 50.0) as i64;
        let mut out = Vec::new();
        let w = std::f64::consts::PI * 1.8;
        for i in 0..n {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let swing = |t: f64| 0.35 * (w * t).sin();
            let att = |t: f64| {
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), walk_yaw - FRAC_PI_2)
                    * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -FRAC_PI_2 + swing(t))
            };
            let q = att(t);
            // Body bounce at the step frequency; the arm's own acceleration is
            // left out (the test is about the axis, not the step detector).
            let acc_enu = Vector3::new(0.0, 0.0, 9.81 + 2.0 * (2.0 * w * t).sin());
            let rate = 0.35 * w * (w * t).cos();
            let inv = q.inverse();
            pdr.on_sensor(&ev(t_ns, SensorData::Accelerometer((inv * acc_enu).into())));
            pdr.on_sensor(&ev(
                t_ns,
                SensorData::Magnetometer((inv * Vector3::new(0.0, 30.0, -40.0)).into()),
            ));
            pdr.on_sensor(&ev(t_ns, SensorData::Gyroscope([rate, 0.0, 0.0])));
            pdr.on_sensor(&ev(
                t_ns,
                SensorData::RotationVector(orientation::to_android(&q)),
            ));
            out.extend(pdr.take_steps());
        }
        out
    }

    #[test]
    fn swinging_hand_heading_follows_the_walk_with_the_tilt_aware_axis() {
        let walk_yaw = 30f64.to_radians();
        for source in [
            HeadingSource::RotationVectorThenMadgwick,
            HeadingSource::RotationVector,
        ] {
            let tilt = PdrConfig {
                heading_source: source,
                ..PdrConfig::default()
            };
            let mut pdr = Pdr::new(&tilt, 0.0);
            let steps = swinging_walk(&mut pdr, 20.0, walk_yaw);
            assert!(steps.len() >= 30, "{}", steps.len());
            assert_eq!(pdr.stats().upright_steps, steps.len() as u64);
            for s in &steps {
                let err = crate::geometry::wrap_angle(s.yaw_rad - walk_yaw).to_degrees();
                assert!(err.abs() < 2.0, "{source:?}: err {err} deg");
            }
            // The paper's axis (the top of the screen) flips with the swing.
            let top = PdrConfig {
                forward_axis: ForwardAxis::Top,
                ..tilt
            };
            let mut pdr = Pdr::new(&top, 0.0);
            let steps = swinging_walk(&mut pdr, 20.0, walk_yaw);
            let backwards = steps
                .iter()
                .filter(|s| crate::geometry::wrap_angle(s.yaw_rad - walk_yaw).abs() > FRAC_PI_2)
                .count();
            assert!(
                backwards * 4 > steps.len(),
                "{backwards} of {} steps backwards",
                steps.len()
            );
            assert_eq!(pdr.stats().upright_steps, 0);
        }
    }

    #[test]
    fn without_rotation_vector_madgwick_gives_heading() {
        let mut pdr = Pdr::new(&PdrConfig::default(), 0.0);
        // Walking towards ENU yaw 20 deg (east-north-east).
        let steps = walk(&mut pdr, 15.0, |_| 20f64.to_radians(), 0.0, false);
        assert!(steps.len() >= 25, "{}", steps.len());
        for s in &steps {
            assert!(
                (s.yaw_rad.to_degrees() - 20.0).abs() < 1.0,
                "{}",
                s.yaw_rad.to_degrees()
            );
        }
    }

    #[test]
    fn without_any_orientation_accelerometer_is_counted_as_skipped() {
        let cfg = PdrConfig {
            madgwick_use_magnetometer: false,
            ..PdrConfig::default()
        };
        let mut pdr = Pdr::new(&cfg, 0.0);
        pdr.on_sensor(&ev(0, SensorData::Accelerometer([0.0, 0.0, 9.81])));
        assert_eq!(pdr.stats().skipped_accelerometer, 1);
        assert!(pdr.yaw_rad().is_none());
        // A gyro sample initialises the IMU-only Madgwick from the accelerometer.
        pdr.on_sensor(&ev(1, SensorData::Gyroscope([0.0; 3])));
        assert!(pdr.yaw_rad().is_some());
    }

    fn any_sensor_data() -> impl proptest::strategy::Strategy<Value = SensorData> {
        use proptest::prelude::*;
        let v = prop_oneof![4 => -30.0f64..30.0, 1 => Just(f64::NAN), 1 => Just(f64::INFINITY), 1 => Just(0.0)];
        let v3 = [v.clone(), v.clone(), v.clone()];
        let v4 = [v.clone(), v.clone(), v.clone(), v];
        prop_oneof![
            v3.clone().prop_map(SensorData::Accelerometer),
            v3.clone().prop_map(SensorData::Gyroscope),
            v3.prop_map(SensorData::Magnetometer),
            v4.clone().prop_map(SensorData::RotationVector),
            v4.prop_map(SensorData::GameRotationVector),
        ]
    }

    proptest::proptest! {
        #[test]
        fn garbage_streams_never_panic_and_outputs_stay_sane(
            evs in proptest::collection::vec((-50i64..2_000, any_sensor_data()), 0..400),
            source in 0usize..4,
            tilt_aware in proptest::bool::ANY,
        ) {
            let heading_source = [
                HeadingSource::RotationVectorThenMadgwick,
                HeadingSource::RotationVector,
                HeadingSource::Madgwick,
                HeadingSource::GameRotationVector,
            ][source];
            let forward_axis = if tilt_aware { ForwardAxis::TiltAware } else { ForwardAxis::Top };
            let cfg = PdrConfig { heading_source, forward_axis, switch_to_madgwick_after_s: Some(0.5), ..PdrConfig::default() };
            let mut pdr = Pdr::new(&cfg, 0.3);
            let mut t = 0i64;
            for (dt_ms, data) in evs {
                t += dt_ms * 1_000_000; // may go backwards or repeat
                pdr.on_sensor(&ev(t, data));
                if let Some(y) = pdr.yaw_rad() {
                    proptest::prop_assert!(y.is_finite() && y.abs() <= PI + 1e-9);
                }
                for s in pdr.take_steps() {
                    proptest::prop_assert!(s.length_m.is_finite() && s.length_m >= 0.0);
                    proptest::prop_assert!(s.yaw_rad.is_finite() && s.z_pp >= 0.0);
                }
            }
        }
    }

    #[test]
    fn config_defaults_validate_and_bad_fields_are_named() {
        PdrConfig::default().validate().unwrap();
        let bad = PdrConfig {
            step_length_beta: -1.0,
            ..PdrConfig::default()
        };
        let msg = bad.validate().unwrap_err().to_string();
        assert!(msg.contains("pdr.step_length_beta"), "{msg}");
        let bad = PdrConfig {
            upright_exit_rad: 1.2,
            ..PdrConfig::default()
        };
        let msg = bad.validate().unwrap_err().to_string();
        assert!(msg.contains("pdr.upright_exit_rad"), "{msg}");
        let bad = PdrConfig {
            upright_enter_rad: 2.0,
            ..PdrConfig::default()
        };
        let msg = bad.validate().unwrap_err().to_string();
        assert!(msg.contains("pdr.upright_enter_rad"), "{msg}");
        let parsed: PdrConfig =
            serde_json::from_str(r#"{"z_th_mps2": 1.5, "heading_source": "madgwick"}"#).unwrap();
        assert_eq!(parsed.z_th_mps2, 1.5);
        assert_eq!(parsed.heading_source, HeadingSource::Madgwick);
        assert!(serde_json::from_str::<PdrConfig>(r#"{"zth": 1}"#).is_err());
    }
}
