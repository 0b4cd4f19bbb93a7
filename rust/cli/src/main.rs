//! `fpbp`: the command-line front end of the fpbp positioning core.
//! The libraries do the work; this binary parses, validates and prints.

mod bundle;
mod calibrate;
mod config;
mod demo;
mod eval;
mod fingerprint;
mod import;
mod map_check;
mod realism;
mod replay;
mod reproduce;
mod simulate;

use clap::{Parser, Subcommand};

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
    Replay(fpbp_eval::replay::ReplayOptions),
    /// Evaluate engines on logs: metrics.json, per-log rows, CDF plot.
    Eval(fpbp_eval::eval::EvalOptions),
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
    /// The five papers on simulated replicas of their testbeds: ours beside the paper's figures.
    Reproduce(reproduce::Args),
    /// One file with a site, its plans and its radio map for the phone
    /// (docs/formats.md "Site bundle"); `--check` loads one with figures.
    Bundle(bundle::Args),
    /// An engine's settings as the JSON `--config` reads: the defaults, or
    /// a config's values with the defaults of what it leaves out.
    Config(config::Args),
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
        Command::Reproduce(a) => reproduce::run(a),
        Command::Fingerprint { command } => fingerprint::run(command),
        Command::Bundle(a) => bundle::run(a),
        Command::Config(a) => config::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {}", error_text(&e));
        std::process::exit(1);
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text
/// the message already holds (typed errors print their source themselves:
/// no "Is a directory (os error 21): Is a directory (os error 21)").
fn error_text(e: &anyhow::Error) -> String {
    let mut s = String::new();
    for cause in e.chain() {
        let c = cause.to_string();
        if s.contains(&c) {
            continue;
        }
        if !s.is_empty() {
            s.push_str(": ");
        }
        s.push_str(&c);
    }
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_cause_already_in_the_message_is_said_once() {
        let io = std::io::Error::new(std::io::ErrorKind::IsADirectory, "Is a directory");
        let e = anyhow::Error::new(fpbp_logs::LogError::Io {
            file: "/tmp".into(),
            source: io,
        });
        assert_eq!(super::error_text(&e), "/tmp: Is a directory");
        let e = anyhow::anyhow!("inner").context("outer");
        assert_eq!(super::error_text(&e), "outer: inner");
    }
}
