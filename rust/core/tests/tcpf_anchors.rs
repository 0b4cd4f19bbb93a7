//! `tcpf` anchors on simulated walks of the demo site: a radio map with the
//! survey's reference scans (fingerprints) built from three survey walks,
//! then an unseen walk replayed with its own start. The reference scans
//! must survive the map's file, position an unseen walk, and keep the engine
//! deterministic; `scan-knn` must position from them alone.

mod common;

use std::sync::Arc;

use common::demo_site;
use fpbp_core::engine::replay::{ReplayOutput, replay};
use fpbp_core::engines::{EngineConfig, EngineData, build_engine_with};
use fpbp_core::events::LogEvent;
use fpbp_core::radio::RadioMap;
use fpbp_core::site::Site;
use fpbp_sim::{SimRequest, simulate};

/// The radio map of three simulated survey walks, with their reference scans.
fn surveyed_map(site: &Site) -> RadioMap {
    common::surveyed_map(site, &[41, 42, 43], <[LogEvent]>::to_vec)
}

fn run(site: &Arc<Site>, map: &Arc<RadioMap>, engine: &str, cfg: &EngineConfig) -> ReplayOutput {
    let log = simulate(site, &SimRequest::new(120.0, 7)).unwrap();
    let data = EngineData {
        radio_map: Some(map.clone()),
        ..Default::default()
    };
    let mut e = build_engine_with(engine, site.clone(), cfg, None, &data).unwrap();
    replay(e.as_mut(), log.events.iter().cloned())
}

fn mean_error(out: &ReplayOutput) -> (f64, usize) {
    let e: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
    (e.iter().sum::<f64>() / e.len().max(1) as f64, e.len())
}

#[test]
fn reference_scans_survive_the_file_and_position_a_walk() {
    let site = demo_site();
    let map = surveyed_map(&site);
    let scans = map.to_file().reference_scans.expect("scans in the file");
    assert!(scans.scans.len() > 300, "{} scans", scans.scans.len());
    // the file round trip keeps every scan
    let back = RadioMap::from_json(&map.to_json().unwrap(), &site).unwrap();
    assert_eq!(back.to_file(), map.to_file());
    let map = Arc::new(back);

    let cfg = EngineConfig::default();
    let knn = run(&site, &map, "scan-knn", &cfg);
    let (knn_err, knn_n) = mean_error(&knn);
    let on = run(&site, &map, "tcpf", &cfg);
    let (on_err, on_n) = mean_error(&on);
    let mut off_cfg = EngineConfig::default();
    off_cfg.tcpf.anchors.k = 0;
    let off = run(&site, &map, "tcpf", &off_cfg);
    let (off_err, _) = mean_error(&off);
    let first = |o: &ReplayOutput| o.scored.iter().find_map(|s| s.error_m()).unwrap();
    eprintln!(
        "demo walk: scan-knn {knn_err:.2} m ({knn_n} points), tcpf with anchors {on_err:.2} m \
         (first point {:.2} m), without {off_err:.2} m (first point {:.2} m)",
        first(&on),
        first(&off)
    );
    assert!(knn_n > 10 && on_n > 10);
    // the fingerprints alone position on a surveyed site
    assert!(knn_err < 6.0, "scan-knn {knn_err:.2} m");
    // and the anchored engine tracks better than they do alone
    assert!(
        on_err < knn_err,
        "tcpf {on_err:.2} m, scan-knn {knn_err:.2} m"
    );
    assert!(on_err < 4.0, "tcpf with anchors {on_err:.2} m");
    // same seed, same track
    let again = run(&site, &map, "tcpf", &cfg);
    assert_eq!(again.track, on.track);
}

#[test]
fn a_radio_map_version_1_file_still_reads() {
    let site = demo_site();
    let map = surveyed_map(&site);
    let mut file = map.to_file();
    file.version = 1;
    file.reference_scans = None;
    let text = serde_json::to_string(&file).unwrap();
    let back = RadioMap::from_json(&text, &site).unwrap();
    assert!(back.to_file().reference_scans.is_none());
    // a reference scan naming a floor the site lacks is refused by field
    let mut file = map.to_file();
    file.reference_scans.as_mut().unwrap().scans[2].floor = 99;
    let err = RadioMap::from_json(&serde_json::to_string(&file).unwrap(), &site)
        .unwrap_err()
        .to_string();
    assert!(err.contains("reference_scans.scans[2].floor"), "{err}");
}
