//! The engines, one module each, and the registry that builds them by name
//! ([`registry`]: `tcpf` the default, the papers' engines, the baselines).
//! The contract they implement (trait, events, pose, stats, tasks) is
//! [`crate::engine`]; it does not depend on this module.

pub mod ble_only;
pub mod config;
pub mod fpbp;
pub mod pdr;
pub mod ppsa;
pub mod prox_pf;
pub mod registry;
pub mod robust_ekf;
pub mod scan_knn;
pub mod tc_ekf;
pub mod tcpf;

pub use config::EngineConfig;
pub use registry::{
    ENGINE_NAMES, EngineData, build_engine, build_engine_with, config_sections,
    engine_settings_json,
};
