//! Device RSSI bias (TC paper eq. 19, device heterogeneity): a scalar
//! random-walk Kalman filter of RSSI_b = measured - calibrated model RSSI,
//! fed with residuals at a known (estimated) position. Any engine with a
//! position estimate can run it and subtract [`RssiBiasEstimator::bias_db`]
//! from raw RSSI before ranging; `tc-ekf` carries the same quantity as a
//! state of its filter.

use super::frontend::FilteredBeacon;
use super::pathloss::range_m;
use crate::Vec2;

/// Random-walk Kalman filter of the RSSI bias.
#[derive(Debug, Clone, PartialEq)]
pub struct RssiBiasEstimator {
    bias_db: f64,
    var_db2: f64,
    q_db2_per_s: f64,
    r_db2: f64,
    last_t_ns: Option<i64>,
    /// Residuals used.
    pub updates: u64,
}

impl RssiBiasEstimator {
    /// Prior 0 dB +- `prior_sigma_db`, random walk `q_db2_per_s`, residual
    /// noise `sigma_db` per beacon.
    pub fn new(prior_sigma_db: f64, q_db2_per_s: f64, sigma_db: f64) -> Self {
        RssiBiasEstimator {
            bias_db: 0.0,
            var_db2: prior_sigma_db * prior_sigma_db,
            q_db2_per_s,
            r_db2: sigma_db * sigma_db,
            last_t_ns: None,
            updates: 0,
        }
    }

    /// The estimate, dB (positive: the phone reads stronger than calibrated).
    pub fn bias_db(&self) -> f64 {
        self.bias_db
    }

    /// Its standard deviation, dB.
    pub fn sigma_db(&self) -> f64 {
        self.var_db2.sqrt()
    }

    /// One residual (measured minus model RSSI, dB) at `t_ns`. Non-finite
    /// residuals are ignored (returns false).
    pub fn update(&mut self, t_ns: i64, residual_db: f64) -> bool {
        if !residual_db.is_finite() {
            return false;
        }
        if let Some(t0) = self.last_t_ns
            && t_ns > t0
        {
            self.var_db2 += self.q_db2_per_s * (t_ns - t0) as f64 * 1e-9;
        }
        if self.last_t_ns.is_none_or(|t0| t_ns > t0) {
            self.last_t_ns = Some(t_ns);
        }
        let k = self.var_db2 / (self.var_db2 + self.r_db2);
        self.bias_db += k * (residual_db - self.bias_db);
        self.var_db2 *= 1.0 - k;
        self.updates += 1;
        true
    }

    /// Residuals of `beacons` heard at position `pos` (phone height folded
    /// into each beacon's `dz_m`), ranges floored at `min_d_m`.
    pub fn update_at(&mut self, t_ns: i64, pos: Vec2, beacons: &[FilteredBeacon], min_d_m: f64) {
        if !(pos.x.is_finite() && pos.y.is_finite()) {
            return;
        }
        for b in beacons {
            let d = range_m(pos, b.pos, b.dz_m, min_d_m);
            self.update(t_ns, b.rssi_dbm - b.model.rssi_at(d, min_d_m));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converges_to_a_constant_bias_and_ignores_nan() {
        let mut e = RssiBiasEstimator::new(6.0, 0.01, 5.0);
        for k in 0..200 {
            let noise = ((k * 7919) % 11) as f64 - 5.0; // deterministic +-5 dB
            e.update(k * 100_000_000, -8.0 + noise);
        }
        assert!(!e.update(0, f64::NAN));
        assert!((e.bias_db() + 8.0).abs() < 1.0, "{}", e.bias_db());
        assert!(e.sigma_db() < 1.0);
        assert_eq!(e.updates, 200);
    }
}
