//! Per-beacon one-dimensional Kalman filter on RSSI. State: the mean RSSI the
//! phone would see now; model: random walk, so between two observations dt
//! seconds apart the variance grows by `q * dt` (Q of the config, dBm^2/s);
//! each advert is a measurement with variance R (dBm^2). The first advert
//! initialises the state with variance R.

/// Filter state of one beacon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RssiKalman {
    /// Filtered RSSI, dBm.
    pub rssi_dbm: f64,
    /// Posterior variance, dBm^2.
    pub var_dbm2: f64,
    /// Time of the last update, ns.
    pub last_t_ns: i64,
    /// Observations absorbed.
    pub samples: u32,
}

impl RssiKalman {
    /// A filter initialised by its first observation.
    pub fn new(t_ns: i64, rssi_dbm: f64, r_dbm2: f64) -> Self {
        RssiKalman {
            rssi_dbm,
            var_dbm2: r_dbm2,
            last_t_ns: t_ns,
            samples: 1,
        }
    }

    /// Predicts to `t_ns` and absorbs one observation. Out-of-order
    /// observations (t earlier than the last update) are absorbed with dt = 0.
    pub fn update(&mut self, t_ns: i64, rssi_dbm: f64, q_dbm2_per_s: f64, r_dbm2: f64) {
        let dt_s = ((t_ns - self.last_t_ns).max(0)) as f64 * 1e-9;
        let p = self.var_dbm2 + q_dbm2_per_s * dt_s;
        let k = p / (p + r_dbm2);
        self.rssi_dbm += k * (rssi_dbm - self.rssi_dbm);
        self.var_dbm2 = (1.0 - k) * p;
        self.last_t_ns = self.last_t_ns.max(t_ns);
        self.samples = self.samples.saturating_add(1);
    }

    /// Predicted variance at `t_ns` (no observation), dBm^2.
    pub fn predicted_var(&self, t_ns: i64, q_dbm2_per_s: f64) -> f64 {
        self.var_dbm2 + q_dbm2_per_s * ((t_ns - self.last_t_ns).max(0)) as f64 * 1e-9
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn constant_input_converges_and_variance_shrinks() {
        let mut k = RssiKalman::new(0, -70.0, 16.0);
        for i in 1..50 {
            k.update(
                i * 100_000_000,
                if i % 2 == 0 { -66.0 } else { -74.0 },
                4.0,
                16.0,
            );
        }
        assert!((k.rssi_dbm + 70.0).abs() < 2.0, "{}", k.rssi_dbm);
        assert!(k.var_dbm2 < 16.0);
    }

    proptest! {
        #[test]
        fn estimate_stays_within_input_range(xs in proptest::collection::vec(-100.0f64..-40.0, 1..40)) {
            let mut k = RssiKalman::new(0, xs[0], 16.0);
            for (i, x) in xs.iter().enumerate().skip(1) {
                k.update(i as i64 * 50_000_000, *x, 4.0, 16.0);
            }
            let lo = xs.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            prop_assert!(k.rssi_dbm >= lo - 1e-9 && k.rssi_dbm <= hi + 1e-9);
            prop_assert!(k.var_dbm2 > 0.0 && k.var_dbm2 <= 16.0 + 1e-9);
        }
    }
}
