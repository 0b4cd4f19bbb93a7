//! Device orientation in the map frame (FP-BP eqs. 26-27) and the yaw of a
//! direction in the MCS (eq. 33).
//!
//! Frames: DCS is Android's device frame (x right, y up the screen, z out of
//! the screen); ECS is east-north-up; the 3-D MCS shares ECS's z axis and is
//! turned about it by the site's `map_from_enu_rad` (counter-clockwise).
//! Quaternions are Android's `[x, y, z, w]` and rotate DCS vectors into ECS.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// R_D^E of eq. 26: the rotation matrix of the quaternion `q = [x, y, z, w]`
/// (DCS -> ECS). The quaternion is normalised first; `None` when it is not
/// finite or has (near) zero norm.
pub fn enu_from_device(q: [f64; 4]) -> Option<Matrix3<f64>> {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if !n.is_finite() || n < 1e-9 {
        return None;
    }
    let (qx, qy, qz, qw) = (q[0] / n, q[1] / n, q[2] / n, q[3] / n);
    Some(Matrix3::new(
        1.0 - 2.0 * qy * qy - 2.0 * qz * qz,
        2.0 * qx * qy - 2.0 * qz * qw,
        2.0 * qx * qz + 2.0 * qy * qw,
        2.0 * qx * qy + 2.0 * qz * qw,
        1.0 - 2.0 * qx * qx - 2.0 * qz * qz,
        2.0 * qy * qz - 2.0 * qx * qw,
        2.0 * qx * qz - 2.0 * qy * qw,
        2.0 * qy * qz + 2.0 * qx * qw,
        1.0 - 2.0 * qx * qx - 2.0 * qy * qy,
    ))
}

/// R_E: the constant rotation ECS -> 3-D MCS, a turn of `map_from_enu_rad`
/// about the shared up axis (site.json's `map_from_enu_rad`).
pub fn map_from_enu(map_from_enu_rad: f64) -> Matrix3<f64> {
    let (s, c) = map_from_enu_rad.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// R_D = R_E * R_D^E (eq. 27): DCS -> 3-D MCS.
pub fn map_from_device(
    map_from_enu: &Matrix3<f64>,
    enu_from_device: &Matrix3<f64>,
) -> Matrix3<f64> {
    map_from_enu * enu_from_device
}

/// Android `[x, y, z, w]` quaternion from an nalgebra unit quaternion.
pub fn to_android(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.i, q.j, q.k, q.w]
}

/// nalgebra unit quaternion from an Android `[x, y, z, w]` quaternion
/// (normalised; `None` when degenerate or not finite).
pub fn from_android(q: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    let quat = nalgebra::Quaternion::new(q[3], q[0], q[1], q[2]);
    let n = quat.norm();
    if !n.is_finite() || n < 1e-9 {
        return None;
    }
    Some(UnitQuaternion::new_normalize(quat))
}

/// Yaw of the device's forward axis (DCS y, the top of the screen) in the MCS
/// (eqs. 32-33 for k <= k0): d' = R_D [0, 1, 0]^T projected on the xy plane,
/// normalised, theta = atan2(d_y, d_x). `None` when the forward axis is
/// (nearly) vertical, i.e. the projection has no direction.
pub fn forward_yaw_rad(map_from_device: &Matrix3<f64>) -> Option<f64> {
    axis_yaw_rad(map_from_device, &Vector3::new(0.0, 1.0, 0.0))
}

/// Yaw in the MCS of the floor projection of the DCS direction `axis`:
/// atan2(d_y, d_x) of d = R_D axis; `None` when d is (nearly) vertical.
pub fn axis_yaw_rad(map_from_device: &Matrix3<f64>, axis: &Vector3<f64>) -> Option<f64> {
    let d = map_from_device * axis;
    let h = d.x.hypot(d.y);
    if h < 1e-6 {
        return None;
    }
    Some(d.y.atan2(d.x))
}

/// The up (vertical) component of a DCS vector in the MCS: the third row of
/// R_D applied to `v` (eq. 28's z component; R_E leaves z unchanged).
pub fn up_component(enu_from_device: &Matrix3<f64>, v: &Vector3<f64>) -> f64 {
    enu_from_device.row(2).transpose().dot(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn eq26_matches_nalgebra() {
        let q = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
        let r = enu_from_device(to_android(&q)).unwrap();
        let expect = q.to_rotation_matrix().into_inner();
        assert!((r - expect).norm() < 1e-12, "{r} vs {expect}");
    }

    #[test]
    fn phone_flat_pointing_north_has_yaw_90_deg_in_enu_aligned_map() {
        // Identity: DCS == ENU, the top of the screen points north (+y in the MCS).
        let rd = map_from_device(
            &map_from_enu(0.0),
            &enu_from_device([0.0, 0.0, 0.0, 1.0]).unwrap(),
        );
        assert!((forward_yaw_rad(&rd).unwrap() - FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn known_quaternion_gives_known_yaw() {
        // Phone flat, turned 30 deg counter-clockwise about up: forward points
        // 30 deg west of north, i.e. yaw 120 deg in ENU; with the map turned by
        // -20 deg the MCS yaw is 100 deg.
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 30f64.to_radians());
        let rd = map_from_device(
            &map_from_enu((-20f64).to_radians()),
            &enu_from_device(to_android(&q)).unwrap(),
        );
        let yaw = forward_yaw_rad(&rd).unwrap().to_degrees();
        assert!((yaw - 100.0).abs() < 1e-9, "{yaw}");
    }

    #[test]
    fn tilted_phone_still_gives_forward_yaw() {
        // Pitched 40 deg (top up), then yawed 10 deg: the horizontal projection keeps the yaw.
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 10f64.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 40f64.to_radians());
        let rd = enu_from_device(to_android(&q)).unwrap();
        let yaw = forward_yaw_rad(&rd).unwrap().to_degrees();
        assert!((yaw - 100.0).abs() < 1e-9, "{yaw}");
    }

    #[test]
    fn degenerate_quaternions_are_rejected() {
        assert!(enu_from_device([0.0; 4]).is_none());
        assert!(enu_from_device([f64::NAN, 0.0, 0.0, 1.0]).is_none());
        assert!(from_android([0.0; 4]).is_none());
    }

    proptest! {
        #[test]
        fn gravity_of_a_still_phone_is_vertical(r in -3.0f64..3.0, p in -1.5f64..1.5, y in -3.0f64..3.0) {
            // A still phone measures +g along ECS up whatever its attitude.
            let q = UnitQuaternion::from_euler_angles(r, p, y);
            let acc_device = q.inverse() * Vector3::new(0.0, 0.0, 9.81);
            let m = enu_from_device(to_android(&q)).unwrap();
            prop_assert!((up_component(&m, &acc_device) - 9.81).abs() < 1e-9);
        }
    }
}
