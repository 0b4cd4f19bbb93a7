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
/// "A told floor holds against the anchors"). With `floor_force_after_told` their run of votes moves the
/// track to floor 1 within 10 s, as it moves a start floor the radio
/// chose; without `floor_force_votes` it does not.
#[test]
fn anchors_move_a_wrong_start_floor_against_a_level_barometer() {
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
    let mut cfg = EngineConfig::default();
    cfg.tcpf.anchors.floor_force_after_told = true;
    let on = run_with(&cfg);
    cfg.tcpf.anchors.floor_force_votes = 0;
    let off = run_with(&cfg);
    let (t_told, t_on, t_off) = (first_on(&told, 1), first_on(&on, 1), first_on(&off, 1));
    eprintln!(
        "first pose on floor 1: told floor held {t_told:?} s, forced {t_on:?} s, not forced {t_off:?} s"
    );
    assert_eq!(t_told, None, "the told floor holds");
    let t_on = t_on.expect("the anchors move the track to floor 1");
    assert!(t_on < 10.0, "moved only at {t_on:.1} s");
    assert!(t_off.is_none_or(|t| t > t_on + 5.0), "{t_off:?}");
    assert_eq!(on.track.last().map(|p| p.floor), Some(1));
    // the start floor from the anchors: no start position, no wrong floor
    let mut e =
        TcpfEngine::with_model(site.clone(), &EngineConfig::default(), None, map.clone()).unwrap();
    let own = replay(&mut e, ev.iter().cloned());
    assert_eq!(own.track.first().map(|p| p.floor), Some(1));
}

/// Floor 1 of a two-floor site is walkable only east of x = 16 m; the
/// walker climbs 5 m (barometer) 10 s into the walk north along x = 7 m.
/// The plan has no floor-1 place within `floor_snap_m` of the track: the
/// change is not made (`floor_keep_off_map`) and the track stays on its
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
    let run_with = |keep: bool| {
        let mut cfg = EngineConfig::default();
        cfg.tcpf.floor_keep_off_map = keep;
        let mut e = TcpfEngine::new(site.clone(), &cfg, init).unwrap();
        let out = replay(&mut e, ev.iter().cloned());
        (out, e.counts.floor_changes, e.counts.floor_changes_off_map)
    };
    let (kept, changes, refused) = run_with(true);
    assert_eq!(changes, 0);
    assert!(refused > 0);
    assert!(kept.track.iter().all(|p| p.floor == 0));
    let max_x = kept.track.iter().map(|p| p.x_m).fold(f64::MIN, f64::max);
    assert!(max_x < 10.0, "{max_x:.1} m");
    // the old way: a global start on floor 1, east of x = 16 m
    let (moved, changes, refused) = run_with(false);
    assert!(changes > 0 && refused == 0, "{changes} {refused}");
    let last = moved.track.last().unwrap();
    assert_eq!(last.floor, 1);
    assert!(last.x_m >= 16.0, "{:.1} m", last.x_m);
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
        // a told start reads `far_db_told`
        cfg.tcpf.anchors.far_db_told = far_db;
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

/// A told start begins with the offset prior `offset.prior_sd_db_told`
/// (when set); a global one with `offset.prior_sd_db`.
#[test]
fn a_told_start_begins_with_the_tighter_offset_prior() {
    let mut cfg = EngineConfig::default();
    let engine = |cfg: &EngineConfig, init| {
        let (site, map) = site_with_scans(1, 0, 0.0);
        TcpfEngine::with_model(site, cfg, init, map).unwrap()
    };
    let prior = cfg.tcpf.offset.prior_sd_db;
    // default 0: the told start's prior is the global one's
    let told = engine(&cfg, Some(BEHIND_THE_WALL));
    assert_eq!(told.offset.phone.sd_db(), prior);
    cfg.tcpf.offset.prior_sd_db_told = 2.0;
    let told = engine(&cfg, Some(BEHIND_THE_WALL));
    assert_eq!(told.offset.phone.sd_db(), 2.0);
    let global = engine(&cfg, None);
    assert_eq!(global.offset.phone.sd_db(), prior);
}

/// The far level in force: `anchors.far_db_told` while the cloud comes
/// from a told position, `anchors.far_db` after a global start.
#[test]
fn a_told_start_reads_its_own_far_level() {
    let (site, map) = site_with_scans(1, 0, 0.0);
    let mut cfg = EngineConfig::default();
    cfg.tcpf.anchors.far_db = 12.0;
    cfg.tcpf.anchors.far_db_told = 8.0;
    let mut e = TcpfEngine::with_model(site, &cfg, Some(BEHIND_THE_WALL), map).unwrap();
    e.anchors.survey_dist_db = Some(10.0);
    e.recovery.told_start = true;
    assert!(e.far_from_survey());
    e.recovery.told_start = false;
    assert!(!e.far_from_survey());
    e.anchors.survey_dist_db = Some(13.0);
    assert!(e.far_from_survey());
    e.anchors.survey_dist_db = Some(7.0);
    e.recovery.told_start = true;
    assert!(!e.far_from_survey());
    // 0: the told level off
    cfg.tcpf.anchors.far_db_told = 0.0;
    let (site, map) = site_with_scans(1, 0, 0.0);
    let mut off = TcpfEngine::with_model(site, &cfg, Some(BEHIND_THE_WALL), map).unwrap();
    off.anchors.survey_dist_db = Some(40.0);
    off.recovery.told_start = true;
    assert!(!off.far_from_survey());
}

/// The survey-distance term widens the radius only beyond
/// `anchors.accuracy_free_db`, by `accuracy_per_db_m` per dB in
/// quadrature, and the hold still reads the cloud's own radius.
#[test]
fn a_window_far_from_the_survey_widens_the_radius() {
    let mut cfg = EngineConfig::default();
    cfg.tcpf.anchors.accuracy_free_db = 6.0;
    cfg.tcpf.anchors.accuracy_per_db_m = 1.0;
    let mut e = TcpfEngine::new(site(), &cfg, None).unwrap();
    e.anchors.survey_dist_db = None;
    assert_eq!(e.accuracy_with_survey(3.0), 3.0);
    e.anchors.survey_dist_db = Some(5.0);
    assert_eq!(e.accuracy_with_survey(3.0), 3.0);
    e.anchors.survey_dist_db = Some(10.0);
    assert!((e.accuracy_with_survey(3.0) - 5.0).abs() < 1e-12);
    cfg.tcpf.anchors.accuracy_per_db_m = 0.0;
    let mut off = TcpfEngine::new(site(), &cfg, None).unwrap();
    off.anchors.survey_dist_db = Some(40.0);
    assert_eq!(off.accuracy_with_survey(3.0), 3.0);
    // end to end: scans 30 dB louder than anything heard put the phone
    // far from the survey, and its radius is wider than beside the survey
    let ev = walk_north(30, None);
    let late_radius = |shift_db: f64| {
        let (site, map) = site_with_scans(1, 0, shift_db);
        let mut cfg = EngineConfig::default();
        cfg.tcpf.anchors.accuracy_per_db_m = 1.0;
        let mut e = TcpfEngine::with_model(site, &cfg, None, map).unwrap();
        let out = replay(&mut e, ev.iter().cloned());
        let late: Vec<f64> = out
            .track
            .iter()
            .filter(|p| p.t_ns > 20_000_000_000)
            .map(|p| p.accuracy_m)
            .collect();
        assert!(!late.is_empty());
        late.iter().sum::<f64>() / late.len() as f64
    };
    let (near, far) = (late_radius(0.0), late_radius(30.0));
    assert!(far > near + 10.0, "near {near:.1} m, far {far:.1} m");
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

/// A scan window that matches no reference scan (the survey's scans 30
/// dB louder than anything heard: a place the survey never went) gives
/// no anchors with `drop_far_db` 15 (off by default): none weigh the
/// particles or place the start, and the start does not wait for them.
/// Near the survey, and with the switch off, the anchors stay.
#[test]
fn candidates_far_from_the_phones_window_are_dropped() {
    let ev = walk_north(30, None);
    let run_with = |shift_db: f64, drop_far_db: f64| {
        let (site, map) = site_with_scans(1, 0, shift_db);
        let mut cfg = EngineConfig::default();
        cfg.tcpf.anchors.drop_far_db = drop_far_db;
        let mut e = TcpfEngine::with_model(site, &cfg, None, map).unwrap();
        let out = replay(&mut e, ev.iter().cloned());
        let first = out.track.first().map(|p| p.t_ns).unwrap();
        (first, e.counts.anchor_queries, e.counts.anchors_dropped_far)
    };
    assert_eq!(EngineConfig::default().tcpf.anchors.drop_far_db, 0.0);
    let (_, near_q, near_dropped) = run_with(0.0, 15.0);
    assert!(near_q > 0 && near_dropped == 0, "{near_q} {near_dropped}");
    let (far_first, far_q, far_dropped) = run_with(30.0, 15.0);
    assert!(far_q == 0 && far_dropped > 0, "{far_q} {far_dropped}");
    let (kept_first, kept_q, kept_dropped) = run_with(30.0, 0.0);
    assert!(kept_q > 0 && kept_dropped == 0, "{kept_q} {kept_dropped}");
    // the start waits for no anchor: as early as with the far ones kept
    assert!(far_first <= kept_first, "{far_first} {kept_first}");
}
