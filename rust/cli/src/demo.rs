//! `fpbp demo`: the main job. Runs tcpf (the default engine), fpbp, bp, gml
//! and pdr on the demo site
//! and its shipped simulated logs, prints one table (mean / p50 / p80 error,
//! mean compute time per task, real-time factor, poses inside walls) and
//! writes OUT/track_<log>.png (one panel per engine over the plan),
//! OUT/track_<log>_<engine>.csv (the replay track layout, with truth rows),
//! OUT/cdf.png and OUT/metrics.json (the one metrics document of eval and
//! replay, `command` "demo").
//!
//! Start-up: every engine finds its own start except `pdr`, which gets the
//! first truth point (the paper's PDR baseline); `--init truth` gives every
//! engine the first truth point.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use fpbp_core::events::LogEvent;

use fpbp_eval::metrics::{EngineMetrics, ReadSummary, fmt_opt};
use fpbp_eval::plot::{self, TrackPlot};
use fpbp_eval::report;
use fpbp_eval::runner::{InitMode, LogRun};

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
    #[arg(long, default_value = "tcpf,fpbp,bp,gml,pdr", value_delimiter = ',')]
    pub engines: Vec<String>,
    /// Engine config: a JSON file, or the JSON itself (`{...}`; docs/parameters.md); defaults when absent.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// `truth`: every engine starts from each log's first truth point (`pdr` always does).
    #[arg(long, value_enum, default_value = "none")]
    pub init: InitMode,
    /// Seed of the engines' RNGs (overrides the config's).
    #[arg(long)]
    pub seed: Option<u64>,
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

fn stem(name: &str) -> &str {
    name.split('.').next().unwrap_or(name)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let site_path = resolve(&args.site);
    let logs_dir = resolve(&args.logs);
    let site = fpbp_core::site::files::load_site(&site_path)?;
    let cfg = fpbp_eval::runner::load_config(args.config.as_deref(), args.seed)?;
    let opts = fpbp_eval::runner::read_options(&site, None, false);
    let logs = log_files(&logs_dir)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;

    let bar = fpbp_eval::progress::bar((logs.len() * args.engines.len()) as u64);
    let mut runs: Vec<Vec<LogRun>> = args.engines.iter().map(|_| Vec::new()).collect();
    let mut reads = Vec::new();
    let mut loaded = Vec::new();
    for path in &logs {
        let log = fpbp_eval::runner::load_log(path, &opts)?;
        reads.push(ReadSummary::from(&log.report));
        let truth: Vec<(f64, f64)> = log
            .events
            .iter()
            .filter_map(LogEvent::as_truth)
            .map(|t| (t.x_m, t.y_m))
            .collect();
        let floor = log
            .events
            .iter()
            .find_map(|e| e.as_truth()?.floor)
            .unwrap_or_else(|| site.default_floor());
        let mut panels = Vec::new();
        for (k, name) in args.engines.iter().enumerate() {
            bar.set_message(format!("{name} on {}", log.name));
            let run = fpbp_eval::runner::run_log(
                &fpbp_eval::runner::core_builder,
                name,
                &site,
                &cfg,
                args.init,
                &log,
            )
            .with_context(|| format!("on {}", path.display()))?;
            report::write_track_csv(
                &args
                    .out
                    .join(format!("track_{}_{name}.csv", stem(&log.name))),
                &run.out,
            )?;
            panels.push(report::track_panel(&site, name, &run, floor));
            runs[k].push(run);
            bar.inc(1);
        }
        plot::track_png(
            &args.out.join(format!("track_{}.png", stem(&log.name))),
            &TrackPlot {
                title: format!("{} on {} (floor {floor})", log.name, site.spec.name),
                map: site.floor(floor),
                panels,
                truth,
            },
        )?;
        loaded.push(fpbp_eval::runner::LoadedLog {
            events: log
                .events
                .into_iter()
                .filter(|e| matches!(e, LogEvent::Ble(_)))
                .collect(),
            ..log
        });
    }
    bar.finish_and_clear();

    let engines: Vec<EngineMetrics> = args
        .engines
        .iter()
        .zip(&runs)
        .map(|(name, r)| EngineMetrics::from_runs(&site, name, args.init, r, &reads))
        .collect();
    let cdf: Vec<plot::CdfSeries> = engines.iter().map(report::cdf_series).collect();
    plot::cdf_png(
        &args.out.join("cdf.png"),
        &format!(
            "Position error, {} simulated logs on {}, seed {}",
            logs.len(),
            site.spec.name,
            cfg.seed
        ),
        &cdf,
    )?;
    report::MetricsDoc::new(
        "demo",
        &site_path,
        &logs,
        args.init,
        vec![cfg.seed],
        started.elapsed().as_secs_f64(),
        &engines,
    )
    .write(&args.out)?;

    println!(
        "fpbp demo: {} logs from {} on {}",
        logs.len(),
        logs_dir.display(),
        site_path.display()
    );
    println!(
        "{:<8} {:>6} {:>7} {:>7} {:>8} {:>7} {:>7} {:>7} {:>8} {:>9} {:>10} {:>10} {:>8}",
        "engine",
        "start",
        "points",
        "mean_m",
        "coverage",
        "p50_m",
        "p80_m",
        "jmp/hm",
        "wall/hm",
        "radio_us",
        "fusion_us",
        "rt_factor",
        "in_wall"
    );
    for m in &engines {
        println!(
            "{:<8} {:>6} {:>7} {:>7} {:>8} {:>7} {:>7} {:>7} {:>8} {:>9} {:>10} {:>10} {:>7.1}%",
            m.engine,
            m.start.name(),
            m.errors.points,
            fmt_opt(m.errors.mpe_m, 2),
            fpbp_eval::eval::fmt_pct(m.errors.coverage),
            fmt_opt(m.errors.p50_m, 2),
            fmt_opt(m.errors.p80_m, 2),
            fmt_opt(m.track.jumps_per_100m, 1),
            fmt_opt(m.track.wall_crossings_per_100m, 1),
            fmt_opt(m.mct_us.radio, 1),
            fmt_opt(m.mct_us.fusion, 1),
            fmt_opt(m.realtime_factor, 0),
            100.0 * m.track.poses_in_wall
        );
    }
    println!(
        "(errors over the points with a pose, every truth point after each log's first; \
         coverage = their share; jmp/hm, wall/hm: track jumps and wall-crossing segments per 100 m; \
         in_wall: poses inside walls)"
    );
    println!(
        "plots and metrics.json in {} ({:.1} s)",
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    let refs: Vec<&fpbp_eval::runner::LoadedLog> = loaded.iter().collect();
    let mrefs: Vec<&EngineMetrics> = engines.iter().collect();
    report::check_positioned(&site, &refs, &args.engines, &runs, &mrefs)
}
