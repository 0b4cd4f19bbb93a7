//! The engines, one module each (see `engine::factory` for the names).

pub mod ble_only;
pub mod fpbp;
pub mod pdr;
pub mod ppsa;
pub mod prox_pf;
pub mod robust_ekf;
pub mod scan_knn;
pub mod tc_ekf;
pub mod tcpf;
