//! Shared EKF math: the measurement update with IGG3 equivalent weights
//! (BMW paper eqs. 22-24), used by `robust-ekf` and `tc-ekf`.

pub mod config;
pub mod walking_direction;

pub use config::EkfConfig;

use nalgebra::{DMatrix, DVector};

/// IGG3 equivalent-weight factor p̄/p of eq. 22 for a normalised residual `u`
/// (eq. 23): 1 for |u| <= k0, k0/|u| * ((k1-|u|)/(k1-k0))^2 for k0 < |u| <= k1,
/// 0 beyond k1. A non-finite `u` gets 0.
pub fn igg3_factor(u: f64, k0: f64, k1: f64) -> f64 {
    let a = u.abs();
    if !a.is_finite() {
        0.0
    } else if a <= k0 {
        1.0
    } else if a <= k1 {
        k0 / a * ((k1 - a) / (k1 - k0)).powi(2)
    } else {
        0.0
    }
}

/// Variance given to a measurement whose IGG3 weight is 0 (it is ignored).
pub const REJECTED_VARIANCE: f64 = 1e12;

/// Outcome of one measurement update.
#[derive(Debug, Clone, PartialEq)]
pub struct UpdateReport {
    /// Normalised residuals u_i (eq. 23).
    pub normalized: Vec<f64>,
    /// IGG3 factors p̄_i / p_i applied.
    pub factors: Vec<f64>,
}

/// Dimension or value error of an update.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UpdateError {
    #[error("EKF update: {0}")]
    Shape(String),
    #[error("EKF update: non-finite or singular innovation")]
    Singular,
}

/// Robust EKF measurement update of state `x` (n) and covariance `p` (n x n)
/// with innovation `v = z - h(x)` (m), Jacobian `h` (m x n) and diagonal
/// measurement variances `r_diag` (m). Each variance is divided by its IGG3
/// factor (R̄ = P̄^-1, eq. 24) with `k0`, `k1`; `None` for `k` gives the plain
/// EKF. On error `x` and `p` are unchanged.
pub fn robust_update(
    x: &mut DVector<f64>,
    p: &mut DMatrix<f64>,
    v: &DVector<f64>,
    h: &DMatrix<f64>,
    r_diag: &DVector<f64>,
    k: Option<(f64, f64)>,
) -> Result<UpdateReport, UpdateError> {
    let n = x.len();
    let m = v.len();
    if p.shape() != (n, n) {
        return Err(UpdateError::Shape(format!(
            "P is {:?}, state has {n}",
            p.shape()
        )));
    }
    if h.shape() != (m, n) {
        return Err(UpdateError::Shape(format!(
            "H is {:?}, expected ({m}, {n})",
            h.shape()
        )));
    }
    if r_diag.len() != m {
        return Err(UpdateError::Shape(format!(
            "R has {} entries, innovation has {m}",
            r_diag.len()
        )));
    }
    if m == 0 {
        return Ok(UpdateReport {
            normalized: Vec::new(),
            factors: Vec::new(),
        });
    }
    if v.iter().chain(r_diag.iter()).any(|a| !a.is_finite()) || r_diag.iter().any(|r| *r <= 0.0) {
        return Err(UpdateError::Singular);
    }
    let hph = h * &*p * h.transpose();
    let mut normalized = Vec::with_capacity(m);
    let mut factors = Vec::with_capacity(m);
    let mut r_bar = DMatrix::zeros(m, m);
    for i in 0..m {
        let s_ii = hph[(i, i)] + r_diag[i];
        let u = v[i] / s_ii.max(1e-12).sqrt();
        let f = match k {
            Some((k0, k1)) => igg3_factor(u, k0, k1),
            None => 1.0,
        };
        normalized.push(u);
        factors.push(f);
        r_bar[(i, i)] = if f > 0.0 {
            r_diag[i] / f
        } else {
            REJECTED_VARIANCE
        };
    }
    let s = hph + r_bar;
    let s_inv = s.try_inverse().ok_or(UpdateError::Singular)?;
    let gain = &*p * h.transpose() * s_inv;
    let nx = &*x + &gain * v;
    let ident = DMatrix::<f64>::identity(n, n);
    let mut np = (ident - &gain * h) * &*p;
    np = (&np + np.transpose()) * 0.5;
    if nx.iter().chain(np.iter()).any(|a| !a.is_finite()) {
        return Err(UpdateError::Singular);
    }
    *x = nx;
    *p = np;
    Ok(UpdateReport {
        normalized,
        factors,
    })
}

pub use crate::geometry::wrap_pi;

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn igg3_weights_follow_eq22() {
        let (k0, k1) = (1.5, 3.0);
        assert_eq!(igg3_factor(0.0, k0, k1), 1.0);
        assert_eq!(igg3_factor(-1.5, k0, k1), 1.0);
        let f = igg3_factor(2.0, k0, k1);
        assert!(
            (f - 1.5 / 2.0 * (1.0f64 / 1.5).powi(2)).abs() < 1e-12,
            "{f}"
        );
        assert!(igg3_factor(2.999, k0, k1) < 1e-5);
        assert_eq!(igg3_factor(3.0, k0, k1), 0.0);
        assert_eq!(igg3_factor(-7.0, k0, k1), 0.0);
        assert_eq!(igg3_factor(f64::NAN, k0, k1), 0.0);
    }

    proptest! {
        #[test]
        fn igg3_is_in_0_1_and_non_increasing(a in 0.0f64..10.0, b in 0.0f64..10.0) {
            let (k0, k1) = (1.0, 2.5);
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            let fl = igg3_factor(lo, k0, k1);
            let fh = igg3_factor(hi, k0, k1);
            prop_assert!((0.0..=1.0).contains(&fl));
            prop_assert!(fh <= fl + 1e-12);
        }
    }

    #[test]
    fn update_checks_dimensions_and_leaves_state_alone_on_error() {
        let mut x = DVector::from_vec(vec![0.0, 0.0, 1.0, 0.5]);
        let mut p = DMatrix::identity(4, 4);
        let x0 = x.clone();
        let h_bad = DMatrix::zeros(2, 3);
        let v = DVector::from_vec(vec![1.0, 1.0]);
        let r = DVector::from_vec(vec![1.0, 1.0]);
        assert!(matches!(
            robust_update(&mut x, &mut p, &v, &h_bad, &r, None),
            Err(UpdateError::Shape(_))
        ));
        let mut h = DMatrix::zeros(2, 4);
        h[(0, 0)] = 1.0;
        h[(1, 1)] = 1.0;
        let r3 = DVector::from_vec(vec![1.0, 1.0, 1.0]);
        assert!(robust_update(&mut x, &mut p, &v, &h, &r3, None).is_err());
        let vnan = DVector::from_vec(vec![f64::NAN, 1.0]);
        assert!(robust_update(&mut x, &mut p, &vnan, &h, &r, None).is_err());
        assert_eq!(x, x0);
        // a 2-row position update of a 4-state filter: P stays 4x4 and the
        // gain halves the innovation on the observed states
        let rep = robust_update(&mut x, &mut p, &v, &h, &r, Some((1.5, 3.0))).unwrap();
        assert_eq!(rep.factors, vec![1.0, 1.0]);
        assert_eq!(p.shape(), (4, 4));
        assert!((x[0] - 0.5).abs() < 1e-12 && (x[1] - 0.5).abs() < 1e-12);
        assert_eq!((x[2], x[3]), (1.0, 0.5));
        assert!((p[(0, 0)] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn igg3_rejects_an_outlier_the_plain_ekf_follows() {
        let h = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
        let r = DVector::from_vec(vec![1.0]);
        let v = DVector::from_vec(vec![20.0]);
        let (mut xa, mut pa) = (DVector::zeros(2), DMatrix::identity(2, 2));
        let (mut xb, mut pb) = (DVector::zeros(2), DMatrix::identity(2, 2));
        robust_update(&mut xa, &mut pa, &v, &h, &r, None).unwrap();
        let rep = robust_update(&mut xb, &mut pb, &v, &h, &r, Some((1.5, 3.0))).unwrap();
        assert!((xa[0] - 10.0).abs() < 1e-9);
        assert_eq!(rep.factors, vec![0.0]);
        assert!(xb[0].abs() < 1e-9, "{}", xb[0]);
    }

    #[test]
    fn wraps_angles() {
        assert!((wrap_pi(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap_pi(-0.5) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn wrap_pi_differs_from_wrap_angle_only_in_the_last_bits_of_negative_angles() {
        use crate::geometry::wrap_angle;
        use std::f64::consts::PI;
        for a in [
            PI,
            -PI,
            3.0 * PI,
            -3.0 * PI,
            0.0,
            -0.0,
            0.5,
            -0.5,
            4.0,
            -4.0,
            1e6,
            -1e6,
        ] {
            assert_eq!(wrap_pi(a).to_bits(), wrap_angle(a).to_bits(), "{a}");
        }
        assert!(wrap_pi(f64::NAN).is_nan() && wrap_angle(f64::NAN).is_nan());
        assert_eq!(wrap_angle(-1e-10), -1e-10);
        assert_ne!(wrap_pi(-1e-10), -1e-10);
        assert!((wrap_pi(-1e-10) + 1e-10).abs() < 1e-15);
        assert_eq!((wrap_pi(-1e-20), wrap_angle(-1e-20)), (0.0, -1e-20));
    }
}
