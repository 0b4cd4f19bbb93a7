//! BLE fingerprinting of the BMW paper (Sec. 3.2): a fingerprint database,
//! its affinity-propagation clustering into sub-databases with the
//! relative-density outlier rule (eqs. 7-8, Table 1), matching a scan to the
//! best sub-database and WKNN inside it.
//!
//! Two sources of reference points: walked survey logs ([`survey`]: eq. 3
//! with the start/end compensation of [`db::compensate_walk`], unheard
//! beacons filled from the path-loss model, eqs. 4-6), or the site's
//! path-loss models alone at walkable grid points
//! ([`store::FingerprintSet::model`]). Either is clustered once into a
//! [`store::FingerprintSet`], which serialises to JSON ([`store::FingerprintFile`]).

pub mod cluster;
pub mod db;
pub mod store;
pub mod survey;
pub mod wknn;

pub use cluster::{SubDatabases, affinity_propagation, relative_density};
pub use db::{Fingerprint, FingerprintDb};
pub use store::{FingerprintFile, FingerprintSet, FloorDb};
pub use survey::{LogSurvey, SurveyBuilder};
pub use wknn::wknn;

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Fingerprinting parameters (`fingerprint` in engine configs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FingerprintConfig {
    /// Spacing of the model-built database's grid, metres. Default 2.0.
    pub grid_step_m: f64,
    /// Most points per floor database (farther grids are thinned). Default 900.
    pub max_points_per_floor: usize,
    /// RSSI used for a beacon not heard (and floor of predicted values), dBm. Default -100.
    pub missing_rssi_dbm: f64,
    /// Damping of affinity propagation, in [0.5, 1). Default 0.7.
    pub ap_damping: f64,
    /// Iterations of affinity propagation. Default 200.
    pub ap_iterations: usize,
    /// k of the density of eq. 7. Default 4.
    pub density_k: usize,
    /// A point whose relative density (eq. 8) is below this is an outlier
    /// and joins its nearest neighbour's cluster (Table 1). Default 0.5.
    pub outlier_relative_density: f64,
    /// Sub-databases to search: the best `search_clusters` by exemplar distance. Default 2.
    pub search_clusters: usize,
    /// k of WKNN. Default 4.
    pub wknn_k: usize,
    /// Only the strongest this many heard beacons of a scan are matched. Default 8.
    pub scan_max_beacons: usize,
    /// Survey builder: one RSSI sample (the BLE front end's filtered vector)
    /// every this many seconds, s. Default 1.0 (the BLE task period).
    pub survey_sample_interval_s: f64,
    /// Survey builder: samples are averaged in square cells of this side,
    /// metres (coarsened until `max_points_per_floor`). Default 1.0.
    pub survey_cell_m: f64,
    /// Survey builder: consecutive known points further apart in time than
    /// this are not a survey line, s. Default 60.
    pub survey_max_segment_s: f64,
    /// Survey builder: model grid points (`grid_step_m`) farther than this
    /// from every surveyed cell are added (the path-loss model covers what
    /// the survey did not walk), metres; 0 = survey points only. Default 0.
    pub survey_model_fill_m: f64,
    /// Survey builder: which truth points of a log are known points. 0 =
    /// every one (a surveyor whose position is known throughout); > 0 =
    /// only the vertices of the truth track simplified to straight lines
    /// within this tolerance (Douglas-Peucker), i.e. the start and end of
    /// each straight survey line, the points the BMW paper's surveyor
    /// labels (Sec. 3.2.1, Fig. 3); the positions between come from the
    /// PDR with eq. 3's compensation. Metres. Default 0.
    pub survey_line_tolerance_m: f64,
}

impl Default for FingerprintConfig {
    fn default() -> Self {
        FingerprintConfig {
            grid_step_m: 2.0,
            max_points_per_floor: 900,
            missing_rssi_dbm: -100.0,
            ap_damping: 0.7,
            ap_iterations: 200,
            density_k: 4,
            outlier_relative_density: 0.5,
            search_clusters: 2,
            wknn_k: 4,
            scan_max_beacons: 8,
            survey_sample_interval_s: 1.0,
            survey_cell_m: 1.0,
            survey_max_segment_s: 60.0,
            survey_model_fill_m: 0.0,
            survey_line_tolerance_m: 0.0,
        }
    }
}

impl FingerprintConfig {
    /// Checks every field's range, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |f: &str, m: &str| Err(Error::config(format!("fingerprint.{f}"), m.to_string()));
        use crate::bounds::{
            MAX_AP_WORK, MAX_FINGERPRINT_POINTS, MAX_ITERATIONS, check_count, check_grid_step,
        };
        check_grid_step("fingerprint.grid_step_m", self.grid_step_m)?;
        check_count(
            "fingerprint.max_points_per_floor",
            self.max_points_per_floor,
            2,
            MAX_FINGERPRINT_POINTS,
        )?;
        check_count(
            "fingerprint.ap_iterations",
            self.ap_iterations,
            1,
            MAX_ITERATIONS,
        )?;
        let work = self.ap_iterations as f64 * (self.max_points_per_floor as f64).powi(2);
        if work > MAX_AP_WORK {
            return Err(Error::config(
                "fingerprint.ap_iterations",
                format!(
                    "ap_iterations x max_points_per_floor^2 = {work:e} is over the limit of \
                     {MAX_AP_WORK:e} (affinity propagation would not finish)"
                ),
            ));
        }
        if !self.missing_rssi_dbm.is_finite() {
            return bad("missing_rssi_dbm", "must be finite");
        }
        if !(0.5..1.0).contains(&self.ap_damping) {
            return bad("ap_damping", "must be in [0.5, 1)");
        }
        for (f, v) in [
            ("density_k", self.density_k),
            ("wknn_k", self.wknn_k),
            ("search_clusters", self.search_clusters),
            ("scan_max_beacons", self.scan_max_beacons),
        ] {
            check_count(&format!("fingerprint.{f}"), v, 1, MAX_FINGERPRINT_POINTS)?;
        }
        for (f, v) in [
            ("survey_sample_interval_s", self.survey_sample_interval_s),
            ("survey_cell_m", self.survey_cell_m),
            ("survey_max_segment_s", self.survey_max_segment_s),
        ] {
            if !(v.is_finite() && v >= 0.01) {
                return bad(f, "must be finite and >= 0.01");
            }
        }
        if !(self.survey_model_fill_m.is_finite() && self.survey_model_fill_m >= 0.0) {
            return bad("survey_model_fill_m", "must be finite and >= 0");
        }
        if !(self.survey_line_tolerance_m.is_finite() && self.survey_line_tolerance_m >= 0.0) {
            return bad("survey_line_tolerance_m", "must be finite and >= 0");
        }
        if !(self.outlier_relative_density.is_finite() && self.outlier_relative_density >= 0.0) {
            return bad("outlier_relative_density", "must be finite and >= 0");
        }
        Ok(())
    }
}

/// Euclidean distance between two RSSI vectors, dB.
pub fn rssi_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// RMS difference over the entries where `scan` is not NaN (beacons heard),
/// dB; infinite when the scan holds none.
pub fn scan_distance(scan: &[f64], fp: &[f64]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (a, b) in scan.iter().zip(fp) {
        if !a.is_nan() {
            sum += (a - b) * (a - b);
            n += 1;
        }
    }
    if n == 0 {
        f64::INFINITY
    } else {
        (sum / n as f64).sqrt()
    }
}
