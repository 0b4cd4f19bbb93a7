//! Issue 20's reproducers: inputs that used to hang or abort the process
//! (site floors, grids, configs, start positions) now give a clean error
//! naming the field, the value and the limit, without allocating much; plus
//! a bounded random-input test of the site and config loaders.
//!
//! Memory is measured with a counting global allocator (the peak of live
//! bytes while a case runs); the tests of this binary take one lock so that
//! their peaks do not mix. A hang shows as a failed test: each case runs on
//! its own thread and must return within [`HANG_S`] (a watchdog against
//! endless loops, not a speed limit: a clean error takes microseconds).
//!
//! Why a `cargo test` random-input test and not cargo-fuzz: cargo-fuzz needs
//! a nightly toolchain, which this project's CI does not install. The fuzz
//! test below mutates valid site and config files with a seeded generator
//! and a fixed case budget, so it runs the same cases, in bounded time, on
//! every `cargo test`.

use std::sync::Arc;
use std::time::Duration;

use fpbp_core::engine::InitialPosition;
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::site::{Site, SiteSpec};
use rand::{RngExt, SeedableRng};

mod counting_alloc;
use counting_alloc::SERIAL;

/// A case that has not returned after this long counts as a hang.
const HANG_S: u64 = 60;
/// Memory a reproducer may use above what was live before it, bytes.
const REPRODUCER_BUDGET: usize = 16 << 20;

/// Runs `f` on a thread; returns its result and the peak of extra live bytes.
fn measured<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> (T, usize) {
    let base = counting_alloc::start();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    let out = rx
        .recv_timeout(Duration::from_secs(HANG_S))
        .expect("case did not return: a hang");
    let peak = counting_alloc::extra_peak(base);
    (out, peak)
}

fn build_site(json: &str) -> fpbp_core::Result<Site> {
    let spec = SiteSpec::from_json(json.as_bytes(), "site.json")?;
    Site::build(spec, "site.json", &mut |_p: &str| {
        Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "no plans here",
        ))
    })
}

fn site_with_floor(floor: &str, extra: &str) -> String {
    format!(r#"{{"format":"fpbp-site","version":1,"name":"t",{extra}"floors":[{floor}]}}"#)
}

/// The site must fail to build with an error containing every `needles`,
/// within the reproducer memory budget.
fn site_refused(json: String, needles: &[&str]) {
    let (r, peak) = measured(move || build_site(&json).map(|_| ()));
    let e = r.expect_err("site must be refused").to_string();
    for n in needles {
        assert!(e.contains(n), "`{n}` not in: {e}");
    }
    assert!(peak < REPRODUCER_BUDGET, "{peak} bytes for: {e}");
}

const OPEN_20X12: &str = r#"{"id":0,"open_area_m":[20,12]}"#;

#[test]
fn tiny_pixels_per_meter_is_refused_not_looped_over() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    site_refused(
        site_with_floor(
            r#"{"id":0,"open_area_m":[10,10],"pixels_per_meter":1e-300}"#,
            "",
        ),
        &["floors[0].pixels_per_meter", "1e-300", "0.01"],
    );
}

#[test]
fn tiny_grid_intervals_are_refused() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    for v in ["1e-6", "0.001"] {
        site_refused(
            site_with_floor(OPEN_20X12, &format!(r#""grid_interval_m":{v},"#)),
            &["grid_interval_m", "0.05"],
        );
    }
    // 0.05 m is allowed but 20 x 12 km at 0.05 m is too many cells
    site_refused(
        site_with_floor(
            r#"{"id":0,"open_area_m":[5000,5000],"pixels_per_meter":0.1}"#,
            r#""grid_interval_m":0.05,"#,
        ),
        &["floors[0].open_area_m", "grid cells", "262144"],
    );
}

#[test]
fn huge_open_floors_are_refused_before_room_labelling() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    for side in ["2000", "1000"] {
        site_refused(
            site_with_floor(
                &format!(r#"{{"id":0,"open_area_m":[{side},{side}],"pixels_per_meter":10}}"#),
                "",
            ),
            &["floors[0].open_area_m", "over the limit of 16777216 px"],
        );
    }
    site_refused(
        site_with_floor(
            r#"{"id":0,"open_area_m":[20000,10],"pixels_per_meter":0.5}"#,
            "",
        ),
        &["floors[0].open_area_m", "10000 m a side"],
    );
}

#[test]
fn nan_coordinates_are_said_to_be_nan() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let json = r#"{"format":"fpbp-site","version":1,"name":"t","floors":[{"id":0,"open_area_m":[20,12]}],
        "beacons":[{"id":"mac:00:00:00:00:00:01","floor":0,"x_m":NaN,"y_m":1,"rssi_1m_dbm":-60,"path_loss_exponent":2}]}"#;
    let e = SiteSpec::from_json(json.as_bytes(), "s.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("NaN and Infinity are not allowed") && e.contains("beacons[0].x_m"),
        "{e}"
    );
}

fn open_site() -> Arc<Site> {
    let json = r#"{"format":"fpbp-site","version":1,"name":"t","floors":[{"id":0,"open_area_m":[20,12]}],
        "beacons":[{"id":"mac:00:00:00:00:00:01","floor":0,"x_m":5,"y_m":5,"rssi_1m_dbm":-60,"path_loss_exponent":2}]}"#;
    Arc::new(build_site(json).unwrap())
}

/// The config must be refused by the parser (and so by `start`) naming `field`.
fn config_refused(json: &str, needles: &[&str]) {
    let json = json.to_string();
    let (r, peak) = measured(move || EngineConfig::from_json(&json).map(|_| ()));
    let e = r.expect_err("config must be refused").to_string();
    for n in needles {
        assert!(e.contains(n), "`{n}` not in: {e}");
    }
    assert!(peak < REPRODUCER_BUDGET, "{peak} bytes for: {e}");
}

#[test]
fn config_steps_and_iterations_are_bounded() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    config_refused(
        r#"{"prox_pf":{"raycast_step_m":1e-300}}"#,
        &["prox_pf.raycast_step_m", "1e-300", "0.001"],
    );
    config_refused(
        r#"{"ekf":{"fingerprint":{"ap_iterations":1000000000}}}"#,
        &["ekf.fingerprint.ap_iterations", "1000000000", "10000"],
    );
    config_refused(
        r#"{"ekf":{"fingerprint":{"grid_step_m":1e-300}}}"#,
        &["ekf.fingerprint.grid_step_m", "1e-300"],
    );
    config_refused(
        r#"{"fusion":{"ppc":{"raycast_step_m":0}}}"#,
        &["fusion.ppc.raycast_step_m"],
    );
    config_refused(r#"{"prox_pf":{"period_s":1e-12}}"#, &["prox_pf.period_s"]);
    config_refused(r#"{"ppsa":{"slot_s":1e-12}}"#, &["ppsa.slot_s"]);
    // a syntax error names the path, not a line/column as the field
    config_refused(
        r#"{"fusion":{"particle_count":"x"}}"#,
        &["`fusion.particle_count`"],
    );
    // the default config and the defaults' neighbours still pass
    EngineConfig::from_json(r#"{"prox_pf":{"raycast_step_m":0.05}}"#).unwrap();
}

#[test]
fn start_positions_are_checked_against_the_site() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let site = open_site();
    let cfg = EngineConfig::default();
    let cases = [
        (-1.58e274, 5.0, -2147483647, "initial_position.floor"),
        (-1.58e274, 5.0, 0, "outside floor 0"),
        (f64::NAN, 5.0, 0, "must be finite"),
        (5.0, f64::INFINITY, 0, "must be finite"),
        (25.0, 5.0, 0, "outside floor 0"),
    ];
    for name in ["fpbp", "pdr", "prox-pf", "gml", "robust-ekf"] {
        for (x, y, floor, needle) in cases {
            let at = InitialPosition {
                x_m: x,
                y_m: y,
                floor,
                heading_rad: None,
            };
            let e = build_engine(name, site.clone(), &cfg, Some(at))
                .err()
                .unwrap_or_else(|| panic!("{name} accepted {at:?}"))
                .to_string();
            assert!(e.contains(needle), "{name}: `{needle}` not in {e}");
        }
        let bad_heading = InitialPosition {
            x_m: 5.0,
            y_m: 5.0,
            floor: 0,
            heading_rad: Some(f64::NAN),
        };
        assert!(build_engine(name, site.clone(), &cfg, Some(bad_heading)).is_err());
        let ok = InitialPosition {
            heading_rad: Some(0.5),
            ..bad_heading
        };
        build_engine(name, site.clone(), &cfg, Some(ok)).unwrap();
    }
}

/// Memory a random site may take: the map limit at ~20 bytes per pixel plus
/// slack for the grid and the spec.
const RANDOM_SITE_BUDGET: usize = 24 * fpbp_core::bounds::MAX_MAP_PIXELS + (64 << 20);

/// A number from a wide, mostly extreme range (the values that used to
/// hang), or with `tame` a plausible site size.
fn number(rng: &mut rand_pcg::Pcg64, tame: bool) -> String {
    if tame {
        return format!("{:.3}", rng.random_range(0.5..30.0));
    }
    wild(rng)
}

fn wild(rng: &mut rand_pcg::Pcg64) -> String {
    match rng.random_range(0..10) {
        0 => "1e-300".into(),
        1 => "1e300".into(),
        2 => "0".into(),
        3 => "-1".into(),
        4 => format!("{}", rng.random_range(0u64..u64::MAX)),
        5 => format!("{:e}", 10f64.powf(rng.random_range(-12.0..12.0))),
        6 => format!("{:.3}", 10f64.powf(rng.random_range(-1.0..3.5))),
        _ => format!("{:.3}", rng.random_range(0.5..30.0)),
    }
}

/// Random site files (random sizes, resolutions, grid intervals, beacons,
/// start positions) either error cleanly or build within the memory budget;
/// every built map respects the pixel and grid limits.
#[test]
fn random_sites_error_cleanly_or_build_within_the_memory_budget() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut rng = rand_pcg::Pcg64::seed_from_u64(20);
    let (mut built, mut refused) = (0, 0);
    for case in 0..300 {
        let tame = case % 3 == 0;
        let floor = format!(
            r#"{{"id":{},"open_area_m":[{},{}],"pixels_per_meter":{}}}"#,
            rng.random_range(-3..3),
            number(&mut rng, tame),
            number(&mut rng, tame),
            number(&mut rng, tame)
        );
        let beacon = if rng.random_range(0..2) == 0 {
            String::new()
        } else {
            format!(
                r#""beacons":[{{"id":"mac:00:00:00:00:00:01","floor":0,"x_m":{},"y_m":{},"rssi_1m_dbm":-60,"path_loss_exponent":{}}}],"#,
                number(&mut rng, tame),
                number(&mut rng, tame),
                number(&mut rng, tame)
            )
        };
        let extra = format!(r#""grid_interval_m":{},{beacon}"#, number(&mut rng, tame));
        let json = site_with_floor(&floor, &extra);
        let j2 = json.clone();
        let (r, peak) = measured(move || build_site(&j2));
        assert!(
            peak < RANDOM_SITE_BUDGET,
            "case {case}: {peak} bytes: {json}"
        );
        match r {
            Ok(site) => {
                built += 1;
                for m in &site.floors {
                    assert!(m.width_px() * m.height_px() <= fpbp_core::bounds::MAX_MAP_PIXELS);
                    assert!(m.grid().len() <= fpbp_core::bounds::MAX_GRID_CELLS);
                }
                let at = InitialPosition {
                    x_m: wild(&mut rng).parse().unwrap_or(0.0),
                    y_m: wild(&mut rng).parse().unwrap_or(0.0),
                    floor: site.default_floor(),
                    heading_rad: None,
                };
                let site = Arc::new(site);
                let (r, _) = measured(move || {
                    build_engine("fpbp", site, &EngineConfig::default(), Some(at)).map(|_| ())
                });
                // refused (outside, not finite) or built: never a hang or abort
                let _ = r;
            }
            Err(e) => {
                refused += 1;
                let s = e.to_string();
                assert!(s.starts_with("site.json: field `"), "case {case}: {s}");
                assert!(s.len() < 600, "case {case}: message too long: {s}");
            }
        }
    }
    // the generator reaches both outcomes
    assert!(
        built > 10 && refused > 100,
        "built {built}, refused {refused}"
    );
}

/// Mutates the bytes of valid files: flips, deletions, numbers replaced by
/// extreme values, truncations.
fn mutate(rng: &mut rand_pcg::Pcg64, text: &str) -> String {
    let mut s = text.to_string();
    for _ in 0..rng.random_range(1..4) {
        let numbers: Vec<(usize, usize)> = {
            let b = s.as_bytes();
            let mut v = Vec::new();
            let mut i = 0;
            while i < b.len() {
                if b[i].is_ascii_digit() {
                    let st = i;
                    while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                        i += 1;
                    }
                    v.push((st, i));
                } else {
                    i += 1;
                }
            }
            v
        };
        match rng.random_range(0..4) {
            0 if !numbers.is_empty() => {
                let (a, b) = numbers[rng.random_range(0..numbers.len())];
                s.replace_range(a..b, &wild(rng));
            }
            1 if !s.is_empty() => {
                let k = rng.random_range(0..s.len());
                if s.is_char_boundary(k) && s.is_char_boundary(k + 1) {
                    s.remove(k);
                }
            }
            2 if !s.is_empty() => {
                let k = rng.random_range(0..s.len());
                if s.is_char_boundary(k) {
                    s.truncate(k);
                }
            }
            _ => {
                let k = rng.random_range(0..=s.len());
                if s.is_char_boundary(k) {
                    let c = [b'{', b'}', b'[', b']', b',', b'"', b':', b'-', b'e']
                        [rng.random_range(0..9)] as char;
                    s.insert(k, c);
                }
            }
        }
    }
    s
}

/// Bounded fuzz test of the site and config loaders (fixed seed, fixed case
/// budget): every mutation of the demo site and of a full config parses and
/// validates or errors, without a panic, a hang or a large allocation.
#[test]
fn fuzz_site_and_config_loaders_with_a_fixed_budget() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let demo = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../maps/demo/site.json"
    ))
    .expect("maps/demo/site.json");
    let demo_open = demo
        .replace(r#""open_area_m": null,"#, "")
        .replace(r#""plan": "plan.png""#, r#""open_area_m": [60, 40]"#);
    let config = serde_json::to_string(&EngineConfig::default()).unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(2020);
    // [kind][refused, accepted]
    let mut outcomes = [[0usize; 2]; 3];
    for case in 0..1500 {
        let (kind, text) = match case % 3 {
            0 => (0, mutate(&mut rng, &demo)),
            1 => (1, mutate(&mut rng, &demo_open)),
            _ => (2, mutate(&mut rng, &config)),
        };
        let t2 = text.clone();
        let (r, peak) = measured(move || {
            std::panic::catch_unwind(move || {
                if kind == 2 {
                    EngineConfig::from_json(&t2).map(|_| ()).is_ok()
                } else {
                    build_site(&t2).is_ok()
                }
            })
        });
        let ok = r.unwrap_or_else(|_| panic!("case {case} panicked on: {text}"));
        outcomes[kind][usize::from(ok)] += 1;
        assert!(
            peak < RANDOM_SITE_BUDGET,
            "case {case}: {peak} bytes: {text}"
        );
    }
    // the open-floor site and the config see accepted and refused inputs
    // (the demo site with its plan is refused: this test reads no plans)
    assert!(
        outcomes[1].iter().chain(&outcomes[2]).all(|&n| n > 0),
        "{outcomes:?}"
    );
}
