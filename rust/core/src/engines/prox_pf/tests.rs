//! Tests of `prox-pf`: moves against walls, the proximity gain, the
//! restart, whole walks.

use super::testkit::*;
use super::*;
use crate::ble::pathloss::PathLoss;
use crate::engine::replay::{ReplayOutput, replay};
use crate::engines::build_engine;
use crate::events::LogEvent;
use crate::map::{Feature, FloorMap};

fn near_beacon(x: f64, y: f64) -> FilteredBeacon {
    FilteredBeacon {
        index: 0,
        floor: 0,
        pos: Vec2::new(x, y),
        dz_m: 0.0,
        model: PathLoss {
            rssi_1m_dbm: -59.0,
            exponent: 2.0,
        },
        rssi_dbm: -65.0,
        var_dbm2: 1.0,
        samples: 3,
        last_t_ns: 0,
    }
}

#[test]
fn a_move_into_a_wall_stops_just_before_it() {
    let map = walled_map();
    let (q, blocked) = move_with_map(&map, Vec2::new(9.0, 5.0), Vec2::new(2.0, 0.0), 0.05);
    assert!(blocked);
    assert!(q.x < 10.0 && q.x > 9.8 && map.is_walkable(q), "{q:?}");
    assert!((q.y - 5.0).abs() < 1e-12);
    let (q, blocked) = move_with_map(&map, Vec2::new(5.0, 5.0), Vec2::new(0.5, 0.6), 0.05);
    assert!(!blocked);
    assert!((q - Vec2::new(5.5, 5.6)).norm() < 1e-12);
    // a door is enterable: no stop, no penalty
    let mut f = vec![Feature::Walkable; 40 * 80];
    for j in 0..80 {
        f[j * 40 + 20] = Feature::Door;
    }
    let doors = FloorMap::from_features(40, 80, 2.0, f);
    let (q, blocked) = move_with_map(&doors, Vec2::new(9.5, 5.0), Vec2::new(1.0, 0.0), 0.05);
    assert!(!blocked && (q - Vec2::new(10.5, 5.0)).norm() < 1e-12);
    // non-finite move: stays
    let (q, blocked) = move_with_map(&map, Vec2::new(5.0, 5.0), Vec2::new(f64::NAN, 0.0), 0.05);
    assert!(!blocked && q == Vec2::new(5.0, 5.0));
}

#[test]
fn wall_penalty_lowers_the_weight_and_clamps_at_zero() {
    // a particle pushed into the wall on every step loses 5 per step; w >= 0
    let cfg = ProxPfConfig::default();
    let map = walled_map();
    let mut w = 7.0;
    let mut p = Vec2::new(9.7, 5.0);
    let mut hits = 0;
    for _ in 0..3 {
        let (q, blocked) = move_with_map(&map, p, Vec2::new(0.65, 0.0), cfg.raycast_step_m);
        p = q;
        let dw = if blocked { cfg.wall_penalty } else { 0.0 };
        hits += usize::from(blocked);
        w = f64::max(w + dw, 0.0);
    }
    assert_eq!(hits, 3);
    assert_eq!(w, 0.0);
    assert!(p.x < 10.0);
}

#[test]
fn proximity_gain_follows_eq_5_and_the_wall_rule() {
    let cfg = ProxPfConfig::default();
    let map = walled_map();
    let b = [near_beacon(12.0, 5.0)];
    // same room, 1.5 m away: P(1.5)
    let g = proximity_gain(Some(&map), Vec2::new(12.0, 6.5), &b, &cfg);
    assert!((g - (1.1077 - 0.3053 * 1.5)).abs() < 1e-12, "{g}");
    // 3 m away across the wall: 0 with the rule, P(3) without
    let p = Vec2::new(9.0, 5.0);
    assert_eq!(proximity_gain(Some(&map), p, &b, &cfg), 0.0);
    let off = ProxPfConfig {
        wall_rule: false,
        ..ProxPfConfig::default()
    };
    let g = proximity_gain(Some(&map), p, &b, &off);
    assert!((g - (1.1077 - 0.3053 * 3.0)).abs() < 1e-12);
    // two Near beacons add up (eq. 8); far particles get nothing
    let two = [near_beacon(12.0, 5.0), near_beacon(12.0, 7.0)];
    let g = proximity_gain(Some(&map), Vec2::new(12.0, 6.0), &two, &cfg);
    assert!((g - 2.0 * (1.1077 - 0.3053)).abs() < 1e-12);
    assert_eq!(
        proximity_gain(Some(&map), Vec2::new(18.0, 30.0), &two, &cfg),
        0.0
    );
    // a beacon mounted on the wall itself is still seen from its own room
    let on_wall = [near_beacon(10.2, 20.0)];
    assert!(proximity_gain(Some(&map), Vec2::new(8.5, 20.0), &on_wall, &cfg) > 0.0);
}

#[test]
fn a_dead_cloud_restarts_from_step_1_only_when_asked() {
    // every particle against the wall with weight 0 (the replica's seed
    // 5 after a turn): as printed the cloud stays there for good; with
    // `restart_when_all_zero` it is spread over the floor again
    for restart in [false, true] {
        let mut cfg = EngineConfig::default();
        cfg.prox_pf.restart_when_all_zero = restart;
        let mut e = ProxPfEngine::new(site(), &cfg, None).unwrap();
        e.floor = Some(0);
        e.evidence = true;
        e.cloud.clear();
        for _ in 0..500 {
            e.cloud.push(Vec2::new(9.9, 5.0), 0.0);
        }
        e.step_once(1_000_000_000);
        let xs: Vec<f64> = e.cloud().positions().iter().map(|p| p.x).collect();
        let spread = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - xs.iter().cloned().fold(f64::INFINITY, f64::min);
        if restart {
            assert_eq!(e.cloud().len(), 500);
            assert!(spread > 10.0, "{spread}");
            assert!(
                e.cloud()
                    .weights()
                    .iter()
                    .all(|w| *w == cfg.prox_pf.initial_weight)
            );
        } else {
            assert_eq!(spread, 0.0);
            assert!(e.cloud().weights().iter().all(|w| *w == 0.0));
        }
    }
}

fn run(events: Vec<LogEvent>, seed: u64) -> ReplayOutput {
    let cfg = EngineConfig {
        seed,
        ..EngineConfig::default()
    };
    let mut e = build_engine("prox-pf", site(), &cfg, None).unwrap();
    replay(e.as_mut(), events)
}

#[test]
fn tracks_a_walk_from_a_uniform_start_and_is_deterministic() {
    let out = run(walk_north(25, None), 7);
    let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
    assert!(errs.len() >= 20, "{} fixes", errs.len());
    let tail = &errs[errs.len() - 10..];
    let mean = tail.iter().sum::<f64>() / tail.len() as f64;
    assert!(mean < 2.0, "mean error of the last 10 s {mean}: {errs:?}");
    assert!(out.stats.steps > 30);
    let again = run(walk_north(25, None), 7);
    assert_eq!(out.track, again.track);
    let other = run(walk_north(25, None), 8);
    assert_ne!(out.track, other.track);
}

#[test]
fn bad_input_gives_no_fix_and_no_nan() {
    for r in [0.0, 5.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let f = move |_: usize, _: f64| r;
        let out = run(walk_north(5, Some(&f)), 1);
        assert!(out.track.is_empty(), "rssi {r}");
        assert!(
            out.stats.no_fix > 0 && out.stats.rejected_inputs > 0,
            "rssi {r}"
        );
    }
    // unknown beacons only
    let ev: Vec<LogEvent> = walk_north(5, None)
        .into_iter()
        .map(|e| match e {
            LogEvent::Ble(mut b) => {
                b.beacon_id = "mac:11:11:11:11:11:11".into();
                LogEvent::Ble(b)
            }
            e => e,
        })
        .collect();
    let out = run(ev, 1);
    assert!(out.track.is_empty() && out.stats.unknown_beacons > 0);
    // a site without floor maps: no particles, no fix, no panic
    let mut s = (*site()).clone();
    s.floors.clear();
    let mut e = build_engine("prox-pf", Arc::new(s), &EngineConfig::default(), None).unwrap();
    let out = replay(e.as_mut(), walk_north(3, None));
    assert!(out.track.is_empty() && out.stats.no_fix > 0);
    // bad config names its field
    let mut cfg = EngineConfig::default();
    cfg.prox_pf.n_particles = 0;
    let err = build_engine("prox-pf", site(), &cfg, None)
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("prox_pf.n_particles"), "{err}");
}
