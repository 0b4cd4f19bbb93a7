//! Tests of `fpbp` / `bp`: start-up, set_position, PPC, room switches,
//! innovation noise, floor changes.

use super::*;
use crate::map::{Feature, FloorMap};
use crate::site::SiteSpec;

/// 20 m x 4 m corridor at 10 px/m with 0.3 m walls all round.
fn corridor_site() -> Arc<Site> {
    let spec: SiteSpec = serde_json::from_str(
        r#"{"format": "fpbp-site", "version": 1, "name": "corridor",
            "floors": [{"id": 0, "open_area_m": [20.0, 4.0]}]}"#,
    )
    .unwrap();
    let (w, h) = (200usize, 40usize);
    let mut f = vec![Feature::Walkable; w * h];
    for j in 0..h {
        for i in 0..w {
            if i < 3 || i >= w - 3 || j < 3 || j >= h - 3 {
                f[j * w + i] = Feature::Wall;
            }
        }
    }
    Arc::new(Site {
        spec,
        floors: vec![FloorMap::from_features(w, h, 10.0, f)],
    })
}

fn fix(t_ns: i64, x: f64, y: f64) -> BleFix {
    BleFix {
        t_ns,
        pos: Vec2::new(x, y),
        raw: Vec2::new(x, y),
        floor: 0,
        beacons: 4,
    }
}

/// The `fpbp` fusion task on the corridor, started at (1, 2) by the caller.
fn corridor_side(cfg: &EngineConfig) -> FusionSide {
    let init = InitialPosition {
        x_m: 1.0,
        y_m: 2.0,
        floor: 0,
        heading_rad: None,
    };
    FusionSide::new(corridor_site(), cfg, true, Some(init)).unwrap()
}

/// Walks east along the corridor with a heading bias of +0.25 rad (the
/// PDR drifts into the north wall); x_B is the truth plus a fixed offset.
fn walk(use_ppc: bool, seed: u64, with_ble: bool) -> (Vec<Vec2>, FusionSide) {
    walk_cfg(use_ppc, seed, with_ble, false)
}

fn walk_cfg(
    use_ppc: bool,
    seed: u64,
    with_ble: bool,
    particle_wall_check: bool,
) -> (Vec<Vec2>, FusionSide) {
    let site = corridor_site();
    let mut cfg = EngineConfig {
        seed,
        ..EngineConfig::default()
    };
    cfg.fusion.particle_wall_check = particle_wall_check;
    // The estimate is the whole cloud's mean, so PPC (not the room-level
    // estimate, which ignores particles in walls) keeps the track in.
    cfg.fusion.room_estimate = false;
    let init = InitialPosition {
        x_m: 1.0,
        y_m: 2.0,
        floor: 0,
        heading_rad: None,
    };
    let mut side = FusionSide::new(site, &cfg, use_ppc, Some(init)).unwrap();
    let mut track = Vec::new();
    for k in 1..=25i64 {
        let t = k * 700_000_000;
        let truth_x = 1.0 + 0.7 * k as f64;
        let xb = with_ble.then(|| fix(t, truth_x + 0.5, 2.0));
        side.run_steps(t, xb, &[(0.7, 0.25)]);
        let p = side.pose().unwrap();
        track.push(Vec2::new(p.x_m, p.y_m));
    }
    (track, side)
}

/// A tap moves the filter without a restart: the pose is the tapped
/// point at once, every particle is there, the next steps start from it,
/// and a point off the site's floors is refused.
#[test]
fn set_position_moves_the_filter_now() {
    let cfg = EngineConfig::default();
    let mut side = corridor_side(&cfg);
    for k in 1..=5i64 {
        let t = k * 700_000_000;
        side.run_steps(t, Some(fix(t, 1.0 + 0.7 * k as f64, 2.0)), &[(0.7, 0.0)]);
    }
    assert_eq!(
        side.pose().unwrap().source,
        crate::engine::PoseSource::Fused
    );
    let at = InitialPosition {
        x_m: 15.0,
        y_m: 2.5,
        floor: 0,
        heading_rad: Some(0.0),
    };
    side.set_position(4_000_000_000, at).unwrap();
    let p = side.pose().unwrap();
    assert_eq!(
        (p.t_ns, p.x_m, p.y_m, p.floor),
        (4_000_000_000, 15.0, 2.5, 0)
    );
    assert_eq!(p.source, crate::engine::PoseSource::DeadReckoning);
    assert!(side.particles().iter().all(|q| *q == Vec2::new(15.0, 2.5)));
    side.run_steps(4_700_000_000, None, &[(0.7, 0.0)]);
    let p = side.pose().unwrap();
    assert!(
        (p.x_m - 15.7).abs() < 0.3 && (p.y_m - 2.5).abs() < 0.3,
        "{p:?}"
    );
    let bad = InitialPosition { floor: 4, ..at };
    let e = side.set_position(5_000_000_000, bad).unwrap_err();
    assert!(e.to_string().contains("floor 4"), "{e}");
    assert_eq!(
        side.pose().unwrap().t_ns,
        4_700_000_000,
        "a refused position changed the pose"
    );
}

/// Through the engine: the BLE side forgets x_B from before the tap.
#[test]
fn engine_set_position_clears_the_old_ble_fix() {
    for name in ["fpbp", "bp"] {
        let mut e =
            crate::engines::build_engine(name, corridor_site(), &EngineConfig::default(), None)
                .unwrap();
        assert!(e.pose().is_none());
        let at = InitialPosition {
            x_m: 3.0,
            y_m: 2.0,
            floor: 0,
            heading_rad: None,
        };
        e.set_position(10, at).unwrap();
        let p = e.pose().unwrap();
        assert_eq!((p.t_ns, p.x_m, p.y_m), (10, 3.0, 2.0), "{name}");
        assert!(e.ble_position().is_none(), "{name}");
    }
}

#[test]
fn same_seed_same_track() {
    let (a, _) = walk(true, 9, true);
    let (b, _) = walk(true, 9, true);
    assert_eq!(a, b);
    let (c, _) = walk(true, 10, true);
    assert_ne!(a, c);
}

#[test]
fn ppc_keeps_the_track_and_particles_off_walls() {
    let (track, side) = walk(true, 1, false);
    let site = corridor_site();
    let map = &site.floors[0];
    assert!(track.iter().all(|p| map.is_walkable(*p)), "{track:?}");
    assert!(side.particles().iter().all(|p| map.is_walkable(*p)));
    assert!(side.ppc_counts.yaw_corrected + side.ppc_counts.blocked > 0);
    // Without PPC the drifting dead reckoning leaves the corridor.
    let (bp, _) = walk(false, 1, false);
    assert!(bp.iter().any(|p| !map.is_walkable(*p)));
    // With PPC the walker still makes progress east along the wall.
    assert!(track.last().unwrap().x > 10.0, "{:?}", track.last());
    // With the particle wall check (default) the cloud itself stays in.
    let (track, side) = walk_cfg(true, 1, false, true);
    assert!(track.iter().all(|p| map.is_walkable(*p)), "{track:?}");
    assert!(side.particles().iter().all(|p| map.is_walkable(*p)));
    assert!(track.last().unwrap().x > 10.0, "{:?}", track.last());
}

#[test]
fn starts_at_the_mean_of_the_first_ble_fixes() {
    let site = corridor_site();
    let cfg = EngineConfig::default();
    let mut side = FusionSide::new(site, &cfg, true, None).unwrap();
    side.run_steps(1, Some(fix(1, 4.0, 2.0)), &[(0.7, 0.0)]);
    side.run_steps(2, Some(fix(2, 5.0, 2.0)), &[]);
    assert!(side.pose().is_none());
    side.run_steps(3, Some(fix(3, 6.0, 1.0)), &[]);
    let p = side.pose().unwrap();
    assert!(
        (p.x_m - 5.0).abs() < 1e-9 && (p.y_m - 5.0 / 3.0).abs() < 1e-9,
        "{p:?}"
    );
}

/// 20 m x 10 m at 10 px/m, border walls, and a wall without a door at
/// x in [10.0, 10.3): room A on the left, room B on the right.
fn two_room_site() -> Arc<Site> {
    let spec: SiteSpec = serde_json::from_str(
        r#"{"format": "fpbp-site", "version": 1, "name": "two rooms",
            "floors": [{"id": 0, "open_area_m": [20.0, 10.0]}]}"#,
    )
    .unwrap();
    let (w, h) = (200usize, 100usize);
    let mut f = vec![Feature::Walkable; w * h];
    for j in 0..h {
        for i in 0..w {
            if i < 3 || i >= w - 3 || j < 3 || j >= h - 3 || (100..103).contains(&i) {
                f[j * w + i] = Feature::Wall;
            }
        }
    }
    Arc::new(Site {
        spec,
        floors: vec![FloorMap::from_features(w, h, 10.0, f)],
    })
}

/// Own start from three fixes at `start`, then `n` short steps with x_B
/// at `x_b`; returns the final pose.
fn stay_with_ble(cfg: &EngineConfig, start: Vec2, x_b: Vec2, n: i64) -> Pose {
    let mut side = FusionSide::new(two_room_site(), cfg, true, None).unwrap();
    for k in 1..=3 {
        side.run_steps(k, Some(fix(k, start.x, start.y)), &[]);
    }
    for k in 1..=n {
        let t = k * 1_000_000_000;
        let yaw = if k % 2 == 0 { 1.5 } else { -1.5 };
        side.run_steps(t, Some(fix(t, x_b.x, x_b.y)), &[(0.1, yaw)]);
    }
    side.pose().unwrap()
}

/// Room-level hypothesis: a cloud spread over both rooms follows
/// persistent x_B into room B through the wall; without the switch PPC
/// keeps the track in room A.
#[test]
fn heaviest_room_takes_the_track_through_a_wall() {
    let mut cfg = EngineConfig::default();
    cfg.fusion.relocalize_after_fixes = 0;
    let (start, x_b) = (Vec2::new(9.0, 5.0), Vec2::new(13.0, 5.0));
    let on = stay_with_ble(&cfg, start, x_b, 20);
    assert!(on.x_m > 10.3, "{on:?}");
    cfg.fusion.room_switch_mass = 0.0;
    let off = stay_with_ble(&cfg, start, x_b, 20);
    assert!(off.x_m < 10.0, "{off:?}");
    cfg.fusion.room_estimate = false;
    let paper = stay_with_ble(&cfg, start, x_b, 20);
    assert!(paper.x_m < 10.0, "{paper:?}");
}

/// A caller's start is trusted: x_B far away in the other room does not
/// re-localise the filter unless `relocalize_after_given_start`.
#[test]
fn given_start_is_not_relocalized_by_default() {
    let run = |cfg: &EngineConfig| {
        let init = InitialPosition {
            x_m: 5.0,
            y_m: 5.0,
            floor: 0,
            heading_rad: None,
        };
        let mut side = FusionSide::new(two_room_site(), cfg, true, Some(init)).unwrap();
        for k in 1..=10i64 {
            let t = k * 1_000_000_000;
            let yaw = if k % 2 == 0 { 1.5 } else { -1.5 };
            side.run_steps(t, Some(fix(t, 15.0, 5.0)), &[(0.1, yaw)]);
        }
        (
            side.pose().unwrap(),
            side.relocalized,
            side.particles().to_vec(),
        )
    };
    let mut cfg = EngineConfig::default();
    let (p, n, parts) = run(&cfg);
    assert!(p.x_m < 10.0 && n == 0, "{p:?} {n}");
    // The given start is exact: no particle crossed into room B.
    assert!(parts.iter().all(|q| q.x < 10.0));
    cfg.fusion.relocalize_after_given_start = true;
    let (p, n, _) = run(&cfg);
    assert!(p.x_m > 10.3 && n == 1, "{p:?} {n}");
}

/// Innovation-driven noise: the PDR reports half the walked distance
/// and x_B follows the truth; with the extra noise the cloud spreads when
/// x_B runs ahead and BLE pulls the track along, without it the track lags.
#[test]
fn innovation_noise_lets_ble_pull_a_lagging_track() {
    let lag = |gain: f64, seed: u64| {
        let mut cfg = EngineConfig {
            seed,
            ..EngineConfig::default()
        };
        cfg.fusion.innovation_noise_gain = gain;
        cfg.fusion.innovation_free_m = 1.0;
        let mut side = corridor_side(&cfg);
        let mut sum = 0.0;
        for k in 1..=25i64 {
            let t = k * 700_000_000;
            let truth_x = 1.0 + 0.7 * k as f64;
            side.run_steps(t, Some(fix(t, truth_x, 2.0)), &[(0.35, 0.0)]);
            sum += truth_x - side.pose().unwrap().x_m;
        }
        sum / 25.0
    };
    for seed in 1..=3 {
        let (off, on) = (lag(0.0, seed), lag(0.3, seed));
        assert!(
            on < 0.7 * off,
            "seed {seed}: mean lag {on} m with, {off} m without"
        );
    }
}

/// `fusion.ppc.enabled = false` (ablation): Algorithm 2 never runs, the
/// drifting track leaves the corridor as bp's does; with it, PPC fires.
#[test]
fn ppc_can_be_switched_off_for_ablations() {
    let run = |enabled: bool| {
        let mut cfg = EngineConfig::default();
        cfg.fusion.ppc.enabled = enabled;
        cfg.fusion.particle_wall_check = false;
        cfg.fusion.room_estimate = false;
        let mut side = corridor_side(&cfg);
        let mut track = Vec::new();
        for k in 1..=25i64 {
            side.run_steps(k * 700_000_000, None, &[(0.7, 0.25)]);
            let p = side.pose().unwrap();
            track.push(Vec2::new(p.x_m, p.y_m));
        }
        let c = side.ppc_counts;
        (track, c.free + c.yaw_corrected + c.blocked + c.door_passed)
    };
    let map = &corridor_site().floors[0];
    let (on, fired_on) = run(true);
    let (off, fired_off) = run(false);
    assert!(fired_on > 0 && fired_off == 0, "{fired_on} {fired_off}");
    assert!(on.iter().all(|p| map.is_walkable(*p)));
    assert!(off.iter().any(|p| !map.is_walkable(*p)));
}

/// A floor change restarts at the mean of the other floor's x_B, or at
/// the track's x, y with `floor_change_keeps_position`.
#[test]
fn floor_change_restart_point() {
    let one = two_room_site();
    let spec: SiteSpec = serde_json::from_str(
        r#"{"format": "fpbp-site", "version": 1, "name": "two floors",
            "floors": [{"id": 0, "open_area_m": [20.0, 10.0]},
                       {"id": 1, "open_area_m": [20.0, 10.0]}]}"#,
    )
    .unwrap();
    let site = Arc::new(Site {
        spec,
        floors: vec![one.floors[0].clone(), one.floors[0].clone()],
    });
    let run = |keep: bool| {
        let mut cfg = EngineConfig::default();
        cfg.fusion.floor_change_keeps_position = keep;
        let init = InitialPosition {
            x_m: 5.0,
            y_m: 5.0,
            floor: 0,
            heading_rad: None,
        };
        let mut side = FusionSide::new(Arc::clone(&site), &cfg, true, Some(init)).unwrap();
        for k in 1..=4i64 {
            let t = k * 1_000_000_000;
            let f = BleFix {
                floor: 1,
                ..fix(t, 15.0, 5.0)
            };
            side.run_steps(t, Some(f), &[(0.1, 0.0)]);
        }
        side.pose().unwrap()
    };
    let moved = run(false);
    assert_eq!(moved.floor, 1);
    assert!(moved.x_m > 12.0, "{moved:?}");
    let kept = run(true);
    assert_eq!(kept.floor, 1);
    assert!(kept.x_m < 8.0, "{kept:?}");
}
