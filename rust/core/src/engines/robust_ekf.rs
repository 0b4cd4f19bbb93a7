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
use crate::engine::{Engine, EngineConfig, EngineStats, InitialPosition, Pose, Task};
use crate::events::{BleObservation, SensorData, SensorEvent};
use crate::fingerprint::{FingerprintSet, wknn};
use crate::floor::FloorTracker;
use crate::kalman::{EkfConfig, robust_update, wrap_pi};
use crate::pdr::Pdr;
use crate::site::Site;

/// Without a step for this long the walker is standing (speed 0), s.
const STILL_AFTER_S: f64 = 1.5;

/// After this many consecutive fingerprint fixes rejected by IGG3 the
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
        let floors = FloorTracker::for_site(&config.ekf.floor, &site, start_floor);
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
            pdr: Pdr::new(&config.pdr, site.spec.map_from_enu_rad),
            ble_cfg: config.ble.clone(),
            cfg: config.ekf.clone(),
            front,
            floors,
            dbs,
            x,
            p,
            initialised,
            floor: start_floor,
            last_predict_t_ns: None,
            last_step_t_ns: None,
            rejected_fixes: 0,
            last_fix: None,
            pose: None,
            ble_period_ns: i64::from(config.tasks.gml_period_ms) * 1_000_000,
            fusion_period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            stats: EngineStats::default(),
        })
    }

    /// The last WKNN fix (x_B).
    fn fingerprint_fix(&mut self, t_ns: i64) -> Option<(i32, Vec2)> {
        let beacons = self.front.current(t_ns);
        let ble_floor = BleFrontEnd::likely_floor(&beacons, self.ble_cfg.gml.top_n)?;
        // floors: the tracker (barometer changes + BLE votes) when the log
        // has pressure, else the BLE floor
        if let Some(v) = self.floors.vote(&beacons, self.ble_cfg.gml.top_n) {
            self.floors.on_ble_floor(t_ns, v);
        }
        let floor = if self.floors.has_pressure() {
            self.floors.floor().unwrap_or(ble_floor)
        } else {
            ble_floor
        };
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
        self.pose = Some(Pose {
            t_ns,
            x_m: self.x[0],
            y_m: self.x[1],
            floor: self.floor,
            heading_rad: self.x[3],
            accuracy_m: (self.p[(0, 0)] + self.p[(1, 1)]).max(0.0).sqrt(),
            floor_prob: 1.0,
            source: crate::engine::PoseSource::Fused,
        });
    }
}

impl Engine for RobustEkfEngine {
    fn name(&self) -> &'static str {
        "robust-ekf"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.stats.sensor_events += 1;
        if let SensorData::Pressure(p) = event.data {
            self.floors.on_pressure(event.t_ns, p);
        }
        self.pdr.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        self.stats.ble_observations += 1;
        self.front.on_observation(obs);
    }

    fn on_wifi(&mut self, scan: &crate::events::WifiScan) {
        // This engine does not use WiFi: counted and ignored.
        self.stats.count_wifi(scan);
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        match task {
            T::Ble => {
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
                    || self.rejected_fixes >= MAX_REJECTED_FIXES
                {
                    self.rejected_fixes = 0;
                    // first fix or floor change: restart the position there
                    self.x[0] = pos.x;
                    self.x[1] = pos.y;
                    self.p[(0, 0)] = self.cfg.fingerprint_sigma_m.powi(2);
                    self.p[(1, 1)] = self.cfg.fingerprint_sigma_m.powi(2);
                    self.p[(0, 1)] = 0.0;
                    self.p[(1, 0)] = 0.0;
                    self.initialised = true;
                    self.floor = floor;
                } else {
                    self.predict(t_ns);
                    let var = self.cfg.fingerprint_sigma_m.powi(2);
                    let rep = self.update(&[(0, pos.x, var), (1, pos.y, var)]);
                    if rep.is_some_and(|r| r.factors.iter().all(|f| *f == 0.0)) {
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
                {
                    self.floor = f;
                }
                self.update(&rows);
                self.publish(t_ns);
            }
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        Some(match task {
            T::Ble => self.ble_period_ns,
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
        let c = self.front.counts();
        let p = self.pdr.stats();
        EngineStats {
            unknown_beacons: c.unknown,
            rejected_inputs: self.stats.rejected_inputs
                + c.rejected
                + self.floors.rejected
                + p.rejected(),
            ..self.stats.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::{PathLoss, range_m};
    use crate::engine::build_engine;
    use crate::engine::replay::replay;
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
    fn tc_ekf_estimates_an_injected_rssi_bias() {
        let site = site();
        let mut e =
            crate::engines::tc_ekf::TcEkfEngine::new(site, &EngineConfig::default(), None).unwrap();
        // a standing phone that reads 6 dB weaker than the calibrated models
        replay(&mut e, walk_at(-6.0, 60, 0.0));
        let (b, sd) = e.rssi_bias_db();
        assert!(
            (b + 6.0).abs() < 2.0 && sd < 3.0,
            "bias {b} +- {sd} {:?} {:?}",
            e.stats(),
            e.pose()
        );
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

    #[test]
    fn survey_database_is_used_when_given() {
        use crate::engine::{EngineData, build_engine_with};
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
