//! fpbp-eval: replaying recorded phone logs through the engines and
//! scoring them, for the `fpbp` command and for research code.
//!
//! - [`runner`]: sites, configs and logs from disk; each engine's start
//!   (its own, or the first truth point); one engine over one log.
//! - [`metrics`]: error statistics, the IPIN score, task times, the rows of
//!   one log and one engine.
//! - [`report`]: metrics.json, track.csv, seed summaries, track quality.
//! - [`eval`]: engines x logs x seeds in parallel ([`parallel`]), with
//!   outputs identical to a serial run; [`replay`]: one log, one engine.
//! - [`plot`]: CDF and track plots; [`progress`]: terminal progress bars.
//! - [`engine_data`], [`radio_map`], [`radios`]: what engines get beside
//!   the site (fingerprints, a radio map) and which radios they hear.
//! - [`heading_bias`]: a site's PDR heading bias from replays with truth.
//! - [`json_patch`]: `--set`-style JSON merges of configs and profiles.
//! - [`reproduce`]: the five papers on their simulated replica testbeds.
//!
//! Option structs (`EvalOptions`, `ReplayOptions`) derive `clap::Args`
//! with the `cli` feature.

pub mod engine_data;
pub mod eval;
pub mod heading_bias;
pub mod json_patch;
pub mod metrics;
pub mod parallel;
pub mod plot;
pub mod progress;
pub mod radio_map;
pub mod radios;
pub mod replay;
pub mod report;
pub mod reproduce;
pub mod runner;

#[cfg(test)]
mod testkit;
