//! `fpbp calibrate --radio-map`: the radio map learned from the survey logs
//! (`fpbp_core::radio::radio_map`), and loading a map file for `eval` and
//! `replay --radio-map`. File glue only.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result};
use fpbp_core::events::LogEvent;
use fpbp_core::radio::map_calibration::{
    DEFAULT_EDGES_M, SurveyFootprint, check_calibration, format_table,
};
use fpbp_core::radio::model::TxKind;
use fpbp_core::radio::radio_map::{RadioMapBuilder, RadioMapConfig};
use fpbp_core::radio::reference_scans::{ReferenceScanConfig, ReferenceScans, ScanMetric};
use fpbp_core::radio::walk_offsets;
use fpbp_core::radio::{RadioMap, RadioModel};
use fpbp_core::site::Site;

/// Builds the map of `logs` (each log's path and events) on `site` (its
/// beacons and APs are the fallback), writes it to `out` (and the
/// per-transmitter report to `report`), prints a summary; with
/// `check_logs` (held-out logs with truth), prints the map's spread
/// calibration on them (`fpbp_core::radio::map_calibration`).
pub fn build(
    site: &Site,
    logs: Vec<(PathBuf, Vec<LogEvent>, Option<String>)>,
    config: Option<&Path>,
    out: &Path,
    report: Option<&Path>,
    check_logs: &[Vec<LogEvent>],
) -> Result<()> {
    let cfg = match config {
        None => RadioMapConfig::default(),
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            serde_json::from_str(&text)
                .with_context(|| format!("{}: radio map config", p.display()))?
        }
    };
    let mut b =
        RadioMapBuilder::new(site, &cfg)?.with_reference_scans(&ReferenceScanConfig::default())?;
    let opts = cfg.survey_options((site.spec.floors.len() == 1).then(|| site.default_floor()));
    let mut footprint = SurveyFootprint::default();
    let bar = crate::progress::bar(logs.len() as u64);
    for (l, events, device) in logs {
        if !check_logs.is_empty() {
            fpbp_core::radio::survey::survey_samples(&events, &opts, |s| {
                footprint.add(s.floor, s.pos)
            });
        }
        bar.set_message(format!("radio map: {}", l.display()));
        bar.inc(1);
        b.add_log_of(&events, device.as_deref());
    }
    bar.finish_and_clear();
    let (map, reports, s) = b.finish()?;
    let scans = map
        .reference_scans()
        .context("the radio map builder was given reference scans")?;
    println!(
        "reference scans: {} ({} transmitters; {} windows left out: too few transmitters or a floor change)",
        scans.scans().len(),
        scans.ids().len(),
        s.reference_scans_skipped
    );
    print_left_out(scans, &s.reference_scan_walks)?;
    print_survey_coverage(site, scans);
    let mut why: std::collections::BTreeMap<String, usize> = Default::default();
    for r in reports.iter().filter_map(|r| r.rejected.as_deref()) {
        let key = if r.contains("min_samples") {
            "too few readings"
        } else if r.contains("min_walks") {
            "heard on too few walks"
        } else if r.contains("moving") {
            "moving or carried"
        } else {
            r
        };
        *why.entry(key.to_string()).or_default() += 1;
    }
    println!(
        "radio map: {} logs, {} readings ({} placed, {} without truth, {} invalid, {} dropped); \
         {} transmitters surveyed, {} kept with grids ({} cells), {} from the site only",
        s.logs,
        s.readings,
        s.placed,
        s.without_truth,
        s.invalid,
        s.dropped,
        s.surveyed,
        s.kept,
        s.cells,
        s.site_only
    );
    for (k, n) in &why {
        println!("  left out: {n} x {k}");
    }
    println!(
        "magnetic map: {} magnetometer samples ({} placed), {} cells with a value",
        s.magnetic_samples, s.magnetic_placed, s.magnetic_cells
    );
    print_devices(map.device_offsets());
    if cfg.walk_offsets {
        let sd = |kind| {
            walk_offsets::spread_db(s.walk_offsets_db(kind))
                .map_or("-".to_string(), |d| format!("{d:.2} dB"))
        };
        println!(
            "walk offsets: {} walk-kind pairs with an offset; spread BLE {}, WiFi {}",
            s.walks_with_offset(),
            sd(TxKind::Ble),
            sd(TxKind::Wifi)
        );
    }
    for (kind, fit) in [("BLE", &s.ble_spread), ("WiFi", &s.wifi_spread)] {
        if let Some(f) = fit {
            let curve = f.curve.map_or("none (too few residuals)".to_string(), |c| {
                format!(
                    "sd(d) = sqrt({:.2}^2 + ({:.3} d)^2) dB",
                    c.s0_db, c.k_db_per_m
                )
            });
            let fb = f
                .fallback_sd_db
                .map_or("kept".to_string(), |v| format!("{v:.2} dB"));
            println!(
                "spread calibration {kind}: {curve} from {:.0} leave-one-walk-out readings; \
                 fallback spread {fb} ({:.0} readings beyond max_distance_m)",
                f.readings, f.far_readings
            );
        }
    }
    for (kind, fit) in [("BLE", &s.ble_wall_prior), ("WiFi", &s.wifi_wall_prior)] {
        if let Some(f) = fit {
            println!(
                "wall prior {kind}: {:.2} dB per wall, {:.2} dB per door; {} transmitters refitted \
                 on {} bins; RMS residual of the bins {:.2} dB from the site's path-loss models, \
                 {:.2} dB from the prior (in-sample)",
                f.loss.wall_db,
                f.loss.door_db,
                f.transmitters,
                f.bins,
                f.rms_site_db,
                f.rms_prior_db
            );
        }
    }
    if !check_logs.is_empty() {
        let held: Vec<&[LogEvent]> = check_logs.iter().map(Vec::as_slice).collect();
        let rep = check_calibration(&map, &footprint, &held, &opts, &DEFAULT_EDGES_M);
        println!(
            "spread check on {} held-out logs ({} readings placed, {} of transmitters the map lacks):",
            held.len(),
            rep.placed,
            rep.unknown_tx
        );
        print!("{}", format_table("raw", &rep.raw));
        print!("{}", format_table("offset-removed", &rep.offset_removed));
    }
    std::fs::write(out, map.to_json()?).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "wrote {} ({} transmitters)",
        out.display(),
        map.transmitters().len()
    );
    if let Some(r) = report {
        std::fs::write(r, serde_json::to_string_pretty(&reports)?)
            .with_context(|| format!("writing {}", r.display()))?;
    }
    Ok(())
}

/// Per floor, the share of the walkable area within 2 m, 2-5 m, 5-10 m
/// and 10 m or more of the reference scans (`fpbp map check --radio-map`
/// draws it; docs/survey.md "Checking the coverage").
fn print_survey_coverage(site: &Site, scans: &fpbp_core::radio::reference_scans::ReferenceScans) {
    use fpbp_core::map::survey_coverage::SurveyCoverage;
    for (fs, map) in site.spec.floors.iter().zip(&site.floors) {
        let pts: Vec<fpbp_core::Vec2> = scans
            .scans()
            .iter()
            .filter(|s| s.floor == fs.id)
            .map(|s| fpbp_core::Vec2::new(s.x_m, s.y_m))
            .collect();
        let sh = SurveyCoverage::of(map, &pts).shares().map(|x| 100.0 * x);
        println!(
            "survey coverage, floor {}: {:.1} % of the walkable area within 2 m of the survey, \
             {:.1} % 2-5 m, {:.1} % 5-10 m, {:.1} % 10 m or more",
            fs.id, sh[0], sh[1], sh[2], sh[3]
        );
    }
}

/// Reads and resolves a radio map file against `site`; errors name the file.
pub fn load(path: &Path, site: &Site) -> Result<Arc<RadioMap>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let map = RadioMap::from_json(&text, site).with_context(|| format!("{}", path.display()))?;
    Ok(Arc::new(map))
}

/// At most this many survey scans (evenly spread) are read against the
/// other walks' scans: the cost grows with their number times the set's.
pub const LEFT_OUT_SCANS: usize = 5000;

/// The survey's phone models and their offsets per radio.
fn print_devices(d: &fpbp_core::radio::device_offsets::DeviceOffsets) {
    if d.is_empty() {
        return;
    }
    let db = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:+.1} dB"));
    let list: Vec<String> = d
        .iter()
        .map(|(name, o)| {
            format!(
                "{name} ({} walks): BLE {}, WiFi {}",
                o.walks,
                db(o.ble_db),
                db(o.wifi_db)
            )
        })
        .collect();
    println!(
        "phone models of the survey, offsets from the map's level: {}",
        list.join("; ")
    );
}

/// The survey scans read against the other walks' scans (leave one walk
/// out, ranked as `tcpf`'s anchors rank by default), by how far the
/// nearest other walk passed: the distance a phone on the survey's lines
/// reads from the survey, and off them (docs/survey.md "Checking the
/// coverage").
fn print_left_out(scans: &ReferenceScans, walk_of: &[usize]) -> Result<()> {
    if scans.is_empty() {
        return Ok(());
    }
    let t0 = std::time::Instant::now();
    let every = scans.scans().len().div_ceil(LEFT_OUT_SCANS).max(1);
    let left_out = scans.left_out_distances(walk_of, ScanMetric::BrayCurtisPowed, every)?;
    println!(
        "survey scans against the other walks' (leave one walk out; {} scans in {:.1} s), RMS dB:",
        left_out.len(),
        t0.elapsed().as_secs_f64()
    );
    let band = |gap_m: f64| usize::from(gap_m >= 3.0) + usize::from(gap_m >= 10.0);
    for (b, name) in ["another walk within 3 m", "3-10 m", "none within 10 m"]
        .iter()
        .enumerate()
    {
        let mut d: Vec<f64> = left_out
            .iter()
            .filter(|l| band(l.gap_m) == b)
            .map(|l| l.dist_db)
            .collect();
        d.sort_by(f64::total_cmp);
        let q = |p| crate::metrics::percentile(&d, p).map_or("-".into(), |v| format!("{v:.1}"));
        println!(
            "  {name}: {} scans, median {}, p90 {}, p95 {}",
            d.len(),
            q(50.0),
            q(90.0),
            q(95.0)
        );
    }
    Ok(())
}
