//! Madgwick orientation filter (R_M of FP-BP eq. 32) on top of the `ahrs`
//! crate (0.8), fed by gyroscope, accelerometer (with gravity) and, when the
//! phone has one, magnetometer.
//!
//! Conventions of `ahrs::Madgwick` (checked in its source and by the tests
//! below): its quaternion rotates sensor vectors into an earth frame whose z
//! axis is up (a still accelerometer reads +g) and whose x axis is horizontal
//! magnetic north, so y is west: North-West-Up (NWU), not NED and not ENU.
//! This wrapper keeps the filter state in NWU and converts at its boundary:
//! q_enu = Rz(+90 deg) * q_nwu. Android's device frame is used unchanged (the
//! filter has no preferred sensor frame).
//!
//! Sample period: `ahrs::Madgwick::new` takes a fixed period and the setter is
//! behind a non-default feature. Android timestamps jitter, so every gyroscope
//! sample rebuilds the (Copy, 3-field) filter with `new_with_quat(dt, beta, q)`
//! where dt is the time since the previous gyroscope sample. Non-positive dt
//! (duplicate or backwards timestamps) skips the update; dt above
//! `max_dt_s` (a gap) is clamped to it.

use ahrs::{Ahrs, Madgwick};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Device -> ENU orientation tracked by a Madgwick filter.
#[derive(Debug, Clone)]
pub struct MadgwickTracker {
    beta: f64,
    max_dt_s: f64,
    use_magnetometer: bool,
    /// Filter state, device -> NWU. `None` until initialised.
    q_nwu: Option<UnitQuaternion<f64>>,
    last_gyro_t_ns: Option<i64>,
    acc: Option<Vector3<f64>>,
    mag: Option<Vector3<f64>>,
    /// Gyroscope samples skipped (timestamp not advancing or non-finite values).
    pub skipped_samples: u64,
}

fn nwu_to_enu() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2)
}

impl MadgwickTracker {
    /// A tracker with gain `beta` (rad/s), gap clamp `max_dt_s`, and whether
    /// magnetometer samples are used (9-axis) or ignored (6-axis IMU update).
    pub fn new(beta: f64, max_dt_s: f64, use_magnetometer: bool) -> Self {
        MadgwickTracker {
            beta,
            max_dt_s,
            use_magnetometer,
            q_nwu: None,
            last_gyro_t_ns: None,
            acc: None,
            mag: None,
            skipped_samples: 0,
        }
    }

    /// Whether the filter has an orientation yet.
    pub fn is_initialised(&self) -> bool {
        self.q_nwu.is_some()
    }

    /// Sets the orientation (device -> ENU), e.g. from the rotation vector at
    /// k0 so that the filter starts from theta_k0 (eq. 32).
    pub fn set_orientation(&mut self, q_enu: UnitQuaternion<f64>) {
        if !q_enu.coords.iter().all(|c| c.is_finite()) {
            return;
        }
        self.q_nwu = Some(nwu_to_enu().inverse() * q_enu);
    }

    /// Current orientation, device -> ENU.
    pub fn orientation(&self) -> Option<UnitQuaternion<f64>> {
        self.q_nwu.map(|q| nwu_to_enu() * q)
    }

    /// Records the latest accelerometer sample (m/s^2, with gravity).
    pub fn on_accelerometer(&mut self, acc: Vector3<f64>) {
        if acc.iter().all(|v| v.is_finite()) {
            self.acc = Some(acc);
        }
    }

    /// Records the latest magnetometer sample (uT).
    pub fn on_magnetometer(&mut self, mag: Vector3<f64>) {
        if mag.iter().all(|v| v.is_finite()) {
            self.mag = Some(mag);
        }
    }

    /// Orientation from the latest accelerometer (tilt) and magnetometer
    /// (yaw) samples, device -> ENU. Without a usable magnetometer the yaw is
    /// arbitrary (the device's x axis is taken as east).
    pub fn static_orientation(&self) -> Option<UnitQuaternion<f64>> {
        let up = self.acc?.try_normalize(1e-6)?;
        let east = self
            .mag
            .filter(|_| self.use_magnetometer)
            .and_then(|m| m.cross(&up).try_normalize(1e-6))
            .or_else(|| {
                let x = Vector3::x();
                (x - up * up.dot(&x))
                    .try_normalize(1e-6)
                    .or_else(|| (Vector3::y() - up * up.y).try_normalize(1e-6))
            })?;
        let north = up.cross(&east);
        // Rows are the ENU axes in device coordinates: R maps device -> ENU.
        let m = Matrix3::from_rows(&[east.transpose(), north.transpose(), up.transpose()]);
        Some(UnitQuaternion::from_rotation_matrix(
            &Rotation3::from_matrix_unchecked(m),
        ))
    }

    /// Integrates one gyroscope sample (rad/s) taken at `t_ns`, corrected by
    /// the latest accelerometer and magnetometer samples. Initialises from
    /// [`Self::static_orientation`] when not yet initialised.
    pub fn on_gyroscope(&mut self, t_ns: i64, gyro: Vector3<f64>) {
        let prev = self.last_gyro_t_ns;
        if prev.is_some_and(|p| t_ns <= p) || !gyro.iter().all(|v| v.is_finite()) {
            self.skipped_samples += 1;
            return;
        }
        self.last_gyro_t_ns = Some(t_ns);
        if self.q_nwu.is_none() {
            if let Some(q) = self.static_orientation() {
                self.set_orientation(q);
            }
            return;
        }
        let (Some(prev), Some(q)) = (prev, self.q_nwu) else {
            return;
        };
        let dt = ((t_ns - prev) as f64 * 1e-9).min(self.max_dt_s);
        let mut filter = Madgwick::new_with_quat(dt, self.beta, q);
        let mag = self
            .mag
            .filter(|m| self.use_magnetometer && m.norm() > 1e-6);
        let updated = match (self.acc, mag) {
            (Some(a), Some(m)) => filter.update(&gyro, &a, &m).copied(),
            (Some(a), None) => filter.update_imu(&gyro, &a).copied(),
            (None, _) => Ok(*filter.update_gyro(&gyro)),
        };
        let q_new = match updated {
            Ok(q) => q,
            // Zero-norm accelerometer or magnetometer: integrate the gyro alone.
            Err(_) => *Madgwick::new_with_quat(dt, self.beta, q).update_gyro(&gyro),
        };
        if q_new.coords.iter().all(|c| c.is_finite()) {
            self.q_nwu = Some(q_new);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdr::orientation::{enu_from_device, forward_yaw_rad, to_android};

    /// Earth field in ENU: 30 uT north, 40 uT down (northern hemisphere).
    fn earth_mag_enu() -> Vector3<f64> {
        Vector3::new(0.0, 30.0, -40.0)
    }

    fn yaw_of(q: &UnitQuaternion<f64>) -> f64 {
        forward_yaw_rad(&enu_from_device(to_android(q)).unwrap()).unwrap()
    }

    #[test]
    fn converges_to_a_known_static_attitude() {
        // True attitude: yaw 50 deg, pitch 20 deg, roll -10 deg (device -> ENU).
        let truth = UnitQuaternion::from_euler_angles(
            -10f64.to_radians(),
            20f64.to_radians(),
            50f64.to_radians(),
        );
        let acc = truth.inverse() * Vector3::new(0.0, 0.0, 9.81);
        let mag = truth.inverse() * earth_mag_enu();
        let mut m = MadgwickTracker::new(0.1, 0.1, true);
        // Start from a wrong attitude (identity) and let the filter converge.
        m.set_orientation(UnitQuaternion::identity());
        let mut t = 0i64;
        for i in 0..3000 {
            // 50 Hz with +-3 ms jitter.
            t += 20_000_000 + if i % 2 == 0 { 3_000_000 } else { -3_000_000 };
            m.on_accelerometer(acc);
            m.on_magnetometer(mag);
            m.on_gyroscope(t, Vector3::zeros());
        }
        let est = m.orientation().unwrap();
        let err_deg = est.angle_to(&truth).to_degrees();
        assert!(err_deg < 1.0, "attitude error {err_deg} deg");
    }

    #[test]
    fn static_initialisation_finds_yaw_from_the_magnetometer() {
        let truth = UnitQuaternion::from_euler_angles(0.05, -0.1, -2.0);
        let mut m = MadgwickTracker::new(0.1, 0.1, true);
        m.on_accelerometer(truth.inverse() * Vector3::new(0.0, 0.0, 9.81));
        m.on_magnetometer(truth.inverse() * earth_mag_enu());
        m.on_gyroscope(0, Vector3::zeros());
        let est = m.orientation().unwrap();
        assert!(est.angle_to(&truth).to_degrees() < 1e-6);
    }

    #[test]
    fn gyro_rotation_is_integrated_with_jittered_dt() {
        // Flat phone turning at 0.5 rad/s about up for 2 s, IMU-only with small
        // gain: the yaw must advance by about 1 rad whatever the sample spacing.
        let mut m = MadgwickTracker::new(0.01, 0.1, false);
        m.set_orientation(UnitQuaternion::identity());
        let mut t = 0i64;
        m.on_accelerometer(Vector3::new(0.0, 0.0, 9.81));
        m.on_gyroscope(t, Vector3::new(0.0, 0.0, 0.5));
        let y0 = yaw_of(&m.orientation().unwrap());
        let mut i = 0;
        while t < 2_000_000_000 {
            let dt = [7_000_000, 13_000_000, 25_000_000][i % 3];
            t = (t + dt).min(2_000_000_000);
            m.on_gyroscope(t, Vector3::new(0.0, 0.0, 0.5));
            i += 1;
        }
        let turned = yaw_of(&m.orientation().unwrap()) - y0;
        assert!((turned - 1.0).abs() < 0.01, "turned {turned} rad");
    }

    #[test]
    fn duplicate_timestamps_are_skipped() {
        let mut m = MadgwickTracker::new(0.1, 0.1, false);
        m.set_orientation(UnitQuaternion::identity());
        m.on_accelerometer(Vector3::new(0.0, 0.0, 9.81));
        m.on_gyroscope(10, Vector3::new(0.0, 0.0, 1.0));
        m.on_gyroscope(10, Vector3::new(0.0, 0.0, 1.0));
        m.on_gyroscope(5, Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(m.skipped_samples, 2);
    }
}
