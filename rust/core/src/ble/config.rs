//! Parameters of the BLE subsystem, one serde struct with sub-structs. Every
//! default and where it came from is listed in docs/parameters.md ("BLE").

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Parameters of the BLE subsystem (`EngineConfig::ble`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BleConfig {
    /// Per-beacon RSSI Kalman filter.
    pub kalman: KalmanConfig,
    /// Observations weaker than this are ignored as noise and counted as
    /// rejected, dBm. Default -110.
    pub min_rssi_dbm: f64,
    /// Height of the phone above the floor, metres (vertical leg of every
    /// beacon range). Default 1.2.
    pub phone_height_m: f64,
    /// Smallest range used in the path-loss model, metres (avoids log 0). Default 0.5.
    pub min_distance_m: f64,
    /// n of eq. 22: the BLE position is the mean of the current estimate and
    /// n - 1 earlier terms (see `mean_mode`). 1 disables the mean filter. Default 3.
    pub mean_window_n: usize,
    /// Which earlier terms eq. 22 averages: `estimates` (the previous raw
    /// estimates, a moving average) or `outputs` (the previous outputs, the
    /// literal recursive reading). Default `estimates`.
    pub mean_mode: super::mean_filter::MeanMode,
    /// The mean filter forgets its history when the last output is older than
    /// this, seconds. Default 5.
    pub mean_reset_s: f64,
    /// The GML estimator (eqs. 9-21).
    pub gml: GmlConfig,
    /// LLS trilateration baseline.
    pub trilat: TrilatConfig,
    /// FRBW baseline (filtered RSSI and beacon weight).
    pub frbw: FrbwConfig,
    /// Continuous maximum-likelihood baseline.
    pub ml: MlConfig,
    /// Weighted-centroid baseline.
    pub wcentroid: WeightedCentroidConfig,
    /// Beacon calibration from survey logs (`fpbp calibrate`).
    pub calibration: CalibrationConfig,
    /// NLOS identification (PPSA eqs. 1-10) and its use by the BLE-only
    /// positioners (`nlos.gml_mode`, default off).
    pub nlos: super::nlos::NlosConfig,
    /// Estimate the phone's RSSI bias (`ble::rssi_bias`, prior 6 dB, random
    /// walk 0.01 dB^2/s, 5 dB per residual) from the residuals at each BLE fix
    /// and subtract it before positioning (GML, fpbp, baselines). Default false.
    pub estimate_rssi_bias: bool,
    /// Choose the BLE task's floor with the floor tracker (`floor::FloorTracker`,
    /// barometer changes fused with the likely-floor votes) when the log has
    /// pressure samples (GML, fpbp, bp, baselines); without pressure nothing
    /// changes. Default true (docs/floors.md).
    pub floor_tracker: bool,
    /// The floor tracker's parameters (as `ekf.floor`).
    pub floor: crate::floor::FloorConfig,
}

impl Default for BleConfig {
    fn default() -> Self {
        BleConfig {
            kalman: KalmanConfig::default(),
            floor_tracker: true,
            floor: crate::floor::FloorConfig::default(),
            min_rssi_dbm: -110.0,
            phone_height_m: 1.2,
            min_distance_m: 0.5,
            mean_window_n: 3,
            mean_mode: super::mean_filter::MeanMode::Estimates,
            mean_reset_s: 5.0,
            gml: GmlConfig::default(),
            trilat: TrilatConfig::default(),
            frbw: FrbwConfig::default(),
            ml: MlConfig::default(),
            wcentroid: WeightedCentroidConfig::default(),
            calibration: CalibrationConfig::default(),
            nlos: super::nlos::NlosConfig::default(),
            estimate_rssi_bias: false,
        }
    }
}

/// One-dimensional Kalman filter on each beacon's RSSI: random-walk state,
/// `P += q * dt` between observations, measurement variance `r`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KalmanConfig {
    /// Process noise Q, dBm^2 per second of elapsed time (how fast the true mean
    /// RSSI may drift as the user walks). Default 4.
    pub process_noise_dbm2_per_s: f64,
    /// Measurement noise R, dBm^2 (variance of one advert's RSSI). Default 16.
    pub measurement_noise_dbm2: f64,
    /// A beacon not heard for this long is dropped from the filtered set, seconds. Default 6.
    pub staleness_s: f64,
    /// Observations a beacon needs before it enters the filtered set. Default 1.
    pub min_samples: u32,
}

impl Default for KalmanConfig {
    fn default() -> Self {
        KalmanConfig {
            process_noise_dbm2_per_s: 4.0,
            measurement_noise_dbm2: 16.0,
            staleness_s: 6.0,
            min_samples: 1,
        }
    }
}

/// GML (FP-BP eqs. 9-21).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GmlConfig {
    /// N of eq. 9: the N strongest filtered beacons are used (N >= 3). Default 6.
    pub top_n: usize,
    /// d0 of eqs. 20-21: Manhattan radius of the candidate set around the previous
    /// position, metres. Default 30.
    pub d0_m: f64,
    /// sigma-hat of eq. 12 (RSSI noise after filtering), dBm. With equal sigma
    /// and equal path-loss exponents every beacon has the same weight, as in the
    /// paper. Default 4.
    pub rssi_sigma_dbm: f64,
    /// Add each beacon's Kalman posterior variance to sigma-hat^2 (per-beacon
    /// eta of eq. 12) instead of the paper's equal eta. Default false.
    pub use_kalman_variance: bool,
    /// Density rule for G'1 vs G'2 (eqs. 20-21): G'1 is used when the previous
    /// position lies inside the hull of the selected beacons and at least this
    /// fraction of the G'2 candidates lies inside that hull; otherwise G'2.
    /// 1.0 never uses G'1 unless the whole neighbourhood is covered. Default 0.5.
    pub dense_min_inside_fraction: f64,
}

impl Default for GmlConfig {
    fn default() -> Self {
        GmlConfig {
            top_n: 6,
            d0_m: 30.0,
            rssi_sigma_dbm: 4.0,
            use_kalman_variance: false,
            dense_min_inside_fraction: 0.5,
        }
    }
}

/// LLS trilateration over all heard beacons.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrilatConfig {
    /// Use at most this many beacons, strongest first; 0 means all heard. Default 0.
    pub max_beacons: usize,
    /// Reject a geometry whose normal matrix has a condition number above this
    /// (collinear beacons). Default 1e6.
    pub max_condition: f64,
}

impl Default for TrilatConfig {
    fn default() -> Self {
        TrilatConfig {
            max_beacons: 0,
            max_condition: 1e6,
        }
    }
}

/// FRBW: weighted centroid of the top beacons with weights d^-g.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrbwConfig {
    /// Beacons used, strongest first (paper: 3). Default 3.
    pub top_n: usize,
    /// Weight adjustable degree g (paper: 5). Default 5.
    pub g: f64,
}

impl Default for FrbwConfig {
    fn default() -> Self {
        FrbwConfig { top_n: 3, g: 5.0 }
    }
}

/// Continuous ML: Levenberg-Marquardt on the cost of eq. 19 from the weighted centroid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MlConfig {
    /// Beacons used, strongest first (same N as GML by default). Default 6.
    pub top_n: usize,
    /// Iteration cap of the Levenberg-Marquardt loop. Default 50.
    pub max_iterations: u32,
}

impl Default for MlConfig {
    fn default() -> Self {
        MlConfig {
            top_n: 6,
            max_iterations: 50,
        }
    }
}

/// Weighted centroid with weights d^-exponent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WeightedCentroidConfig {
    /// Beacons used, strongest first; 0 means all heard. Default 4.
    pub top_n: usize,
    /// Weight exponent on the estimated range. Default 1.
    pub exponent: f64,
}

impl Default for WeightedCentroidConfig {
    fn default() -> Self {
        WeightedCentroidConfig {
            top_n: 4,
            exponent: 1.0,
        }
    }
}

/// Beacon calibration from survey logs with ground truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrationConfig {
    /// Adverts of one transmitter on one path are averaged into bins of this
    /// length, seconds. Default 1.
    pub bin_s: f64,
    /// Observations farther than this from the nearest truth point in time are
    /// dropped (no interpolation across long gaps), seconds. Default 20.
    pub max_truth_gap_s: f64,
    /// A transmitter must be heard on at least this many paths. Default 3.
    pub min_paths: usize,
    /// ... and in at least this many bins. Default 20.
    pub min_bins: usize,
    /// Largest robust residual spread (1.4826 MAD) of the path-loss fit, dBm. Default 7.
    pub max_residual_dbm: f64,
    /// Pearson correlation of RSSI with log10(distance) must be at most this
    /// (RSSI must fall with distance). Default -0.4.
    pub max_correlation: f64,
    /// Fitted path-loss exponent must lie in [min_exponent, max_exponent]. Default 1.0.
    pub min_exponent: f64,
    /// Default 5.0.
    pub max_exponent: f64,
    /// Largest spread of the per-path mean residuals (a moving or carried
    /// device shows path-dependent offsets), dBm. Default 5.
    pub max_path_bias_dbm: f64,
    /// Largest RMS over paths of the per-path excess residual: for each path,
    /// sqrt((Huber cost at the common position - Huber cost at that path's own
    /// best position) * 2 / bins), exponent fixed, each path with its own offset. A fixed transmitter
    /// explains every path from one place; a moving one does not. dBm. Default 2.5.
    pub max_path_excess_dbm: f64,
    /// The transmitter may lie this far outside the box of the positions where it
    /// was heard, metres. Default 10.
    pub search_margin_m: f64,
    /// Coarse step of the position search, metres. Default 2.
    pub coarse_step_m: f64,
    /// Huber threshold of the robust path-loss fit, dBm. Default 4.
    pub huber_k_dbm: f64,
    /// The path-loss exponent the fit leans towards (a Gaussian prior on
    /// n). Default 2.5.
    pub exponent_prior: f64,
    /// Strength of that prior: n one away from `exponent_prior` costs as
    /// much as this many bins 1 dB off (0: no prior). It keeps a
    /// transmitter heard only from afar from being fitted near the survey
    /// with a flat curve. Default 0.
    pub exponent_prior_bins: f64,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        CalibrationConfig {
            bin_s: 1.0,
            max_truth_gap_s: 20.0,
            min_paths: 3,
            min_bins: 20,
            max_residual_dbm: 7.0,
            max_correlation: -0.4,
            min_exponent: 1.0,
            max_exponent: 5.0,
            max_path_bias_dbm: 5.0,
            max_path_excess_dbm: 2.5,
            search_margin_m: 10.0,
            coarse_step_m: 2.0,
            huber_k_dbm: 4.0,
            exponent_prior: 2.5,
            exponent_prior_bins: 0.0,
        }
    }
}

fn positive(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::config(
            field,
            format!("must be finite and > 0, got {v}"),
        ))
    }
}

fn non_negative(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(Error::config(
            field,
            format!("must be finite and >= 0, got {v}"),
        ))
    }
}

impl BleConfig {
    /// Checks every field's range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        let k = &self.kalman;
        non_negative(
            "ble.kalman.process_noise_dbm2_per_s",
            k.process_noise_dbm2_per_s,
        )?;
        positive(
            "ble.kalman.measurement_noise_dbm2",
            k.measurement_noise_dbm2,
        )?;
        positive("ble.kalman.staleness_s", k.staleness_s)?;
        if k.min_samples == 0 {
            return Err(Error::config("ble.kalman.min_samples", "must be >= 1"));
        }
        if !(self.min_rssi_dbm.is_finite() && self.min_rssi_dbm < 0.0) {
            return Err(Error::config("ble.min_rssi_dbm", "must be finite and < 0"));
        }
        non_negative("ble.phone_height_m", self.phone_height_m)?;
        positive("ble.min_distance_m", self.min_distance_m)?;
        crate::bounds::check_count("ble.mean_window_n", self.mean_window_n, 1, 100_000)?;
        positive("ble.mean_reset_s", self.mean_reset_s)?;
        let g = &self.gml;
        if g.top_n < 3 {
            return Err(Error::config("ble.gml.top_n", "must be >= 3 (eq. 9)"));
        }
        positive("ble.gml.d0_m", g.d0_m)?;
        positive("ble.gml.rssi_sigma_dbm", g.rssi_sigma_dbm)?;
        if !(0.0..=1.0).contains(&g.dense_min_inside_fraction) {
            return Err(Error::config(
                "ble.gml.dense_min_inside_fraction",
                "must be in [0, 1]",
            ));
        }
        positive("ble.trilat.max_condition", self.trilat.max_condition)?;
        if self.trilat.max_beacons != 0 && self.trilat.max_beacons < 3 {
            return Err(Error::config(
                "ble.trilat.max_beacons",
                "must be 0 (all) or >= 3",
            ));
        }
        if self.frbw.top_n < 1 {
            return Err(Error::config("ble.frbw.top_n", "must be >= 1"));
        }
        non_negative("ble.frbw.g", self.frbw.g)?;
        if self.ml.top_n < 3 {
            return Err(Error::config("ble.ml.top_n", "must be >= 3"));
        }
        crate::bounds::check_count(
            "ble.ml.max_iterations",
            self.ml.max_iterations as usize,
            1,
            crate::bounds::MAX_ITERATIONS,
        )?;
        non_negative("ble.wcentroid.exponent", self.wcentroid.exponent)?;
        self.nlos.validate("ble.nlos")?;
        self.floor.validate().map_err(|e| e.within("ble."))?;
        self.calibration.validate()
    }
}

impl CalibrationConfig {
    /// Checks every field's range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        positive("ble.calibration.bin_s", self.bin_s)?;
        positive("ble.calibration.max_truth_gap_s", self.max_truth_gap_s)?;
        if self.min_paths == 0 {
            return Err(Error::config("ble.calibration.min_paths", "must be >= 1"));
        }
        if self.min_bins < 3 {
            return Err(Error::config("ble.calibration.min_bins", "must be >= 3"));
        }
        positive("ble.calibration.max_residual_dbm", self.max_residual_dbm)?;
        if !(-1.0..=1.0).contains(&self.max_correlation) {
            return Err(Error::config(
                "ble.calibration.max_correlation",
                "must be in [-1, 1]",
            ));
        }
        positive("ble.calibration.min_exponent", self.min_exponent)?;
        if !(self.max_exponent.is_finite() && self.max_exponent > self.min_exponent) {
            return Err(Error::config(
                "ble.calibration.max_exponent",
                "must be finite and > min_exponent",
            ));
        }
        positive("ble.calibration.max_path_bias_dbm", self.max_path_bias_dbm)?;
        positive(
            "ble.calibration.max_path_excess_dbm",
            self.max_path_excess_dbm,
        )?;
        non_negative("ble.calibration.search_margin_m", self.search_margin_m)?;
        crate::bounds::check_range(
            "ble.calibration.exponent_prior",
            self.exponent_prior,
            self.min_exponent,
            self.max_exponent,
        )?;
        crate::bounds::check_range(
            "ble.calibration.exponent_prior_bins",
            self.exponent_prior_bins,
            0.0,
            1e9,
        )?;
        crate::bounds::check_grid_step("ble.calibration.coarse_step_m", self.coarse_step_m)?;
        crate::bounds::check_range(
            "ble.calibration.search_margin_m",
            self.search_margin_m,
            0.0,
            crate::bounds::MAX_FLOOR_SIDE_M,
        )?;
        positive("ble.calibration.huber_k_dbm", self.huber_k_dbm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_and_round_trips() {
        let c = BleConfig::default();
        c.validate().unwrap();
        let s = serde_json::to_string(&c).unwrap();
        let back: BleConfig = serde_json::from_str(&s).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn bad_field_is_named() {
        let mut c = BleConfig::default();
        c.gml.top_n = 2;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("ble.gml.top_n"), "{e}");
        let e = serde_json::from_str::<BleConfig>(r#"{"gml":{"topn":3}}"#).unwrap_err();
        assert!(e.to_string().contains("topn"));
        for (field, v) in [("exponent_prior", 0.5), ("exponent_prior_bins", -1.0)] {
            let mut c = BleConfig::default();
            match field {
                "exponent_prior" => c.calibration.exponent_prior = v,
                _ => c.calibration.exponent_prior_bins = v,
            }
            let e = c.validate().unwrap_err().to_string();
            assert!(e.contains(&format!("ble.calibration.{field}")), "{e}");
        }
    }
}
