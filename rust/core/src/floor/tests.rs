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
    let cfg = FloorConfig::default();
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
    let mut ft = FloorTracker::new(&FloorConfig::default(), &[(3, 0.0), (5, 0.0)], 5);
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
