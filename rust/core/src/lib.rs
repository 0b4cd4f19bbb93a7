//! fpbp-core: the positioning core of fpbp.
//!
//! Map preprocessing (FP-BP Sec. IV-A), BLE positioning (Sec. III), PDR
//! (Sec. IV-B), particle-filter fusion and post-position correction
//! (Sec. IV-C/D), and the engines built from them. The core does no file,
//! network or platform I/O: callers hand it bytes and events.
#![deny(unsafe_code)]

pub mod ble;
pub mod bounds;
pub mod bundle;
pub mod engine;
pub mod engines;
pub mod error;
pub mod events;
pub mod fast_math;
pub mod fingerprint;
pub mod floor;
pub mod fusion;
pub mod geo;
pub mod geometry;
pub mod kalman;
pub mod map;
pub mod pdr;
pub mod radio;
pub mod radio_id;
pub mod simd;
pub mod site;
pub mod stats;
pub mod wifi;

pub use error::{Error, Result};
pub use geometry::Vec2;
