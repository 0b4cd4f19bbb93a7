//! Reads every real log in ../shared/datasets (when present) and checks the
//! counts against ../shared/datasets/README.md. Skips with a clear message when
//! the datasets are not there.

use std::path::Path;

use fpbp_core::site::GeoRef;
use fpbp_logs::{LogFormat, ReadOptions, ReadReport, open_log};

mod common;
use common::{datasets, gz_files};

fn read(path: &Path, opts: &ReadOptions) -> ReadReport {
    let mut r = open_log(path, opts).unwrap_or_else(|e| panic!("{e}"));
    let mut last = i64::MIN;
    while let Some(e) = r.try_next().unwrap_or_else(|e| panic!("{e}")) {
        assert!(e.t_ns() >= last, "{}: events out of order", path.display());
        last = e.t_ns();
    }
    r.report()
}

#[test]
fn every_ilc_trace_parses_with_expected_counts() {
    let Some(d) = datasets() else { return };
    // (floor dir, files, waypoints, total startTime->endTime duration s) from datasets/README.md.
    for (floor, n_files, n_waypoints, total_s) in [
        ("ilc/site2/F4", 26, 193, 925.0),
        ("ilc/site1/F1", 106, 742, 4175.0),
    ] {
        let files = gz_files(&d.join(floor).join("path_data_files"));
        assert_eq!(files.len(), n_files, "{floor}");
        let (mut truth, mut dur, mut backwards, mut late, mut ble) = (0, 0.0, 0, 0, 0);
        for f in &files {
            let rep = read(f, &ReadOptions::default());
            assert_eq!(rep.format, Some(LogFormat::Ilc));
            assert_eq!(rep.malformed_skipped, 0, "{:?}", rep.first_malformed);
            assert_eq!(rep.non_finite_dropped, 0, "{}", f.display());
            assert!(rep.io_error.is_none());
            assert!(
                rep.events.acc > 0
                    && rep.events.acc == rep.events.gyr
                    && rep.events.acc == rep.events.rot,
                "{}: {:?}",
                f.display(),
                rep.events
            );
            assert!(rep.events.truth >= 2, "{}", f.display());
            truth += rep.events.truth;
            dur += rep.duration_s();
            backwards += rep.backwards_timestamps;
            late += rep.late_dropped;
            ble += rep.events.ble;
        }
        println!(
            "{floor}: {} files, {truth} waypoints, {dur:.0} s, {ble} BLE events, {backwards} rows stepping back, {late} dropped as late",
            files.len()
        );
        assert_eq!(truth, n_waypoints, "{floor}");
        assert!(
            dur <= total_s + 1.0 && dur > 0.95 * total_s,
            "{floor}: {dur}"
        );
        assert_eq!(late, 0, "{floor}: rows later than the reorder window");
    }
}

/// (trial_repetition, POSI, BLE4 rows, PRES rows) from the table in datasets/README.md.
const IPIN_COUNTS: &[(&str, u64, u64, u64)] = &[
    ("01_repetition01", 14, 649, 1440),
    ("01_repetition02", 14, 742, 1233),
    ("01_repetition03", 14, 170, 2010),
    ("01_repetition04", 14, 195, 2064),
    ("02_repetition01", 12, 359, 1155),
    ("02_repetition02", 12, 354, 1188),
    ("02_repetition03", 12, 135, 1923),
    ("02_repetition04", 12, 115, 1943),
    ("03_repetition01", 14, 1114, 1307),
    ("03_repetition02", 14, 1125, 1357),
    ("03_repetition03", 14, 491, 2231),
    ("03_repetition04", 14, 465, 2195),
    ("04_repetition01", 14, 570, 1004),
    ("04_repetition02", 14, 576, 1029),
    ("04_repetition03", 14, 404, 1682),
    ("04_repetition04", 14, 447, 1685),
    ("21_repetition01", 10, 203, 1492),
    ("21_repetition02", 10, 211, 1460),
    ("21_repetition03", 10, 527, 844),
    ("21_repetition04", 10, 495, 835),
    ("22_repetition01", 12, 923, 997),
    ("22_repetition02", 12, 1007, 1008),
    ("22_repetition03", 12, 307, 1530),
    ("22_repetition04", 12, 338, 1569),
    ("23_repetition01", 12, 1095, 914),
    ("23_repetition02", 12, 1052, 917),
    ("23_repetition03", 12, 438, 1427),
    ("23_repetition04", 12, 438, 1476),
    ("24_repetition01", 16, 1464, 1238),
    ("24_repetition02", 16, 1323, 1177),
    ("24_repetition03", 16, 571, 1918),
    ("24_repetition04", 16, 588, 1891),
    ("25_repetition01", 26, 1576, 1548),
    ("25_repetition02", 26, 1656, 1539),
    ("25_repetition03", 26, 606, 2533),
    ("25_repetition04", 26, 537, 2385),
    ("26_repetition01", 14, 154, 1656),
    ("26_repetition02", 14, 151, 1638),
    ("26_repetition03", 14, 696, 1122),
    ("26_repetition04", 14, 633, 1048),
    ("51_repetition02", 16, 619, 3016),
    ("52_repetition01", 12, 12, 2471),
];

#[test]
fn every_ipin_log_parses_with_expected_counts() {
    let Some(d) = datasets() else { return };
    let files = gz_files(&d.join("ipin2023/logs"));
    assert_eq!(files.len(), IPIN_COUNTS.len());
    // The .cal centre of the maps as georeference (any point works for counting).
    let georef = GeoRef {
        lat_deg: 49.46115181,
        lon_deg: 11.11114911,
        x_m: 0.0,
        y_m: 0.0,
    };
    let with_geo = ReadOptions {
        site_georef: Some((georef, 0.0)),
        ..Default::default()
    };
    let mut worst_ahrs = 0.0f64;
    for (f, &(tag, posi, ble4, pres)) in files.iter().zip(IPIN_COUNTS) {
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        assert!(name.contains(tag), "{name} vs {tag}");
        let rep = read(f, &with_geo);
        assert_eq!(rep.format, Some(LogFormat::Ipin));
        assert_eq!(rep.malformed_skipped, 0, "{:?}", rep.first_malformed);
        assert_eq!(rep.late_dropped, 0, "{name}");
        assert!(rep.io_error.is_none());
        assert_eq!(rep.events.truth, posi, "{name}: POSI");
        assert_eq!(
            rep.events.ble + rep.duplicates_dropped,
            ble4,
            "{name}: BLE4"
        );
        assert_eq!(rep.events.prs, pres, "{name}: PRES");
        assert!(
            rep.events.acc > 0 && rep.events.rot > 0 && rep.events.gnss > 0,
            "{name}"
        );
        worst_ahrs = worst_ahrs.max(rep.orientation_check_max_deg.unwrap_or(f64::INFINITY));
        // Without a georeference, POSI points are counted, not emitted.
        if tag.ends_with("01") {
            let rep = read(f, &ReadOptions::default());
            assert_eq!(rep.events.truth, 0);
            assert_eq!(rep.truth_without_georef, posi);
        }
    }
    println!(
        "ipin: {} logs, worst AHRS angle/quaternion disagreement {worst_ahrs:.3} deg",
        files.len()
    );
    assert!(worst_ahrs < 1.0, "AHRS convention: {worst_ahrs} deg");
}
