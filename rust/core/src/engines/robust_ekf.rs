//! Engine `robust-ekf` (BMW paper): BLE fingerprinting (sub-databases by
//! affinity propagation + WKNN), PDR speed and heading, and an EKF with state
//! [x, y, v, phi] (eqs. 20-21, in the MCS instead of east/north) whose gain
//! uses IGG3 equivalent weights (eqs. 22-24); floors from the barometric
//! floor tracker (eqs. 25-26, Table 2).
//!
//! Tasks: the Fusion task predicts (eq. 20) and updates with the PDR speed
//! and heading of the steps since the last run (speed 0 when none); the BLE
//! task updates the position with the WKNN fix. Step length is the PDR's
//! C * (Amax - Amin)^(1/4) with C = `pdr.step_length_beta`.
//!
//! The fingerprint databases are a walked survey database when one is given
//! ([`RobustEkfEngine::with_fingerprints`], built by
//! [`crate::fingerprint::SurveyBuilder`]), else the site's path-loss models
//! at walkable grid points (eq. 6 applied to every point); either way every
//! floor is clustered before the first BLE task call.

use std::collections::BTreeMap;
use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use crate::Result;
use crate::Vec2;
use crate::ble::{BleConfig, BleFrontEnd};
use crate::engine::Task as T;
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorEvent};
use crate::fingerprint::{FingerprintSet, wknn};
use crate::floor::FloorTracker;
use crate::kalman::{EkfConfig, robust_update, wrap_pi};
use crate::pdr::Pdr;
use crate::site::Site;

use super::tc_ekf::{ekf_pose, tracked_floor};

/// Without a step for this long the walker is standing (speed 0), s.
const STILL_AFTER_S: f64 = 1.5;

/// After this many consecutive fingerprint fixes rejected by IGG3 (a fix
/// counts as rejected when either of its coordinates gets weight 0) the
/// filter restarts at the fix (the robust gain would otherwise lock out a
/// filter that has drifted away).
const MAX_REJECTED_FIXES: u32 = 5;

/// The robust EKF engine.
pub struct RobustEkfEngine {
    ble_cfg: BleConfig,
    cfg: EkfConfig,
    front: BleFrontEnd,
    pdr: Pdr,
    floors: FloorTracker,
    /// Clustered databases of every floor (survey or model), built before the first call.
    dbs: Arc<FingerprintSet>,
    x: DVector<f64>,
    p: DMatrix<f64>,
    initialised: bool,
    floor: i32,
    /// The floor changed since the last fix (the floor tracker moved it in
    /// the Fusion task): the position belongs to the old floor's database
    /// and restarts at the next fix.
    floor_changed: bool,
    last_predict_t_ns: Option<i64>,
    last_step_t_ns: Option<i64>,
    /// Consecutive fingerprint fixes IGG3 gave weight 0.
    rejected_fixes: u32,
    last_fix: Option<Pose>,
    pose: Option<Pose>,
    ble_period_ns: i64,
    fusion_period_ns: i64,
    stats: EngineStats,
}

impl RobustEkfEngine {
    /// Builds the engine on the site's model fingerprint databases (every
    /// floor clustered now); `init` (optional) seeds position, floor and heading.
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        config.validate()?;
        let dbs = Arc::new(FingerprintSet::model(
            &site,
            &config.ble,
            &config.ekf.fingerprint,
        ));
        Self::with_fingerprints(site, config, init, dbs)
    }

    /// Builds the engine on given fingerprint databases (e.g. a survey
    /// database loaded with [`FingerprintSet::from_json`]; shared between
    /// engines, resolved against the same site). Floors without a database
    /// give no fix.
    pub fn with_fingerprints(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
        dbs: Arc<FingerprintSet>,
    ) -> Result<Self> {
        config.validate()?;
        let front = BleFrontEnd::new(&config.ble, &site);
        let start_floor = init.map_or(site.default_floor(), |i| i.floor);
        let floors = FloorTracker::new(&config.ekf.floor, &site.floor_heights(), start_floor);
        let mut x = DVector::zeros(4);
        let mut p = DMatrix::identity(4, 4) * 100.0;
        let mut initialised = false;
        if let Some(i) = init.filter(|i| i.x_m.is_finite() && i.y_m.is_finite()) {
            x[0] = i.x_m;
            x[1] = i.y_m;
            x[3] = i.heading_rad.filter(|h| h.is_finite()).unwrap_or(0.0);
            p[(0, 0)] = 1.0;
            p[(1, 1)] = 1.0;
            p[(3, 3)] = if i.heading_rad.is_some() { 0.1 } else { 10.0 };
            initialised = true;
        }
        p[(2, 2)] = 1.0;
        Ok(RobustEkfEngine {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            ble_cfg: config.ble.clone(),
            cfg: config.ekf.clone(),
            front,
            floors,
            dbs,
            x,
            p,
            initialised,
            floor: start_floor,
            floor_changed: false,
            last_predict_t_ns: None,
            last_step_t_ns: None,
            rejected_fixes: 0,
            last_fix: None,
            pose: None,
            ble_period_ns: i64::from(config.tasks.radio_period_ms) * 1_000_000,
            fusion_period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            stats: EngineStats::default(),
        })
    }

    /// The last WKNN fix (x_B).
    fn fingerprint_fix(&mut self, t_ns: i64) -> Option<(i32, Vec2)> {
        let beacons = self.front.current(t_ns);
        let ble_floor = BleFrontEnd::likely_floor(&beacons, self.ble_cfg.gml.top_n)?;
        let top_n = self.ble_cfg.gml.top_n;
        let floor = tracked_floor(&mut self.floors, t_ns, &beacons, top_n, ble_floor);
        let fcfg = &self.cfg.fingerprint;
        let fdb = self.dbs.floors.get(&floor)?;
        // the strongest heard beacons (current() is sorted strongest first)
        let heard: BTreeMap<usize, f64> = beacons
            .iter()
            .take(fcfg.scan_max_beacons)
            .map(|b| (b.index, b.rssi_dbm))
            .collect();
        let scan = fdb.db.scan_vector(|i| heard.get(&i).copied());
        if scan.iter().all(|r| r.is_nan()) {
            return None;
        }
        let clusters = fdb.sub.best(&scan, fcfg.search_clusters);
        let cands: Vec<usize> = clusters
            .iter()
            .flat_map(|c| fdb.sub.members[*c].iter().copied())
            .collect();
        wknn(&fdb.db, &cands, &scan, fcfg.wknn_k).map(|p| (floor, p))
    }

    fn predict(&mut self, t_ns: i64) {
        let dt = match self.last_predict_t_ns {
            Some(t0) if t_ns > t0 => (t_ns - t0) as f64 * 1e-9,
            Some(_) => return,
            None => {
                self.last_predict_t_ns = Some(t_ns);
                return;
            }
        };
        self.last_predict_t_ns = Some(t_ns);
        let (v, phi) = (self.x[2], self.x[3]);
        let (s, c) = phi.sin_cos();
        let mut f = DMatrix::identity(4, 4);
        f[(0, 2)] = dt * c;
        f[(0, 3)] = -v * dt * s;
        f[(1, 2)] = dt * s;
        f[(1, 3)] = v * dt * c;
        self.x[0] += v * dt * c;
        self.x[1] += v * dt * s;
        let mut q = DMatrix::zeros(4, 4);
        q[(0, 0)] = self.cfg.q_pos_m2_per_s * dt;
        q[(1, 1)] = self.cfg.q_pos_m2_per_s * dt;
        q[(2, 2)] = self.cfg.q_speed_m2_per_s3 * dt;
        q[(3, 3)] = self.cfg.q_heading_rad2_per_s * dt;
        self.p = &f * &self.p * f.transpose() + q;
    }

    fn update(&mut self, rows: &[(usize, f64, f64)]) -> Option<crate::kalman::UpdateReport> {
        let n = rows.len();
        let mut h = DMatrix::zeros(n, 4);
        let mut v = DVector::zeros(n);
        let mut r = DVector::zeros(n);
        for (k, &(idx, z, var)) in rows.iter().enumerate() {
            h[(k, idx)] = 1.0;
            v[k] = if idx == 3 {
                wrap_pi(z - self.x[3])
            } else {
                z - self.x[idx]
            };
            r[k] = var;
        }
        let k = Some((self.cfg.igg3_k0, self.cfg.igg3_k1));
        let rep = robust_update(&mut self.x, &mut self.p, &v, &h, &r, k);
        if rep.is_err() {
            self.stats.rejected_inputs += 1;
        }
        self.x[3] = wrap_pi(self.x[3]);
        self.x[2] = self.x[2].clamp(0.0, 3.0);
        rep.ok()
    }

    fn publish(&mut self, t_ns: i64) {
        if !self.initialised {
            return;
        }
        self.pose = Some(ekf_pose(t_ns, &self.x, &self.p, self.floor, self.x[3]));
    }
}

impl Engine for RobustEkfEngine {
    fn name(&self) -> &'static str {
        "robust-ekf"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        super::tc_ekf::on_sensor(&mut self.floors, &mut self.pdr, event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        self.front.on_observation(obs);
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        match task {
            T::Radio => {
                let Some((floor, pos)) = self.fingerprint_fix(t_ns) else {
                    self.stats.no_fix += 1;
                    return;
                };
                self.last_fix = Some(Pose {
                    t_ns,
                    x_m: pos.x,
                    y_m: pos.y,
                    floor,
                    heading_rad: self.x[3],
                    accuracy_m: self.cfg.fingerprint_sigma_m,
                    floor_prob: 1.0,
                    source: crate::engine::PoseSource::Radio,
                });
                if !self.initialised
                    || floor != self.floor
                    || self.floor_changed
                    || self.rejected_fixes >= MAX_REJECTED_FIXES
                {
                    self.rejected_fixes = 0;
                    self.floor_changed = false;
                    // first fix, floor change or lock-out: restart the position there
                    self.predict(t_ns);
                    self.x[0] = pos.x;
                    self.x[1] = pos.y;
                    // the new position is independent of speed and heading
                    for i in 0..2 {
                        for j in 0..4 {
                            self.p[(i, j)] = 0.0;
                            self.p[(j, i)] = 0.0;
                        }
                    }
                    self.p[(0, 0)] = self.cfg.fingerprint_sigma_m.powi(2);
                    self.p[(1, 1)] = self.cfg.fingerprint_sigma_m.powi(2);
                    self.initialised = true;
                    self.floor = floor;
                } else {
                    self.predict(t_ns);
                    let var = self.cfg.fingerprint_sigma_m.powi(2);
                    let rep = self.update(&[(0, pos.x, var), (1, pos.y, var)]);
                    if rep.is_some_and(|r| r.factors.contains(&0.0)) {
                        self.rejected_fixes += 1;
                    } else {
                        self.rejected_fixes = 0;
                    }
                }
                self.publish(t_ns);
            }
            T::Fusion => {
                let steps = self.pdr.take_steps();
                self.predict(t_ns);
                let mut rows = Vec::new();
                let still = self
                    .last_step_t_ns
                    .is_none_or(|t0| (t_ns - t0) as f64 * 1e-9 > STILL_AFTER_S);
                if steps.is_empty() && still {
                    rows.push((2, 0.0, self.cfg.speed_sigma_mps.powi(2)));
                }
                for s in &steps {
                    // speed: this step's length over the time since the previous step
                    if let Some(t0) = self.last_step_t_ns {
                        let dt = (s.t_ns - t0) as f64 * 1e-9;
                        if dt > 0.2 && dt < STILL_AFTER_S {
                            rows.push((2, s.length_m / dt, self.cfg.speed_sigma_mps.powi(2)));
                        }
                    }
                    self.last_step_t_ns = Some(s.t_ns);
                    rows.push((3, s.yaw_rad, self.cfg.heading_sigma_rad.powi(2)));
                    self.floors.on_step(true);
                    self.stats.steps += 1;
                }
                if self.floors.has_pressure()
                    && let Some(f) = self.floors.floor()
                    && f != self.floor
                {
                    // the position came from the old floor's database: restart at the next fix
                    self.floor = f;
                    self.floor_changed = true;
                }
                self.update(&rows);
                self.publish(t_ns);
            }
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        Some(match task {
            T::Radio => self.ble_period_ns,
            T::Fusion => self.fusion_period_ns,
        })
    }

    fn pose(&self) -> Option<Pose> {
        self.pose
    }

    fn ble_position(&self) -> Option<Pose> {
        self.last_fix
    }

    fn stats(&self) -> EngineStats {
        let stages = self.floors.rejected + self.pdr.stats().rejected();
        self.stats.with_stages(self.front.counts(), stages)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::{PathLoss, range_m};
    use crate::engine::replay::replay;
    use crate::engines::build_engine;
    use crate::events::SensorData;
    use crate::events::{GnssFix, LogEvent, TruthPoint};
    use crate::site::testkit::{beacon_site, open_map};

    const MODEL: PathLoss = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };
    const BEACONS: [(f64, f64); 6] = [
        (2.0, 2.0),
        (18.0, 2.0),
        (38.0, 2.0),
        (2.0, 28.0),
        (20.0, 28.0),
        (38.0, 28.0),
    ];

    fn site() -> Arc<Site> {
        beacon_site(
            "test",
            vec![open_map(40, 30), open_map(40, 30)],
            &BEACONS,
            MODEL,
        )
    }

    /// Adverts every 0.2 s (with `bias` dB added) along a slow walk east, truth every second.
    fn walk(bias: f64, seconds: i64) -> Vec<LogEvent> {
        walk_at(bias, seconds, 0.5)
    }

    fn walk_at(bias: f64, seconds: i64, speed_mps: f64) -> Vec<LogEvent> {
        let mut ev = Vec::new();
        for k in 0..seconds * 5 {
            let t_ns = k * 200_000_000;
            let p = Vec2::new(8.5 + 0.2 * speed_mps * k as f64, 12.5);
            for (i, &(x, y)) in BEACONS.iter().enumerate() {
                let r = MODEL.rssi_at(range_m(p, Vec2::new(x, y), 0.0, 0.5), 0.5);
                ev.push(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: format!("mac:00:00:00:00:00:{i:02X}"),
                    rssi_dbm: r + bias,
                    tx_power_dbm: None,
                }));
            }
            if k % 5 == 0 {
                ev.push(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                }));
            }
        }
        ev
    }

    fn mean_error(name: &str, ev: Vec<LogEvent>) -> (f64, usize) {
        let mut e = build_engine(name, site(), &EngineConfig::default(), None).unwrap();
        let out = replay(e.as_mut(), ev);
        let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
        assert!(errs.iter().all(|e| e.is_finite()));
        (
            errs.iter().sum::<f64>() / errs.len().max(1) as f64,
            errs.len(),
        )
    }

    #[test]
    fn both_engines_track_a_noise_free_walk() {
        // no motion sensors in this log: tc-ekf (no PDR steps) lags the
        // 0.5 m/s walker, robust-ekf follows its fingerprint fixes
        for (name, limit) in [("robust-ekf", 3.0), ("tc-ekf", 6.0)] {
            let (err, n) = mean_error(name, walk(0.0, 30));
            assert!(n >= 25, "{name}: {n} scored");
            assert!(err < limit, "{name}: mean error {err}");
        }
    }

    #[test]
    fn bad_input_is_counted_and_gives_no_nan_and_no_fix() {
        for name in ["robust-ekf", "tc-ekf"] {
            let mut e = build_engine(name, site(), &EngineConfig::default(), None).unwrap();
            let mut ev = Vec::new();
            for k in 0..20i64 {
                let t_ns = k * 200_000_000;
                ev.push(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: "garbage".into(),
                    rssi_dbm: f64::NAN,
                    tx_power_dbm: None,
                }));
                ev.push(LogEvent::Sensor(SensorEvent {
                    t_ns,
                    data: SensorData::Pressure(f64::NAN),
                }));
                ev.push(LogEvent::Sensor(SensorEvent {
                    t_ns,
                    data: SensorData::Accelerometer([f64::NAN, 0.0, 1e300]),
                }));
                ev.push(LogEvent::Gnss(GnssFix {
                    t_ns,
                    lat_deg: f64::INFINITY,
                    lon_deg: 0.0,
                    alt_m: None,
                    accuracy_m: Some(-1.0),
                    speed_mps: None,
                    bearing_deg: None,
                }));
            }
            ev.push(LogEvent::Truth(TruthPoint {
                t_ns: 3_000_000_000,
                x_m: 1.0,
                y_m: 1.0,
                floor: Some(0),
            }));
            let out = replay(e.as_mut(), ev);
            assert!(e.pose().is_none(), "{name}");
            assert!(out.scored.iter().all(|s| s.error_m().is_none()), "{name}");
            let st = e.stats();
            assert!(
                st.no_fix > 0 && st.unknown_beacons > 0 && st.rejected_inputs > 0,
                "{name}: {st:?}"
            );
        }
    }

    #[test]
    fn deterministic() {
        let a = {
            let mut e = build_engine("robust-ekf", site(), &EngineConfig::default(), None).unwrap();
            replay(e.as_mut(), walk(0.0, 10));
            e.pose()
        };
        let b = {
            let mut e = build_engine("robust-ekf", site(), &EngineConfig::default(), None).unwrap();
            replay(e.as_mut(), walk(0.0, 10));
            e.pose()
        };
        assert!(a.is_some());
        assert_eq!(a, b);
    }

    /// Adverts (every 0.2 s, noise-free model RSSI, `bias` dB added) of the
    /// floor-0 beacons at `truth(t)` and truth points every second, for
    /// `t0 <= t < t0 + seconds` (s).
    fn adverts_along(
        truth: &dyn Fn(f64) -> Vec2,
        t0: f64,
        seconds: f64,
        beacons: &[(usize, f64, f64)],
        with_truth: bool,
    ) -> Vec<LogEvent> {
        let mut ev = Vec::new();
        let n = (seconds * 5.0).round() as i64;
        for k in 0..n {
            let t = t0 + 0.2 * k as f64;
            let t_ns = (t * 1e9).round() as i64;
            let p = truth(t);
            for &(i, x, y) in beacons {
                let r = MODEL.rssi_at(range_m(p, Vec2::new(x, y), 0.0, 0.5), 0.5);
                ev.push(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: format!("mac:00:00:00:00:00:{i:02X}"),
                    rssi_dbm: r,
                    tx_power_dbm: None,
                }));
            }
            if with_truth && k % 5 == 0 {
                ev.push(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                }));
            }
        }
        ev
    }

    #[test]
    fn a_filter_off_along_the_walking_direction_restarts_at_the_fixes() {
        // Started 20 m east of the walker, who walks east: the fixes' x
        // residual is an outlier (IGG3 weight 0) on every fix while their y
        // agrees. Counting a fix as rejected only when *both* coordinates
        // had weight 0 never restarted the filter: it stayed 20 m off for
        // the whole walk (the replica's seed 2, 25 m mean error).
        let init = InitialPosition {
            x_m: 28.5,
            y_m: 12.5,
            floor: 0,
            heading_rad: Some(0.0),
        };
        let mut e = RobustEkfEngine::new(site(), &EngineConfig::default(), Some(init)).unwrap();
        let out = replay(&mut e, walk(0.0, 30));
        let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
        assert!(errs.len() >= 25);
        let tail = &errs[errs.len() - 10..];
        assert!(
            tail.iter().all(|e| *e < 3.0),
            "still off at the end of the walk: {errs:?}"
        );
    }

    #[test]
    fn a_floor_change_by_the_tracker_restarts_the_position_at_the_next_fix() {
        // Floor-1 beacons (ids 0x10..) in the other half of the site. The
        // phone hears them with the barometer's tracker on floor 1 (position
        // from floor 1's database near (32, 6)); then the tracker moves to
        // floor 0 (here by `reset_to_floor`, as its barometer/vote histogram
        // does between two BLE tasks) and the phone hears the floor-0
        // beacons around (6, 24). The position from floor 1's database must
        // not survive that: the next floor-0 fix restarts it. Before, the
        // Fusion task changed the floor without a restart and the BLE task,
        // seeing no floor change, fed the fixes 28 m away to IGG3, which
        // rejected them (the replica's seed 2: tracker on floor 1 at the
        // first fix, on floor 0 0.2 s later, 25 m mean error).
        let mut spec = site().spec.clone();
        let up = [(32.0, 2.0), (38.0, 8.0), (26.0, 8.0), (32.0, 12.0)];
        for (k, &(x, y)) in up.iter().enumerate() {
            let mut b = spec.beacons[0].clone();
            b.id = format!("mac:00:00:00:00:00:{:02X}", 0x10 + k);
            b.floor = 1;
            b.x_m = x;
            b.y_m = y;
            spec.beacons.push(b);
        }
        let site = Arc::new(Site {
            spec,
            floors: site().floors.clone(),
        });
        let upper: Vec<(usize, f64, f64)> = up
            .iter()
            .enumerate()
            .map(|(k, &(x, y))| (0x10 + k, x, y))
            .collect();
        let lower: Vec<(usize, f64, f64)> = BEACONS
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| (i, x, y))
            .collect();
        let at_upper = |_: f64| Vec2::new(32.0, 6.0);
        let at_lower = |_: f64| Vec2::new(6.0, 24.0);
        let pressure = |t0: i64, n: i64| {
            (0..n).map(move |k| {
                LogEvent::Sensor(SensorEvent {
                    t_ns: t0 + k * 100_000_000,
                    data: SensorData::Pressure(1000.0),
                })
            })
        };
        let mut first = adverts_along(&at_upper, 0.0, 5.0, &upper, false);
        first.extend(pressure(0, 50));
        first.sort_by_key(LogEvent::t_ns);
        let mut second = adverts_along(&at_lower, 5.0, 20.0, &lower, true);
        second.extend(pressure(5_000_000_000, 200));
        second.sort_by_key(LogEvent::t_ns);
        let mut e = RobustEkfEngine::new(site, &EngineConfig::default(), None).unwrap();
        e.floors.reset_to_floor(1);
        replay(&mut e, first);
        let up_pose = e.pose().unwrap();
        assert_eq!(up_pose.floor, 1, "{up_pose:?}");
        assert!((up_pose.x_m - 32.0).abs() < 4.0, "{up_pose:?}");
        e.floors.reset_to_floor(0);
        let out = replay(&mut e, second);
        let mut on_floor_0_since: Option<i64> = None;
        let mut worst_after = 0.0f64;
        for sp in &out.scored {
            let Some(pose) = sp.estimate else { continue };
            if pose.floor != 0 {
                on_floor_0_since = None;
                continue;
            }
            let since = *on_floor_0_since.get_or_insert(sp.truth.t_ns);
            if sp.truth.t_ns - since > 2_500_000_000 {
                worst_after = worst_after.max(sp.error_m().unwrap_or(f64::INFINITY));
            }
        }
        assert_eq!(e.pose().map(|p| p.floor), Some(0), "{:?}", e.pose());
        assert!(on_floor_0_since.is_some());
        assert!(
            worst_after < 3.0,
            "the position stayed on the old floor's fix: {worst_after} m; {:?}",
            e.pose()
        );
    }

    /// A walk east from (4, 5) for `east_s` seconds, then north (a sharp
    /// 90-degree turn) for `north_s`: phone flat, top forward, 50 Hz
    /// accelerometer and rotation vector, steps at 1.8 Hz of the length the
    /// PDR measures on this signal; noise-free adverts every 0.2 s, truth
    /// every second. Returns the events and the turn time (s).
    fn l_walk(east_s: f64, north_s: f64) -> (Vec<LogEvent>, f64) {
        use crate::engines::prox_pf::testkit::{STEP_HZ, STEP_M};
        use crate::pdr::orientation::to_android;
        use nalgebra::{UnitQuaternion, Vector3};
        let v = STEP_HZ * STEP_M;
        let corner = Vec2::new(4.0 + v * east_s, 5.0);
        let truth = move |t: f64| {
            if t < east_s {
                Vec2::new(4.0 + v * t, 5.0)
            } else {
                corner + Vec2::new(0.0, v * (t - east_s))
            }
        };
        let lower: Vec<(usize, f64, f64)> = BEACONS
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| (i, x, y))
            .collect();
        let mut ev = adverts_along(&truth, 0.0, east_s + north_s, &lower, true);
        for i in 0..((east_s + north_s) * 50.0) as i64 {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            // top of the phone east (yaw 0) before the corner, north after
            let turn = if t < east_s {
                -std::f64::consts::FRAC_PI_2
            } else {
                0.0
            };
            let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), turn);
            let acc = [
                0.0,
                0.0,
                9.81 + 2.5 * (std::f64::consts::TAU * STEP_HZ * t).sin(),
            ];
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::Accelerometer(acc),
            }));
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::RotationVector(to_android(&q)),
            }));
        }
        ev.sort_by_key(LogEvent::t_ns);
        (ev, east_s)
    }

    #[test]
    fn the_heading_follows_a_turn() {
        // A walker's 90-degree turn is not an outlier of the MEMS heading:
        // with a heading random walk of 0.05 rad^2/s the prediction's sigma
        // was ~0.25 rad, the turn's normalised residual ~6 > k1 and IGG3
        // gave it weight 0 for ~5 s (8 steps): the filter walked on past
        // the corner (the replica's turns, 4-6 m errors).
        let (ev, turn_s) = l_walk(14.0, 14.0);
        let mut e = RobustEkfEngine::new(site(), &EngineConfig::default(), None).unwrap();
        let out = replay(&mut e, ev);
        let t_turn = (turn_s * 1e9) as i64;
        let after: Vec<(f64, f64)> = out
            .track
            .iter()
            .filter(|p| p.t_ns > t_turn + 1_500_000_000)
            .map(|p| {
                (
                    (p.t_ns - t_turn) as f64 * 1e-9,
                    wrap_pi(p.heading_rad - std::f64::consts::FRAC_PI_2),
                )
            })
            .collect();
        assert!(after.len() > 20, "{}", after.len());
        let bad: Vec<&(f64, f64)> = after.iter().filter(|(_, d)| d.abs() > 0.3).collect();
        assert!(
            bad.is_empty(),
            "heading off north 1.5 s after the turn: {bad:?}"
        );
        // and it was east before the turn
        let before = out
            .track
            .iter()
            .filter(|p| p.t_ns > 5_000_000_000 && p.t_ns < t_turn)
            .all(|p| wrap_pi(p.heading_rad).abs() < 0.3);
        assert!(before);
    }

    #[test]
    fn survey_database_is_used_when_given() {
        use crate::engines::{EngineData, build_engine_with};
        use crate::fingerprint::SurveyBuilder;
        use crate::fingerprint::survey::tests as st;
        let site = st::site();
        let cfg = EngineConfig {
            pdr: st::rv_pdr(),
            ..EngineConfig::default()
        };
        let mut b = SurveyBuilder::new(&site, &cfg.ble, &cfg.pdr, &cfg.ekf.fingerprint);
        b.add_log(&st::straight_walk(1.4, 20.0).0);
        let set = Arc::new(b.finish());
        // every survey point lies on y = 12.5: fixes from this DB can only be on that line
        let data = EngineData {
            fingerprints: Some(set),
            ..EngineData::default()
        };
        let mut e = build_engine_with("robust-ekf", site.clone(), &cfg, None, &data).unwrap();
        let (ev, truth) = st::straight_walk(1.0, 20.0);
        let out = replay(e.as_mut(), ev);
        let fix = e.ble_position().unwrap();
        assert!((fix.y_m - 12.5).abs() < 1e-6, "{fix:?}");
        let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
        assert!(!errs.is_empty());
        let end = e.pose().unwrap();
        assert!(
            (Vec2::new(end.x_m, end.y_m) - truth(end.t_ns)).norm() < 3.0,
            "{end:?}"
        );
        // an empty set gives no fix at all
        let empty = EngineData {
            fingerprints: Some(Arc::new(FingerprintSet {
                source: crate::fingerprint::store::Source::Survey,
                floors: Default::default(),
            })),
            ..EngineData::default()
        };
        let mut e = build_engine_with("robust-ekf", site, &cfg, None, &empty).unwrap();
        replay(e.as_mut(), st::straight_walk(1.0, 5.0).0);
        assert!(e.pose().is_none() && e.stats().no_fix > 0);
    }
}
