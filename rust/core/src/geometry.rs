//! Small geometry helpers shared by every module. Positions are in the map
//! coordinate system (MCS): metres, x right, y up (FP-BP eq. 23).

/// A 2-D point or vector in the MCS, metres.
pub type Vec2 = nalgebra::Vector2<f64>;

/// Wraps an angle to (-pi, pi].
pub fn wrap_angle(a_rad: f64) -> f64 {
    let mut a = a_rad % std::f64::consts::TAU;
    if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    } else if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    }
    a
}

/// Wraps an angle to (-pi, pi].
///
/// Not [`wrap_angle`], though it agrees with it at ±pi,
/// on multiples of pi, on positive angles and on NaN: a negative angle goes
/// through `a + 2 pi` here and comes back up to half an ulp of 2 pi off
/// (`wrap_pi(-1e-10)` is -1.00000008e-10, `wrap_pi(-1e-20)` is 0), where
/// `wrap_angle` returns an angle already in range unchanged. The robust
/// EKF's heading innovations go through it, so its tracks depend on these
/// bits (unit test).
pub fn wrap_pi(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let mut w = a.rem_euclid(t);
    if w > std::f64::consts::PI {
        w -= t;
    }
    w
}

/// Rotates `v` counter-clockwise by `phi_rad` (FP-BP eq. 38).
pub fn rotate(v: Vec2, phi_rad: f64) -> Vec2 {
    let (s, c) = phi_rad.sin_cos();
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// The included angle between two vectors, in [0, pi]; 0 when either is zero.
pub fn included_angle(a: Vec2, b: Vec2) -> f64 {
    let na = a.norm();
    let nb = b.norm();
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    (a.dot(&b) / (na * nb)).clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn wrap_stays_in_range(a in -100.0f64..100.0) {
            let w = wrap_angle(a);
            prop_assert!(w > -std::f64::consts::PI - 1e-12 && w <= std::f64::consts::PI + 1e-12);
            prop_assert!(((w - a) / std::f64::consts::TAU).round() * std::f64::consts::TAU - (w - a) < 1e-9);
        }
    }

    #[test]
    fn rotate_quarter_turn() {
        let r = rotate(Vec2::new(1.0, 0.0), std::f64::consts::FRAC_PI_2);
        assert!((r - Vec2::new(0.0, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn included_angle_of_opposites_is_pi() {
        let a = included_angle(Vec2::new(1.0, 0.0), Vec2::new(-2.0, 0.0));
        assert!((a - std::f64::consts::PI).abs() < 1e-12);
    }
}
