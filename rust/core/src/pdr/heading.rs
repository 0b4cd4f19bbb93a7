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

/// Tracks the k0 switch of [`HeadingSource::RotationVectorThenMadgwick`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchClock {
    /// k0 as a time after the first sensor sample, ns; `None`: never switch.
    k0_ns: Option<i64>,
    first_t_ns: Option<i64>,
    switched: bool,
}

impl SwitchClock {
    pub fn new(k0_s: Option<f64>) -> Self {
        SwitchClock {
            k0_ns: k0_s.map(|s| (s * 1e9) as i64),
            first_t_ns: None,
            switched: false,
        }
    }

    /// Notes a sensor time; returns true exactly once, at the first sample at
    /// or after k0.
    pub fn tick(&mut self, t_ns: i64) -> bool {
        let first = *self.first_t_ns.get_or_insert(t_ns);
        if self.switched {
            return false;
        }
        match self.k0_ns {
            Some(k0) if t_ns - first >= k0 => {
                self.switched = true;
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
