//! How a dead-reckoned track drifts from the truth, per log: the similarity
//! (scale and rotation about the start) that best maps the truth onto the
//! track, the RMS error before and after removing it, and the error per
//! metre walked. Run on `fpbp eval --engine pdr --init truth` outputs of
//! simulated and real logs, it tells whether the simulator's PDR errors are
//! as large as a real phone's (docs/sim.md, "PDR drift").
//!
//! Usage: cargo run --release -p fpbp-cli --example pdr_drift -- [--engine pdr]
//!        [--max-walked M] EVAL_DIR...
//!
//! `--max-walked M` keeps only each log's first M metres (along the truth),
//! so that long simulated walks compare with short real paths.
//!
//! For each log of each EVAL_DIR/points.csv (points with an estimate only):
//! t_k = truth_k - truth_0 and e_k = est_k - est_0 as complex numbers; the
//! least-squares a = sum(conj(t) e) / sum(|t|^2) gives scale |a| and
//! rotation arg(a). Logs whose truth stays within 5 m RMS of the start are
//! skipped (no direction to fit). Error per metre walked: error_k / walked_k
//! for points more than 5 m along the truth polyline.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

struct Point {
    truth: (f64, f64),
    est: (f64, f64),
    error_m: f64,
}

struct Fit {
    scale: f64,
    angle_deg: f64,
    rms_raw_m: f64,
    rms_fitted_m: f64,
    walked_m: f64,
}

fn quantile(v: &[f64], q: f64) -> f64 {
    fpbp_core::stats::quantile(v, q).unwrap_or(f64::NAN)
}

fn fit(points: &[Point]) -> Option<Fit> {
    let (t0, e0) = (points.first()?.truth, points.first()?.est);
    let (mut num_re, mut num_im, mut den) = (0.0, 0.0, 0.0);
    for p in points {
        let (tx, ty) = (p.truth.0 - t0.0, p.truth.1 - t0.1);
        let (ex, ey) = (p.est.0 - e0.0, p.est.1 - e0.1);
        // conj(t) * e
        num_re += tx * ex + ty * ey;
        num_im += tx * ey - ty * ex;
        den += tx * tx + ty * ty;
    }
    if den / (points.len() as f64) < 25.0 {
        return None;
    }
    let (a_re, a_im) = (num_re / den, num_im / den);
    let (mut raw, mut fitted) = (0.0, 0.0);
    for p in points {
        let (tx, ty) = (p.truth.0 - t0.0, p.truth.1 - t0.1);
        let (ex, ey) = (p.est.0 - e0.0, p.est.1 - e0.1);
        raw += (ex - tx).powi(2) + (ey - ty).powi(2);
        let (fx, fy) = (a_re * tx - a_im * ty, a_re * ty + a_im * tx);
        fitted += (ex - fx).powi(2) + (ey - fy).powi(2);
    }
    let n = points.len() as f64;
    let walked_m = points
        .windows(2)
        .map(|w| (w[1].truth.0 - w[0].truth.0).hypot(w[1].truth.1 - w[0].truth.1))
        .sum();
    Some(Fit {
        scale: a_re.hypot(a_im),
        angle_deg: a_im.atan2(a_re).to_degrees(),
        rms_raw_m: (raw / n).sqrt(),
        rms_fitted_m: (fitted / n).sqrt(),
        walked_m,
    })
}

fn per_metre(points: &[Point]) -> Vec<f64> {
    let mut walked = 0.0;
    let mut out = Vec::new();
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            let q = &points[i - 1];
            walked += (p.truth.0 - q.truth.0).hypot(p.truth.1 - q.truth.1);
        }
        if walked > 5.0 {
            out.push(p.error_m / walked);
        }
    }
    out
}

fn first_metres(points: &mut Vec<Point>, max_walked_m: f64) {
    let mut walked = 0.0;
    let mut keep = points.len();
    for i in 1..points.len() {
        let (p, q) = (&points[i], &points[i - 1]);
        walked += (p.truth.0 - q.truth.0).hypot(p.truth.1 - q.truth.1);
        if walked > max_walked_m {
            keep = i;
            break;
        }
    }
    points.truncate(keep);
}

fn read_points(dir: &Path, engine: &str) -> Result<BTreeMap<String, Vec<Point>>> {
    let path = dir.join("points.csv");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .with_context(|| format!("{}: empty", path.display()))?
        .split(',')
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .with_context(|| format!("{}: no column `{name}`", path.display()))
    };
    let (c_engine, c_log) = (col("engine")?, col("log")?);
    let (c_tx, c_ty, c_ex, c_ey, c_err) = (
        col("truth_x_m")?,
        col("truth_y_m")?,
        col("est_x_m")?,
        col("est_y_m")?,
        col("error_m")?,
    );
    let mut logs: BTreeMap<String, Vec<Point>> = BTreeMap::new();
    for (i, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != header.len() {
            bail!(
                "{}:{}: {} fields, header has {}",
                path.display(),
                i + 2,
                f.len(),
                header.len()
            );
        }
        if f[c_engine] != engine {
            continue;
        }
        let num = |c: usize| f[c].parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(tx), Some(ty), Some(ex), Some(ey), Some(err)) =
            (num(c_tx), num(c_ty), num(c_ex), num(c_ey), num(c_err))
        else {
            continue;
        };
        logs.entry(f[c_log].to_string()).or_default().push(Point {
            truth: (tx, ty),
            est: (ex, ey),
            error_m: err,
        });
    }
    Ok(logs)
}

fn main() -> Result<()> {
    let mut engine = "pdr".to_string();
    let mut max_walked_m = f64::INFINITY;
    let mut dirs = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--engine" => engine = args.next().context("--engine needs a value")?,
            "--max-walked" => {
                max_walked_m = args
                    .next()
                    .context("--max-walked needs metres")?
                    .parse()
                    .context("--max-walked: not a number")?
            }
            _ => dirs.push(PathBuf::from(a)),
        }
    }
    if dirs.is_empty() {
        bail!("usage: pdr_drift [--engine pdr] [--max-walked M] EVAL_DIR...");
    }
    println!(
        "{:<28} {:>4} {:>7} | {:>17} | {:>13} {:>8} | {:>7} {:>7} | {:>9}",
        "eval dir",
        "logs",
        "walked",
        "scale p10/50/90",
        "angle p50/p90",
        "angle sd",
        "rms raw",
        "fitted",
        "err/m p50"
    );
    for dir in &dirs {
        let mut logs = read_points(dir, &engine)?;
        for points in logs.values_mut() {
            first_metres(points, max_walked_m);
        }
        let fits: Vec<Fit> = logs.values().filter_map(|p| fit(p)).collect();
        if fits.is_empty() {
            println!(
                "{:<28} no log with a fit for engine {engine}",
                dir.display()
            );
            continue;
        }
        let col = |f: &dyn Fn(&Fit) -> f64| fits.iter().map(f).collect::<Vec<f64>>();
        let scale = col(&|f| f.scale);
        let abs_angle = col(&|f| f.angle_deg.abs());
        let angle_sd =
            (fits.iter().map(|f| f.angle_deg.powi(2)).sum::<f64>() / fits.len() as f64).sqrt();
        let per_m: Vec<f64> = logs.values().flat_map(|p| per_metre(p)).collect();
        println!(
            "{:<28} {:>4} {:>6.0}m | {:>5.2} {:>5.2} {:>5.2} | {:>6.1} {:>6.1} {:>8.1} | {:>7.2} {:>7.2} | {:>9.3}",
            dir.display().to_string(),
            fits.len(),
            quantile(&col(&|f| f.walked_m), 0.5),
            quantile(&scale, 0.1),
            quantile(&scale, 0.5),
            quantile(&scale, 0.9),
            quantile(&abs_angle, 0.5),
            quantile(&abs_angle, 0.9),
            angle_sd,
            quantile(&col(&|f| f.rms_raw_m), 0.5),
            quantile(&col(&|f| f.rms_fitted_m), 0.5),
            quantile(&per_m, 0.5),
        );
    }
    Ok(())
}
