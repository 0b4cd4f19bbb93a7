//! Library part of the `fpbp` command: the pieces the binary's subcommands
//! share with the crate's examples (plots, site loading), so examples call
//! them instead of keeping copies.

pub mod json_patch;
pub mod plan_draw;
pub mod plot;
pub mod replica_sites;
pub mod replica_survey;
pub mod site_io;
