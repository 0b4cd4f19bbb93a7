//! Golden tracks: every engine's published track on every shipped log
//! (host-tests/logs), pinned by a hash of the track written at full
//! precision, so a change shows which engines and logs it moves.
//!
//! Runs: each engine from its own start (`pdr` from the first truth point,
//! as `fpbp eval` does), each engine from the first truth point (`--init
//! truth`), and `tcpf` / `scan-knn` with a radio map calibrated on the even
//! logs (as `fpbp calibrate --split even --radio-map` writes it).
//!
//! The pinned hashes are in `tests/golden/tracks.tsv`. A change that moves a
//! track on purpose re-blesses them and says why in its commit:
//!
//!     FPBP_BLESS=1 cargo test --release -p fpbp-cli --test golden_tracks
//!
//! A failure lists every (engine, start, log) whose track changed, with the
//! pose count before and after.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

mod common;

use fpbp_core::engine::replay::Replayer;
use fpbp_core::engine::{InitialPosition, Pose};
use fpbp_core::engines::{ENGINE_NAMES, EngineConfig, EngineData, build_engine_with};
use fpbp_core::events::LogEvent;
use fpbp_core::site::Site;
use fpbp_logs::ReadOptions;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn golden_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/tracks.tsv")
}

fn shipped_logs() -> Vec<PathBuf> {
    let mut logs: Vec<PathBuf> = std::fs::read_dir(repo().join("host-tests/logs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".log.gz"))
        .collect();
    logs.sort();
    assert!(logs.len() >= 8, "shipped logs missing: {logs:?}");
    logs
}

/// FNV-1a, 64 bits: stable across Rust versions and platforms (std's
/// hasher is not).
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The track as text, every float in its shortest exact form.
fn track_text(track: &[Pose]) -> String {
    let mut s = String::new();
    for p in track {
        writeln!(
            s,
            "{},{:?},{:?},{},{:?},{:?},{:?},{:?}",
            p.t_ns, p.x_m, p.y_m, p.floor, p.heading_rad, p.accuracy_m, p.floor_prob, p.source
        )
        .unwrap();
    }
    s
}

/// Replays `events` through `engine`, started as `fpbp eval` starts it:
/// from the first truth point (replay after it) when `from_truth` or the
/// engine needs a start, else from the first event.
fn run(
    site: &Arc<Site>,
    engine: &str,
    events: &[LogEvent],
    from_truth: bool,
    data: &EngineData,
) -> Vec<Pose> {
    let (init, start) = if from_truth || engine == "pdr" {
        let (k, tp) = events
            .iter()
            .enumerate()
            .find_map(|(k, e)| Some((k, *e.as_truth()?)))
            .expect("shipped logs have truth");
        let init = InitialPosition {
            x_m: tp.x_m,
            y_m: tp.y_m,
            floor: tp.floor.unwrap_or_else(|| site.default_floor()),
            heading_rad: None,
        };
        (Some(init), k + 1)
    } else {
        (None, 0)
    };
    let mut e = build_engine_with(engine, site.clone(), &EngineConfig::default(), init, data)
        .unwrap_or_else(|err| panic!("engine {engine}: {err}"));
    let mut r = Replayer::new(e.as_mut());
    for ev in &events[start..] {
        r.push(ev);
    }
    r.finish().track
}

/// A radio map of the demo site calibrated on the even shipped logs.
fn radio_map(site: &Site, logs: &[PathBuf]) -> EngineData {
    let dir = std::env::temp_dir().join(format!("fpbp-golden-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let map = dir.join("radio-map.json");
    common::calibrate_demo(&dir, logs, "even");
    let text = std::fs::read_to_string(&map).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    EngineData::from_json(&text, site, &EngineConfig::default().ble).unwrap()
}

/// key (engine, start, log) -> "poses hash".
fn current() -> BTreeMap<String, String> {
    let site = fpbp_core::site::files::load_site(&repo().join("maps/demo/site.json")).unwrap();
    let logs = shipped_logs();
    let opts = ReadOptions {
        site_georef: site.spec.georef.map(|g| (g, site.spec.map_from_enu_rad)),
        default_floor: Some(site.default_floor()),
        ..ReadOptions::default()
    };
    let rm = radio_map(&site, &logs);
    let none = EngineData::default();
    let mut out = BTreeMap::new();
    for log in &logs {
        let name = log.file_name().unwrap().to_string_lossy().into_owned();
        let (events, _) = fpbp_logs::read_all(log, &opts).unwrap();
        let mut record = |engine: &str, start: &str, track: Vec<Pose>| {
            let key = format!("{engine}\t{start}\t{name}");
            let text = track_text(&track);
            let value = format!("{}\t{:016x}", track.len(), fnv1a(text.as_bytes()));
            out.insert(key, value);
        };
        for &engine in ENGINE_NAMES {
            if engine == "scan-knn" {
                continue; // needs a radio map: below
            }
            record(engine, "own", run(&site, engine, &events, false, &none));
            record(engine, "truth", run(&site, engine, &events, true, &none));
        }
        for engine in ["tcpf", "scan-knn"] {
            record(
                &format!("{engine}+radio-map"),
                "own",
                run(&site, engine, &events, false, &rm),
            );
            record(
                &format!("{engine}+radio-map"),
                "truth",
                run(&site, engine, &events, true, &rm),
            );
        }
    }
    out
}

fn parse(text: &str) -> BTreeMap<String, String> {
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(f.len(), 5, "golden line: {l}");
            (
                format!("{}\t{}\t{}", f[0], f[1], f[2]),
                format!("{}\t{}", f[3], f[4]),
            )
        })
        .collect()
}

#[test]
fn every_engine_track_on_the_shipped_logs_is_unchanged() {
    let now = current();
    if std::env::var_os("FPBP_BLESS").is_some() {
        let mut text = String::from(
            "# engine\tstart\tlog\tposes\tfnv1a-64 of the track (tests/golden_tracks.rs)\n",
        );
        for (k, v) in &now {
            writeln!(text, "{k}\t{v}").unwrap();
        }
        std::fs::create_dir_all(golden_file().parent().unwrap()).unwrap();
        std::fs::write(golden_file(), text).unwrap();
        eprintln!(
            "blessed {} tracks into {}",
            now.len(),
            golden_file().display()
        );
        return;
    }
    let pinned = parse(
        &std::fs::read_to_string(golden_file())
            .expect("tests/golden/tracks.tsv missing: run with FPBP_BLESS=1 once"),
    );
    let mut diffs = Vec::new();
    for (k, v) in &now {
        match pinned.get(k) {
            Some(p) if p == v => {}
            Some(p) => diffs.push(format!("changed  {k}: {p} -> {v}")),
            None => diffs.push(format!("new      {k}: {v}")),
        }
    }
    for k in pinned.keys().filter(|k| !now.contains_key(*k)) {
        diffs.push(format!("missing  {k}"));
    }
    assert!(
        diffs.is_empty(),
        "{} of {} golden tracks differ (re-bless with FPBP_BLESS=1 if on purpose, and say why in the commit):\n{}",
        diffs.len(),
        now.len(),
        diffs.join("\n")
    );
}

/// The hash tells tracks apart: a pose moved by a hundredth of a millimetre
/// changes it (guards against a hash of something that ignores the track).
#[test]
fn the_track_hash_sees_a_tiny_move() {
    let p = Pose {
        t_ns: 1,
        x_m: 1.0,
        y_m: 2.0,
        floor: 0,
        heading_rad: 0.0,
        accuracy_m: 1.0,
        floor_prob: 1.0,
        source: Default::default(),
    };
    let q = Pose {
        x_m: 1.000_000_01,
        ..p
    };
    assert_ne!(
        fnv1a(track_text(&[p]).as_bytes()),
        fnv1a(track_text(&[q]).as_bytes())
    );
}
