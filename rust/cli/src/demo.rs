//! `fpbp demo`: the main job. Runs fpbp, bp, gml and pdr on the demo site
//! and its shipped simulated logs, prints one table (mean / p50 / p80 error,
//! mean compute time per task, real-time factor, poses inside walls) and
//! writes OUT/track_<log>.png (tracks over the plan), OUT/track_<log>_<engine>.csv,
//! OUT/cdf.png and
//! OUT/metrics.json (the `fpbp eval` engine objects plus `poses_in_wall`).
//!
//! Start-up: every engine finds its own start except `pdr`, which gets the
//! first truth point (the paper's PDR baseline); `--init truth` gives every
//! engine the first truth point.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use fpbp_core::Vec2;
use fpbp_core::engine::replay::ReplayOutput;
use fpbp_core::events::LogEvent;
use fpbp_core::map::Feature;
use fpbp_core::site::Site;
use serde::Serialize;

use crate::common::{self, EngineMetrics, InitMode, LogRun, ReadSummary, fmt_opt};
use crate::plot::{self, Series, TrackPlot};

/// Arguments of `fpbp demo`.
#[derive(clap::Args)]
pub struct Args {
    /// Site file.
    #[arg(long, default_value = "maps/demo/site.json")]
    pub site: PathBuf,
    /// Folder of the shipped logs (every *.log, *.txt, *.log.gz, *.txt.gz in it).
    #[arg(long, default_value = "host-tests/logs")]
    pub logs: PathBuf,
    /// Output folder for plots and metrics.json (created).
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Engines to run, comma-separated.
    #[arg(long, default_value = "fpbp,bp,gml,pdr", value_delimiter = ',')]
    pub engines: Vec<String>,
    /// Engine config JSON (docs/parameters.md); defaults when absent.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// `truth`: every engine starts from each log's first truth point (`pdr` always does).
    #[arg(long, value_enum, default_value = "none")]
    pub init: InitMode,
    /// Seed of the engines' RNGs (overrides the config's).
    #[arg(long)]
    pub seed: Option<u64>,
}

/// One engine in the demo's metrics.json.
#[derive(Serialize)]
struct DemoEngine {
    #[serde(flatten)]
    metrics: EngineMetrics,
    /// Fraction of published poses that lie inside a Wall.
    poses_in_wall: f64,
}

/// A default path relative to the working directory, else relative to the
/// repository the binary was built from (so the demo runs from any folder).
pub(crate) fn resolve(p: &Path) -> PathBuf {
    if p.is_absolute() || p.exists() {
        return p.to_path_buf();
    }
    let q = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(p);
    if q.exists() { q } else { p.to_path_buf() }
}

fn log_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list the logs folder {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                    let n = n.strip_suffix(".gz").unwrap_or(n);
                    !n.starts_with('.') && (n.ends_with(".log") || n.ends_with(".txt"))
                })
        })
        .collect();
    v.sort();
    if v.is_empty() {
        bail!("no logs in {}", dir.display());
    }
    Ok(v)
}

/// Fraction of track poses inside a Wall of their floor.
fn in_wall_fraction(site: &Site, outs: &[&ReplayOutput]) -> f64 {
    let (mut n, mut bad) = (0usize, 0usize);
    for o in outs {
        for p in &o.track {
            n += 1;
            if site
                .floor(p.floor)
                .is_some_and(|m| m.feature(Vec2::new(p.x_m, p.y_m)) == Feature::Wall)
            {
                bad += 1;
            }
        }
    }
    if n == 0 { 0.0 } else { bad as f64 / n as f64 }
}

/// Writes an engine's published poses as CSV (t_ns, x_m, y_m, floor, heading_rad, accuracy_m).
fn write_track_csv(path: &Path, out: &ReplayOutput) -> anyhow::Result<()> {
    use std::fmt::Write as _;
    let mut s = String::from("t_ns,x_m,y_m,floor,heading_rad,accuracy_m\n");
    for p in &out.track {
        let _ = writeln!(
            s,
            "{},{:.3},{:.3},{},{:.4},{:.2}",
            p.t_ns, p.x_m, p.y_m, p.floor, p.heading_rad, p.accuracy_m
        );
    }
    std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))
}

fn stem(name: &str) -> &str {
    name.split('.').next().unwrap_or(name)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let site_path = resolve(&args.site);
    let logs_dir = resolve(&args.logs);
    let site = crate::site_io::load_site(&site_path)?;
    let cfg = common::load_config(args.config.as_deref(), args.seed)?;
    let opts = common::read_options(&site, None, false);
    let logs = log_files(&logs_dir)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;

    let mut runs: Vec<Vec<LogRun>> = args.engines.iter().map(|_| Vec::new()).collect();
    let mut reads = Vec::new();
    for path in &logs {
        let log = common::load_log(path, &opts)?;
        reads.push(ReadSummary::from(&log.report));
        let truth: Vec<(f64, f64)> = log
            .events
            .iter()
            .filter_map(|e| match e {
                LogEvent::Truth(t) => Some((t.x_m, t.y_m)),
                _ => None,
            })
            .collect();
        let floor = log
            .events
            .iter()
            .find_map(|e| match e {
                LogEvent::Truth(t) => t.floor,
                _ => None,
            })
            .unwrap_or_else(|| site.default_floor());
        let mut tracks = Vec::new();
        for (k, name) in args.engines.iter().enumerate() {
            let run = common::run_log(&common::core_builder, name, &site, &cfg, args.init, &log)
                .with_context(|| format!("on {}", path.display()))?;
            write_track_csv(
                &args
                    .out
                    .join(format!("track_{}_{name}.csv", stem(&log.name))),
                &run.out,
            )?;
            tracks.push(Series {
                label: name.clone(),
                points: run
                    .out
                    .track
                    .iter()
                    .filter(|p| p.floor == floor)
                    .map(|p| (p.x_m, p.y_m))
                    .collect(),
            });
            runs[k].push(run);
        }
        plot::track_png(
            &args.out.join(format!("track_{}.png", stem(&log.name))),
            &TrackPlot {
                title: format!("{} on {}", log.name, site.spec.name),
                map: site.floor(floor),
                tracks,
                truth,
            },
        )?;
    }

    let mut engines = Vec::new();
    let mut cdf = Vec::new();
    for (name, r) in args.engines.iter().zip(&runs) {
        let outs: Vec<&ReplayOutput> = r.iter().map(|x| &x.out).collect();
        engines.push(DemoEngine {
            metrics: EngineMetrics::from_runs(name, args.init, r, &reads),
            poses_in_wall: in_wall_fraction(&site, &outs),
        });
        cdf.push((name.clone(), EngineMetrics::errors_of(r)));
    }
    plot::cdf_png(
        &args.out.join("cdf.png"),
        &format!(
            "Position error, {} simulated logs on {}",
            logs.len(),
            site.spec.name
        ),
        &cdf,
    )?;
    let json = serde_json::to_string_pretty(&engines)?;
    let metrics_path = args.out.join("metrics.json");
    std::fs::write(&metrics_path, json)
        .with_context(|| format!("cannot write {}", metrics_path.display()))?;

    println!(
        "fpbp demo: {} logs from {} on {}",
        logs.len(),
        logs_dir.display(),
        site_path.display()
    );
    println!(
        "{:<8} {:>6} {:>7} {:>7} {:>7} {:>7} {:>9} {:>10} {:>10} {:>8}",
        "engine",
        "start",
        "points",
        "mean_m",
        "p50_m",
        "p80_m",
        "gml_us",
        "fusion_us",
        "rt_factor",
        "in_wall"
    );
    for e in &engines {
        let m = &e.metrics;
        let start = if args.init == InitMode::Truth
            || common::NEEDS_TRUTH_START.contains(&m.engine.as_str())
        {
            "truth"
        } else {
            "own"
        };
        println!(
            "{:<8} {:>6} {:>7} {:>7} {:>7} {:>7} {:>9} {:>10} {:>10} {:>7.1}%",
            m.engine,
            start,
            m.errors.points,
            fmt_opt(m.errors.mpe_m, 2),
            fmt_opt(m.errors.p50_m, 2),
            fmt_opt(m.errors.p80_m, 2),
            fmt_opt(m.mct_us.gml, 1),
            fmt_opt(m.mct_us.fusion, 1),
            fmt_opt(m.realtime_factor, 0),
            100.0 * e.poses_in_wall
        );
    }
    println!(
        "plots and metrics.json in {} ({:.1} s)",
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
