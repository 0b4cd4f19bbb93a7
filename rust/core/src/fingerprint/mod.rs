//! BLE fingerprinting of the BMW paper (Sec. 3.2): a fingerprint database,
//! its affinity-propagation clustering into sub-databases with the
//! relative-density outlier rule (eqs. 7-8, Table 1), matching a scan to the
//! best sub-database and WKNN inside it.
//!
//! The database here is built from the site's beacons and path-loss models
//! at walkable grid points (the paper's eq. 6 interpolation applied to every
//! point), see [`db::FingerprintDb::from_model`]; walked survey samples
//! (eq. 3) can be added with [`db::FingerprintDb::push`] after the start/end
//! compensation of [`db::compensate_walk`].

pub mod cluster;
pub mod db;
pub mod wknn;

pub use cluster::{SubDatabases, affinity_propagation, relative_density};
pub use db::{Fingerprint, FingerprintDb};
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
        }
    }
}

impl FingerprintConfig {
    /// Checks every field's range, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |f: &str, m: &str| Err(Error::config(format!("fingerprint.{f}"), m.to_string()));
        if !(self.grid_step_m.is_finite() && self.grid_step_m > 0.0) {
            return bad("grid_step_m", "must be finite and > 0");
        }
        if self.max_points_per_floor < 2 {
            return bad("max_points_per_floor", "must be >= 2");
        }
        if !self.missing_rssi_dbm.is_finite() {
            return bad("missing_rssi_dbm", "must be finite");
        }
        if !(0.5..1.0).contains(&self.ap_damping) {
            return bad("ap_damping", "must be in [0.5, 1)");
        }
        if self.ap_iterations == 0
            || self.density_k == 0
            || self.wknn_k == 0
            || self.search_clusters == 0
        {
            return bad(
                "ap_iterations/density_k/wknn_k/search_clusters",
                "must be >= 1",
            );
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
