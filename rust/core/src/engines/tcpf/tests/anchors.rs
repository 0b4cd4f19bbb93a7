//! Reference-scan anchors: the start floor, the survey's reach, the
//! mixture, the dropped candidates.

use super::*;

/// A two-floor copy of the test site whose radio map carries reference
/// scans of the walk heard on floor 1 only, the walker's barometer level.
fn two_floors_with_scans_on_1() -> (Arc<Site>, Arc<crate::radio::RadioMap>, Vec<LogEvent>) {
    let (site, map) = site_with_scans(2, 1, 0.0);
    let mut ev = walk_north(30, None);
    for i in 0..300 {
        ev.push(LogEvent::Sensor(SensorEvent {
            t_ns: i * 100_000_000 + 1,
            data: SensorData::Pressure(1000.0),
        }));
    }
    ev.sort_by_key(|e| e.t_ns());
    (site, map, ev)
}

/// First time the track is on floor `f`, s.
fn first_on(out: &ReplayOutput, f: i32) -> Option<f64> {
    out.track
        .iter()
        .find(|p| p.floor == f)
        .map(|p| p.t_ns as f64 * 1e-9)
}

/// The survey's scans, all on floor 1, match what the walker hears; the
/// barometer stays level; the walker is told floor 0. By default the told
/// floor holds: on a route the survey never walked the anchors can name
/// the floor above or below for many updates in a row (IPIN, docs/tcpf.md
/// "A told floor holds against the anchors").
#[test]
fn a_told_floor_holds_and_the_own_start_takes_the_anchors_floor() {
    let (site, map, ev) = two_floors_with_scans_on_1();
    let init = Some(InitialPosition {
        x_m: 7.0,
        y_m: 4.0,
        floor: 0,
        heading_rad: None,
    });
    let run_with = |cfg: &EngineConfig| {
        let mut e = TcpfEngine::with_model(site.clone(), cfg, init, map.clone()).unwrap();
        replay(&mut e, ev.iter().cloned())
    };
    let told = run_with(&EngineConfig::default());
    assert_eq!(first_on(&told, 1), None, "the told floor holds");
    // the start floor from the anchors: no start position, no wrong floor
    let mut e =
        TcpfEngine::with_model(site.clone(), &EngineConfig::default(), None, map.clone()).unwrap();
    let own = replay(&mut e, ev.iter().cloned());
    assert_eq!(own.track.first().map(|p| p.floor), Some(1));
}

/// Floor 1 of a two-floor site is walkable only east of x = 16 m; the
/// walker climbs 5 m (barometer) 10 s into the walk north along x = 7 m.
/// The plan has no floor-1 place within `floor_snap_m` of the track: the
/// change is not made and the track stays on its
/// line, where a global start on floor 1 would move it 9+ m east.
#[test]
fn a_floor_change_off_the_new_floors_plan_is_not_made() {
    use crate::map::Feature;
    let (w, h) = (40usize, 80usize);
    let mut f = vec![Feature::Wall; w * h];
    for j in 0..h {
        for i in 32..w {
            f[j * w + i] = Feature::Walkable;
        }
    }
    let east_only = crate::map::FloorMap::from_features(w, h, 2.0, f);
    let bs: Vec<(f64, f64)> = beacons().iter().map(|p| (p.x, p.y)).collect();
    let site =
        crate::site::testkit::beacon_site("two-floors", vec![walled_map(), east_only], &bs, MODEL);
    let mut ev = walk_north(30, None);
    for i in 0..300 {
        let climbed = (f64::from(i) / 10.0 - 10.0).clamp(0.0, 1.0);
        ev.push(LogEvent::Sensor(SensorEvent {
            t_ns: i64::from(i) * 100_000_000 + 1,
            data: SensorData::Pressure(1000.0 - 0.6 * climbed),
        }));
    }
    ev.sort_by_key(|e| e.t_ns());
    let init = Some(InitialPosition {
        x_m: 7.0,
        y_m: 4.0,
        floor: 0,
        heading_rad: None,
    });
    let run = || {
        let cfg = EngineConfig::default();
        let mut e = TcpfEngine::new(site.clone(), &cfg, init).unwrap();
        let out = replay(&mut e, ev.iter().cloned());
        (out, e.counts.floor_changes, e.counts.floor_changes_off_map)
    };
    let (kept, changes, refused) = run();
    assert_eq!(changes, 0);
    assert!(refused > 0);
    assert!(kept.track.iter().all(|p| p.floor == 0));
    let max_x = kept.track.iter().map(|p| p.x_m).fold(f64::MIN, f64::max);
    assert!(max_x < 10.0, "{max_x:.1} m");
}

#[test]
fn far_from_the_survey_the_cloud_is_not_reseeded_from_the_radio() {
    // the wrong start of `recovers_from_a_wrong_start_in_the_other_room`,
    // with a radio map carrying reference scans along the walk: scans the
    // phone resembles let the surface re-seed the cloud; scans 30 dB
    // louder than anything heard say the phone is far from the survey,
    // where the map is its own extrapolation: no re-seeding
    let ev = walk_north(30, None);
    let init = Some(BEHIND_THE_WALL);
    let late_error = error_after_20_s;
    let run_with = |shift_db: f64, far_db: f64| {
        let (site, map) = site_with_scans(1, 0, shift_db);
        let mut cfg = EngineConfig::default();
        cfg.tcpf.anchors.far_db = far_db;
        let mut e = TcpfEngine::with_model(site, &cfg, init, map).unwrap();
        let out = replay(&mut e, ev.iter().cloned());
        let c = &e.counts;
        assert!(c.far_updates <= c.radio_updates);
        (out, c.reseeded, c.reseed_far, c.far_updates)
    };
    let (near, near_reseeded, near_far, near_updates) = run_with(0.0, 12.0);
    assert!(
        near_reseeded > 0 && near_far == 0 && near_updates == 0,
        "{near_reseeded} {near_far} {near_updates}"
    );
    assert!(late_error(&near) < 3.0, "{:.1} m", late_error(&near));
    let (far, far_reseeded, far_far, far_updates) = run_with(30.0, 12.0);
    assert_eq!(far_reseeded, 0);
    assert!(far_far > 0 && far_updates > 0, "{far_far} {far_updates}");
    // still lost near its wrong start (seeds 1-10: 9.1-10.4 m far, 1.4-2.0
    // m near, with the stop-31 roughening that spreads the cloud more)
    assert!(late_error(&far) > 6.0, "{:.1} m", late_error(&far));
    // the gate off: the same survey re-seeds
    let (_, off_reseeded, _, off_updates) = run_with(30.0, 0.0);
    assert!(off_reseeded > 0 && off_updates == 0);
}

#[test]
fn the_batched_anchor_mixture_is_the_per_point_one() {
    // anchors on two floors (the other floor's left out), points near and
    // far (exp underflows), to the bit
    let anchors: Vec<Anchor> = (0..9)
        .map(|k| Anchor {
            floor: i32::from(k % 4 == 3),
            pos: Vec2::new(3.0 * f64::from(k), 20.0 - 2.5 * f64::from(k)),
            w: 0.05 + 0.02 * f64::from(k),
            dist_db: 0.0,
        })
        .collect();
    let ps: Vec<Vec2> = (0..777)
        .map(|i| Vec2::new(f64::from(i % 37) * 0.9 - 3.0, f64::from(i / 37) * 1.3))
        .chain([Vec2::new(5e3, -7e3)])
        .collect();
    for (floor, sigma_m) in [(0, 8.0), (1, 4.0), (2, 8.0)] {
        let mut out = vec![7.0];
        anchor_mix_many(&anchors, floor, &ps, sigma_m, &mut out);
        assert_eq!(out.len(), ps.len() + 1);
        for (p, m) in ps.iter().zip(&out[1..]) {
            assert_eq!(
                m.to_bits(),
                anchor_mix(&anchors, floor, *p, sigma_m).to_bits()
            );
        }
    }
}
