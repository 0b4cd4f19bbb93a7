//! End-to-end tests of [`crate::simulate`] on a synthetic two-room site.

use fpbp_core::Vec2;
use fpbp_core::events::LogEvent;
use fpbp_core::map::Feature;

use crate::testmap::two_rooms_site;
use crate::{SimRequest, ble, simulate, stats};

fn request(seconds: f64, seed: u64) -> SimRequest {
    let mut r = SimRequest::new(seconds, seed);
    r.profile.walk.min_goal_distance_m = 2.0;
    r
}

#[test]
fn same_seed_same_events_other_seed_other_events() {
    let site = two_rooms_site();
    let a = simulate(&site, &request(30.0, 11)).unwrap();
    let b = simulate(&site, &request(30.0, 11)).unwrap();
    let c = simulate(&site, &request(30.0, 12)).unwrap();
    let ja = serde_json::to_string(&a.events).unwrap();
    assert_eq!(ja, serde_json::to_string(&b.events).unwrap());
    assert_ne!(ja, serde_json::to_string(&c.events).unwrap());
    assert_eq!(a.header, b.header);
}

#[test]
fn events_are_in_time_order_and_inside_the_log() {
    let site = two_rooms_site();
    let r = request(40.0, 1);
    let log = simulate(&site, &r).unwrap();
    assert!(log.events.windows(2).all(|w| w[0].t_ns() <= w[1].t_ns()));
    let end = r.t0_ns + 40_000_000_000;
    assert!(
        log.events
            .iter()
            .all(|e| e.t_ns() >= r.t0_ns && e.t_ns() <= end)
    );
    let kinds = |f: fn(&LogEvent) -> bool| log.events.iter().filter(|e| f(e)).count();
    assert!(kinds(|e| matches!(e, LogEvent::Ble(_))) > 100);
    // 10 Hz truth plus one per step.
    let truth = kinds(|e| matches!(e, LogEvent::Truth(_)));
    assert!(truth >= 401 && truth <= 401 + log.header.steps, "{truth}");
}

#[test]
fn truth_never_crosses_a_wall() {
    let site = two_rooms_site();
    let map = &site.floors[0];
    for seed in 0..4 {
        let log = simulate(&site, &request(120.0, seed)).unwrap();
        let pts: Vec<Vec2> = log
            .events
            .iter()
            .filter_map(LogEvent::as_truth)
            .map(|t| Vec2::new(t.x_m, t.y_m))
            .collect();
        let mut rooms = [false; 2];
        for w in pts.windows(2) {
            if let Some(hit) = map.raycast(w[0], w[1], 0.01) {
                assert_ne!(
                    hit.feature,
                    Feature::Wall,
                    "seed {seed}: {:?} -> {:?}",
                    w[0],
                    w[1]
                );
            }
            let n = ((w[1] - w[0]).norm() / 0.01).ceil().max(1.0) as usize;
            for k in 0..=n {
                let p = w[0] + (w[1] - w[0]) * (k as f64 / n as f64);
                assert_ne!(map.feature(p), Feature::Wall, "seed {seed}: wall at {p:?}");
            }
            rooms[usize::from(w[0].x > 5.0)] = true;
        }
        assert!(rooms[0] && rooms[1], "seed {seed}: walks through the door");
    }
}

#[test]
fn detected_steps_match_true_steps() {
    let site = two_rooms_site();
    for (seed, profile) in [(21, "default"), (22, "swinging")] {
        let mut r = request(120.0, seed);
        r.profile = crate::SimProfile::named(profile).unwrap();
        r.profile.walk.min_goal_distance_m = 2.0;
        let log = simulate(&site, &r).unwrap();
        let truth = log.header.steps as f64;
        assert!(truth > 100.0);
        // The world-frame vertical (rotation vector) works for both carries; the
        // gravity low-pass detector of `fpbp realism` only for the phone in front.
        let found = stats::detect_steps(&stats::vertical_accel_world(&log.events)).len() as f64;
        let rel = (found - truth).abs() / truth;
        assert!(
            rel < 0.05,
            "{profile}: detected {found} steps, truth {truth}"
        );
        if profile == "default" {
            let found = stats::detect_steps(&stats::vertical_accel(&log.events)).len() as f64;
            let rel = (found - truth).abs() / truth;
            assert!(
                rel < 0.05,
                "{profile}: low-pass detector found {found} steps, truth {truth}"
            );
        }
    }
}

/// RSSI residuals against the model, split by whether the link crosses walls.
fn residuals(nlos_rate: f64, seeds: std::ops::Range<u64>) -> (Vec<f64>, Vec<f64>, f64) {
    let (mut los, mut nlos, mut sigma) = (Vec::new(), Vec::new(), 0.0);
    for seed in seeds {
        let (a, b, s) = residuals_one(nlos_rate, seed);
        los.extend(a);
        nlos.extend(b);
        sigma = s;
    }
    (los, nlos, sigma)
}

fn residuals_one(nlos_rate: f64, seed: u64) -> (Vec<f64>, Vec<f64>, f64) {
    let site = two_rooms_site();
    let mut r = request(300.0, seed);
    r.profile.ble.nlos_rate = nlos_rate;
    let log = simulate(&site, &r).unwrap();
    let cfg = &r.profile.ble;
    let sigma = cfg.shadowing_sigma_db.hypot(cfg.fast_fading_sigma_db);
    let (mut los, mut nlos) = (Vec::new(), Vec::new());
    for e in &log.events {
        let LogEvent::Ble(o) = e else { continue };
        let b = site
            .spec
            .beacons
            .iter()
            .find(|b| b.id == o.beacon_id)
            .unwrap();
        let t = (o.t_ns - r.t0_ns) as f64 * 1e-9;
        let pos = log.trajectory.position_at(t);
        let l = ble::link(&site, cfg, b, 0, pos, r.profile.walk.phone_height_m);
        // Far from the sensitivity cut, which would bias the mean.
        if l.model_rssi_dbm < cfg.sensitivity_dbm + 3.0 * sigma {
            continue;
        }
        let res = o.rssi_dbm - l.model_rssi_dbm;
        if l.walls == 0 && l.doors == 0 {
            los.push(res)
        } else {
            nlos.push(res)
        }
    }
    (los, nlos, sigma)
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let s = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
    (m, s)
}

#[test]
fn rssi_statistics_match_the_model() {
    // Shadowing is correlated over ~2 m of walking, so pool four 300 s walks
    // (standard error of the mean about 0.2 dB).
    let (los, nlos, sigma) = residuals(0.0, 1..5);
    assert!(los.len() > 2500, "{}", los.len());
    let (m, s) = mean_std(&los);
    // Integer rounding adds 1/12 dB^2 of variance.
    let expect = (sigma * sigma + 1.0 / 12.0).sqrt();
    assert!(m.abs() < 0.6, "LOS mean residual {m}");
    assert!(
        (s - expect).abs() < 0.15 * expect,
        "LOS residual std {s}, model {expect}"
    );
    // Links through the inner wall carry its attenuation in the model: residual ~0 too.
    assert!(nlos.len() > 1000, "{}", nlos.len());
    let (mn, _) = mean_std(&nlos);
    assert!(mn.abs() < 1.0, "wall-link mean residual {mn}");
}

#[test]
fn injected_nlos_lowers_rssi_by_rate_times_mean() {
    let (los, _, _) = residuals(0.5, 1..3);
    let (m, _) = mean_std(&los);
    // Half the adverts lose N(10, 4) dB (clipped at 0): mean about -5 dB.
    assert!(
        (m + 5.0).abs() < 1.0,
        "mean residual with NLOS rate 0.5: {m}"
    );
}

/// Core PDR step count and walked distance / true distance of one walk.
fn pdr_walked_ratio(site: &fpbp_core::site::Site, r: &SimRequest) -> (usize, usize, f64) {
    use fpbp_core::pdr::{Pdr, PdrConfig};
    let log = simulate(site, r).unwrap();
    let mut pdr = Pdr::new(&PdrConfig::default(), site.spec.map_from_enu_rad);
    for e in &log.events {
        if let LogEvent::Sensor(s) = e {
            pdr.on_sensor(s);
        }
    }
    let steps = pdr.take_steps();
    let truth: Vec<_> = log.trajectory.steps_in_log().collect();
    let walked: f64 = truth.iter().map(|s| s.length_m).sum();
    let pdr_walked: f64 = steps.iter().map(|s| s.length_m).sum();
    (steps.len(), truth.len(), pdr_walked / walked)
}

#[test]
fn walkers_differ_from_the_pdr_step_length_model() {
    // Walker factor sd 0.12: over eight walks the PDR's walked-distance
    // ratio spreads like the drawn factors; with sd 0 it stays near 1.
    let site = two_rooms_site();
    let ratios = |sd: f64| -> Vec<f64> {
        (41..49)
            .map(|seed| {
                let mut r = request(40.0, seed);
                r.profile.imu.walker_step_length_sd_rel = sd;
                pdr_walked_ratio(&site, &r).2
            })
            .collect()
    };
    let spread = |v: &[f64]| {
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    let (with, without) = (ratios(0.12), ratios(0.0));
    assert!(spread(&with) > 0.15, "ratios {with:?}");
    assert!(
        without.iter().all(|r| (r - 1.0).abs() < 0.06),
        "ratios {without:?}"
    );
}

#[test]
fn core_pdr_finds_the_true_steps_and_lengths() {
    let site = two_rooms_site();
    let mut r = request(120.0, 31);
    // A walker whose Weinberg coefficient is the PDR's own.
    r.profile.imu.walker_step_length_sd_rel = 0.0;
    let (found, true_steps, ratio) = pdr_walked_ratio(&site, &r);
    let rel = (found as f64 - true_steps as f64).abs() / true_steps as f64;
    assert!(rel < 0.05, "core PDR: {found} steps, truth {true_steps}");
    eprintln!("PDR distance / true distance = {ratio}");
    assert!(
        (ratio - 1.0).abs() < 0.05,
        "PDR distance / true distance = {ratio}"
    );
}

/// The WiFi profile's scans: 2-4 s apart, results with their own ages
/// (some cached), the throttle at most 4 scans in any 2 minutes.
#[test]
fn wifi_scans_intervals_ages_and_the_throttle() {
    let site = two_rooms_site();
    let mut r = request(600.0, 5);
    r.profile.wifi = Some(crate::wifi::WifiSimConfig {
        layout_spacing_m: 3.0,
        ..Default::default()
    });
    let scans = |r: &SimRequest| -> Vec<fpbp_core::events::WifiScan> {
        simulate(&site, r)
            .unwrap()
            .events
            .into_iter()
            .filter_map(|e| match e {
                LogEvent::Wifi(w) => Some(w),
                _ => None,
            })
            .collect()
    };
    let free = scans(&r);
    assert!(free.len() > 140 && free.len() < 310, "{}", free.len());
    for w in free.windows(2) {
        let dt = (w[1].t_ns - w[0].t_ns) as f64 * 1e-9;
        assert!((2.0..=4.0).contains(&dt), "{dt}");
    }
    let ages: Vec<f64> = free
        .iter()
        .flat_map(|s| {
            s.results
                .iter()
                .map(move |x| (s.t_ns - x.seen_t_ns) as f64 * 1e-9)
        })
        .collect();
    assert!(ages.iter().all(|a| (0.0..=30.0).contains(a)));
    assert!(ages.iter().any(|a| *a > 2.0), "no cached result");
    assert!(free.iter().all(|s| !s.results.is_empty()));
    r.profile.wifi.as_mut().unwrap().throttled = true;
    let thr = scans(&r);
    // 600 s: at most 4 per 120 s window, and the throttle does bite
    assert!(thr.len() <= 4 * 5 + 4 && thr.len() >= 16, "{}", thr.len());
    for (i, s) in thr.iter().enumerate() {
        let in_window = thr[i..]
            .iter()
            .take_while(|o| o.t_ns - s.t_ns < 120_000_000_000)
            .count();
        assert!(in_window <= 4, "{in_window} scans within 2 min");
    }
    // WiFi draws come last: BLE, sensors and truth are those without WiFi
    let mut plain = r.clone();
    plain.profile.wifi = None;
    let a: Vec<LogEvent> = simulate(&site, &plain).unwrap().events;
    let b: Vec<LogEvent> = simulate(&site, &r)
        .unwrap()
        .events
        .into_iter()
        .filter(|e| !matches!(e, LogEvent::Wifi(_)))
        .collect();
    assert_eq!(a, b);
}

/// A simulated log with access points only positions with `wifi-wcentroid`,
/// better than always answering the floor's centre.
#[test]
fn a_log_with_access_points_only_positions() {
    use fpbp_core::engine::replay::replay;
    use fpbp_core::engines::{EngineConfig, build_engine};
    // an open 40 x 30 m floor with APs on a 10 m lattice
    let mut site = two_rooms_site();
    site.floors = vec![fpbp_core::site::open_floor_map(40.0, 30.0, 5.0, 1.0).unwrap()];
    site.spec.floors[0].open_area_m = Some([40.0, 30.0]);
    site.spec.floors[0].pixels_per_meter = Some(5.0);
    let cfg = crate::wifi::WifiSimConfig {
        layout_spacing_m: 10.0,
        ..Default::default()
    };
    site.spec.beacons.clear();
    site.spec.access_points = crate::wifi::access_points(&site, &cfg, 0);
    assert_eq!(site.spec.access_points.len(), 12);
    let mut r = request(300.0, 8);
    r.profile.wifi = Some(cfg);
    let log = simulate(&site, &r).unwrap();
    assert!(!log.events.iter().any(|e| matches!(e, LogEvent::Ble(_))));
    let site = std::sync::Arc::new(site);
    let mut e = build_engine(
        "wifi-wcentroid",
        site.clone(),
        &EngineConfig::default(),
        None,
    )
    .unwrap();
    let out = replay(e.as_mut(), log.events.iter().cloned());
    let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
    assert!(
        errs.len() as f64 >= 0.95 * out.scored.len() as f64,
        "{} of {}",
        errs.len(),
        out.scored.len()
    );
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    let m = &site.floors[0];
    let centre = Vec2::new(m.width_m() / 2.0, m.height_m() / 2.0);
    let centre_err = out
        .scored
        .iter()
        .map(|s| (Vec2::new(s.truth.x_m, s.truth.y_m) - centre).norm())
        .sum::<f64>()
        / out.scored.len() as f64;
    assert!(
        mean < 0.8 * centre_err,
        "wifi {mean} m vs centre {centre_err} m"
    );
}
