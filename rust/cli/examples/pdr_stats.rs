//! PDR measured on the real logs in ../shared/datasets (ILC site2/F4, site1/F1,
//! IPIN 2023 training logs): steps per path, walked-distance ratio, heading
//! error on straight legs, and the `pdr` engine's error at the truth points.
//!
//! Usage: cargo run --release -p fpbp-cli --example pdr_stats -- [DATASETS_DIR]
//!        [--config JSON] [--only ilc|ipin] [--per-path]
//! `--config` is a PdrConfig as JSON (e.g. '{"step_length_beta":0.5}').
//!
//! Definitions:
//! - steps and ratio use only steps whose peak lies between the first and the
//!   last truth point of a log (IPIN logs start with a minute of deliberate
//!   phone motion and standing; ILC paths start at their first waypoint);
//! - ratio = sum of step lengths / length of the truth polyline;
//! - straight legs: consecutive truth points >= 5 m apart; the PDR yaw is the
//!   circular mean of the step yaws on the leg, compared with the leg's
//!   direction. Reported raw, after removing one constant offset per path
//!   (the circular mean of that path's leg errors), and after one global
//!   offset per dataset;
//! - engine error: the `pdr` engine (default tasks) started at the first truth
//!   point, fed the events from that point's time on, scored at every later
//!   truth point (the replay rule of `engine::replay`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use fpbp_core::engine::InitialPosition;
use fpbp_core::engine::replay::replay;
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::{LogEvent, TruthPoint};
use fpbp_core::geometry::wrap_angle;
use fpbp_core::pdr::{Pdr, PdrConfig, Step};
use fpbp_core::site::{GeoRef, Site, SiteSpec};
use fpbp_logs::{ReadOptions, read_all};

struct PathResult {
    name: String,
    steps: usize,
    duration_s: f64,
    truth_len_m: f64,
    walked_m: f64,
    /// Sum of z_pp^(1/4) over the steps (the walked distance at beta = 1).
    walked_beta1: f64,
    leg_err_rad: Vec<f64>,
    engine_err_m: Vec<f64>,
    /// Steps of the whole log, and those headed by the screen normal.
    all_steps: u64,
    upright_steps: u64,
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let mut root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets");
    let mut cfg = PdrConfig::default();
    let mut only: Option<String> = None;
    let mut per_path = false;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--config" => {
                let text = args.next().context("--config needs a JSON value")?;
                cfg = serde_json::from_str(&text).context("--config")?;
                cfg.validate()?;
            }
            "--only" => only = Some(args.next().context("--only needs ilc or ipin")?),
            "--per-path" => per_path = true,
            other if !other.starts_with("--") => root = PathBuf::from(other),
            other => bail!("unknown option {other}"),
        }
    }
    if !root.is_dir() {
        println!("skipped: {} not found", root.display());
        return Ok(());
    }
    println!("config: {}", serde_json::to_string(&cfg)?);
    let mut ilc_all = Vec::new();
    if only.as_deref() != Some("ipin") {
        for floor in ["ilc/site2/F4", "ilc/site1/F1"] {
            let dir = root.join(floor).join("path_data_files");
            let res = run_dir(&dir, &cfg, None, per_path)?;
            summarise(floor, &res, &cfg);
            ilc_all.extend(res);
        }
        let b1: Vec<f64> = ilc_all
            .iter()
            .map(|r| r.walked_beta1 / r.truth_len_m)
            .collect();
        println!(
            "ILC both floors: beta giving a pooled median ratio of 1: {:.4}",
            1.0 / median(&b1)
        );
    }
    if only.as_deref() != Some("ilc") {
        // IPIN: lat/lon truth into a local ENU frame at the .cal centre
        // (datasets/README.md "Map georeference"); distances and directions only.
        let georef = GeoRef {
            lat_deg: 49.46115181,
            lon_deg: 11.11114911,
            x_m: 0.0,
            y_m: 0.0,
        };
        let res = run_dir(&root.join("ipin2023/logs"), &cfg, Some(georef), per_path)?;
        summarise("ipin2023 training", &res, &cfg);
    }
    Ok(())
}

fn run_dir(
    dir: &Path,
    cfg: &PdrConfig,
    georef: Option<GeoRef>,
    per_path: bool,
) -> Result<Vec<PathResult>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| dir.display().to_string())?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".txt.gz"))
        .collect();
    files.sort();
    let mut out = Vec::new();
    for f in &files {
        let opts = ReadOptions {
            site_georef: georef.map(|g| (g, 0.0)),
            default_floor: Some(0),
            ..ReadOptions::default()
        };
        let (events, _report) = read_all(f, &opts).with_context(|| f.display().to_string())?;
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        match measure(&name, &events, cfg)? {
            Some(r) => {
                if per_path {
                    println!(
                        "  {:<48} steps {:>4} ({:.2}/s) ratio {:.3} legs {:>2} engine mean {:.1} m",
                        r.name,
                        r.steps,
                        r.steps as f64 / r.duration_s.max(1e-9),
                        r.walked_m / r.truth_len_m,
                        r.leg_err_rad.len(),
                        mean(&r.engine_err_m)
                    );
                }
                out.push(r)
            }
            None => println!("  {name}: fewer than 2 truth points or zero-length truth, skipped"),
        }
    }
    Ok(out)
}

fn measure(name: &str, events: &[LogEvent], cfg: &PdrConfig) -> Result<Option<PathResult>> {
    let truth: Vec<TruthPoint> = events
        .iter()
        .filter_map(LogEvent::as_truth)
        .copied()
        .collect();
    let truth_len_m: f64 = truth
        .windows(2)
        .map(|w| (w[1].x_m - w[0].x_m).hypot(w[1].y_m - w[0].y_m))
        .sum();
    if truth.len() < 2 || truth_len_m <= 0.0 {
        return Ok(None);
    }
    let (t0, t1) = (truth[0].t_ns, truth[truth.len() - 1].t_ns);

    // PDR over the whole log (orientation warm-up), steps kept in [t0, t1].
    let mut pdr = Pdr::new(cfg, 0.0);
    let mut steps: Vec<Step> = Vec::new();
    for e in events {
        if let LogEvent::Sensor(s) = e {
            pdr.on_sensor(s);
            steps.extend(pdr.take_steps());
        }
    }
    steps.retain(|s| s.t_ns >= t0 && s.t_ns <= t1);
    let walked_m: f64 = steps.iter().map(|s| s.length_m).sum();
    let walked_beta1: f64 = steps.iter().map(|s| s.z_pp.max(0.0).powf(0.25)).sum();

    // Heading on straight legs.
    let mut leg_err_rad = Vec::new();
    for w in truth.windows(2) {
        let (dx, dy) = (w[1].x_m - w[0].x_m, w[1].y_m - w[0].y_m);
        if dx.hypot(dy) < 5.0 {
            continue;
        }
        let yaws: Vec<f64> = steps
            .iter()
            .filter(|s| s.t_ns >= w[0].t_ns && s.t_ns <= w[1].t_ns)
            .map(|s| s.yaw_rad)
            .collect();
        if yaws.len() < 3 {
            continue;
        }
        leg_err_rad.push(wrap_angle(circular_mean(&yaws) - dy.atan2(dx)));
    }

    // The pdr engine from the first truth point.
    let spec: SiteSpec = serde_json::from_str(
        r#"{"format":"fpbp-site","version":1,"name":"pdr_stats","floors":[{"id":0,"open_area_m":[1000,1000]}]}"#,
    )?;
    let site = Arc::new(Site {
        spec,
        floors: Vec::new(),
    });
    let config = EngineConfig {
        pdr: cfg.clone(),
        ..EngineConfig::default()
    };
    let init = InitialPosition {
        x_m: truth[0].x_m,
        y_m: truth[0].y_m,
        floor: 0,
        heading_rad: None,
    };
    let mut engine = build_engine("pdr", site, &config, Some(init))?;
    let out = replay(
        engine.as_mut(),
        events.iter().filter(|e| e.t_ns() >= t0).cloned(),
    );
    let engine_err_m: Vec<f64> = out
        .scored
        .iter()
        .skip(1)
        .filter_map(|s| s.error_m())
        .collect();

    Ok(Some(PathResult {
        name: name.to_string(),
        steps: steps.len(),
        duration_s: (t1 - t0) as f64 * 1e-9,
        truth_len_m,
        walked_m,
        walked_beta1,
        leg_err_rad,
        engine_err_m,
        all_steps: pdr.stats().steps,
        upright_steps: pdr.stats().upright_steps,
    }))
}

fn summarise(label: &str, res: &[PathResult], cfg: &PdrConfig) {
    if res.is_empty() {
        println!("{label}: no paths");
        return;
    }
    let steps: Vec<f64> = res.iter().map(|r| r.steps as f64).collect();
    let rate: Vec<f64> = res
        .iter()
        .map(|r| r.steps as f64 / r.duration_s.max(1e-9))
        .collect();
    let ratio: Vec<f64> = res.iter().map(|r| r.walked_m / r.truth_len_m).collect();
    let b1: Vec<f64> = res.iter().map(|r| r.walked_beta1 / r.truth_len_m).collect();
    let (q1, q2, q3) = quartiles(&ratio);
    println!(
        "== {label}: {} paths, beta {}",
        res.len(),
        cfg.step_length_beta
    );
    println!(
        "  steps per path: median {:.0} (min {:.0}, max {:.0}, total {:.0}); steps/s median {:.2} (IQR {:.2}-{:.2})",
        median(&steps),
        steps.iter().cloned().fold(f64::INFINITY, f64::min),
        steps.iter().cloned().fold(0.0, f64::max),
        steps.iter().sum::<f64>(),
        median(&rate),
        quartiles(&rate).0,
        quartiles(&rate).2
    );
    println!(
        "  walked-distance ratio: median {q2:.3}, IQR {q1:.3}-{q3:.3} (width {:.3}); beta for median 1 on this set: {:.4}",
        q3 - q1,
        1.0 / median(&b1)
    );
    let raw: Vec<f64> = res
        .iter()
        .flat_map(|r| r.leg_err_rad.iter().cloned())
        .collect();
    if !raw.is_empty() {
        let global = circular_mean(&raw);
        let per_path: Vec<f64> = res
            .iter()
            .filter(|r| !r.leg_err_rad.is_empty())
            .flat_map(|r| {
                let off = circular_mean(&r.leg_err_rad);
                r.leg_err_rad.iter().map(move |e| wrap_angle(e - off))
            })
            .collect();
        let deg = |v: &[f64]| -> Vec<f64> { v.iter().map(|e| e.abs().to_degrees()).collect() };
        let g: Vec<f64> = raw.iter().map(|e| wrap_angle(e - global)).collect();
        println!(
            "  heading error on {} straight legs (|err|, deg): raw median {:.1} p80 {:.1}; global offset {:.1} removed: median {:.1} p80 {:.1}; per-path offset removed: median {:.1} p80 {:.1}",
            raw.len(),
            median(&deg(&raw)),
            percentile(&deg(&raw), 0.8),
            global.to_degrees(),
            median(&deg(&g)),
            percentile(&deg(&g), 0.8),
            median(&deg(&per_path)),
            percentile(&deg(&per_path), 0.8)
        );
    }
    let all: u64 = res.iter().map(|r| r.all_steps).sum();
    let upright: u64 = res.iter().map(|r| r.upright_steps).sum();
    println!(
        "  forward axis {:?}: {upright} of {all} steps (whole logs) headed by the screen normal, in {} paths",
        cfg.forward_axis,
        res.iter().filter(|r| r.upright_steps > 0).count()
    );
    let e: Vec<f64> = res
        .iter()
        .flat_map(|r| r.engine_err_m.iter().cloned())
        .collect();
    if !e.is_empty() {
        println!(
            "  pdr engine error at {} truth points (after the start): mean {:.2} m, p50 {:.2} m, p80 {:.2} m, max {:.1} m",
            e.len(),
            mean(&e),
            median(&e),
            percentile(&e, 0.8),
            e.iter().cloned().fold(0.0, f64::max)
        );
    }
}

fn circular_mean(a: &[f64]) -> f64 {
    let (s, c) = a
        .iter()
        .fold((0.0, 0.0), |(s, c), x| (s + x.sin(), c + x.cos()));
    s.atan2(c)
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Linear-interpolated percentile, `q` in [0, 1].
fn percentile(v: &[f64], q: f64) -> f64 {
    let s: Vec<f64> = v.iter().cloned().filter(|x| x.is_finite()).collect();
    fpbp_core::stats::quantile(&s, q).unwrap_or(f64::NAN)
}

fn median(v: &[f64]) -> f64 {
    percentile(v, 0.5)
}

fn quartiles(v: &[f64]) -> (f64, f64, f64) {
    (percentile(v, 0.25), percentile(v, 0.5), percentile(v, 0.75))
}
