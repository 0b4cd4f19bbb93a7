//! A walk that starts in a wing the survey never walked (issue 39): with
//! a radio map surveyed over the west wing of the demo site only, `tcpf`'s
//! own start (global) must converge once the walker is in the surveyed
//! wing.

mod common;

use std::sync::Arc;

use common::demo_site;
use fpbp_core::engine::InitialPosition;
use fpbp_core::engine::replay::replay;
use fpbp_core::engines::{EngineConfig, EngineData, build_engine_with};
use fpbp_core::events::LogEvent;
use fpbp_core::site::Site;
use fpbp_sim::{SimRequest, simulate};

/// The survey walked only west of this, MCS metres.
const SURVEYED_X_M: f64 = 34.0;

/// `events` without the radio readings made while the walker was east of
/// `SURVEYED_X_M` (the last truth point before each reading says where).
fn west_only(events: &[LogEvent]) -> Vec<LogEvent> {
    common::with_truth_x(events)
        .filter(|(x, e)| {
            let radio = matches!(e, LogEvent::Ble(_) | LogEvent::Wifi(_));
            !radio || x.is_some_and(|x| x <= SURVEYED_X_M)
        })
        .map(|(_, e)| e.clone())
        .collect()
}

/// The survey: four simulated walks of 240 s (sim seeds 41-44) with their
/// readings east of `SURVEYED_X_M` left out, as `fpbp calibrate
/// --radio-map` builds it (grids and reference scans).
fn west_wing_map(site: &Site) -> EngineData {
    EngineData {
        radio_map: Some(Arc::new(common::surveyed_map(
            site,
            &[41, 42, 43, 44],
            west_only,
        ))),
        ..EngineData::default()
    }
}

/// Simulated walks of 240 s (sim seeds 1-40) that start at least 4 m
/// into the unsurveyed east wing and later come at least 4 m into the
/// surveyed one; the own start (no told position), engine seed = sim
/// seed. Per walk, the mean error at the truth points inside the
/// surveyed wing 30-60 s after the walker first came into it.
///
/// Issue 39 asks for convergence within 30 s of entering the surveyed
/// wing: 17 of the 18 walks are within 5 m then (mean over the walks
/// 2.40 m). Before `tcpf.offset.reseed_prior_beyond_sd` 14 of 18 (mean
/// 3.50 m): four walks kept a cloud that started in the wrong place
/// 5-11 m off, held there by the phone offset the lost cloud had learned
/// (-14 dB on sim seed 32, whose phone reads as the map), since every
/// re-seeding profiled its surface under that belief. The one left
/// (sim seed 32, 6.6 m) starts at the survey's edge with an offset of
/// -10 dB (the weak readings far east read as a weak phone at the edge)
/// and keeps -5 to -7 dB in the surveyed wing (docs/lab/tcpf-radio-trust.md
/// "The one offset's learning slowed where the map or the cloud is
/// unsure": neither variant there mends it robustly). Per-particle offsets (`tcpf.offset.per_particle`) give 18 of
/// 18 (2.26 m) but cost the real sets' own start (docs/lab/tcpf-radio-trust.md
/// "The unsurveyed-wing start: the phone offset of a lost cloud"). The test
/// guards at least 16 of the walks within 5 m and the mean at most 3 m.
#[test]
fn a_start_in_an_unsurveyed_wing_converges_in_the_surveyed_one() {
    let site = demo_site();
    let data = west_wing_map(&site);
    let (mut walks, mut within, mut sum) = (0, 0, 0.0);
    for seed in 1u64..=40 {
        let log = simulate(&site, &SimRequest::new(240.0, seed)).unwrap();
        let truth: Vec<_> = log
            .events
            .iter()
            .filter_map(|e| match e {
                LogEvent::Truth(t) => Some(*t),
                _ => None,
            })
            .collect();
        if truth.first().is_none_or(|t| t.x_m <= SURVEYED_X_M + 4.0) {
            continue;
        }
        let Some(enter) = truth.iter().find(|t| t.x_m < SURVEYED_X_M - 4.0) else {
            continue;
        };
        let cfg = EngineConfig {
            seed,
            ..EngineConfig::default()
        };
        let mut e = build_engine_with("tcpf", site.clone(), &cfg, None, &data).unwrap();
        let out = replay(e.as_mut(), log.events.iter().cloned());
        let errors: Vec<f64> = out
            .scored
            .iter()
            .filter(|p| {
                let dt = (p.truth.t_ns - enter.t_ns) as f64 / 1e9;
                (30.0..60.0).contains(&dt) && p.truth.x_m <= SURVEYED_X_M
            })
            .filter_map(|p| p.error_m())
            .collect();
        // walks that left the surveyed wing again within 30 s say nothing
        if errors.len() < 50 {
            continue;
        }
        let m = errors.iter().sum::<f64>() / errors.len() as f64;
        eprintln!(
            "seed {seed}: starts at x {:.1} m, in the surveyed wing after {:.0} s; 30-60 s later {m:.2} m",
            truth[0].x_m,
            (enter.t_ns - truth[0].t_ns) as f64 / 1e9
        );
        walks += 1;
        sum += m;
        if m <= 5.0 {
            within += 1;
        }
    }
    let mean = sum / f64::from(walks.max(1));
    eprintln!("{within} of {walks} walks within 5 m 30-60 s after entering; mean {mean:.2} m");
    assert!(walks >= 15, "{walks} walks");
    assert!(within >= 16, "{within} of {walks} walks within 5 m");
    assert!(mean <= 3.0, "mean {mean:.2} m");
}

/// Share of the truth points within the published accuracy radius, in
/// the unsurveyed east wing and in the surveyed west wing, over sim
/// seeds 1-12 (240 s, own start, engine seed = sim seed).
fn within_radius(site: &Arc<Site>, data: &EngineData, cfg: &EngineConfig) -> [(usize, usize); 2] {
    let mut counts = [(0, 0); 2];
    for seed in 1u64..=12 {
        let log = simulate(site, &SimRequest::new(240.0, seed)).unwrap();
        let cfg = EngineConfig {
            seed,
            ..cfg.clone()
        };
        let mut e = build_engine_with("tcpf", site.clone(), &cfg, None, data).unwrap();
        let out = replay(e.as_mut(), log.events.iter().cloned());
        for p in &out.scored {
            let (Some(err), Some(est)) = (p.error_m(), p.estimate) else {
                continue;
            };
            let c = &mut counts[usize::from(p.truth.x_m <= SURVEYED_X_M)];
            c.1 += 1;
            if err <= est.accuracy_m {
                c.0 += 1;
            }
        }
    }
    counts
}

/// The accuracy radius where the survey never went: the readings misfit
/// the map at the cloud there, and the radius widens with the misfit
/// (`tcpf.integrity.fit_accuracy_m_per_z2`), so the east wing's points
/// are within it about as often as the promise says (68 %) instead of
/// half of the time; the surveyed wing's radius stays about as it was.
/// "Without": the same defaults with `fit_accuracy_m_per_z2` 0.
#[test]
fn the_accuracy_radius_widens_where_the_survey_never_went() {
    let site = demo_site();
    let data = west_wing_map(&site);
    let on = EngineConfig::default();
    let mut off = EngineConfig::default();
    off.tcpf.integrity.fit_accuracy_m_per_z2 = 0.0;
    let share = |c: (usize, usize)| c.0 as f64 / c.1.max(1) as f64;
    let [east_off, west_off] = within_radius(&site, &data, &off);
    let [east_on, west_on] = within_radius(&site, &data, &on);
    eprintln!(
        "within the radius, east (unsurveyed) / west: without {:.2} / {:.2}, with {:.2} / {:.2} ({} / {} points)",
        share(east_off),
        share(west_off),
        share(east_on),
        share(west_on),
        east_on.1,
        west_on.1
    );
    // measured: without 0.46 / 0.71, with 0.73 / 0.83
    assert!(
        east_on.1 > 5000 && west_on.1 > 5000,
        "{east_on:?} {west_on:?}"
    );
    assert!(share(east_on) >= 0.65, "east {:.2}", share(east_on));
    assert!(
        share(east_on) >= share(east_off) + 0.15,
        "east {:.2} against {:.2} without the fit term",
        share(east_on),
        share(east_off)
    );
    assert!(share(west_on) <= 0.9, "west {:.2}", share(west_on));
}

/// Mean error in the unsurveyed east wing and in the surveyed west wing,
/// and the mean distance of the east wing's estimates from the survey's
/// edge (x = `SURVEYED_X_M`, positive to the east), over sim seeds
/// 1-24 (240 s, started at the first truth point, engine seed = sim seed).
fn told_start_errors(site: &Arc<Site>, data: &EngineData, cfg: &EngineConfig) -> [f64; 3] {
    let (mut sum, mut n) = ([0.0; 3], [0usize; 2]);
    for seed in 1u64..=24 {
        let log = simulate(site, &SimRequest::new(240.0, seed)).unwrap();
        let t = log.events.iter().find_map(LogEvent::as_truth).unwrap();
        let first = InitialPosition {
            x_m: t.x_m,
            y_m: t.y_m,
            floor: t.floor.unwrap_or_else(|| site.default_floor()),
            heading_rad: None,
        };
        let cfg = EngineConfig {
            seed,
            ..cfg.clone()
        };
        let mut e = build_engine_with("tcpf", site.clone(), &cfg, Some(first), data).unwrap();
        let out = replay(e.as_mut(), log.events.iter().cloned());
        for p in &out.scored {
            let (Some(err), Some(est)) = (p.error_m(), p.estimate) else {
                continue;
            };
            let east = p.truth.x_m > SURVEYED_X_M;
            let k = usize::from(!east);
            sum[k] += err;
            n[k] += 1;
            if east {
                sum[2] += est.x_m - SURVEYED_X_M;
            }
        }
    }
    [
        sum[0] / n[0].max(1) as f64,
        sum[1] / n[1].max(1) as f64,
        sum[2] / n[0].max(1) as f64,
    ]
}

/// Far from the survey (the window unlike every reference scan), the
/// survey's own lines are where the phone is least likely
/// (`tcpf.anchors.far_survey_penalty`): from a told start in the
/// unsurveyed east wing, the track is not drawn west onto the surveyed
/// wing by the map's extrapolation and its anchors. "Without": the same
/// defaults with the penalty 0.
#[test]
fn far_from_the_survey_the_track_is_not_drawn_onto_its_lines() {
    let site = demo_site();
    let data = west_wing_map(&site);
    let on = EngineConfig::default();
    let mut off = EngineConfig::default();
    off.tcpf.anchors.far_survey_penalty = 0.0;
    let [east_off, west_off, depth_off] = told_start_errors(&site, &data, &off);
    let [east_on, west_on, depth_on] = told_start_errors(&site, &data, &on);
    eprintln!(
        "told start, mean error east (unsurveyed) / west: without {east_off:.2} / {west_off:.2} m, \
         with {east_on:.2} / {west_on:.2} m; east estimates' mean x beyond the survey's edge: \
         {depth_off:.2} / {depth_on:.2} m"
    );
    // measured: without 8.49 / 2.78 m, with 7.64 / 2.84 m; depth 7.20 / 7.77 m
    assert!(
        east_on <= 0.95 * east_off,
        "east {east_on:.2} m against {east_off:.2} without the penalty"
    );
    assert!(
        west_on <= west_off + 0.3,
        "west {west_on:.2} m against {west_off:.2}"
    );
    assert!(
        depth_on >= depth_off + 0.25,
        "east estimates {depth_on:.2} m beyond the edge against {depth_off:.2}"
    );
}
