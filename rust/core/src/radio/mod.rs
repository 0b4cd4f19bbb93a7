//! The radio measurement model shared by the tightly coupled engines: what
//! RSSI a transmitter (BLE beacon or WiFi access point, one kind of
//! [`Transmitter`] each) should give at a position, how likely a heard RSSI
//! is there, the phone's RSSI offset, and the window that turns raw
//! advertisements and scans into one measurement set per radio update.
//!
//! - [`derived`]: values derived from a model (grids over its survey
//!   scans) built once per model and shared by the engines on it.
//! - [`model`]: the [`RadioModel`] trait and [`PathLossModel`], the fitted
//!   log-distance model of every beacon and access point of the site
//!   (`fpbp calibrate`, `calibrate --wifi`).
//! - [`likelihood`]: heavy-tailed (Student-t) per-transmitter likelihood,
//!   tempered by the number of transmitters heard, with the phone offset
//!   profiled or given.
//! - [`offset`]: the online phone RSSI offset (no per-model table, no truth).
//! - [`window`]: per-transmitter readings since the last update.
//! - [`radio_map`]: [`RadioMap`], a radio map learned from survey walks
//!   (per-transmitter kernel-smoothed mean and spread on a grid, path-loss
//!   or prior fallback far from the walks), built by [`radio_map_build`]
//!   from [`survey`] samples; its JSON file `fpbp-radio-map` in
//!   [`radio_map_file`].
//! - [`map_calibration`]: is a radio map's spread honest? Standardised
//!   residuals of held-out walks by distance from the survey.
//! - [`survey_track`]: the survey walker's position between truth points
//!   shaped by its own PDR (`fpbp calibrate --survey-track pdr`).
//! - [`reference_scans`]: the survey walks' scan vectors (fingerprints)
//!   and their k-nearest-neighbour query, carried in the radio map file;
//!   `tcpf` anchors its start and re-seeding on them.
//! - [`wall_prior`]: a multi-wall path-loss prior fitted on the survey
//!   (walls counted on the floor plan) under the radio map, where the
//!   survey never went.

pub mod derived;
pub mod device_offsets;
pub mod fast_ln;
pub mod likelihood;
pub mod magnetic_map;
pub mod map_calibration;
pub mod model;
pub mod offset;
pub mod radio_map;
pub mod radio_map_build;
pub mod radio_map_config;
pub mod radio_map_file;
pub mod radio_map_spread;
pub mod reference_scans;
pub mod survey;
pub mod survey_track;
pub mod walk_offsets;
pub mod wall_prior;
pub mod window;

pub use likelihood::{LikelihoodConfig, Measurement};
pub use model::{PathLossModel, RadioModel, Transmitter, TxKind};
pub use offset::PhoneOffset;
pub use radio_map::{RadioMap, RadioMapBuilder, RadioMapConfig};
pub use window::ScanWindow;
