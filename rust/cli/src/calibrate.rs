//! `fpbp calibrate`: estimate transmitter positions and path-loss models from
//! survey logs with ground truth, and write the site with those beacons.
//! The work is done by `fpbp_core::ble::calibrate`; this is file glue.
//!
//! `--check-logs` replays the BLE-only engines on held-out logs with the
//! calibrated site and prints mean / p50 / p80 error at the truth points and
//! the share of truth points that had a position.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::ble::calibrate::{SurveyPath, TransmitterReport, apply_to_site, calibrate};
use fpbp_core::engine::replay::replay;
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::{LogEvent, SensorData, TruthPoint};
use fpbp_core::geometry::wrap_angle;
use fpbp_core::map::{Feature, FloorMap};
use fpbp_core::radio::survey_track::{ShapeCounts, ShapeLimits, pdr_shaped_truth, with_truth};
use fpbp_core::site::SiteSpec;
use fpbp_core::wifi::calibrate::{WifiSurveyPath, apply_aps_to_site, calibrate_aps};
use fpbp_eval::heading_bias::{HeadingSegment, heading_bias, segments};
use fpbp_logs::{ReadOptions, read_all};

use fpbp_eval::eval::{Split, select_logs};
use fpbp_eval::runner::{InitMode, LoadedLog, LogRun, core_builder, run_log};

/// Arguments of `fpbp calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// Site file (site.json) whose floors the logs were recorded on.
    #[arg(long)]
    pub site: PathBuf,
    /// Survey logs with ground truth (native, ILC or IPIN; gzip ok).
    #[arg(long, num_args = 1.., required = true)]
    pub logs: Vec<PathBuf>,
    /// Output site file: the input site with the accepted beacons added/replaced.
    #[arg(long)]
    pub out: PathBuf,
    /// Use only this half of the logs (sorted by file name).
    #[arg(long, value_enum, default_value = "all")]
    pub split: Split,
    /// Engine config JSON (its `ble.calibration` section tunes the fit).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Floor of truth points whose log does not say (ILC); default: the site's first floor.
    #[arg(long)]
    pub floor: Option<i32>,
    /// Write every transmitter's report (accepted and rejected) as JSON here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Held-out logs to replay the BLE engines on with the calibrated site.
    #[arg(long, num_args = 1..)]
    pub check_logs: Vec<PathBuf>,
    /// Split applied to --check-logs.
    #[arg(long, value_enum, default_value = "all")]
    pub check_split: Split,
    /// Engines for --check-logs.
    #[arg(long, default_value = "gml,trilat,frbw,ml,wcentroid")]
    pub check_engines: String,
    /// Also calibrate the WiFi access points heard in the logs (config
    /// section `wifi`) and write them as the site's `access_points`.
    #[arg(long)]
    pub wifi: bool,
    /// Write every AP transmitter's report (accepted and rejected) as JSON here.
    #[arg(long)]
    pub wifi_report: Option<PathBuf>,
    /// Also learn a radio map (`fpbp-radio-map`, docs/formats.md) from the
    /// same logs and write it here; the written site is its fallback.
    #[arg(long)]
    pub radio_map: Option<PathBuf>,
    /// Radio map settings JSON (`RadioMapConfig`, docs/parameters.md).
    #[arg(long, requires = "radio_map")]
    pub radio_map_config: Option<PathBuf>,
    /// Held-out logs with truth to check the radio map's spread on
    /// (standardised residuals by distance from the survey).
    #[arg(long, num_args = 1.., requires = "radio_map")]
    pub radio_map_check_logs: Vec<PathBuf>,
    /// Split applied to --radio-map-check-logs.
    #[arg(long, value_enum, default_value = "all")]
    pub radio_map_check_split: Split,
    /// Write every surveyed transmitter's radio-map report as JSON here.
    #[arg(long, requires = "radio_map")]
    pub radio_map_report: Option<PathBuf>,
    /// Where the survey walker was between two truth points: `pdr` (its
    /// own PDR track, mapped onto the two points: pauses and turns kept)
    /// or `linear` (a straight line at constant speed).
    #[arg(long, value_enum, default_value = "linear")]
    pub survey_track: SurveyTrack,
}

/// `fpbp calibrate --survey-track`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurveyTrack {
    Linear,
    Pdr,
}

fn read_options(spec: &SiteSpec, floor: Option<i32>) -> ReadOptions {
    ReadOptions {
        site_georef: spec.georef.map(|g| (g, spec.map_from_enu_rad)),
        default_floor: Some(
            floor.unwrap_or_else(|| spec.floors.first().map(|f| f.id).unwrap_or(0)),
        ),
        ..ReadOptions::default()
    }
}

pub(crate) fn load_events(path: &Path, opts: &ReadOptions) -> Result<Vec<LogEvent>> {
    Ok(load_log(path, opts)?.events)
}

/// A log's events and read report (malformed lines warned about).
fn load_log(path: &Path, opts: &ReadOptions) -> Result<LoadedLog> {
    let (events, report) =
        read_all(path, opts).with_context(|| format!("reading {}", path.display()))?;
    if report.malformed_skipped > 0 {
        log::warn!(
            "{}: {} malformed lines skipped",
            path.display(),
            report.malformed_skipped
        );
    }
    Ok(LoadedLog {
        path: path.to_path_buf(),
        name: path.display().to_string(),
        events,
        report,
    })
}

fn load_spec(path: &Path) -> Result<SiteSpec> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_slice(&bytes)
        .with_context(|| format!("{}: not a valid site.json", path.display()))
}

/// Plan paths are relative to the site file: when the output goes to another
/// directory, point them at the input's plans by a path relative to the
/// output's directory (`../site/plan.png`), so that the output holds no
/// path of this machine (`fpbp bundle` names plan entries by these paths).
/// Absolute only when no relative path exists (another drive).
fn rebase_plans(spec: &mut SiteSpec, from: &Path, to: &Path) {
    let dir = |p: &Path| p.parent().map(Path::to_path_buf).unwrap_or_default();
    let (a, b) = (dir(from), dir(to));
    let canon = |p: &Path| {
        std::fs::canonicalize(if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        })
        .ok()
    };
    let Some(b) = canon(&b) else { return };
    if canon(&a).as_ref() == Some(&b) {
        return;
    }
    for f in &mut spec.floors {
        if let Some(plan) = &f.plan
            && Path::new(plan).is_relative()
            && let Some(abs) = canon(&a.join(plan))
        {
            let p = relative_path(&abs, &b).unwrap_or(abs);
            // forward slashes: the site file is read on any system
            let parts: Vec<String> = p
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            f.plan = Some(if p.is_absolute() {
                p.display().to_string()
            } else {
                parts.join("/")
            });
        }
    }
}

/// `path` relative to the directory `base` (both canonical), or `None`
/// when they share no root.
fn relative_path(path: &Path, base: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let p: Vec<Component> = path.components().collect();
    let b: Vec<Component> = base.components().collect();
    let common = p.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let rooted = |c: &Component| matches!(c, Component::Prefix(_) | Component::RootDir);
    if common == 0 || p[..common].iter().all(|c| !rooted(c)) {
        return None;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &p[common..] {
        out.push(c.as_os_str());
    }
    Some(out)
}

fn load_config(path: Option<&PathBuf>) -> Result<EngineConfig> {
    match path {
        None => Ok(EngineConfig::default()),
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            EngineConfig::from_json(&text).with_context(|| format!("{}", p.display()))
        }
    }
}

fn print_table(reports: &[TransmitterReport]) {
    let mut shown: Vec<&TransmitterReport> = reports.iter().filter(|r| r.x_m.is_some()).collect();
    shown.sort_by(|a, b| {
        b.accepted()
            .cmp(&a.accepted())
            .then(b.bins.cmp(&a.bins))
            .then(a.id.cmp(&b.id))
    });
    println!(
        "{:<48} {:>5} {:>5} {:>6} {:>7} {:>7} {:>6} {:>5} {:>6} {:>6} {:>6}  verdict",
        "id", "floor", "paths", "bins", "x_m", "y_m", "r0", "n", "resid", "corr", "excess"
    );
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}"));
    let f2 = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    for r in shown {
        println!(
            "{:<48} {:>5} {:>5} {:>6} {:>7} {:>7} {:>6} {:>5} {:>6} {:>6} {:>6}  {}",
            r.id,
            r.floor,
            r.paths,
            r.bins,
            f(r.x_m),
            f(r.y_m),
            f(r.rssi_1m_dbm),
            f2(r.path_loss_exponent),
            f(r.residual_dbm),
            f2(r.correlation),
            f(r.path_excess_dbm),
            r.rejected.as_deref().unwrap_or("fixed")
        );
    }
}

/// Quantile `q` in [0, 1] of sorted values (`fpbp_core::stats`); NaN when empty.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    fpbp_core::stats::quantile_sorted(sorted, q).unwrap_or(f64::NAN)
}

fn check(args: &Args, spec: &SiteSpec, cfg: &EngineConfig) -> Result<()> {
    let logs = select_logs(&args.check_logs, args.check_split);
    let site: Arc<fpbp_core::site::Site> = fpbp_core::site::files::load_site(&args.out)?;
    let opts = read_options(spec, args.floor);
    let mut all_events = Vec::new();
    for l in &logs {
        all_events.push(load_events(l, &opts)?);
    }
    println!(
        "\ncheck on {} held-out logs (errors at truth points, engines find their own start):",
        logs.len()
    );
    println!(
        "{:<10} {:>7} {:>7} {:>7} {:>7} {:>8} {:>8}",
        "engine", "points", "fixed%", "mean_m", "p50_m", "p80_m", "no_fix"
    );
    for name in args
        .check_engines
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
    {
        let mut errs = Vec::new();
        let (mut points, mut no_fix) = (0usize, 0u64);
        for events in &all_events {
            let mut e = build_engine(name, site.clone(), cfg, None)?;
            let out = replay(e.as_mut(), events.iter().cloned());
            points += out.scored.len();
            no_fix += out.stats.no_fix;
            errs.extend(out.scored.iter().filter_map(|s| s.error_m()));
        }
        errs.sort_by(f64::total_cmp);
        let fig = |v: f64| {
            if errs.is_empty() {
                "-".to_string()
            } else {
                format!("{v:.2}")
            }
        };
        let mean = errs.iter().sum::<f64>() / errs.len().max(1) as f64;
        println!(
            "{:<10} {:>7} {:>6.1}% {:>7} {:>7} {:>8} {:>8}",
            name,
            points,
            100.0 * errs.len() as f64 / points.max(1) as f64,
            fig(mean),
            fig(percentile(&errs, 0.5)),
            fig(percentile(&errs, 0.8)),
            no_fix
        );
    }
    Ok(())
}

/// The survey log's `pdr` replay from its first truth point on the input
/// site (none without truth).
fn pdr_run(
    log: &LoadedLog,
    site: &Arc<fpbp_core::site::Site>,
    cfg: &EngineConfig,
) -> Result<Option<LogRun>> {
    if !log.events.iter().any(|e| matches!(e, LogEvent::Truth(_))) {
        return Ok(None);
    }
    run_log(&core_builder, "pdr", site, cfg, InitMode::Truth, log).map(Some)
}

/// `events` with their truth points densified along the PDR `run`'s
/// track ([`pdr_shaped_truth`]), in time order.
fn shaped_events(events: Vec<LogEvent>, run: &LogRun) -> (Vec<LogEvent>, ShapeCounts) {
    let truth: Vec<TruthPoint> = events
        .iter()
        .filter_map(LogEvent::as_truth)
        .copied()
        .collect();
    let track: Vec<(i64, Vec2)> = run
        .out
        .track
        .iter()
        .map(|p| (p.t_ns, Vec2::new(p.x_m, p.y_m)))
        .collect();
    let (dense, counts) = pdr_shaped_truth(&truth, &track, &ShapeLimits::default());
    (with_truth(events, dense), counts)
}

/// One survey log read for calibration: its events (truth densified with
/// `--survey-track pdr`) and its PDR-vs-truth displacements ([`segments`]).
fn survey_log(
    path: &Path,
    opts: &ReadOptions,
    site: &Arc<fpbp_core::site::Site>,
    cfg: &EngineConfig,
    track: SurveyTrack,
) -> Result<SurveyLog> {
    let log = load_log(path, opts)?;
    let device = log.report.device.clone();
    let Some(run) = pdr_run(&log, site, cfg)? else {
        return Ok((log.events, Vec::new(), ShapeCounts::default(), device));
    };
    let segs = segments(&run.out.scored);
    match track {
        SurveyTrack::Linear => Ok((log.events, segs, ShapeCounts::default(), device)),
        SurveyTrack::Pdr => {
            let (events, counts) = shaped_events(log.events, &run);
            Ok((events, segs, counts, device))
        }
    }
}

/// A survey log's events, heading segments, track shaping counts and the
/// phone model that recorded it (when the log says).
type SurveyLog = (
    Vec<LogEvent>,
    Vec<HeadingSegment>,
    ShapeCounts,
    Option<String>,
);

pub fn run(args: Args) -> Result<()> {
    let spec = load_spec(&args.site)?;
    let cfg = load_config(args.config.as_ref())?;
    let logs = select_logs(&args.logs, args.split);
    if logs.is_empty() {
        bail!("no logs left after --split {:?}", args.split);
    }
    let opts = read_options(&spec, args.floor);
    let mut paths = Vec::new();
    let mut wifi_paths = Vec::new();
    let mut heading_segments = Vec::new();
    let mut shape = ShapeCounts::default();
    // each log's events as the fits saw them (truth densified with
    // `--survey-track pdr`), kept for the radio map: one PDR replay a log
    let mut radio_map_logs = Vec::new();
    let input = fpbp_core::site::files::load_site(&args.site)?;
    let bar = fpbp_eval::progress::bar(logs.len() as u64 + 1);
    for l in &logs {
        bar.set_message(format!("reading {}", l.display()));
        bar.inc(1);
        let (events, segs, counts, device) = survey_log(l, &opts, &input, &cfg, args.survey_track)?;
        heading_segments.extend(segs);
        shape += counts;
        let mut p = SurveyPath {
            name: l.display().to_string(),
            ..Default::default()
        };
        let mut scans = Vec::new();
        for e in &events {
            match e {
                LogEvent::Ble(b) => p.observations.push(b.clone()),
                LogEvent::Truth(t) => p.truth.push(*t),
                LogEvent::Wifi(w) if args.wifi => scans.push(w.clone()),
                _ => {}
            }
        }
        if args.radio_map.is_some() {
            // the map reads radio, truth and the magnetometer only: the
            // other sensor samples (most of a log) are not kept across the
            // logs
            let mut events = events;
            events.retain(radio_map_reads);
            events.shrink_to_fit();
            radio_map_logs.push((l.clone(), events, device));
        }
        if p.truth.len() < 2 {
            eprintln!("{}: fewer than 2 truth points, skipped", l.display());
            continue;
        }
        if args.wifi {
            wifi_paths.push(WifiSurveyPath {
                name: p.name.clone(),
                scans,
                truth: p.truth.clone(),
            });
        }
        paths.push(p);
    }
    bar.set_message("fitting beacons");
    let (mut reports, mut summary) = calibrate(&paths, &cfg.ble).context("calibration")?;
    bar.finish_and_clear();
    place_on_maps(&mut reports, &mut summary, &input);
    print_table(&reports);
    let too_little = reports.iter().filter(|r| r.x_m.is_none()).count();
    println!(
        "\n{} paths, {} BLE observations ({} without truth around them, {} invalid); {} transmitters: {} left out for too little data, {} fitted, {} fixed-looking kept",
        summary.paths,
        summary.observations,
        summary.without_truth,
        summary.invalid,
        summary.transmitters,
        too_little,
        summary.transmitters - too_little,
        summary.accepted
    );
    if args.survey_track == SurveyTrack::Pdr {
        println!(
            "survey track: {} of {} truth segments shaped by the PDR, {} truth points added",
            shape.shaped, shape.segments, shape.added
        );
    }
    let mut out = apply_to_site(&spec, &reports, cfg.ble.phone_height_m);
    match heading_bias(&heading_segments) {
        Some(b) => {
            let verdict = if b.significant() {
                out.heading_bias_rad = wrap_angle(spec.heading_bias_rad + b.rad);
                "applied"
            } else {
                "within its noise, not applied"
            };
            println!(
                "heading bias: the PDR meets the truth turned by {:+.1} deg, standard error {:.1} deg ({} segments, sd {:.1} deg, {} left out): {verdict}; site heading_bias_rad {:.4}",
                b.rad.to_degrees(),
                b.se_rad().to_degrees(),
                b.segments,
                b.sd_rad.to_degrees(),
                b.left_out,
                out.heading_bias_rad
            );
        }
        None => println!(
            "heading bias: too few PDR segments ({}), heading_bias_rad kept at {:.4}",
            heading_segments.len(),
            spec.heading_bias_rad
        ),
    }
    if args.wifi {
        out = calibrate_wifi(&args, &wifi_paths, &cfg, &input, &out)?;
    }
    rebase_plans(&mut out, &args.site, &args.out);
    let text = out.to_json_pretty();
    std::fs::write(&args.out, text).with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "wrote {} ({} beacons, {} access points)",
        args.out.display(),
        out.beacons.len(),
        out.access_points.len()
    );
    if let Some(r) = &args.report {
        std::fs::write(r, serde_json::to_string_pretty(&reports)?)
            .with_context(|| format!("writing {}", r.display()))?;
    }
    if let Some(rm) = &args.radio_map {
        let site = fpbp_core::site::files::load_site(&args.out)?;
        let mut check_logs = Vec::new();
        for l in select_logs(&args.radio_map_check_logs, args.radio_map_check_split) {
            let mut events = load_events(&l, &opts)?;
            events.retain(radio_map_reads);
            check_logs.push(events);
        }
        fpbp_eval::radio_map::build(
            &site,
            radio_map_logs,
            args.radio_map_config.as_deref(),
            rm,
            args.radio_map_report.as_deref(),
            &check_logs,
        )?;
    }
    if !args.check_logs.is_empty() {
        check(&args, &out, &cfg)?;
    }
    Ok(())
}

/// `fpbp calibrate --wifi`: fits the APs (`fpbp_core::wifi::calibrate`),
/// places them on the maps as beacons are placed, prints a summary and the
/// residuals per band, and returns `site` with the accepted APs.
fn calibrate_wifi(
    args: &Args,
    paths: &[WifiSurveyPath],
    cfg: &EngineConfig,
    input: &fpbp_core::site::Site,
    site: &SiteSpec,
) -> Result<SiteSpec> {
    let mut cal = calibrate_aps(paths, &cfg.wifi, &cfg.ble).context("AP calibration")?;
    place_on_maps(&mut cal.reports, &mut cal.summary, input);
    let fitted: Vec<&TransmitterReport> = cal.reports.iter().filter(|r| r.x_m.is_some()).collect();
    let accepted: Vec<&TransmitterReport> =
        fitted.iter().copied().filter(|r| r.accepted()).collect();
    let mut resid: Vec<f64> = accepted.iter().filter_map(|r| r.residual_dbm).collect();
    resid.sort_by(f64::total_cmp);
    let mut reasons: std::collections::BTreeMap<String, usize> = Default::default();
    for r in &fitted {
        if let Some(why) = &r.rejected {
            let head = why
                .split(['(', ':'])
                .next()
                .unwrap_or(why)
                .trim()
                .to_string();
            *reasons.entry(head).or_default() += 1;
        }
    }
    println!(
        "\nWiFi ({:?} grouping): {} results, {} used (new, at most {} s old, >= {} dBm); {} transmitters, {} fitted, {} accepted ({} BSSIDs); residual of the accepted p25/p50/p75 {:.1}/{:.1}/{:.1} dB",
        cfg.wifi.grouping,
        cal.results,
        cal.used,
        cfg.wifi.max_age_s,
        cfg.wifi.min_rssi_dbm,
        cal.reports.len(),
        fitted.len(),
        accepted.len(),
        accepted
            .iter()
            .map(|r| cal.members.get(&r.id).map_or(0, |m| m.len()))
            .sum::<usize>(),
        percentile(&resid, 0.25),
        percentile(&resid, 0.5),
        percentile(&resid, 0.75)
    );
    for (why, n) in &reasons {
        println!("  rejected: {n} {why}");
    }
    if let Some(r) = &args.wifi_report {
        std::fs::write(r, serde_json::to_string_pretty(&cal.reports)?)
            .with_context(|| format!("writing {}", r.display()))?;
    }
    Ok(apply_aps_to_site(site, &cal, cfg.ble.phone_height_m))
}

/// A transmitter fitted outside its floor's map cannot go into the site; one
/// fitted on a Wall pixel moves to the nearest non-Wall point (BLE beacons
/// and WiFi APs alike).
fn place_on_maps(
    reports: &mut [TransmitterReport],
    summary: &mut fpbp_core::ble::calibrate::CalibrationSummary,
    input: &fpbp_core::site::Site,
) {
    for r in reports.iter_mut().filter(|r| r.accepted()) {
        let (Some(x), Some(y)) = (r.x_m, r.y_m) else {
            continue;
        };
        let inside = input
            .floor(r.floor)
            .is_some_and(|m| (0.0..=m.width_m()).contains(&x) && (0.0..=m.height_m()).contains(&y));
        if !inside {
            r.rejected = Some(format!(
                "fitted at ({x:.1}, {y:.1}) m, outside floor {}'s map",
                r.floor
            ));
            summary.accepted -= 1;
            continue;
        }
        // Site files refuse beacons on Wall pixels. A fitted position inside a
        // wall (ceiling beacons above shop fronts, fitting error) moves to the
        // nearest non-Wall point within MAX_WALL_SHIFT_M; farther ones are dropped.
        let Some(map) = input.floor(r.floor) else {
            continue;
        };
        match nearest_non_wall(map, Vec2::new(x, y), MAX_WALL_SHIFT_M) {
            Some(p) if p != Vec2::new(x, y) => {
                eprintln!(
                    "{}: fitted at ({x:.1}, {y:.1}) m inside a wall, moved {:.2} m to ({:.1}, {:.1})",
                    r.id,
                    (p - Vec2::new(x, y)).norm(),
                    p.x,
                    p.y
                );
                r.x_m = Some(p.x);
                r.y_m = Some(p.y);
            }
            Some(_) => {}
            None => {
                r.rejected = Some(format!(
                    "fitted at ({x:.1}, {y:.1}) m inside a wall, no open floor within {MAX_WALL_SHIFT_M} m"
                ));
                summary.accepted -= 1;
            }
        }
    }
}

/// Largest move of a fitted beacon out of a wall, metres.
const MAX_WALL_SHIFT_M: f64 = 3.0;

/// The centre of the nearest non-Wall pixel to `p` within `max_m` (`p` itself
/// when it is not on a Wall pixel).
fn nearest_non_wall(map: &FloorMap, p: Vec2, max_m: f64) -> Option<Vec2> {
    if map.feature(p) != Feature::Wall {
        return Some(p);
    }
    let (ci, cj) = map.pixel_of(p)?;
    let r = map.pixels_per_meter();
    let max_px = (max_m * r).ceil() as isize;
    let mut best: Option<(f64, Vec2)> = None;
    for dj in -max_px..=max_px {
        for di in -max_px..=max_px {
            let (i, j) = (ci as isize + di, cj as isize + dj);
            if map.feature_px(i, j) == Feature::Wall {
                continue;
            }
            let q = map.ics_to_mcs(Vec2::new(i as f64 + 0.5, j as f64 + 0.5));
            let d = (q - p).norm();
            if d <= max_m && best.is_none_or(|(b, _)| d < b) {
                best = Some((d, q));
            }
        }
    }
    best.map(|(_, q)| q)
}

/// The events `fpbp calibrate --radio-map` keeps of each survey log for the
/// radio map: radio readings, truth, and the magnetometer samples its
/// magnetic section is learned from (every other sensor sample is dropped
/// so the survey's logs fit in memory together).
fn radio_map_reads(e: &LogEvent) -> bool {
    match e {
        LogEvent::Ble(_) | LogEvent::Wifi(_) | LogEvent::Truth(_) => true,
        LogEvent::Sensor(s) => matches!(s.data, SensorData::Magnetometer(_)),
        LogEvent::Gnss(_) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_climb_to_the_common_directory() {
        let rel = |p: &str, b: &str| relative_path(Path::new(p), Path::new(b));
        assert_eq!(
            rel("/w/maps/demo/plan.png", "/tmp/out"),
            Some(PathBuf::from("../../w/maps/demo/plan.png"))
        );
        assert_eq!(
            rel("/w/maps/demo/plan.png", "/w/maps/cal"),
            Some(PathBuf::from("../demo/plan.png"))
        );
        assert_eq!(
            rel("/w/maps/plan.png", "/w/maps"),
            Some(PathBuf::from("plan.png"))
        );
        assert_eq!(rel("plan.png", "/w"), None);
    }
    use fpbp_core::engine::replay::ReplayOutput;
    use fpbp_core::engine::{Pose, PoseSource};
    use fpbp_core::events::BleObservation;

    fn truth(t_s: i64, x: f64) -> LogEvent {
        LogEvent::Truth(TruthPoint {
            t_ns: t_s * 1_000_000_000,
            x_m: x,
            y_m: 0.0,
            floor: Some(1),
        })
    }

    fn ble(t_s: i64) -> LogEvent {
        LogEvent::Ble(BleObservation {
            t_ns: t_s * 1_000_000_000,
            beacon_id: "mac:AA:BB:CC:DD:EE:FF".into(),
            rssi_dbm: -70.0,
            tx_power_dbm: None,
        })
    }

    #[test]
    fn shaped_truth_is_merged_into_the_events_in_time_order() {
        // the walker stood 5 s at x 0, then walked to x 10 in 5 s; the PDR
        // (1.6 times short) saw the same
        let events = vec![
            truth(0, 0.0),
            ble(2),
            ble(6),
            ble(8),
            truth(10, 10.0),
            ble(11),
        ];
        let track = (0..=10)
            .map(|s| Pose {
                t_ns: s * 1_000_000_000,
                x_m: 1.25 * (s - 5).max(0) as f64,
                y_m: 0.0,
                floor: 1,
                heading_rad: 0.0,
                accuracy_m: 1.0,
                floor_prob: 1.0,
                source: PoseSource::DeadReckoning,
            })
            .collect();
        let run = LogRun {
            log: "x".into(),
            init: None,
            out: ReplayOutput {
                track,
                ..Default::default()
            },
        };
        let (out, c) = shaped_events(events, &run);
        assert_eq!((c.shaped, c.added), (1, 9));
        assert!(out.windows(2).all(|w| w[0].t_ns() <= w[1].t_ns()));
        assert_eq!(
            out.iter().filter(|e| matches!(e, LogEvent::Ble(_))).count(),
            4
        );
        let at = |t: i64| {
            out.iter()
                .find_map(|e| match e {
                    LogEvent::Truth(p) if p.t_ns == t * 1_000_000_000 => Some(p.x_m),
                    _ => None,
                })
                .expect("truth point")
        };
        assert_eq!(at(4), 0.0);
        assert!((at(8) - 6.0).abs() < 1e-9);
        assert_eq!(at(10), 10.0);
    }
}
