//! `fpbp calibrate --radio-map` end to end on a shipped log with truth:
//! the written radio map carries the survey's magnetic field (the maps of
//! docs/lab/tcpf-history.md "Stop 32" learned none from `calibrate`, which dropped the magnetometer
//! samples with the other sensors before building the map).

use std::path::{Path, PathBuf};

mod common;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn calibrate_writes_the_magnetic_section_of_a_survey_with_a_magnetometer() {
    let dir = std::env::temp_dir().join(format!("fpbp-calib-rm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let map = dir.join("radio-map.json");
    let logs = ["demo-walk-1.log.gz", "demo-walk-2.log.gz"]
        .map(|l| repo().join("host-tests/logs").join(l));
    let out = common::calibrate_demo(&dir, &logs, "all");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&map).unwrap()).unwrap();
    let magnetic = json
        .get("magnetic")
        .unwrap_or_else(|| panic!("no magnetic section; calibrate said:\n{stdout}"));
    assert_eq!(json["version"], 3, "a map with a magnetic section is v3");
    // the two walks' 6001 magnetometer samples each, placed on truth
    let line = stdout
        .lines()
        .find(|l| l.starts_with("magnetic map:"))
        .expect("calibrate prints the magnetic map's figures");
    let samples: usize = line
        .split_whitespace()
        .nth(2)
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert!(samples >= 12_000, "{line}");
    assert!(
        magnetic.to_string().len() > 100,
        "an empty magnetic section: {magnetic}"
    );
    // each walk's scans read against the other walk's: where the two
    // passed within 3 m of each other there are scans to read
    let near = stdout
        .lines()
        .skip_while(|l| !l.starts_with("survey scans against the other walks'"))
        .find(|l| l.trim_start().starts_with("another walk within 3 m:"))
        .unwrap_or_else(|| panic!("no leave-one-walk-out lines; calibrate said:\n{stdout}"));
    let scans: usize = near
        .split_whitespace()
        .nth(5)
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{near}"));
    assert!(scans > 0 && near.contains("median "), "{near}");
    std::fs::remove_dir_all(&dir).ok();
}
