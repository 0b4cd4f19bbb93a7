//! `fpbp`: the command-line front end of the fpbp positioning core.
//! The libraries do the work; this binary parses, validates and prints.

mod calibrate;
mod common;
mod demo;
mod eval;
mod fingerprint;
mod import;
mod import_geojson;
mod import_ilc;
mod import_ipin;
mod import_overlay;
mod import_raster;
mod import_truth;
mod map_check;
mod realism;
mod replay;
mod report;
mod simulate;

use clap::{Parser, Subcommand};
use fpbp_cli::{plot, site_io};

/// fpbp: floor-plan-assisted BLE + PDR indoor positioning.
#[derive(Parser)]
#[command(name = "fpbp", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Site and map tools.
    Map {
        #[command(subcommand)]
        command: MapCommand,
    },
    /// Replay one log through one engine: track.csv, metrics.json, track.png.
    Replay(replay::Args),
    /// Evaluate engines on logs: metrics.json, per-log rows, CDF plot.
    Eval(eval::Args),
    /// Write a simulated native log with ground truth.
    Simulate(simulate::Args),
    /// Compare simulated and real logs (step frequency, accel p-p, BLE rate, RSSI slope).
    Realism(realism::Args),
    /// Estimate beacon positions and path-loss models from survey logs with truth.
    Calibrate(calibrate::Args),
    /// Import a real building as an fpbp site.
    Import {
        #[command(subcommand)]
        command: import::Command,
    },
    /// The main job: every engine on the demo site and its shipped logs.
    Demo(demo::Args),
    /// Fingerprint databases for robust-ekf (walked survey logs).
    Fingerprint {
        #[command(subcommand)]
        command: fingerprint::Command,
    },
}

#[derive(Subcommand)]
enum MapCommand {
    /// Validate a site, print its figures and write DIR/overlay.png.
    Check(map_check::Args),
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Map {
            command: MapCommand::Check(a),
        } => map_check::run(a),
        Command::Replay(a) => replay::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Realism(a) => realism::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Import { command } => import::run(command),
        Command::Demo(a) => demo::run(a),
        Command::Fingerprint { command } => fingerprint::run(command),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
