//! `wifi` section of the engine config: which scan results count, how
//! BSSIDs are grouped, the AP calibration and the WiFi-only baseline.

use serde::{Deserialize, Serialize};

use super::BssidGrouping;
use crate::Result;
use crate::ble::CalibrationConfig;

/// WiFi settings (docs/parameters.md "WiFi" gives every default's source).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WifiConfig {
    /// A result more than this older than its scan (Android's cached
    /// results) is not used, seconds.
    pub max_age_s: f64,
    /// Which BSSIDs share a position and path-loss model in calibration.
    pub grouping: BssidGrouping,
    /// Results weaker than this are not used, dBm.
    pub min_rssi_dbm: f64,
    /// Fit and acceptance tests of AP calibration (the BLE calibration's).
    pub calibration: CalibrationConfig,
    /// `wifi-wcentroid`: number of strongest APs (by Kalman-filtered RSSI)
    /// averaged, weights 1 / range^exponent.
    pub wcentroid_top_n: usize,
    pub wcentroid_exponent: f64,
}

impl Default for WifiConfig {
    fn default() -> Self {
        WifiConfig {
            max_age_s: 10.0,
            grouping: BssidGrouping::Bssid,
            min_rssi_dbm: -100.0,
            calibration: CalibrationConfig::default(),
            wcentroid_top_n: 6,
            wcentroid_exponent: 1.0,
        }
    }
}

impl WifiConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        if !(self.max_age_s.is_finite() && self.max_age_s >= 0.0) {
            return Err(crate::Error::config("wifi.max_age_s", "must be >= 0"));
        }
        if !(self.min_rssi_dbm.is_finite() && self.min_rssi_dbm < 0.0) {
            return Err(crate::Error::config("wifi.min_rssi_dbm", "must be < 0"));
        }
        if self.wcentroid_top_n == 0 || self.wcentroid_top_n > 64 {
            return Err(crate::Error::config(
                "wifi.wcentroid_top_n",
                "must be in 1..=64",
            ));
        }
        if !(self.wcentroid_exponent.is_finite() && self.wcentroid_exponent >= 0.0) {
            return Err(crate::Error::config(
                "wifi.wcentroid_exponent",
                "must be >= 0",
            ));
        }
        self.calibration.validate()
    }

    /// `max_age_s` in ns.
    pub fn max_age_ns(&self) -> i64 {
        (self.max_age_s * 1e9).min(9.0e18) as i64
    }
}
