//! iBeacon-style proximity classes (proximity-PF paper, Sec. II) and the
//! "Near" likelihood P(d) of its eq. 5.
//!
//! The paper reads the classes from the iOS/Android beacon API. We derive
//! them from the Kalman-filtered RSSI and each beacon's own path-loss model:
//! the class boundaries are the paper's distances (Immediate: d <= 1 m,
//! Near: 1 m < d <= 3 m, Far: d > 3 m), turned into per-beacon RSSI
//! thresholds R0 - 10 n log10(d) on the 3-D range. A beacon not in the
//! filtered set is Unknown.

use serde::{Deserialize, Serialize};

use super::frontend::FilteredBeacon;
use crate::{Error, Result};

/// A proximity class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Proximity {
    Immediate,
    Near,
    Far,
    Unknown,
}

/// Distance boundaries of the classes (`prox_pf.proximity`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProximityConfig {
    /// Upper bound of Immediate, metres (3-D range). Default 1 (paper Sec. II).
    pub immediate_max_m: f64,
    /// Upper bound of Near, metres (3-D range). Default 3 (paper Sec. II).
    pub near_max_m: f64,
}

impl Default for ProximityConfig {
    fn default() -> Self {
        ProximityConfig {
            immediate_max_m: 1.0,
            near_max_m: 3.0,
        }
    }
}

impl ProximityConfig {
    /// Checks the fields; errors name the field under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        if !(self.immediate_max_m.is_finite() && self.immediate_max_m > 0.0) {
            return Err(Error::config(
                format!("{prefix}.immediate_max_m"),
                "must be finite and > 0",
            ));
        }
        if !(self.near_max_m.is_finite() && self.near_max_m > self.immediate_max_m) {
            return Err(Error::config(
                format!("{prefix}.near_max_m"),
                "must be finite and > immediate_max_m",
            ));
        }
        Ok(())
    }

    /// RSSI thresholds (Immediate at or above the first, Near at or above the
    /// second) of a beacon with model `b.model`, dBm.
    pub fn thresholds_dbm(&self, b: &FilteredBeacon) -> (f64, f64) {
        (
            b.model.rssi_at(self.immediate_max_m, 1e-3),
            b.model.rssi_at(self.near_max_m, 1e-3),
        )
    }

    /// The class of a beacon in the filtered set.
    pub fn classify(&self, b: &FilteredBeacon) -> Proximity {
        if !b.rssi_dbm.is_finite() {
            return Proximity::Unknown;
        }
        let (imm, near) = self.thresholds_dbm(b);
        if b.rssi_dbm >= imm {
            Proximity::Immediate
        } else if b.rssi_dbm >= near {
            Proximity::Near
        } else {
            Proximity::Far
        }
    }
}

/// P(d) of eq. 5, the probability of reading "Near" at horizontal distance
/// `d_m` from a beacon: 1.1077 - 0.3053 d, clamped to [0, 1] (the line is
/// fitted on 0 <= d <= 2.4 m; it is 1 below 0.35 m and 0 beyond 3.63 m).
pub fn near_probability(d_m: f64) -> f64 {
    if !d_m.is_finite() {
        return 0.0;
    }
    (1.1077 - 0.3053 * d_m).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec2;
    use crate::ble::pathloss::PathLoss;

    fn b(rssi: f64) -> FilteredBeacon {
        FilteredBeacon {
            index: 0,
            floor: 0,
            pos: Vec2::zeros(),
            dz_m: 0.0,
            model: PathLoss {
                rssi_1m_dbm: -60.0,
                exponent: 2.0,
            },
            rssi_dbm: rssi,
            var_dbm2: 1.0,
            samples: 1,
            last_t_ns: 0,
        }
    }

    #[test]
    fn classes_follow_the_beacon_model() {
        let c = ProximityConfig::default();
        // -60 at 1 m, -69.54 at 3 m
        assert_eq!(c.classify(&b(-55.0)), Proximity::Immediate);
        assert_eq!(c.classify(&b(-60.0)), Proximity::Immediate);
        assert_eq!(c.classify(&b(-65.0)), Proximity::Near);
        assert_eq!(c.classify(&b(-69.5)), Proximity::Near);
        assert_eq!(c.classify(&b(-69.6)), Proximity::Far);
        assert_eq!(c.classify(&b(f64::NAN)), Proximity::Unknown);
        let (imm, near) = c.thresholds_dbm(&b(-70.0));
        assert!((imm + 60.0).abs() < 1e-12);
        assert!((near - (-60.0 - 20.0 * 3f64.log10())).abs() < 1e-12);
    }

    #[test]
    fn near_likelihood_is_eq_5_clamped() {
        assert!((near_probability(2.4) - (1.1077 - 0.3053 * 2.4)).abs() < 1e-12);
        // paper's example: P(2.4) measured 19/56 = 0.339; the fitted line gives 0.375
        assert!((near_probability(2.4) - 0.339).abs() < 0.04);
        assert_eq!(near_probability(0.0), 1.0);
        assert_eq!(near_probability(0.2), 1.0);
        assert_eq!(near_probability(3.7), 0.0);
        assert_eq!(near_probability(100.0), 0.0);
        assert_eq!(near_probability(f64::NAN), 0.0);
        // monotone non-increasing
        let mut last = 1.0;
        for k in 0..100 {
            let p = near_probability(k as f64 * 0.05);
            assert!(p <= last && (0.0..=1.0).contains(&p));
            last = p;
        }
    }

    #[test]
    fn bad_config_names_the_field() {
        let c = ProximityConfig {
            immediate_max_m: 2.0,
            near_max_m: 1.0,
        };
        let e = c.validate("prox_pf.proximity").unwrap_err().to_string();
        assert!(e.contains("prox_pf.proximity.near_max_m"), "{e}");
    }
}
