//! Particle-filter fusion of PDR steps with the BLE position x_B (FP-BP
//! Sec. IV-C) and the floor-plan post-position correction PPC (Sec. IV-D,
//! Algorithm 2).
//!
//! The generic particle filter:
//! - [`cloud`]: the particle set ([`Cloud`]): positions, weights and
//!   per-particle state columns; normalisation, ESS, resampling, estimates
//!   (mean, spread), shift, replacement, injection,
//!   log-likelihood weights.
//! - [`model`]: the traits [`MotionModel`] (moves the cloud for one
//!   control input, drawing from the filter's RNG) and [`MeasurementModel`]
//!   (weighs it by one measurement).
//! - [`random`]: normals (Box-Muller, batched), points in a disc or around
//!   a centre, uniform indices; [`uniforms`]: many PCG-64 uniforms at once.
//! - [`cells`]: draws from a likelihood surface over cells.
//! - [`kld`]: the adaptive particle count of KLD-sampling (Fox 2003).
//!
//! FP-BP on it:
//! - [`fpbp_models`]: eq. 34 (transition, with per-particle heading offsets
//!   and step scales as an extension) and eq. 36 (weights).
//! - [`particle_filter`]: [`ParticleFilter`], the cloud with FP-BP's models,
//!   resampling, eq. 35b (estimate), eq. 44 (shift) and tcpf's hooks.
//! - [`ppc`]: Algorithm 2 on a [`ppc::PlanQueries`] map (raycast, room, normal).
//! - [`recovery`]: extensions letting persistent BLE evidence move the
//!   cloud between rooms (augmented-MCL re-seeding, room-level estimate).
//! - [`weighted_quantile`]: a cloud's weighted distance quantile by
//!   quickselect (accuracy radii).
//! - [`FusionConfig`]: every threshold, with units and defaults.

pub mod cells;
pub mod cloud;
pub mod config;
pub mod fpbp_models;
pub mod kld;
pub mod model;
pub mod particle_filter;
pub mod ppc;
pub mod random;
pub mod recovery;
pub mod uniforms;
pub mod weighted_quantile;

pub use cloud::Cloud;
pub use config::{FusionConfig, PpcConfig, Resampling};
pub use model::{MeasurementModel, MotionModel};
pub use particle_filter::ParticleFilter;
pub use ppc::{PlanQueries, PpcCase, PpcOutcome};
