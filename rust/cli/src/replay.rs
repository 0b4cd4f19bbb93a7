//! `fpbp replay`: one log through one engine -> DIR/track.csv, DIR/metrics.json,
//! DIR/track.png.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use serde::Serialize;

use crate::common::{self, EngineBuilder, EngineMetrics, InitMode, ReadSummary};
use crate::plot;

/// Arguments of `fpbp replay`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Site file (site.json).
    #[arg(long)]
    pub site: PathBuf,
    /// Log file (native v1, ILC trace or IPIN logfile; gzip or plain).
    #[arg(long)]
    pub log: PathBuf,
    /// Engine name (see `fpbp eval --help` for the list).
    #[arg(long)]
    pub engine: String,
    /// Output folder (created).
    #[arg(long)]
    pub out: PathBuf,
    /// Engine config JSON (missing fields take their defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// `truth`: hand the engine the log's first truth point as its start
    /// (`pdr` always gets it).
    #[arg(long, value_enum, default_value = "none")]
    pub init: InitMode,
    /// Seed of the engine's RNGs (overrides the config's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Floor id of truth points whose log gives none (default: the site's floor
    /// when it has only one).
    #[arg(long, allow_hyphen_values = true)]
    pub floor: Option<i32>,
    /// Fail on the first malformed log line instead of skipping it.
    #[arg(long)]
    pub strict: bool,
}

#[derive(Serialize)]
struct ReplayMetrics<'a> {
    format: &'static str,
    version: u32,
    site: String,
    log: String,
    #[serde(flatten)]
    metrics: &'a EngineMetrics,
    read_report: &'a fpbp_logs::ReadReport,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let m = run_with(&args, &common::core_builder)?;
    let e = &m.errors;
    println!(
        "{}: {} truth points, {} without fix, mean {} m, p50 {} m, p80 {} m, max {} m; realtime x{}",
        m.engine,
        e.points,
        e.no_fix,
        common::fmt_opt(e.mpe_m, 2),
        common::fmt_opt(e.p50_m, 2),
        common::fmt_opt(e.p80_m, 2),
        common::fmt_opt(e.max_m, 2),
        common::fmt_opt(m.realtime_factor, 0)
    );
    println!(
        "wrote {}/{{track.csv,metrics.json,track.png}}",
        args.out.display()
    );
    Ok(())
}

/// Runs the replay with `build` and writes the outputs; returns the metrics.
pub fn run_with(args: &Args, build: &EngineBuilder) -> anyhow::Result<EngineMetrics> {
    let site = common::load_site(&args.site)?;
    let cfg = common::load_config(args.config.as_deref(), args.seed)?;
    let log = common::load_log(
        &args.log,
        &common::read_options(&site, args.floor, args.strict),
    )?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let run = common::run_log(build, &args.engine, &site, &cfg, args.init, &log)?;

    let csv_path = args.out.join("track.csv");
    let mut csv = std::io::BufWriter::new(
        std::fs::File::create(&csv_path)
            .with_context(|| format!("cannot create {}", csv_path.display()))?,
    );
    writeln!(csv, "t_s,x_m,y_m,floor,heading_rad,accuracy_m")?;
    for p in &run.out.track {
        writeln!(
            csv,
            "{},{},{},{},{},{}",
            p.t_ns as f64 * 1e-9,
            p.x_m,
            p.y_m,
            p.floor,
            p.heading_rad,
            p.accuracy_m
        )?;
    }
    csv.flush()
        .with_context(|| format!("cannot write {}", csv_path.display()))?;

    let read = ReadSummary::from(&log.report);
    let metrics = EngineMetrics::from_runs(
        &args.engine,
        args.init,
        std::slice::from_ref(&run),
        std::slice::from_ref(&read),
    );
    let doc = ReplayMetrics {
        format: "fpbp-replay-metrics",
        version: 1,
        site: args.site.display().to_string(),
        log: args.log.display().to_string(),
        metrics: &metrics,
        read_report: &log.report,
    };
    let mp = args.out.join("metrics.json");
    std::fs::write(&mp, serde_json::to_string_pretty(&doc)? + "\n")
        .with_context(|| format!("cannot write {}", mp.display()))?;

    // Draw the floor most of the track is on.
    let mut floors: BTreeMap<i32, usize> = BTreeMap::new();
    for p in &run.out.track {
        *floors.entry(p.floor).or_default() += 1;
    }
    let floor = floors
        .iter()
        .max_by_key(|(_, n)| **n)
        .map_or(site.default_floor(), |(f, _)| *f);
    let plot = plot::TrackPlot {
        title: format!("{} on {} (floor {floor})", args.engine, log.name),
        map: site.floor(floor),
        tracks: vec![plot::Series {
            label: args.engine.clone(),
            points: run
                .out
                .track
                .iter()
                .filter(|p| p.floor == floor)
                .map(|p| (p.x_m, p.y_m))
                .collect(),
        }],
        // The start point (when the engine got one from truth) and the scored points.
        truth: run
            .init
            .filter(|i| i.floor == floor)
            .map(|i| (i.x_m, i.y_m))
            .into_iter()
            .chain(
                run.out
                    .scored
                    .iter()
                    .filter(|s| s.truth.floor.is_none_or(|f| f == floor))
                    .map(|s| (s.truth.x_m, s.truth.y_m)),
            )
            .collect(),
    };
    plot::track_png(&args.out.join("track.png"), &plot)?;
    Ok(metrics)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::common::test_support::*;

    #[test]
    fn replay_writes_track_metrics_and_plot() {
        let d = tmp_dir("replay");
        let site_path = d.join("site.json");
        std::fs::write(&site_path, r#"{"format":"fpbp-site","version":1,"name":"t","floors":[{"id":3,"open_area_m":[30,10]}]}"#).unwrap();
        let log = d.join("walk.log");
        write_log(&log, 6);
        let args = Args {
            site: site_path,
            log,
            engine: "pdr".into(),
            out: d.join("out"),
            config: None,
            init: InitMode::None,
            seed: Some(3),
            floor: None,
            strict: true,
        };
        let m = run_with(&args, &builder).unwrap();
        assert_eq!(m.errors.points, 5);
        assert_eq!(m.errors.floor_accuracy, Some(1.0));
        let csv = std::fs::read_to_string(d.join("out/track.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some("t_s,x_m,y_m,floor,heading_rad,accuracy_m")
        );
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert!(rows.len() > 40, "{}", rows.len());
        assert!(rows.iter().all(|r| r.len() == 6 && r[3] == 3.0));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("out/metrics.json")).unwrap())
                .unwrap();
        for k in [
            "engine",
            "logs",
            "points",
            "mpe_m",
            "p50_m",
            "p75_m",
            "p80_m",
            "p95_m",
            "max_m",
            "floor_accuracy",
            "mct_us",
            "realtime_factor",
            "no_fix",
        ] {
            assert!(json.get(k).is_some(), "missing {k}");
        }
        assert_eq!(json["read_report"]["events"]["truth"], 6);
        assert!(image::open(d.join("out/track.png")).is_ok());
        // An engine that does not exist is an error naming it.
        let e = run_with(
            &Args {
                engine: "nope".into(),
                ..args
            },
            &builder,
        )
        .unwrap_err();
        assert!(format!("{e:#}").contains("nope"));
        std::fs::remove_dir_all(&d).ok();
    }
}
