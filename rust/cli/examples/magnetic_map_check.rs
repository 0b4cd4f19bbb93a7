//! Is the magnetic field's magnitude a usable map signal on a real floor?
//! A feasibility check, not an engine: it reads ILC traces with truth
//! (default ../shared/datasets/ilc/site1/F1), places every calibrated
//! magnetometer sample (TYPE_MAGNETIC_FIELD, |B| in uT) on the straight line
//! between the two truth points around it, as `fpbp calibrate --radio-map`
//! does (`fpbp_core::radio::survey::magnetic_samples`: pairs more than 20 s
//! apart are skipped), and bins the samples in square cells. It prints:
//! - within one cell, the spread of the per-walk mean |B| across the walks
//!   that crossed it (median over cells with at least 2 walks), against the
//!   spread of the cell means over the floor: how repeatable the field is
//!   across walkers and phones, against how much it varies from place to
//!   place;
//! - held out: a map of the cell means from the even-indexed traces (name
//!   order, cells with at least 5 samples), and the residuals |B| - map of
//!   every 10th sample of the odd traces at their true cell and at a cell
//!   `d` metres away (direction: the golden angle times the residual's
//!   index, so the directions cover the circle evenly): how far apart two
//!   places must be for one sample to tell them apart.
//!
//! Usage: cargo run --release -p fpbp-cli --example magnetic_map_check --
//!        [TRACE_DIR] [--cell M]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use fpbp_core::radio::RadioMapConfig;
use fpbp_core::radio::survey::magnetic_samples;
use fpbp_logs::{ReadOptions, read_all};

/// Samples of one trace: (x m, y m, |B| uT).
type Samples = Vec<(f64, f64, f64)>;

fn placed_samples(path: &Path) -> Result<Samples> {
    let opts = ReadOptions {
        default_floor: Some(0),
        ..ReadOptions::default()
    };
    let (events, _) = read_all(path, &opts).with_context(|| format!("{}", path.display()))?;
    // placed as `fpbp calibrate --radio-map` places them
    let mut out = Vec::new();
    magnetic_samples(
        &events,
        &RadioMapConfig::default().survey_options(Some(0)),
        |_, p, ut| out.push((p.x, p.y, ut)),
    );
    Ok(out)
}

fn median(v: &[f64]) -> f64 {
    fpbp_core::stats::median(v).unwrap_or(f64::NAN)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn sd(v: &[f64]) -> f64 {
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

fn main() -> Result<()> {
    let mut dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ilc/site1/F1/path_data_files");
    let mut cell_m = 2.0;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--cell" => cell_m = args.next().context("--cell needs metres")?.parse()?,
            _ => dir = PathBuf::from(a),
        }
    }
    if !(0.1..=50.0).contains(&cell_m) {
        bail!("--cell {cell_m}: expected 0.1-50 m");
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("{}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".txt.gz"))
        .collect();
    files.sort();
    let walks: Vec<Samples> = files
        .iter()
        .map(|f| placed_samples(f))
        .collect::<Result<_>>()?;
    let key = |x: f64, y: f64| ((x / cell_m).floor() as i64, (y / cell_m).floor() as i64);

    // repeatability: per cell, the per-walk means
    let mut cells: BTreeMap<(i64, i64), BTreeMap<usize, Vec<f64>>> = BTreeMap::new();
    for (w, s) in walks.iter().enumerate() {
        for &(x, y, b) in s {
            cells
                .entry(key(x, y))
                .or_default()
                .entry(w)
                .or_default()
                .push(b);
        }
    }
    let (mut within, mut means) = (Vec::new(), Vec::new());
    for per_walk in cells.values().filter(|c| c.len() >= 2) {
        let m: Vec<f64> = per_walk.values().map(|v| mean(v)).collect();
        within.push(sd(&m));
        means.push(mean(&m));
    }
    let n: usize = walks.iter().map(Vec::len).sum();
    println!(
        "{}: {} traces, {n} placed samples, {cell_m} m cells",
        dir.display(),
        walks.len()
    );
    if within.is_empty() {
        bail!("no cell was crossed by two walks");
    }
    println!(
        "cells crossed by >= 2 walks: {}; spread of the walks' mean |B| within a cell (median): {:.2} uT; spread of the cell means over the floor: {:.2} uT",
        within.len(),
        median(&within),
        sd(&means)
    );

    // held out: even traces make the map, odd traces are scored
    let mut map: BTreeMap<(i64, i64), Vec<f64>> = BTreeMap::new();
    for s in walks.iter().step_by(2) {
        for &(x, y, b) in s {
            map.entry(key(x, y)).or_default().push(b);
        }
    }
    let map: BTreeMap<(i64, i64), f64> = map
        .into_iter()
        .filter(|(_, v)| v.len() >= 5)
        .map(|(k, v)| (k, mean(&v)))
        .collect();
    println!("held out (map: even traces; scored: every 10th sample of the odd traces)");
    for shift in [0.0, 2.0, 4.0, 6.0, 10.0] {
        let (mut res, mut turn) = (Vec::new(), 0u64);
        for s in walks.iter().skip(1).step_by(2) {
            for &(x, y, b) in s.iter().step_by(10) {
                // the golden angle: evenly spread directions, no RNG
                let a = turn as f64 * 2.399_963_229_728_653;
                turn += 1;
                let k = key(x + shift * a.cos(), y + shift * a.sin());
                if let Some(m) = map.get(&k) {
                    res.push(b - m);
                }
            }
        }
        if res.is_empty() {
            continue;
        }
        let rms = (res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64).sqrt();
        let abs: Vec<f64> = res.iter().map(|r| r.abs()).collect();
        println!(
            "  {shift:>4} m from the true position: {} residuals, median |r| {:.2} uT, RMS {:.2} uT",
            res.len(),
            median(&abs),
            rms
        );
    }
    Ok(())
}
