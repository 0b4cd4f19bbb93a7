//! Engine `tcpf` on simulated walks of the demo site: the two-phone case of
//! issue 16 (the same walk heard by a phone 9 dB weaker), a start from a
//! scan far from the walks, the published track against the walls, the
//! wrong-wing maps, and engines sharing one radio map.

mod common;

use std::path::Path;
use std::sync::Arc;

use common::demo_site;
use fpbp_core::Vec2;
use fpbp_core::engine::replay::{ReplayOutput, replay};
use fpbp_core::engine::{Pose, track_segment_crosses_wall};
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::LogEvent;
use fpbp_core::site::Site;
use fpbp_sim::{SimRequest, simulate};

fn run(site: &Arc<Site>, events: &[LogEvent], seed: u64) -> ReplayOutput {
    run_with(site, events, seed, &EngineConfig::default())
}

fn run_with(site: &Arc<Site>, events: &[LogEvent], seed: u64, cfg: &EngineConfig) -> ReplayOutput {
    let cfg = EngineConfig {
        seed,
        ..cfg.clone()
    };
    let mut e = build_engine("tcpf", site.clone(), &cfg, None).unwrap();
    replay(e.as_mut(), events.iter().cloned())
}

/// The pose of `track` at or just before `t_ns`.
fn at(track: &[Pose], t_ns: i64) -> Option<Pose> {
    let k = track.partition_point(|p| p.t_ns <= t_ns);
    k.checked_sub(1).map(|i| track[i])
}

/// The same walk heard by a second phone reading every beacon 9 dB weaker
/// (readings pushed below `min_rssi_dbm` = -100 dBm are lost, as a weaker
/// phone loses them): issue 16's "same track within 1 m after the offset
/// converges", as the median separation of the two tracks after 60 s over
/// six simulated walks. Met with each particle carrying its own offset,
/// the default on a site without a radio map such as this one
/// (`offset.per_particle_without_map`; with a radio map it cost ILC F1
/// and IPIN odd 0.1-0.2 m and is off there; docs/tcpf.md "Two phones").
#[test]
fn a_phone_nine_db_weaker_is_seen_as_one() {
    let site = demo_site();
    let cfg = EngineConfig::default();
    let mut sep = Vec::new();
    let mut offsets = Vec::new();
    for seed in 3u64..=8 {
        let log = simulate(&site, &SimRequest::new(180.0, seed)).unwrap();
        let weak: Vec<LogEvent> = log
            .events
            .iter()
            .cloned()
            .map(|e| match e {
                LogEvent::Ble(mut b) => {
                    b.rssi_dbm -= 9.0;
                    LogEvent::Ble(b)
                }
                other => other,
            })
            .collect();
        let a = run_with(&site, &log.events, 1, &cfg);
        let b = run_with(&site, &weak, 1, &cfg);
        let (oa, ob) = (
            a.stats.rssi_offset_db.unwrap(),
            b.stats.rssi_offset_db.unwrap(),
        );
        offsets.push(oa - ob);
        let t0 = log.events[0].t_ns();
        for p in a.track.iter().filter(|p| p.t_ns - t0 > 60_000_000_000) {
            if let Some(q) = at(&b.track, p.t_ns) {
                sep.push((p.x_m - q.x_m).hypot(p.y_m - q.y_m));
            }
        }
    }
    sep.sort_by(f64::total_cmp);
    let (median, p90) = (sep[sep.len() / 2], sep[sep.len() * 9 / 10]);
    eprintln!(
        "two phones: offsets apart {offsets:?} dB, track separation after 60 s median {median:.2} m, p90 {p90:.2} m"
    );
    // With each particle carrying its own offset (docs/tcpf.md "Two
    // phones") the tracks are a median 0.61 m apart after 60 s over walks
    // 3-8 (one offset for the whole cloud, the default before: 5.27 m); walks 3
    // and 4 alone 1.21 m (9.72 m with the default). Not everywhere: the p90 is 7.5 m, on walk 3
    // the weaker phone's start lands wrong and stays 11 m off. The
    // offsets end 5-6 dB apart, not 9: the weaker phone loses the readings
    // pushed below -100 dBm, the far beacons that the simulator's walls
    // attenuate more than the path-loss model expects (their residuals
    // pull the reference phone's offset to -7 dB).
    assert!(
        median < 1.0,
        "separation after 60 s: median {median:.2} m, p90 {p90:.2} m"
    );
    for d in &offsets {
        assert!(
            (4.0..12.0).contains(d),
            "offset difference {d:.2} dB, want most of the 9 dB"
        );
    }
}

/// The floor of the two-phone measure: the very same readings replayed
/// with engine seeds 1 and 2 (no offset at all) give tracks a median
/// 0.18 m apart after 60 s over simulated walks 4, 5, 7 and 8 (p90
/// 0.46 m): the filter's own divergence leaves room for the 1 m;
/// the two-phone case misses it through the offset and the start
/// (`a_phone_nine_db_weaker_is_seen_as_one`).
#[test]
fn the_same_readings_with_another_engine_seed_stay_within_a_metre() {
    let site = demo_site();
    let mut sep = Vec::new();
    for sim in [4u64, 5, 7, 8] {
        let log = simulate(&site, &SimRequest::new(180.0, sim)).unwrap();
        let (a, b) = (run(&site, &log.events, 1), run(&site, &log.events, 2));
        let t0 = log.events[0].t_ns();
        for p in a.track.iter().filter(|p| p.t_ns - t0 > 60_000_000_000) {
            if let Some(q) = at(&b.track, p.t_ns) {
                sep.push((p.x_m - q.x_m).hypot(p.y_m - q.y_m));
            }
        }
    }
    assert!(sep.len() > 1000, "{} poses compared", sep.len());
    sep.sort_by(f64::total_cmp);
    let (median, p90) = (sep[sep.len() / 2], sep[sep.len() * 9 / 10]);
    eprintln!("engine seeds 1 vs 2: separation after 60 s median {median:.2} m, p90 {p90:.2} m");
    assert!(
        median < 1.0 && p90 < 1.0,
        "separation median {median:.2} m, p90 {p90:.2} m"
    );
}

/// A first scan heard far from where the transmitters' strongest readings
/// are still gives a pose, with a broad accuracy radius, not a sharp
/// wrong one.
#[test]
fn a_weak_first_scan_gives_a_broad_cloud() {
    let site = demo_site();
    let log = simulate(&site, &SimRequest::new(20.0, 5)).unwrap();
    // only the weakest readings survive the first 3 s
    let t0 = log.events[0].t_ns();
    let events: Vec<LogEvent> = log
        .events
        .iter()
        .filter(|e| match e {
            LogEvent::Ble(b) => e.t_ns() - t0 > 3_000_000_000 || b.rssi_dbm < -85.0,
            _ => true,
        })
        .cloned()
        .collect();
    let out = run(&site, &events, 1);
    let first = out.track.first().expect("a pose");
    assert!(first.t_ns - t0 < 3_000_000_000, "first pose after 3 s");
    let truth = out
        .scored
        .first()
        .map(|s| Vec2::new(s.truth.x_m, s.truth.y_m));
    if let Some(t) = truth {
        let err = (first.x_m - t.x).hypot(first.y_m - t.y);
        assert!(
            first.accuracy_m >= 0.5 * err,
            "accuracy {:.1} m for an error of {err:.1} m",
            first.accuracy_m
        );
    }
    assert!(
        first.accuracy_m >= 5.0,
        "accuracy {:.1} m",
        first.accuracy_m
    );
}

/// Issue 16: "the published track never crosses a wall on the shipped
/// logs". Every shipped log, engine seeds 1-3, counted with the check
/// `fpbp eval` counts wall crossings with (`track_segment_crosses_wall`).
/// Before the published point walked through the doors, tcpf's tracks
/// crossed 2.4 times per 100 m (33 segments over the 8 logs, seed 1).
#[test]
fn the_published_track_never_crosses_a_wall_on_the_shipped_logs() {
    let site = demo_site();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../host-tests/logs");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".log.gz"))
        .collect();
    files.sort();
    assert!(files.len() >= 8, "shipped logs: {files:?}");
    let opts = fpbp_logs::ReadOptions {
        default_floor: Some(site.default_floor()),
        ..Default::default()
    };
    let (mut segments, mut crossings, mut length_m) = (0usize, Vec::new(), 0.0);
    for f in &files {
        let (events, _) = fpbp_logs::read_all(f, &opts).unwrap();
        for seed in 1..=3u64 {
            let out = run(&site, &events, seed);
            assert!(
                out.track.len() > 100,
                "{}: {} poses",
                f.display(),
                out.track.len()
            );
            for w in out.track.windows(2) {
                segments += 1;
                length_m += (w[1].x_m - w[0].x_m).hypot(w[1].y_m - w[0].y_m);
                if track_segment_crosses_wall(&site, &w[0], &w[1]) {
                    crossings.push((f.file_name().unwrap().to_owned(), seed, w[0], w[1]));
                }
            }
        }
    }
    eprintln!(
        "{} logs x 3 seeds: {segments} segments, {length_m:.0} m, {} wall crossings",
        files.len(),
        crossings.len()
    );
    assert!(length_m > 1000.0, "tracks of {length_m:.0} m");
    assert!(crossings.is_empty(), "crossings: {crossings:?}");
}

/// The demo site's path-loss model, wrong by 10 dB east of `WING_X_M`:
/// there every transmitter's expected RSSI is 10 dB off, stronger for
/// even-numbered transmitters and weaker for odd ones (a phone offset
/// cannot explain it away), as a radio map is where its survey went
/// wrong or a transmitter moved.
struct WrongWing(fpbp_core::radio::PathLossModel);

const WING_X_M: f64 = 34.0;

impl fpbp_core::radio::RadioModel for WrongWing {
    fn transmitters(&self) -> &[fpbp_core::radio::Transmitter] {
        self.0.transmitters()
    }

    fn lookup(&self, kind: fpbp_core::radio::TxKind, id: &str) -> Option<usize> {
        self.0.lookup(kind, id)
    }

    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        let (mu, sd) = self.0.expected(tx, floor, p)?;
        let off = if p.x <= WING_X_M {
            0.0
        } else if tx % 2 == 0 {
            10.0
        } else {
            -10.0
        };
        Some((mu + off, sd))
    }
}

/// `tcpf` recording its radio trust after every task run.
struct TrustRecorder {
    e: fpbp_core::engines::tcpf::TcpfEngine,
    trust: std::sync::Arc<std::sync::Mutex<f64>>,
}

impl fpbp_core::engine::Engine for TrustRecorder {
    fn name(&self) -> &'static str {
        "tcpf"
    }
    fn on_sensor(&mut self, ev: &fpbp_core::events::SensorEvent) {
        self.e.on_sensor(ev)
    }
    fn on_ble(&mut self, obs: &fpbp_core::events::BleObservation) {
        self.e.on_ble(obs)
    }
    fn on_wifi(&mut self, scan: &fpbp_core::events::WifiScan) {
        self.e.on_wifi(scan)
    }
    fn run_task(&mut self, task: fpbp_core::engine::Task, t_ns: i64) {
        self.e.run_task(task, t_ns);
        *self.trust.lock().unwrap() = self.e.radio_trust();
    }
    fn task_period_ns(&self, task: fpbp_core::engine::Task) -> Option<i64> {
        self.e.task_period_ns(task)
    }
    fn pose(&self) -> Option<Pose> {
        self.e.pose()
    }
    fn stats(&self) -> fpbp_core::engine::EngineStats {
        self.e.stats()
    }
}

/// Errors at the truth points east of `WING_X_M` (in order, `None`
/// without a pose) and the radio's trust there and elsewhere, of one
/// engine over the walks of [`wing_walks`].
struct WingRun {
    wing_errors: Vec<Option<f64>>,
    trust_in: Vec<f64>,
    trust_out: Vec<f64>,
}

/// One walk of the wrong-wing case: sim seed, log, told start.
type WingWalk = (u64, fpbp_sim::SimLog, fpbp_core::engine::InitialPosition);

/// The wrong-wing case's walks (demo site, 180 s, sim seeds 1-8) with
/// their first truth point as the told start.
fn wing_walks(site: &Arc<Site>) -> Vec<WingWalk> {
    (1u64..=8)
        .map(|seed| {
            let log = simulate(site, &SimRequest::new(180.0, seed)).unwrap();
            let t0 = log
                .events
                .iter()
                .find_map(|e| match e {
                    LogEvent::Truth(t) => Some(*t),
                    _ => None,
                })
                .expect("a truth point");
            let init = fpbp_core::engine::InitialPosition {
                x_m: t0.x_m,
                y_m: t0.y_m,
                floor: t0.floor.unwrap_or(0),
                heading_rad: None,
            };
            (seed, log, init)
        })
        .collect()
}

/// `tcpf` with `cfg` on the wrong-wing model (or `pdr` when `cfg` is
/// `None`) over `walks`, engine seed = sim seed. The model: `map` (a
/// radio map surveyed wrong in the wing, [`wrong_wing_map`]), or else the
/// path-loss model made wrong there ([`WrongWing`]).
fn wing_run(
    site: &Arc<Site>,
    walks: &[WingWalk],
    cfg: Option<&EngineConfig>,
    map: Option<&Arc<dyn fpbp_core::radio::RadioModel>>,
) -> WingRun {
    use fpbp_core::engine::replay::Replayer;
    use fpbp_core::engines::tcpf::TcpfEngine;
    let mut run = WingRun {
        wing_errors: Vec::new(),
        trust_in: Vec::new(),
        trust_out: Vec::new(),
    };
    for (seed, log, init) in walks {
        let out = match cfg {
            None => {
                let c = EngineConfig {
                    seed: *seed,
                    ..EngineConfig::default()
                };
                let mut pdr = build_engine("pdr", site.clone(), &c, Some(*init)).unwrap();
                replay(pdr.as_mut(), log.events.iter().cloned())
            }
            Some(cfg) => {
                let c = EngineConfig {
                    seed: *seed,
                    ..cfg.clone()
                };
                let model: Arc<dyn fpbp_core::radio::RadioModel> = match map {
                    Some(m) => Arc::clone(m),
                    None => Arc::new(WrongWing(fpbp_core::radio::PathLossModel::for_site(
                        site,
                        TcpfEngine::path_loss_params(&c),
                    ))),
                };
                let trust = Arc::new(std::sync::Mutex::new(1.0));
                let mut rec = TrustRecorder {
                    e: TcpfEngine::with_model(site.clone(), &c, Some(*init), model).unwrap(),
                    trust: trust.clone(),
                };
                // the trust at each truth point (after the last task run
                // before it), by where the walker is
                let mut r = Replayer::new(&mut rec);
                for ev in &log.events {
                    r.push(ev);
                    if let LogEvent::Truth(tp) = ev {
                        let t = *trust.lock().unwrap();
                        if tp.x_m > WING_X_M {
                            run.trust_in.push(t);
                        } else {
                            run.trust_out.push(t);
                        }
                    }
                }
                r.finish()
            }
        };
        for p in out.scored.iter().filter(|p| p.truth.x_m > WING_X_M) {
            run.wing_errors.push(p.error_m());
        }
    }
    run
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The fit check's promise in the wrong wing: its error there (`f`)
/// within 1.1 x `pdr`'s (`q`), its trust in the wing (`ti`) well below
/// the trust outside (`to`).
fn assert_the_fit_check_holds_the_wing(f: f64, q: f64, ti: f64, to: f64) {
    assert!(
        f <= 1.1 * q,
        "fit check {f:.2} m against pdr {q:.2} m in the wrong wing"
    );
    assert!(
        ti < to - 0.3,
        "fit check's trust in the wing {ti:.2}, outside {to:.2}"
    );
}

/// The wing's points where every run has a pose: their count, the
/// number of wing points, and each run's mean error over them.
fn wing_means(runs: &[&WingRun]) -> (usize, usize, Vec<f64>) {
    let n = runs[0].wing_errors.len();
    assert!(runs.iter().all(|r| r.wing_errors.len() == n));
    let both: Vec<usize> = (0..n)
        .filter(|&i| runs.iter().all(|r| r.wing_errors[i].is_some()))
        .collect();
    assert!(both.len() > 50, "{} wing points", both.len());
    let means = runs
        .iter()
        .map(|r| {
            mean(
                &both
                    .iter()
                    .filter_map(|&i| r.wing_errors[i])
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    (both.len(), n, means)
}

/// Issue 39's integrity case: a radio model 10 dB wrong over the east
/// wing of the demo site, walks started at their first truth point.
/// The fit check (on by default, `tcpf.integrity.fit_free_z2` 1.7): the
/// track's error at the truth points in the wing is within 1.1 x `pdr`'s,
/// and the radio's trust is lower in the wing than outside it.
///
/// Guards the check alone (the told start's reach off in both runs): an
/// option that changes nothing, or a trust that never drops, fails.
/// Figures printed with `--nocapture` (seeds 1-8: fit check 5.31 m,
/// without it 19.44 m, `pdr` 5.65 m; the deleted pull check gave 12.16 m:
/// docs/lab/tcpf-deleted-mechanisms.md).
#[test]
fn a_radio_wrong_over_one_wing_is_not_followed_there_from_a_known_start() {
    let site = demo_site();
    let walks = wing_walks(&site);
    // the fit check is on by default; the other run turns it off
    // the check alone: without the told start's reach (`told_reach_m`,
    // tested below), which bounds all three runs
    let mut fit_cfg = EngineConfig::default();
    fit_cfg.tcpf.told_reach_m = 0.0;
    let mut off_cfg = fit_cfg.clone();
    off_cfg.tcpf.integrity.fit_free_z2 = 0.0;
    let fit = wing_run(&site, &walks, Some(&fit_cfg), None);
    let off = wing_run(&site, &walks, Some(&off_cfg), None);
    let pdr = wing_run(&site, &walks, None, None);
    let (both, n, means) = wing_means(&[&fit, &off, &pdr]);
    let [f, o, q] = means[..] else { unreachable!() };
    eprintln!(
        "wing ({both} of {n} points): tcpf fit check {f:.2} m, without {o:.2} m, pdr {q:.2} m"
    );
    let (ti, to) = (mean(&fit.trust_in), mean(&fit.trust_out));
    eprintln!("fit check's mean radio trust in the wing {ti:.2}, outside {to:.2}");
    assert_the_fit_check_holds_the_wing(f, q, ti, to);
    assert!(f <= 0.8 * o, "fit check {f:.2} m, without {o:.2} m");
}

/// The told start's reach (`tcpf.told_reach_m` 3 m +
/// `told_reach_per_walked` 0.1 x the distance walked around the wedge of
/// the steps' displacement, `told_reach_weight` 10; on by default) in the
/// same wrong wing, alone (the fit check off): the radio cannot carry a
/// cloud told where it started beyond the steps' drift from the
/// dead-reckoned track, so the error in the wing is at most 0.9 x the
/// error without the reach (measured 16.22 m against 19.44, seeds 1-8;
/// the disc of 3 m + 0.3 m per metre walked around the dead-reckoned
/// point gave 16.02: the walks are minutes long, and either reach grows
/// with them to the wing's size; the walls also release it where they
/// kill the cloud); with the defaults (the fit check too) within 1.1 x
/// `pdr`'s (5.32 m against 5.65: the fit check does the work here).
/// Figures printed with `--nocapture`.
#[test]
fn a_told_start_is_not_carried_beyond_the_steps_reach() {
    let site = demo_site();
    let walks = wing_walks(&site);
    let mut reach_cfg = EngineConfig::default();
    reach_cfg.tcpf.integrity.fit_free_z2 = 0.0;
    let mut off_cfg = reach_cfg.clone();
    off_cfg.tcpf.told_reach_m = 0.0;
    let reach = wing_run(&site, &walks, Some(&reach_cfg), None);
    let off = wing_run(&site, &walks, Some(&off_cfg), None);
    let def = wing_run(&site, &walks, Some(&EngineConfig::default()), None);
    let pdr = wing_run(&site, &walks, None, None);
    let (both, n, means) = wing_means(&[&reach, &off, &def, &pdr]);
    let [r, o, d, q] = means[..] else {
        unreachable!()
    };
    eprintln!(
        "wing ({both} of {n} points): told reach alone {r:.2} m, neither {o:.2} m, defaults \
         {d:.2} m, pdr {q:.2} m"
    );
    assert!(r <= 0.9 * o, "told reach {r:.2} m, without {o:.2} m");
    assert!(d <= 1.1 * q, "defaults {d:.2} m, pdr {q:.2} m");
}

/// A radio map surveyed wrong over the east wing: four simulated survey
/// walks (240 s, sim seeds 41-44) over the whole demo site, their
/// readings made east of `WING_X_M` 10 dB off as [`WrongWing`] has it
/// (stronger for even-numbered transmitters, weaker for odd ones), as
/// when transmitters were moved or re-powered there after the survey.
fn wrong_wing_map(site: &Site) -> Arc<dyn fpbp_core::radio::RadioModel> {
    use fpbp_core::radio::{PathLossModel, RadioModel, TxKind};
    let index = PathLossModel::for_site(
        site,
        fpbp_core::engines::tcpf::TcpfEngine::path_loss_params(&EngineConfig::default()),
    );
    let off = |kind: TxKind, id: &str| match index.lookup(kind, id) {
        Some(tx) if tx % 2 == 0 => 10.0,
        Some(_) => -10.0,
        None => 0.0,
    };
    let wrong_in_the_wing = |events: &[LogEvent]| {
        common::with_truth_x(events)
            .map(|(x, e)| {
                let wing = x.is_some_and(|x| x > WING_X_M);
                match e {
                    LogEvent::Ble(o) if wing => {
                        let mut o = o.clone();
                        o.rssi_dbm += off(TxKind::Ble, &o.beacon_id);
                        LogEvent::Ble(o)
                    }
                    LogEvent::Wifi(s) if wing => {
                        let mut s = s.clone();
                        for r in &mut s.results {
                            r.rssi_dbm += off(TxKind::Wifi, &r.bssid);
                        }
                        LogEvent::Wifi(s)
                    }
                    _ => e.clone(),
                }
            })
            .collect()
    };
    Arc::new(common::surveyed_map(
        site,
        &[41, 42, 43, 44],
        wrong_in_the_wing,
    ))
}

/// The same case with a radio map whose survey went wrong over the
/// wing ([`wrong_wing_map`]), walks started at their first truth point.
/// - The defaults (the fit check with a map, `fit_free_z2` 1.7, read
///   against the survey's own misfit, `fit_local_cell_m` 4, never holding
///   the re-seeding, `fit_reseed_min_trust` 0; with the told start's
///   reach, `told_reach_m`): the track's error in the wing within 1.1 x
///   `pdr`'s (measured 4.21 m against 5.65; 5.25 m before the reach) and
///   the radio's trust lower there than outside (0.62 / 0.96): the
///   survey's scans fit the wrong map in the wing, so the local level does
///   not excuse the walk's misfit there.
/// - Without the fit check (`fit_free_z2` 0, the earlier default; the
///   reach on): more error in the wing (measured 5.25 m) and a trust of 1
///   in and out.
///
/// Figures printed with `--nocapture`.
#[test]
fn a_radio_map_wrong_over_one_wing_is_not_followed_there() {
    let site = demo_site();
    let walks = wing_walks(&site);
    let map = wrong_wing_map(&site);
    let default_cfg = EngineConfig::default();
    let mut off_cfg = EngineConfig::default();
    off_cfg.tcpf.integrity.fit_free_z2 = 0.0;
    let def = wing_run(&site, &walks, Some(&default_cfg), Some(&map));
    let off = wing_run(&site, &walks, Some(&off_cfg), Some(&map));
    let pdr = wing_run(&site, &walks, None, None);
    let (both, n, means) = wing_means(&[&def, &off, &pdr]);
    let [d, o, q] = means[..] else { unreachable!() };
    let (di, dout) = (mean(&def.trust_in), mean(&def.trust_out));
    let (oi, oout) = (mean(&off.trust_in), mean(&off.trust_out));
    eprintln!(
        "radio map wrong in the wing ({both} of {n} points): defaults {d:.2} m, without the fit \
         check {o:.2} m, pdr {q:.2} m; radio trust in the wing / outside: defaults \
         {di:.2} / {dout:.2}, without the fit check {oi:.2} / {oout:.2}"
    );
    assert_the_fit_check_holds_the_wing(d, q, di, dout);
    assert!(d < o, "defaults {d:.2} m, without the fit check {o:.2} m");
}

/// The grids `tcpf` derives from a radio map (the survey's own misfit per
/// place, the distance to its walks) are built once per map and shared by
/// every engine on it (`fpbp_core::radio::derived`): an engine on a map
/// other engines have used gives, to the bit, the track of an engine on a
/// fresh copy of the map.
#[test]
fn engines_sharing_a_radio_map_give_the_track_of_one_alone() {
    use fpbp_core::engines::{EngineData, build_engine_with};
    use fpbp_core::radio::RadioModel;
    let site = demo_site();
    let map = common::surveyed_map(&site, &[1, 2, 3, 4, 5, 6], |e| e.to_vec());
    let log = simulate(&site, &SimRequest::new(120.0, 7)).unwrap();
    let track = |data: &EngineData| {
        let cfg = EngineConfig {
            seed: 3,
            ..EngineConfig::default()
        };
        let mut e = build_engine_with("tcpf", site.clone(), &cfg, None, data).unwrap();
        replay(e.as_mut(), log.events.iter().cloned()).track
    };
    let shared = Arc::new(map.clone());
    let data = EngineData {
        radio_map: Some(shared.clone()),
        ..EngineData::default()
    };
    let first = track(&data);
    let kept = shared.derived().map_or(0, |d| d.len());
    assert!(kept >= 1, "the first engine kept {kept} derived grids");
    let second = track(&data);
    let fresh = track(&EngineData {
        radio_map: Some(Arc::new(map)),
        ..EngineData::default()
    });
    assert!(!first.is_empty());
    assert_eq!(first, second, "a second engine on the shared map");
    assert_eq!(first, fresh, "an engine on a fresh copy of the map");
}
