//! `fpbp replay`: one log through one engine -> DIR/track.csv, DIR/metrics.json,
//! DIR/track.png.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Context;

use crate::metrics::{EngineMetrics, ReadSummary};
use crate::runner::{EngineBuilder, InitMode};
use crate::{plot, report};

/// Arguments of `fpbp replay`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ReplayOptions {
    /// Site file (site.json).
    #[cfg_attr(feature = "cli", arg(long))]
    pub site: PathBuf,
    /// Log file (native v1, ILC trace or IPIN logfile; gzip or plain).
    #[cfg_attr(feature = "cli", arg(long))]
    pub log: PathBuf,
    /// Engine name: tcpf (the default engine), fpbp, bp, pdr, gml, trilat,
    /// frbw, ml, wcentroid, prox-pf,
    /// ppsa, robust-ekf, tc-ekf, wifi-wcentroid, scan-knn (README.md, "Engines").
    #[cfg_attr(feature = "cli", arg(long))]
    pub engine: String,
    /// Output folder (created).
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Engine config: a JSON file, or the JSON itself (`{...}`); missing fields take their defaults.
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
    /// `truth`: hand the engine the log's first truth point as its start
    /// (`pdr` always gets it).
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "none"))]
    pub init: InitMode,
    /// Seed of the engine's RNGs (overrides the config's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub seed: Option<u64>,
    /// Floor id of truth points whose log gives none (default: the site's floor
    /// when it has only one).
    #[cfg_attr(feature = "cli", arg(long, allow_hyphen_values = true))]
    pub floor: Option<i32>,
    /// Fail on the first malformed log line instead of skipping it.
    #[cfg_attr(feature = "cli", arg(long))]
    pub strict: bool,
    /// Radio map for `tcpf` (`fpbp calibrate --radio-map`); default: the site's path-loss models.
    #[cfg_attr(feature = "cli", arg(long))]
    pub radio_map: Option<PathBuf>,
}

/// Runs the replay with `build` and writes the outputs; returns the metrics
/// (an error, after writing, when the engine positioned nothing).
#[cfg(test)]
pub fn run_with(args: &ReplayOptions, build: &EngineBuilder) -> anyhow::Result<EngineMetrics> {
    let (m, empty) = run_checked(args, build)?;
    empty.map(|_| m)
}

/// Replays the log and writes the outputs; returns the metrics and, apart,
/// the "nothing positioned" check (an error the caller reports after
/// printing the figures).
pub fn run_checked(
    args: &ReplayOptions,
    build: &EngineBuilder,
) -> anyhow::Result<(EngineMetrics, anyhow::Result<()>)> {
    let started = std::time::Instant::now();
    let site = crate::runner::load_site(&args.site)?;
    let cfg = crate::runner::load_config(args.config.as_deref(), args.seed)?;
    let log = crate::runner::load_log(
        &args.log,
        &crate::runner::read_options(&site, args.floor, args.strict),
    )?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let run = crate::runner::run_log(build, &args.engine, &site, &cfg, args.init, &log)?;
    report::write_track_csv(&args.out.join("track.csv"), &run.out)?;

    let read = ReadSummary::from(&log.report);
    let metrics = EngineMetrics::from_runs(
        &site,
        &args.engine,
        args.init,
        std::slice::from_ref(&run),
        std::slice::from_ref(&read),
    );
    report::MetricsDoc {
        read_reports: vec![&log.report],
        ..report::MetricsDoc::new(
            "replay",
            &args.site,
            std::slice::from_ref(&args.log),
            args.init,
            vec![cfg.seed],
            started.elapsed().as_secs_f64(),
            std::slice::from_ref(&metrics),
        )
    }
    .write(&args.out)?;

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
        panels: vec![report::track_panel(&site, &args.engine, &run, floor)],
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
    let empty = report::check_positioned(
        &site,
        &[&log],
        std::slice::from_ref(&args.engine),
        std::slice::from_ref(&vec![run]),
        &[&metrics],
    );
    Ok((metrics, empty))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testkit::*;

    #[test]
    fn replay_writes_track_metrics_and_plot() {
        let d = tmp_dir("replay");
        let site_path = d.join("site.json");
        std::fs::write(&site_path, r#"{"format":"fpbp-site","version":1,"name":"t","floors":[{"id":3,"open_area_m":[30,10]}]}"#).unwrap();
        let log = d.join("walk.log");
        write_log(&log, 6);
        let args = ReplayOptions {
            site: site_path,
            log,
            engine: "pdr".into(),
            out: d.join("out"),
            config: None,
            init: InitMode::None,
            seed: Some(3),
            floor: None,
            strict: true,
            radio_map: None,
        };
        let m = run_with(&args, &builder).unwrap();
        assert_eq!(m.errors.points, 5);
        assert_eq!(m.errors.floor_accuracy, Some(1.0));
        assert_eq!(m.start, report::StartMode::Truth);
        let csv = std::fs::read_to_string(d.join("out/track.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some(report::TRACK_CSV_HEADER));
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        let poses: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == "pose").collect();
        let truth: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == "truth").collect();
        assert!(poses.len() > 40, "{}", poses.len());
        assert!(poses.iter().all(|r| r.len() == 13 && r[4] == "3"));
        // 5 scored truth points, each with the truth and an error
        assert_eq!(truth.len(), 5);
        assert!(
            truth
                .iter()
                .all(|r| r[12].parse::<f64>().unwrap() < 0.2 && r[11] == "3")
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("out/metrics.json")).unwrap())
                .unwrap();
        assert_eq!(
            (&json["format"], &json["version"], &json["command"]),
            (
                &serde_json::json!("fpbp-metrics"),
                &serde_json::json!(3),
                &serde_json::json!("replay")
            )
        );
        let eng = &json["engines"][0];
        for k in crate::report::ENGINE_KEYS {
            assert!(eng.get(k).is_some(), "missing {k}");
        }
        assert_eq!(eng["track"]["jumps"], 0);
        assert_eq!(json["read_reports"][0]["events"]["truth"], 6);
        assert!(image::open(d.join("out/track.png")).is_ok());
        // An engine that does not exist is an error naming it.
        let e = run_with(
            &ReplayOptions {
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
