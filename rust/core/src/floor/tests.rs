use super::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn gauss(rng: &mut Pcg64, sd: f64) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    sd * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Pressure at height `h_m` by inverting eq. 25 (H ~ h for small heights).
fn pressure_at(h_m: f64) -> f64 {
    SEA_LEVEL_HPA * (1.0 - h_m / 44_330.76).powf(1.0 / 0.190_255)
}

#[test]
fn eq25_gives_zero_at_sea_level_and_about_8_m_per_hpa() {
    assert!(baro_height_m(SEA_LEVEL_HPA).unwrap().abs() < 1e-9);
    let dh = baro_height_m(1000.0).unwrap() - baro_height_m(1001.0).unwrap();
    assert!((dh - 8.3).abs() < 0.2, "{dh}");
    let h = 123.4;
    assert!((pressure_height_m(pressure_at(h)).unwrap() - h).abs() < 1e-6);
    // eq. 26 is a small correction at building heights
    assert!((geometric_height_m(100.0) - 100.0).abs() < 0.01);
    assert_eq!(baro_height_m(f64::NAN), None);
    assert_eq!(baro_height_m(-3.0), None);
}

/// Walk 20 s on floor 0, climb 24 stairs (0.17 m each, 0.6 s per step) in
/// a staircase, walk 20 s on floor 1, then go back down: the floor follows.
#[test]
fn synthetic_stair_climb_changes_floor_and_back() {
    let floors = [(0, 0.0), (1, 4.08), (2, 8.16)];
    let cfg = FloorConfig {
        mode: FloorMode::Stairs,
        ..FloorConfig::default()
    };
    let mut ft = FloorTracker::new(&cfg, &floors, 0);
    let mut rng = Pcg64::seed_from_u64(7);
    let base_h = 250.0;
    let mut t = 0.0f64;
    let mut true_h = 0.0f64;
    let mut floor_log = Vec::new();
    // (duration s, vertical speed m/s, in staircase)
    let phases = [
        (20.0, 0.0, false),
        (14.4, 0.17 / 0.6, true),
        (20.0, 0.0, false),
        (14.4, -0.17 / 0.6, true),
        (10.0, 0.0, false),
    ];
    for (dur, vz, stairs) in phases {
        let end = t + dur;
        let mut next_step = t + 0.6;
        while t < end {
            t += 0.04; // 25 Hz barometer
            true_h += vz * 0.04;
            let p = pressure_at(base_h + true_h) + gauss(&mut rng, 0.012) /* hPa, ~0.1 m */;
            ft.on_pressure((t * 1e9) as i64, p);
            if t >= next_step {
                next_step += 0.6;
                ft.on_step(stairs);
            }
        }
        floor_log.push(ft.floor().unwrap());
    }
    assert_eq!(floor_log, vec![0, 1, 1, 0, 0], "heights {}", ft.height_m());
    assert!(ft.height_m().abs() < 1.0, "{}", ft.height_m());
}

#[test]
fn steps_outside_a_staircase_keep_the_height_and_bad_pressure_is_counted() {
    let stairs = FloorConfig {
        mode: FloorMode::Stairs,
        ..FloorConfig::default()
    };
    let mut ft = FloorTracker::new(&stairs, &[(3, 0.0), (5, 0.0)], 5);
    // heights all 0: floors stack in id order at 4 m, so floor 5 is at 4 m
    assert_eq!(ft.floor(), Some(5));
    for i in 0..100 {
        ft.on_pressure(i * 40_000_000, pressure_at(100.0 + i as f64 * 0.02));
        ft.on_step(false);
    }
    assert_eq!(ft.floor(), Some(5));
    ft.on_pressure(4_000_000_000, f64::NAN);
    ft.on_pressure(4_000_000_000, -1.0);
    ft.on_pressure(1, 1000.0); // out of time order
    assert_eq!(ft.rejected, 3);
    assert!(ft.height_m().is_finite());
    assert!(
        FloorConfig {
            stair_height_m: 0.0,
            ..FloorConfig::default()
        }
        .validate()
        .unwrap_err()
        .to_string()
        .contains("floor.stair_height_m")
    );
}

/// A walk through a 3-floor building with an unknown barometric offset:
/// (duration s, vertical speed m/s). Floors at 0, 3.5 and 7 m.
const FLOORS: [(i32, f64); 3] = [(0, 0.0), (1, 3.5), (2, 7.0)];

/// The floor the walker is on at height `h` (None on the way between floors).
fn true_floor(h: f64) -> Option<i32> {
    FLOORS
        .iter()
        .find(|(_, fh)| (h - fh).abs() < 0.3)
        .map(|(id, _)| *id)
}

struct Walk {
    /// (t s, true height m, BLE vote)
    samples: Vec<(f64, f64, Option<i32>)>,
}

/// Simulates a walk: floor 0 for 60 s, stairs up two floors (0.25 m/s),
/// 60 s on floor 2, a lift down one floor (1 m/s), 80 s on floor 1.
/// BLE votes once a second: right with probability `p_ok`, else a random
/// other floor; `bursts` are (start s, end s, floor) spans of a persistent
/// wrong vote (a strong beacon from another floor).
fn walk(seed: u64, p_ok: f64, bursts: &[(f64, f64, i32)]) -> Walk {
    let mut rng = Pcg64::seed_from_u64(seed);
    let phases = [
        (60.0, 0.0),
        (28.0, 0.25),
        (60.0, 0.0),
        (3.5, -1.0),
        (80.0, 0.0),
    ];
    let mut samples = Vec::new();
    let (mut t, mut h) = (0.0f64, 0.0f64);
    let mut next_vote = 1.0;
    for (dur, vz) in phases {
        let end = t + dur;
        while t < end - 1e-9 {
            t += 0.04;
            h += vz * 0.04;
            let vote = if t >= next_vote {
                next_vote += 1.0;
                let burst = bursts.iter().find(|b| t >= b.0 && t < b.1).map(|b| b.2);
                let truth = FLOORS
                    .iter()
                    .min_by(|a, b| (a.1 - h).abs().total_cmp(&(b.1 - h).abs()))
                    .unwrap()
                    .0;
                Some(burst.unwrap_or_else(|| {
                    if rng.random::<f64>() < p_ok {
                        truth
                    } else {
                        let others: Vec<i32> =
                            FLOORS.iter().map(|f| f.0).filter(|f| *f != truth).collect();
                        others[(rng.random::<f64>() * others.len() as f64) as usize % others.len()]
                    }
                }))
            } else {
                None
            };
            samples.push((t, h, vote));
        }
    }
    Walk { samples }
}

/// Runs `cfg` over the walk with barometer (base height `base_m`, 0.012 hPa
/// noise) or without; returns (fraction of on-floor seconds with the right
/// floor, the same for the raw BLE vote, seconds wrong after t = 20 s).
fn run(cfg: &FloorConfig, w: &Walk, base_m: Option<f64>, seed: u64) -> (f64, f64, f64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut ft = FloorTracker::new(cfg, &FLOORS, 0);
    let (mut n, mut ok, mut ble_ok, mut wrong_late) = (0usize, 0usize, 0usize, 0.0);
    for &(t, h, vote) in &w.samples {
        let t_ns = (t * 1e9) as i64;
        if let Some(b) = base_m {
            ft.on_pressure(t_ns, pressure_at(b + h) + gauss(&mut rng, 0.012));
        }
        if let Some(v) = vote {
            ft.on_ble_floor(t_ns, v);
            if let Some(tf) = true_floor(h) {
                n += 1;
                let good = ft.floor() == Some(tf);
                ok += good as usize;
                ble_ok += (v == tf) as usize;
                if !good && t > 40.0 {
                    wrong_late += 1.0;
                }
            }
        }
    }
    (ok as f64 / n as f64, ble_ok as f64 / n as f64, wrong_late)
}

/// Stairs up two floors and a lift ride down one, BLE votes right 70 % of the
/// time, a 30 s burst of a wrong floor right after the lift, a wrong first
/// vote, and an unknown barometric offset (two very different base heights):
/// the fused tracker is right nearly all the time after the first 40 s, far
/// better than the votes (votes alone: what the tracker reports without
/// pressure) and than the barometer alone (Table 2 started on the first vote).
#[test]
fn fused_tracker_follows_stairs_and_lift_with_unreliable_ble_floor() {
    // the votes below are right 70 % of the time: tell the tracker so
    let cfg = FloorConfig {
        ble_floor_correct_prob: 0.7,
        ..FloorConfig::default()
    };
    let bursts = [(0.0, 3.0, 2), (155.0, 185.0, 0)];
    for (seed, base) in [(1u64, 273.0), (2, 312.0), (3, -20.0)] {
        let w = walk(seed, 0.7, &bursts);
        let (acc, ble_acc, wrong_late) = run(&cfg, &w, Some(base), seed + 100);
        assert!(ble_acc < 0.75, "the votes are noisy: {ble_acc}");
        assert!(
            acc > 0.8 && wrong_late <= 3.0,
            "seed {seed}: fused {acc} (ble {ble_acc}), {wrong_late} s wrong after 40 s"
        );
        // without a barometer: the latest vote
        let (acc_nb, ble_nb, _) = run(&cfg, &w, None, seed + 100);
        assert!((acc_nb - ble_nb).abs() < 1e-12, "{acc_nb} {ble_nb}");
        // barometer without BLE fusion (Table 2 from the first, wrong, vote)
        let stairs = FloorConfig {
            mode: FloorMode::Stairs,
            ..cfg.clone()
        };
        let (acc_stairs, _, _) = run(&stairs, &w, Some(base), seed + 100);
        assert!(acc_stairs + 0.2 < acc, "stairs {acc_stairs} vs fused {acc}");
        assert!(acc_nb + 0.2 < acc, "votes {acc_nb} vs fused {acc}");
    }
}

#[test]
fn fused_tracker_starts_from_reset_floor_and_ignores_votes_on_the_move() {
    let cfg = FloorConfig::default();
    let mut ft = FloorTracker::new(&cfg, &FLOORS, 0);
    ft.reset_to_floor(1);
    assert_eq!(ft.floor(), Some(1));
    let mut t = 0.0f64;
    // 20 s level at floor 1, one vote a second, every fourth one wrong: stays
    let mut k = 0;
    while t < 20.0 {
        t += 0.04;
        ft.on_pressure((t * 1e9) as i64, pressure_at(300.0 + 3.5));
        if (t * 25.0).round() as i64 % 25 == 0 {
            k += 1;
            ft.on_ble_floor((t * 1e9) as i64, if k % 4 == 0 { 2 } else { 1 });
        }
    }
    assert_eq!(ft.floor(), Some(1));
    assert!((ft.height_m() - 3.5).abs() < 0.5, "{}", ft.height_m());
    // climbing at 0.5 m/s: votes are ignored
    let before = ft.ble_votes_ignored;
    while t < 27.0 {
        t += 0.04;
        let h = 3.5 + 0.5 * (t - 20.0);
        ft.on_pressure((t * 1e9) as i64, pressure_at(300.0 + h));
        ft.on_ble_floor((t * 1e9) as i64, 0);
    }
    assert!(ft.ble_votes_ignored > before);
    // 7 m higher: floor 2 by the barometer alone
    for _ in 0..100 {
        t += 0.04;
        ft.on_pressure((t * 1e9) as i64, pressure_at(300.0 + 7.0));
    }
    assert_eq!(ft.floor(), Some(2));
    // unknown vote floors are ignored, config errors name the field
    ft.on_ble_floor((t * 1e9) as i64 + 1, 42);
    assert_eq!(ft.floor(), Some(2));
    for (bad, field) in [
        (
            FloorConfig {
                ble_floor_correct_prob: 1.0,
                ..cfg.clone()
            },
            "floor.ble_floor_correct_prob",
        ),
        (
            FloorConfig {
                hysteresis: -0.1,
                ..cfg.clone()
            },
            "floor.hysteresis",
        ),
        (
            FloorConfig {
                offset_cell_m: 0.0,
                ..cfg.clone()
            },
            "floor.offset_cell_m",
        ),
    ] {
        assert!(bad.validate().unwrap_err().to_string().contains(field));
    }
}
