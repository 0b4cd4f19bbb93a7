//! Engine `tcpf` on the synthetic walled site of the prox-pf tests: own
//! start, the phone offset, recovery from a wrong start, walls,
//! determinism, set_position.

use super::*;
use crate::engine::build_engine;
use crate::engine::replay::{ReplayOutput, replay};
use crate::engines::prox_pf::testkit::{MODEL, beacons, site, walk_north, walled_map};
use crate::events::LogEvent;

fn run(events: &[LogEvent], init: Option<InitialPosition>, cfg: &EngineConfig) -> ReplayOutput {
    let mut e = build_engine("tcpf", site(), cfg, init).unwrap();
    replay(e.as_mut(), events.iter().cloned())
}

fn mean_error(out: &ReplayOutput) -> f64 {
    let e: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
    assert!(!e.is_empty(), "no scored pose");
    e.iter().sum::<f64>() / e.len() as f64
}

/// Model RSSI shifted by `offset` dB with a deterministic +-3 dB ripple.
fn biased(offset: f64) -> impl Fn(usize, f64) -> f64 {
    move |k, t| {
        let p = Vec2::new(7.0, 4.0 + 1.8 * 0.616 * t);
        let b = beacons()[k];
        let d = crate::ble::pathloss::range_m(p, b, 0.0, 0.5);
        MODEL.rssi_at(d, 0.5) + offset + 3.0 * ((k as f64 * 1.7 + t * 2.3).sin())
    }
}

#[test]
fn finds_its_own_start_from_the_first_scan_and_tracks() {
    let ev = walk_north(20, None);
    let out = run(&ev, None, &EngineConfig::default());
    let first = out.track.first().expect("a pose");
    assert!(
        first.t_ns <= 1_500_000_000,
        "first pose at {} ns",
        first.t_ns
    );
    assert!(first.accuracy_m >= 1.0);
    // the beacons stand on one line (x = 5) and the walk runs 2 m beside
    // it: the radio cannot tell x = 7 from its mirror x = 3, so the cloud
    // straddles the line and the error settles near 2 m
    let err = mean_error(&out);
    assert!(err < 2.6, "mean error {err:.2} m");
    assert!(out.scored.iter().skip(1).all(|s| s.error_m().is_some()));
}

#[test]
fn learns_a_phone_offset_and_reports_it() {
    let f = biased(-9.0);
    let ev = walk_north(30, Some(&f));
    let out = run(&ev, None, &EngineConfig::default());
    let o = out.stats.rssi_offset_db.expect("tcpf reports its offset");
    assert!((o + 9.0).abs() < 2.5, "offset {o:.2} dB");
    let err = mean_error(&out);
    assert!(err < 4.5, "mean error {err:.2} m");
    let mut cfg = EngineConfig::default();
    cfg.tcpf.offset.enabled = false;
    let fixed = run(&ev, None, &cfg);
    assert_eq!(fixed.stats.rssi_offset_db, Some(0.0));
}

#[test]
fn recovers_from_a_wrong_start_in_the_other_room() {
    // told it starts behind the wall at (15, 33): radio says x = 7, y from
    // 4; walking north, the wrong cloud soon runs into the floor's north
    // edge (the walls say it is lost), the radio shows where to re-seed.
    // (With heavy-tailed residuals the radio alone disagrees by only ~9
    // tempered log units here, below `recovery_radio_alone_margin`: a
    // kidnapped cloud whose steps fit the map is not recovered by the
    // radio alone; docs/tcpf.md.)
    let ev = walk_north(30, None);
    let init = Some(InitialPosition {
        x_m: 15.0,
        y_m: 33.0,
        floor: 0,
        heading_rad: None,
    });
    let out = run(&ev, init, &EngineConfig::default());
    let late: Vec<f64> = out
        .scored
        .iter()
        .filter(|s| s.truth.t_ns > 20_000_000_000)
        .filter_map(|s| s.error_m())
        .collect();
    assert!(!late.is_empty());
    let m = late.iter().sum::<f64>() / late.len() as f64;
    assert!(m < 3.0, "error after 20 s {m:.2} m");
}

#[test]
fn the_published_track_never_crosses_the_wall() {
    let map = walled_map();
    let ev = walk_north(30, Some(&biased(0.0)));
    for seed in 1..=3 {
        let cfg = EngineConfig {
            seed,
            ..Default::default()
        };
        let out = run(&ev, None, &cfg);
        for w in out.track.windows(2) {
            let (a, b) = (Vec2::new(w[0].x_m, w[0].y_m), Vec2::new(w[1].x_m, w[1].y_m));
            let crossed = map.crosses_wall(a, b, 0.05);
            // a jump after the hold is counted; none is expected here
            assert!(!crossed, "seed {seed}: {a:?} -> {b:?} crosses the wall");
        }
    }
}

#[test]
fn same_seed_same_track_other_seed_other_track() {
    let ev = walk_north(12, Some(&biased(-3.0)));
    let a = run(&ev, None, &EngineConfig::default());
    let b = run(&ev, None, &EngineConfig::default());
    assert_eq!(a.track, b.track);
    let c = run(
        &ev,
        None,
        &EngineConfig {
            seed: 7,
            ..Default::default()
        },
    );
    assert_ne!(a.track, c.track);
}

#[test]
fn set_position_moves_the_cloud_and_rejects_bad_points() {
    let s = site();
    let mut e = TcpfEngine::new(s, &EngineConfig::default(), None).unwrap();
    let at = InitialPosition {
        x_m: 6.0,
        y_m: 30.0,
        floor: 0,
        heading_rad: Some(1.0),
    };
    e.set_position(5, at).unwrap();
    let p = e.pose().unwrap();
    assert_eq!(p.t_ns, 5);
    assert!((p.x_m - 6.0).abs() < 1.0 && (p.y_m - 30.0).abs() < 1.0);
    assert!(
        e.set_position(6, InitialPosition { floor: 9, ..at })
            .is_err()
    );
    assert!(
        e.set_position(
            6,
            InitialPosition {
                x_m: f64::NAN,
                ..at
            }
        )
        .is_err()
    );
    // a tap on the wall line starts beside it
    e.set_position(7, InitialPosition { x_m: 10.2, ..at })
        .unwrap();
    let q = e.pose().unwrap();
    assert!(walled_map().is_walkable(Vec2::new(q.x_m, q.y_m)));
}

#[test]
fn config_errors_name_the_field() {
    let mut cfg = EngineConfig::default();
    cfg.tcpf.particle_count = 0;
    let e = build_engine("tcpf", site(), &cfg, None).err().unwrap();
    assert!(e.to_string().contains("tcpf.particle_count"), "{e}");
    let mut cfg = EngineConfig::default();
    cfg.tcpf.offset.prior_sd_db = f64::NAN;
    let e = build_engine("tcpf", site(), &cfg, None).err().unwrap();
    assert!(e.to_string().contains("tcpf.offset.prior_sd_db"), "{e}");
}
