//! Particle-filter fusion of PDR steps with the BLE position x_B (FP-BP
//! Sec. IV-C) and the floor-plan post-position correction PPC (Sec. IV-D,
//! Algorithm 2).
//!
//! - [`particle_filter`]: eq. 34 (transition), eq. 36 (weights), resampling,
//!   eq. 35b (estimate), eq. 44 (shift).
//! - [`ppc`]: Algorithm 2 on a [`ppc::PlanQueries`] map (raycast, room, normal).
//! - [`recovery`]: extensions letting persistent BLE evidence move the
//!   cloud between rooms (augmented-MCL re-seeding, room-level estimate).
//! - [`weighted_quantile`]: a cloud's weighted distance quantile by
//!   quickselect (accuracy radii).
//! - [`FusionConfig`]: every threshold, with units and defaults.

pub mod config;
pub mod particle_filter;
pub mod ppc;
pub mod recovery;
pub mod uniforms;
pub mod weighted_quantile;

pub use config::{FusionConfig, PpcConfig, Resampling};
pub use particle_filter::ParticleFilter;
pub use ppc::{PlanQueries, PpcCase, PpcOutcome};
