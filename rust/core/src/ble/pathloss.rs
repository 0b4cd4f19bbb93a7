//! The log-distance path-loss model (FP-BP eq. 1): R = R0 - 10 n log10(d) + X(sigma),
//! with R0 the RSSI at 1 m and n the path-loss exponent.

use serde::{Deserialize, Serialize};

/// One transmitter's model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PathLoss {
    /// R0, dBm at 1 m.
    pub rssi_1m_dbm: f64,
    /// n, the path-loss exponent (> 0).
    pub exponent: f64,
}

impl PathLoss {
    /// Expected RSSI at range `d_m` (clamped to at least `min_d_m`), dBm.
    pub fn rssi_at(&self, d_m: f64, min_d_m: f64) -> f64 {
        self.rssi_1m_dbm - 10.0 * self.exponent * d_m.max(min_d_m).log10()
    }

    /// log10 of the range implied by `rssi_dbm` (eq. 10b): (R0 - R) / (10 n).
    pub fn log10_distance(&self, rssi_dbm: f64) -> f64 {
        (self.rssi_1m_dbm - rssi_dbm) / (10.0 * self.exponent)
    }

    /// Range implied by `rssi_dbm`, metres.
    pub fn distance(&self, rssi_dbm: f64) -> f64 {
        10f64.powf(self.log10_distance(rssi_dbm))
    }
}

/// 3-D range between a phone at horizontal position `p` (height
/// `phone_height_m`) and a beacon at `b` mounted at `beacon_z_m`, floored at
/// `min_d_m`.
pub fn range_m(p: crate::Vec2, b: crate::Vec2, dz_m: f64, min_d_m: f64) -> f64 {
    let h2 = (p - b).norm_squared();
    (h2 + dz_m * dz_m).sqrt().max(min_d_m)
}

/// Horizontal range implied by a 3-D range and the vertical offset (0 when the
/// 3-D range is shorter than the offset).
pub fn horizontal_m(d3_m: f64, dz_m: f64) -> f64 {
    (d3_m * d3_m - dz_m * dz_m).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn distance_inverts_rssi(d in 0.5f64..200.0, r0 in -80.0f64..-40.0, n in 1.0f64..5.0) {
            let m = PathLoss { rssi_1m_dbm: r0, exponent: n };
            let r = m.rssi_at(d, 0.1);
            prop_assert!((m.distance(r) - d).abs() < 1e-9 * d.max(1.0));
        }
    }

    #[test]
    fn one_metre_gives_r0_and_ten_metres_loses_10n() {
        let m = PathLoss {
            rssi_1m_dbm: -59.0,
            exponent: 2.0,
        };
        assert!((m.rssi_at(1.0, 0.1) + 59.0).abs() < 1e-12);
        assert!((m.rssi_at(10.0, 0.1) + 79.0).abs() < 1e-12);
        assert!((m.rssi_at(0.0, 0.5) - m.rssi_at(0.5, 0.5)).abs() < 1e-12);
    }
}
