//! `fpbp eval`: engines over logs -> DIR/metrics.json (the keys of
//! docs/ARCHITECTURE.md "Evaluation protocol" per engine, per-log rows),
//! DIR/cdf.png, a progress bar and a table.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use serde::Serialize;

use crate::metrics::{EngineMetrics, ReadSummary};
use crate::plot;
use crate::runner::{EngineBuilder, InitMode, LogRun};

/// Which logs of the sorted list to evaluate (the fixed split of
/// docs/ARCHITECTURE.md "Evaluation protocol": sort by file name; even
/// indices, from 0, calibrate; odd indices test).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Split {
    Even,
    Odd,
    All,
}

/// Arguments of `fpbp eval`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct EvalOptions {
    /// Site file (site.json).
    #[cfg_attr(feature = "cli", arg(long))]
    pub site: PathBuf,
    /// Log files (native, ILC or IPIN; gzip or plain).
    #[cfg_attr(feature = "cli", arg(long, num_args = 1.., required = true))]
    pub logs: Vec<PathBuf>,
    /// Engine names, comma-separated: tcpf (the default engine), fpbp, bp,
    /// pdr, gml, trilat, frbw, ml,
    /// wcentroid, prox-pf, ppsa, robust-ekf, tc-ekf, wifi-wcentroid, scan-knn (README.md,
    /// "Engines").
    #[cfg_attr(feature = "cli", arg(long, value_delimiter = ',', required = true))]
    pub engine: Vec<String>,
    /// Output folder (created).
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Engine config: a JSON file, or the JSON itself (`{...}`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub config: Option<PathBuf>,
    /// `truth`: every engine starts from each log's first truth point (`pdr` always does).
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "none"))]
    pub init: InitMode,
    /// Which logs of the name-sorted list: even or odd indices, or all.
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "all"))]
    pub split: Split,
    /// Seed of the engines' RNGs (overrides the config's).
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "seeds"))]
    pub seed: Option<u64>,
    /// Several engine seeds (`1-5`, `1,3,7`): each engine runs once per seed
    /// (outputs in DIR/seed-S/) and DIR/metrics.json and the table give the
    /// mean and spread over the seeds.
    #[cfg_attr(feature = "cli", arg(long, value_parser = crate::report::seed_list))]
    pub seeds: Option<crate::report::SeedList>,
    /// Floor id of truth points whose log gives none.
    #[cfg_attr(feature = "cli", arg(long, allow_hyphen_values = true))]
    pub floor: Option<i32>,
    /// Fail on the first malformed log line.
    #[cfg_attr(feature = "cli", arg(long))]
    pub strict: bool,
    /// Fingerprint database for `robust-ekf` (`fpbp fingerprint build`); default: the site's model database.
    #[cfg_attr(feature = "cli", arg(long))]
    pub fingerprints: Option<PathBuf>,
    /// Radio map for `tcpf` (`fpbp calibrate --radio-map`); default: the site's path-loss models.
    #[cfg_attr(feature = "cli", arg(long))]
    pub radio_map: Option<PathBuf>,
    /// Radios whose events the engines get (the others' are dropped before replay).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, value_delimiter = ',', default_value = "ble,wifi")
    )]
    pub radios: Vec<crate::radios::Radio>,
    /// Also write every engine's whole track on every log:
    /// DIR/tracks/ENGINE/LOG.csv in the track.csv layout of `fpbp replay`
    /// (every f64 printed exactly; the JVM host tests compare them bit for bit).
    #[cfg_attr(feature = "cli", arg(long))]
    pub tracks: bool,
    /// Worker threads: the (log, seed) replays run in parallel, each engine
    /// on its own RNG, so the tracks and metrics do not depend on it
    /// (default: every core; 1 = serial).
    #[cfg_attr(feature = "cli", arg(long, value_parser = clap::value_parser!(u16).range(1..=1024)))]
    pub jobs: Option<u16>,
}

/// Applies the split to `logs` sorted by file name.
pub fn select_logs(logs: &[PathBuf], split: Split) -> Vec<PathBuf> {
    let mut v = logs.to_vec();
    v.sort_by(|a, b| a.file_name().cmp(&b.file_name()).then_with(|| a.cmp(b)));
    v.into_iter()
        .enumerate()
        .filter(|(i, _)| match split {
            Split::Even => i % 2 == 0,
            Split::Odd => i % 2 == 1,
            Split::All => true,
        })
        .map(|(_, p)| p)
        .collect()
}

/// Runs the evaluation once per seed (DIR/seed-S/ each) and writes
/// DIR/metrics.json with the mean and spread over the seeds per engine.
pub fn run_seeds(
    args: &EvalOptions,
    seeds: &[u64],
    build: &EngineBuilder,
    progress: bool,
) -> anyhow::Result<Vec<crate::report::SeedSummary>> {
    let started = std::time::Instant::now();
    let plan = Plan::new(args)?;
    let cfgs = seeds
        .iter()
        .map(|&s| crate::runner::load_config(args.config.as_deref(), Some(s)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if progress {
        eprintln!(
            "seeds {seeds:?}: {} replays on {} threads",
            seeds.len() * plan.logs.len() * plan.engines.len(),
            jobs(args)
        );
    }
    let units = replay_all(args, &plan, &cfgs, build, progress)?;
    let mut per_seed: Vec<Vec<EngineMetrics>> = Vec::new();
    let mut failed = None;
    for ((&s, cfg), units) in seeds.iter().zip(&cfgs).zip(units) {
        let a = EvalOptions {
            seed: Some(s),
            seeds: None,
            out: args.out.join(format!("seed-{s}")),
            ..args.clone()
        };
        let (m, empty) = write_outputs(&a, &plan, cfg, units, started)?;
        failed = failed.or(empty.err());
        per_seed.push(m);
    }
    let summary: Vec<crate::report::SeedSummary> = (0..per_seed[0].len())
        .map(|i| {
            let v: Vec<&EngineMetrics> = per_seed.iter().map(|m| &m[i]).collect();
            crate::report::SeedSummary::of(&v)
        })
        .collect();
    let logs = select_logs(&args.logs, args.split);
    crate::report::MetricsDoc {
        split: Some(args.split),
        ..crate::report::MetricsDoc::new(
            "eval",
            &args.site,
            &logs,
            args.init,
            seeds.to_vec(),
            started.elapsed().as_secs_f64(),
            &summary,
        )
    }
    .write(&args.out)?;
    let series: Vec<plot::CdfSeries> = summary
        .iter()
        .zip(&per_seed[0])
        .map(|(s, m)| plot::CdfSeries {
            label: format!(
                "{} ({} start, seed {}; mean over seeds {} m, coverage {})",
                s.engine,
                s.start.name(),
                seeds[0],
                crate::metrics::fmt_opt(s.mpe_m.mean, 2),
                fmt_pct(s.coverage.mean)
            ),
            errors: m.cdf_errors.clone(),
            points: m.errors.points,
        })
        .collect();
    plot::cdf_png(
        &args.out.join("cdf.png"),
        &format!(
            "error CDF, {} logs, seed {} of {:?}",
            logs.len(),
            seeds[0],
            seeds
        ),
        &series,
    )?;
    match failed {
        Some(e) => Err(e),
        None => Ok(summary),
    }
}

/// A share as a percentage for tables ("-" when unknown).
pub fn fmt_pct(v: Option<f64>) -> String {
    v.map_or("-".to_string(), |x| format!("{:.0}%", 100.0 * x))
}

/// Runs the evaluation with `build`, writes metrics.json and cdf.png, returns
/// the metrics; an error (after writing) when an engine positioned nothing.
pub fn run_with(
    args: &EvalOptions,
    build: &EngineBuilder,
    progress: bool,
) -> anyhow::Result<Vec<EngineMetrics>> {
    let (m, empty) = run_inner(args, build, progress)?;
    empty.map(|_| m)
}

/// [`run_with`] returning the metrics and, apart, the "nothing positioned" check.
fn run_inner(
    args: &EvalOptions,
    build: &EngineBuilder,
    progress: bool,
) -> anyhow::Result<(Vec<EngineMetrics>, anyhow::Result<()>)> {
    let started = std::time::Instant::now();
    let plan = Plan::new(args)?;
    let cfg = crate::runner::load_config(args.config.as_deref(), args.seed)?;
    let units = replay_all(args, &plan, std::slice::from_ref(&cfg), build, progress)?
        .pop()
        .unwrap_or_default();
    write_outputs(args, &plan, &cfg, units, started)
}

/// What an evaluation runs: the site, the logs after the split and the engines.
struct Plan {
    site: std::sync::Arc<fpbp_core::site::Site>,
    opts: fpbp_logs::ReadOptions,
    logs: Vec<PathBuf>,
    engines: Vec<String>,
}

impl Plan {
    fn new(args: &EvalOptions) -> anyhow::Result<Plan> {
        let site = crate::runner::load_site(&args.site)?;
        let opts = crate::runner::read_options(&site, args.floor, args.strict);
        let logs = select_logs(&args.logs, args.split);
        if logs.is_empty() {
            bail!("no logs left after --split {:?}", args.split);
        }
        let engines: Vec<String> = args
            .engine
            .iter()
            .map(|e| e.trim().to_string())
            .filter(|e| !e.is_empty())
            .collect();
        if engines.is_empty() {
            bail!("--engine: no engine named");
        }
        Ok(Plan {
            site,
            opts,
            logs,
            engines,
        })
    }
}

/// One log replayed by every engine of the plan under one config.
struct LogUnit {
    /// One run per engine, in the plan's order.
    runs: Vec<LogRun>,
    read: ReadSummary,
    /// The log with only what the no-pose diagnosis reads (BLE rows).
    loaded: crate::runner::LoadedLog,
}

/// The worker threads of `args` (`--jobs`, else every core).
fn jobs(args: &EvalOptions) -> usize {
    args.jobs.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        usize::from,
    )
}

/// Replays every (config, log) pair of the plan on [`jobs`] threads; the
/// result is indexed [config][log] whatever the order the work ran in, and
/// the first error (in that order) is returned. Each log is read once for
/// all the configs (seeds) that replay it ([`SharedLogs`]).
fn replay_all(
    args: &EvalOptions,
    plan: &Plan,
    cfgs: &[fpbp_core::engines::EngineConfig],
    build: &EngineBuilder,
    progress: bool,
) -> anyhow::Result<Vec<Vec<LogUnit>>> {
    let bar = if progress {
        crate::progress::bar((cfgs.len() * plan.logs.len() * plan.engines.len()) as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    // log-major: the configs of one log run one after the other, so a read
    // log is dropped soon after it is read
    let work: Vec<(usize, usize)> = (0..plan.logs.len())
        .flat_map(|l| (0..cfgs.len()).map(move |c| (c, l)))
        .collect();
    let logs = SharedLogs::new(plan.logs.len(), cfgs.len());
    let done = crate::parallel::map_in_order(&work, jobs(args), |&(c, l)| {
        let log = logs.get(l, || read_log(args, plan, &plan.logs[l]))?;
        replay_log(args, plan, &cfgs[c], &log, build, &bar)
    });
    bar.finish_and_clear();
    let mut grid: Vec<Vec<Option<anyhow::Result<LogUnit>>>> = cfgs
        .iter()
        .map(|_| plan.logs.iter().map(|_| None).collect())
        .collect();
    for ((c, l), unit) in work.into_iter().zip(done) {
        grid[c][l] = Some(unit);
    }
    grid.into_iter()
        .map(|row| row.into_iter().flatten().collect())
        .collect()
}

/// Logs read once and handed to every config that replays them: slot `l`
/// holds log `l` from its first reader until its last user took it.
struct SharedLogs {
    slots: Vec<std::sync::Mutex<SharedSlot>>,
}

struct SharedSlot {
    log: Option<std::sync::Arc<crate::runner::LoadedLog>>,
    /// Users still to come (the configs).
    uses_left: usize,
}

impl SharedLogs {
    fn new(logs: usize, uses: usize) -> Self {
        SharedLogs {
            slots: (0..logs)
                .map(|_| {
                    std::sync::Mutex::new(SharedSlot {
                        log: None,
                        uses_left: uses,
                    })
                })
                .collect(),
        }
    }

    /// Log `l`, read by `read` if no earlier user kept it (a failed read is
    /// not kept: the next user reads again, and fails the same way).
    fn get(
        &self,
        l: usize,
        read: impl FnOnce() -> anyhow::Result<crate::runner::LoadedLog>,
    ) -> anyhow::Result<std::sync::Arc<crate::runner::LoadedLog>> {
        let mut slot = self.slots[l].lock().unwrap_or_else(|e| e.into_inner());
        slot.uses_left = slot.uses_left.saturating_sub(1);
        let log = match &slot.log {
            Some(log) => std::sync::Arc::clone(log),
            None => std::sync::Arc::new(read()?),
        };
        slot.log = (slot.uses_left > 0).then(|| std::sync::Arc::clone(&log));
        Ok(log)
    }
}

/// Reads `path` with the plan's options and keeps the radios asked for.
fn read_log(
    args: &EvalOptions,
    plan: &Plan,
    path: &Path,
) -> anyhow::Result<crate::runner::LoadedLog> {
    let mut log = crate::runner::load_log(path, &plan.opts)?;
    crate::radios::keep_radios(&mut log.events, &args.radios);
    Ok(log)
}

/// Replays `log` through every engine of the plan.
fn replay_log(
    args: &EvalOptions,
    plan: &Plan,
    cfg: &fpbp_core::engines::EngineConfig,
    log: &crate::runner::LoadedLog,
    build: &EngineBuilder,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<LogUnit> {
    let read = ReadSummary::from(&log.report);
    let mut runs = Vec::with_capacity(plan.engines.len());
    for e in &plan.engines {
        bar.set_message(format!("{e} on {}", short(&log.path)));
        runs.push(crate::runner::run_log(
            build, e, &plan.site, cfg, args.init, log,
        )?);
        bar.inc(1);
    }
    let loaded = crate::runner::LoadedLog {
        path: log.path.clone(),
        name: log.name.clone(),
        events: log
            .events
            .iter()
            .filter(|e| matches!(e, fpbp_core::events::LogEvent::Ble(_)))
            .cloned()
            .collect(),
        report: log.report.clone(),
    };
    Ok(LogUnit { runs, read, loaded })
}

/// Scores one config's replays and writes DIR/metrics.json, cdf.png and
/// points.csv; returns the metrics and, apart, the "nothing positioned" check.
fn write_outputs(
    args: &EvalOptions,
    plan: &Plan,
    cfg: &fpbp_core::engines::EngineConfig,
    units: Vec<LogUnit>,
    started: std::time::Instant,
) -> anyhow::Result<(Vec<EngineMetrics>, anyhow::Result<()>)> {
    let (site, logs, engines) = (&plan.site, &plan.logs, &plan.engines);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut runs: Vec<Vec<LogRun>> = engines.iter().map(|_| Vec::new()).collect();
    let mut reads: Vec<ReadSummary> = Vec::new();
    let mut loaded = Vec::new();
    for unit in units {
        for (i, r) in unit.runs.into_iter().enumerate() {
            runs[i].push(r);
        }
        reads.push(unit.read);
        loaded.push(unit.loaded);
    }
    let metrics: Vec<EngineMetrics> = engines
        .iter()
        .zip(&runs)
        .map(|(e, r)| EngineMetrics::from_runs(site, e, args.init, r, &reads))
        .collect();
    crate::report::MetricsDoc {
        split: Some(args.split),
        ..crate::report::MetricsDoc::new(
            "eval",
            &args.site,
            logs,
            args.init,
            vec![cfg.seed],
            started.elapsed().as_secs_f64(),
            &metrics,
        )
    }
    .write(&args.out)?;
    let series: Vec<plot::CdfSeries> = metrics.iter().map(crate::report::cdf_series).collect();
    let title = format!(
        "error CDF, {} logs, split {:?}, seed {}",
        logs.len(),
        args.split,
        cfg.seed
    )
    .to_lowercase();
    plot::cdf_png(&args.out.join("cdf.png"), &title, &series)?;
    let pp = args.out.join("points.csv");
    std::fs::write(&pp, points_csv(engines, &runs))
        .with_context(|| format!("cannot write {}", pp.display()))?;
    if args.tracks {
        for (e, rs) in engines.iter().zip(&runs) {
            let dir = args.out.join("tracks").join(e);
            std::fs::create_dir_all(&dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            for r in rs {
                crate::report::write_track_csv(&dir.join(format!("{}.csv", r.log)), &r.out)?;
            }
        }
    }
    let refs: Vec<&crate::runner::LoadedLog> = loaded.iter().collect();
    let mrefs: Vec<&EngineMetrics> = metrics.iter().collect();
    let empty = crate::report::check_positioned(site, &refs, engines, &runs, &mrefs);
    Ok((metrics, empty))
}

/// DIR/points.csv: one row per engine and scored truth point, with the
/// estimated and true floors, the point's IPIN error and the pose's accuracy
/// radius (empty fields: no fix or no truth floor).
fn points_csv(engines: &[String], runs: &[Vec<LogRun>]) -> String {
    use std::fmt::Write;
    let mut s = String::from(
        "engine,log,t_s,truth_x_m,truth_y_m,truth_floor,est_x_m,est_y_m,est_floor,error_m,ipin_error_m,accuracy_m\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.3}"));
    for (e, rs) in engines.iter().zip(runs) {
        for r in rs {
            for p in &r.out.scored {
                let t = &p.truth;
                let _ = writeln!(
                    s,
                    "{e},{},{:.3},{:.3},{:.3},{},{},{},{},{},{},{}",
                    r.log,
                    t.t_ns as f64 * 1e-9,
                    t.x_m,
                    t.y_m,
                    t.floor.map_or(String::new(), |f| f.to_string()),
                    opt(p.estimate.map(|q| q.x_m)),
                    opt(p.estimate.map(|q| q.y_m)),
                    p.estimate.map_or(String::new(), |q| q.floor.to_string()),
                    opt(p.error_m()),
                    opt(crate::metrics::ipin_error_m(p)),
                    opt(p.estimate.map(|q| q.accuracy_m)),
                );
            }
        }
    }
    s
}

fn short(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testkit::*;

    /// The engine list in `--engine`'s help (and replay's) is the factory's.
    #[cfg(feature = "cli")]
    #[test]
    fn engine_help_lists_every_engine() {
        use clap::{CommandFactory, Parser};
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            eval: EvalOptions,
        }
        let help = Cli::command().render_long_help().to_string();
        // and the arguments parse (clap checks its definitions here)
        let cli = Cli::try_parse_from([
            "t", "--site", "s", "--logs", "l", "--engine", "fpbp", "--out", "o", "--seeds", "1-3,7",
        ])
        .unwrap();
        assert_eq!(
            cli.eval.seeds,
            Some(crate::report::SeedList(vec![1, 2, 3, 7]))
        );
        assert!(
            Cli::try_parse_from([
                "t", "--site", "s", "--logs", "l", "--engine", "fpbp", "--out", "o", "--seeds",
                "3-1"
            ])
            .is_err()
        );
        let replay = include_str!("replay.rs");
        for name in fpbp_core::engines::ENGINE_NAMES {
            assert!(help.contains(name), "eval --engine help lacks {name}");
            assert!(
                replay.contains(&format!(" {name},")) || replay.contains(&format!(" {name} (")),
                "replay --engine help lacks {name}"
            );
        }
    }

    #[test]
    fn a_shared_log_is_read_once_and_dropped_after_its_last_user() {
        let reads = std::sync::atomic::AtomicUsize::new(0);
        let read = || {
            reads.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            Ok(crate::runner::LoadedLog {
                path: "a.log".into(),
                name: "a.log".into(),
                events: Vec::new(),
                report: Default::default(),
            })
        };
        let logs = SharedLogs::new(2, 3);
        for _ in 0..3 {
            assert_eq!(logs.get(0, read).unwrap().name, "a.log");
        }
        assert_eq!(reads.load(std::sync::atomic::Ordering::Relaxed), 1);
        assert!(
            logs.slots[0].lock().unwrap().log.is_none(),
            "kept after the last user"
        );
        // a failed read is not kept: the next user reads again
        let fail = || Err(anyhow::anyhow!("gone"));
        assert!(logs.get(1, fail).is_err());
        assert!(logs.get(1, read).is_ok());
        assert_eq!(reads.load(std::sync::atomic::Ordering::Relaxed), 2);
    }

    #[test]
    fn split_follows_the_sorted_file_names() {
        let logs: Vec<PathBuf> = ["d/c.txt", "a/b.txt", "z/a.txt", "d.txt"]
            .iter()
            .map(PathBuf::from)
            .collect();
        let names = |s| {
            select_logs(&logs, s)
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
        };
        assert_eq!(
            names(Split::All),
            ["z/a.txt", "a/b.txt", "d/c.txt", "d.txt"]
        );
        assert_eq!(names(Split::Even), ["z/a.txt", "d/c.txt"]);
        assert_eq!(names(Split::Odd), ["a/b.txt", "d.txt"]);
    }

    #[test]
    fn eval_writes_metrics_with_design_keys_and_cdf() {
        let d = tmp_dir("eval");
        let site_path = d.join("site.json");
        std::fs::write(&site_path, r#"{"format":"fpbp-site","version":1,"name":"t","floors":[{"id":0,"open_area_m":[30,10]}]}"#).unwrap();
        let logs: Vec<PathBuf> = (0..3).map(|k| d.join(format!("walk{k}.log"))).collect();
        for (k, l) in logs.iter().enumerate() {
            write_log(l, 4 + k as i64);
        }
        let args = EvalOptions {
            site: site_path,
            logs: logs.clone(),
            engine: vec!["pdr".into(), "walk-east".into()],
            out: d.join("out"),
            config: None,
            init: InitMode::None,
            split: Split::All,
            seed: None,
            seeds: None,
            floor: None,
            strict: false,
            fingerprints: None,
            radio_map: None,
            radios: vec![crate::radios::Radio::Ble, crate::radios::Radio::Wifi],
            tracks: true,
            jobs: None,
        };
        // walk-east has no start without --init truth: it positions nothing,
        // which is an error naming it (after the outputs are written)
        let e = run_with(&args, &builder, false).unwrap_err().to_string();
        assert!(e.contains("nothing positioned by walk-east"), "{e}");
        // --tracks: every engine's whole track per log, track.csv layout
        let t = std::fs::read_to_string(d.join("out/tracks/pdr/walk1.log.csv")).unwrap();
        assert_eq!(t.lines().next(), Some(crate::report::TRACK_CSV_HEADER));
        assert!(t.lines().any(|l| l.starts_with("pose,")), "{t}");
        let (ms, empty) = run_inner(&args, &builder, false).unwrap();
        assert!(empty.is_err());
        assert_eq!(ms.len(), 2);
        // pdr: 4+5+6 truth points minus the 3 start points, all with a fix.
        assert_eq!(
            (ms[0].logs, ms[0].errors.points, ms[0].errors.no_fix),
            (3, 12, 0)
        );
        assert_eq!(
            (ms[0].start, ms[0].errors.coverage),
            (crate::report::StartMode::Truth, Some(1.0))
        );
        // walk-east is scored on the same 12 points (every truth point after
        // each log's first), all without a pose: coverage 0.
        assert_eq!((ms[1].errors.points, ms[1].errors.no_fix), (12, 12));
        assert_eq!(
            (ms[1].start, ms[1].errors.coverage),
            (crate::report::StartMode::Own, Some(0.0))
        );
        let pdr_all = ms[0].errors.mpe_m;
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("out/metrics.json")).unwrap())
                .unwrap();
        assert_eq!(json["format"], "fpbp-metrics");
        assert_eq!(json["command"], "eval");
        let e0 = &json["engines"][0];
        for k in crate::report::ENGINE_KEYS {
            assert!(e0.get(k).is_some(), "missing {k}");
        }
        assert!(e0["mct_us"].get("radio").is_some() && e0["mct_us"]["fusion"].as_f64().is_some());
        assert_eq!(e0["per_log"].as_array().unwrap().len(), 3);
        assert_eq!(e0["per_log"][0]["log"], "walk0.log");
        assert!(image::open(d.join("out/cdf.png")).is_ok());
        // points.csv: header + one row per engine and scored point (12 + 12)
        let csv = std::fs::read_to_string(d.join("out/points.csv")).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 1 + 12 + 12, "{csv}");
        assert!(lines[0].contains("est_floor") && lines[0].ends_with("ipin_error_m,accuracy_m"));
        // a pdr row has an estimated floor; a walk-east row (no fix) has none
        assert_eq!(lines[1].split(',').nth(8), Some("0"));
        assert_eq!(lines[13].split(',').nth(8), Some(""));
        // the pose's radius beside its error; none without a fix
        let acc: f64 = lines[1].split(',').nth(11).unwrap().parse().unwrap();
        assert!(acc.is_finite() && acc >= 0.0, "{}", lines[1]);
        assert_eq!(lines[13].split(',').nth(11), Some(""));
        // The odd split keeps one log.
        let ms = run_with(
            &EvalOptions {
                split: Split::Odd,
                out: d.join("odd"),
                engine: vec!["pdr".into()],
                ..args.clone()
            },
            &builder,
            false,
        )
        .unwrap();
        assert_eq!(ms[0].per_log.len(), 1);
        assert_eq!(ms[0].per_log[0].log, "walk1.log");
        // Several seeds: one run per seed in DIR/seed-S, the summary in DIR.
        let seeds = [1, 2, 3];
        let ss = run_seeds(
            &EvalOptions {
                out: d.join("seeds"),
                engine: vec!["pdr".into()],
                ..args.clone()
            },
            &seeds,
            &builder,
            false,
        )
        .unwrap();
        assert_eq!(ss.len(), 1);
        assert_eq!(ss[0].mpe_m.per_seed.len(), 3);
        // the test engine ignores the seed: no spread
        assert_eq!(ss[0].mpe_m.sd, Some(0.0));
        assert_eq!(ss[0].mpe_m.mean, pdr_all);
        for s in seeds {
            assert!(d.join(format!("seeds/seed-{s}/metrics.json")).is_file());
        }
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("seeds/metrics.json")).unwrap())
                .unwrap();
        assert_eq!(json["seeds"], serde_json::json!([1, 2, 3]));
        assert!(json["engines"][0]["coverage"]["mean"].as_f64() == Some(1.0));
        // Serial and parallel runs write the same points and metrics (all
        // but the timing fields) for every seed.
        for jobs in [1, 3] {
            run_seeds(
                &EvalOptions {
                    out: d.join(format!("jobs-{jobs}")),
                    engine: vec!["pdr".into(), "walk-east".into()],
                    init: InitMode::Truth,
                    jobs: Some(jobs),
                    ..args.clone()
                },
                &seeds,
                &builder,
                false,
            )
            .unwrap();
        }
        for s in seeds {
            let read = |jobs: u16, f: &str| {
                std::fs::read_to_string(d.join(format!("jobs-{jobs}/seed-{s}/{f}"))).unwrap()
            };
            assert!(read(1, "points.csv").lines().count() > 20);
            assert_eq!(read(1, "points.csv"), read(3, "points.csv"), "seed {s}");
            let errors = |jobs: u16| {
                let v: serde_json::Value =
                    serde_json::from_str(&read(jobs, "metrics.json")).unwrap();
                v["engines"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|e| {
                        (
                            e["engine"].clone(),
                            e["mpe_m"].clone(),
                            e["per_log"]
                                .as_array()
                                .unwrap()
                                .iter()
                                .map(|l| l["log"].clone())
                                .collect::<Vec<_>>(),
                        )
                    })
                    .collect::<Vec<_>>()
            };
            assert_eq!(errors(1), errors(3), "seed {s}");
        }
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn eval_runs_the_core_pdr_engine_on_real_ilc_traces() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/datasets/ilc/site2/F4/path_data_files");
        if !data.is_dir() {
            println!("skipped: ../shared/datasets not found ({})", data.display());
            return;
        }
        let d = tmp_dir("eval-ilc");
        let site_path = d.join("site.json");
        std::fs::write(&site_path, r#"{"format":"fpbp-site","version":1,"name":"F4","floors":[{"id":4,"open_area_m":[236.71,219.75]}]}"#).unwrap();
        let mut logs: Vec<PathBuf> = std::fs::read_dir(&data)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        logs.sort();
        logs.truncate(4);
        let args = EvalOptions {
            site: site_path,
            logs,
            engine: vec!["pdr".into()],
            out: d.join("out"),
            config: None,
            init: InitMode::None,
            split: Split::Odd,
            seed: None,
            seeds: None,
            floor: None,
            strict: true,
            fingerprints: None,
            radio_map: None,
            radios: vec![crate::radios::Radio::Ble, crate::radios::Radio::Wifi],
            tracks: false,
            jobs: None,
        };
        let ms = run_with(&args, &crate::runner::core_builder, false).unwrap();
        let m = &ms[0];
        assert_eq!(m.logs, 2);
        assert_eq!(m.errors.no_fix, 0, "{m:?}");
        // Every waypoint but the start is scored.
        for (row, path) in m.per_log.iter().zip(select_logs(&args.logs, Split::Odd)) {
            let (_, rep) = fpbp_logs::read_all(&path, &fpbp_logs::ReadOptions::default()).unwrap();
            assert_eq!(
                row.errors.points as u64,
                rep.events.truth - 1,
                "{}",
                row.log
            );
        }
        assert!(
            m.per_log
                .iter()
                .all(|l| l.steps > 0 && l.init_from_truth && l.read.malformed_skipped == 0)
        );
        assert!(m.errors.mpe_m.unwrap().is_finite() && m.errors.floor_accuracy == Some(1.0));
        std::fs::remove_dir_all(&d).ok();
    }
}
