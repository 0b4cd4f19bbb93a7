//! BLE positioning (FP-BP Sec. III): beacon ids and registry, the log-distance
//! path-loss model (eq. 1), per-beacon Kalman filtering of RSSI, the GML
//! estimator (eqs. 9-22), the baselines of the paper's comparison (LLS
//! trilateration, FRBW, continuous ML, weighted centroid), the BLE task that
//! bundles them with the mean filter (eq. 22), and beacon calibration from
//! survey logs.
//!
//! Distances: every range is the 3-D distance between the phone (held at
//! `phone_height_m` above the floor) and the beacon (mounted at `z_m`),
//! floored at `min_distance_m`; see [`pathloss`].

pub mod baselines;
pub mod calibrate;
pub mod config;
pub mod frontend;
pub mod gml;
pub mod gml_tables;
pub mod grid;
pub mod hull;
pub mod kalman;
pub mod mean_filter;
pub mod nlos;
pub mod pathloss;
pub mod positioner;
pub mod proximity;
pub mod registry;
pub mod rssi_bias;
pub mod task;

pub use crate::radio_id::{BeaconId, normalize_beacon_id};
pub use config::{
    BleConfig, CalibrationConfig, FrbwConfig, GmlConfig, KalmanConfig, MlConfig, TrilatConfig,
    WeightedCentroidConfig,
};
pub use frontend::{BleFrontEnd, FilteredBeacon};
pub use positioner::{BlePositioner, PositionerKind};
pub use registry::BeaconRegistry;
pub use task::BleTask;

#[cfg(test)]
pub(crate) mod testutil;
