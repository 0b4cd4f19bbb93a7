//! One started engine and the conversions of every entry point, in plain Rust
//! (no JNI types), so they are unit-tested without a JVM.

use std::path::Path;
use std::sync::Arc;

use fpbp_core::engine::{
    Engine, EngineConfig, EngineData, EngineStats, InitialPosition, Pose, Task, build_engine_with,
};
use fpbp_core::events::{BleObservation, GnssFix, SensorData, SensorEvent};
use fpbp_core::fingerprint::FingerprintSet;

use crate::error::BridgeError;
use crate::site_loader;

/// Task codes of the Kotlin side (`NativeBridge.TASK_GML`, `TASK_FUSION`).
pub const TASK_GML: i32 = 0;
pub const TASK_FUSION: i32 = 1;

/// Number of doubles `getPose` writes: x, y, floor, heading, accuracy.
pub const POSE_LEN: usize = 5;

/// A running engine plus what the bridge itself counted.
pub struct Session {
    engine: Box<dyn Engine>,
    /// Samples the bridge rejected before they reached the engine (unknown
    /// sensor type, too few values, non-finite values, missing array).
    bridge_rejected: u64,
}

/// Maps a Kotlin task code to the core's task.
pub fn task_from_code(code: i32) -> Result<Task, BridgeError> {
    match code {
        TASK_GML => Ok(Task::Ble),
        TASK_FUSION => Ok(Task::Fusion),
        other => Err(BridgeError::IllegalArgument(format!(
            "task code {other} (known: {TASK_GML} = gml, {TASK_FUSION} = fusion)"
        ))),
    }
}

/// `[x, y, floor, heading_rad]` (heading NaN = unknown) -> start position.
pub fn init_from_array(v: &[f64]) -> Result<InitialPosition, BridgeError> {
    if v.len() != 4 {
        return Err(BridgeError::IllegalArgument(format!(
            "initial position: expected [x_m, y_m, floor, heading_rad], got {} values",
            v.len()
        )));
    }
    if !(v[0].is_finite() && v[1].is_finite() && v[2].is_finite()) {
        return Err(BridgeError::IllegalArgument(
            "initial position: x_m, y_m and floor must be finite".into(),
        ));
    }
    if v[2].fract() != 0.0 || v[2].abs() > f64::from(i32::MAX) {
        return Err(BridgeError::IllegalArgument(format!(
            "initial position: floor {} is not an integer",
            v[2]
        )));
    }
    Ok(InitialPosition {
        x_m: v[0],
        y_m: v[1],
        floor: v[2] as i32,
        heading_rad: v[3].is_finite().then_some(v[3]),
    })
}

impl Session {
    /// Loads the site, parses the config (empty text = defaults) and builds
    /// `engine`. `fingerprints_json` is an optional `fpbp-fingerprints` file
    /// (docs/fingerprints.md, e.g. from `fpbp fingerprint build`) for
    /// `robust-ekf`; the other engines ignore it.
    pub fn start(
        site_json: &str,
        site_dir: &Path,
        config_json: &str,
        engine: &str,
        init: Option<InitialPosition>,
        fingerprints_json: Option<&str>,
    ) -> Result<Session, BridgeError> {
        if !fpbp_core::engine::ENGINE_NAMES.contains(&engine) {
            return Err(fpbp_core::Error::UnknownEngine(
                engine.to_string(),
                fpbp_core::engine::ENGINE_NAMES.join(", "),
            )
            .into());
        }
        let config = if config_json.trim().is_empty() {
            EngineConfig::default()
        } else {
            EngineConfig::from_json(config_json)?
        };
        let site = site_loader::load_site(site_json, site_dir)?;
        let fingerprints = match fingerprints_json.filter(|t| !t.trim().is_empty()) {
            Some(text) => Some(Arc::new(FingerprintSet::from_json(
                text,
                &site,
                &config.ble,
            )?)),
            None => None,
        };
        let data = EngineData { fingerprints };
        let engine = build_engine_with(engine, Arc::new(site), &config, init, &data)?;
        Ok(Session::from_engine(engine))
    }

    /// Wraps an already built engine.
    pub fn from_engine(engine: Box<dyn Engine>) -> Session {
        Session {
            engine,
            bridge_rejected: 0,
        }
    }

    /// Forwards one sensor sample; a bad one is counted, never an error.
    pub fn on_sensor(&mut self, sensor_type: i32, t_ns: i64, values: Option<&[f64]>) {
        let Some(values) = values else {
            self.reject("sensor sample without values");
            return;
        };
        match SensorData::from_android(sensor_type, values) {
            Ok(data) => self.engine.on_sensor(&SensorEvent { t_ns, data }),
            Err(msg) => self.reject(&msg),
        }
    }

    /// Forwards one BLE observation (`tx_power_dbm` NaN = not advertised).
    /// Invalid RSSI values are the engine's to count.
    pub fn on_ble(
        &mut self,
        t_ns: i64,
        beacon_id: Option<String>,
        rssi_dbm: f64,
        tx_power_dbm: f64,
    ) {
        let Some(beacon_id) = beacon_id else {
            self.reject("BLE observation without beacon id");
            return;
        };
        self.engine.on_ble(&BleObservation {
            t_ns,
            beacon_id,
            rssi_dbm,
            tx_power_dbm: tx_power_dbm.is_finite().then_some(tx_power_dbm),
        });
    }

    /// Forwards one GNSS fix; `[alt_m, accuracy_m, speed_mps, bearing_deg]` NaN = absent.
    pub fn on_gnss(&mut self, t_ns: i64, lat_deg: f64, lon_deg: f64, optional: [f64; 4]) {
        if !(lat_deg.is_finite() && lon_deg.is_finite()) {
            self.reject("GNSS fix with non-finite latitude/longitude");
            return;
        }
        let opt = |v: f64| v.is_finite().then_some(v);
        self.engine.on_gnss(&GnssFix {
            t_ns,
            lat_deg,
            lon_deg,
            alt_m: opt(optional[0]),
            accuracy_m: opt(optional[1]),
            speed_mps: opt(optional[2]),
            bearing_deg: opt(optional[3]),
        });
    }

    /// Runs one periodic task at `t_ns`.
    pub fn run_task(&mut self, task: Task, t_ns: i64) {
        self.engine.run_task(task, t_ns);
    }

    /// Period of `task`, ns; 0 when the engine has no such task.
    pub fn task_period_ns(&self, task: Task) -> i64 {
        self.engine
            .task_period_ns(task)
            .filter(|p| *p > 0)
            .unwrap_or(0)
    }

    /// The latest pose.
    pub fn pose(&self) -> Option<Pose> {
        self.engine.pose()
    }

    /// The last BLE-only position (x_B).
    pub fn ble_position(&self) -> Option<Pose> {
        self.engine.ble_position()
    }

    /// The engine's name.
    pub fn engine_name(&self) -> &'static str {
        self.engine.name()
    }

    /// Engine counters plus the bridge's own rejections, as JSON.
    pub fn stats_json(&self) -> String {
        let mut stats: EngineStats = self.engine.stats();
        stats.rejected_inputs += self.bridge_rejected;
        serde_json::json!({
            "engine": self.engine.name(),
            "sensor_events": stats.sensor_events,
            "ble_observations": stats.ble_observations,
            "unknown_beacons": stats.unknown_beacons,
            "rejected_inputs": stats.rejected_inputs,
            "bridge_rejected": self.bridge_rejected,
            "steps": stats.steps,
            "no_fix": stats.no_fix,
        })
        .to_string()
    }

    fn reject(&mut self, why: &str) {
        self.bridge_rejected += 1;
        if self.bridge_rejected.is_power_of_two() {
            log::debug!("rejected input #{}: {why}", self.bridge_rejected);
        }
    }
}

/// Writes `pose` into `out` as `[x, y, floor, heading, accuracy]`.
pub fn pose_to_array(pose: &Pose) -> [f64; POSE_LEN] {
    [
        pose.x_m,
        pose.y_m,
        f64::from(pose.floor),
        pose.heading_rad,
        pose.accuracy_m,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::engine::EngineStats;

    /// A test double that records what reaches the engine.
    #[derive(Default)]
    struct Recorder {
        sensors: Vec<SensorEvent>,
        ble: Vec<BleObservation>,
        gnss: Vec<GnssFix>,
        tasks: Vec<(Task, i64)>,
    }

    impl Engine for Recorder {
        fn name(&self) -> &'static str {
            "recorder"
        }
        fn on_sensor(&mut self, e: &SensorEvent) {
            self.sensors.push(*e);
        }
        fn on_ble(&mut self, o: &BleObservation) {
            self.ble.push(o.clone());
        }
        fn on_gnss(&mut self, f: &GnssFix) {
            self.gnss.push(*f);
        }
        fn run_task(&mut self, task: Task, t_ns: i64) {
            self.tasks.push((task, t_ns));
        }
        fn task_period_ns(&self, task: Task) -> Option<i64> {
            (task == Task::Fusion).then_some(200_000_000)
        }
        fn pose(&self) -> Option<Pose> {
            self.tasks.last().map(|(_, t)| Pose {
                t_ns: *t,
                x_m: 1.0,
                y_m: 2.0,
                floor: -1,
                heading_rad: 0.5,
                accuracy_m: 3.0,
                floor_prob: 1.0,
                source: fpbp_core::engine::PoseSource::Fused,
            })
        }
        fn stats(&self) -> EngineStats {
            EngineStats {
                sensor_events: self.sensors.len() as u64,
                ble_observations: self.ble.len() as u64,
                ..Default::default()
            }
        }
    }

    #[test]
    fn bad_samples_are_counted_and_never_reach_the_engine() {
        let mut s = Session::from_engine(Box::new(Recorder::default()));
        s.on_sensor(1, 10, Some(&[0.0, 0.0, 9.8]));
        s.on_sensor(1, 11, Some(&[0.0, 9.8]));
        s.on_sensor(99, 12, Some(&[0.0, 0.0, 9.8]));
        s.on_sensor(4, 13, Some(&[f64::NAN, 0.0, 0.0]));
        s.on_sensor(4, 14, None);
        s.on_ble(15, None, -70.0, f64::NAN);
        s.on_ble(16, Some("mac:00:00:00:00:00:01".into()), -70.0, f64::NAN);
        s.on_gnss(17, f64::NAN, 11.0, [f64::NAN; 4]);
        s.on_gnss(18, 49.0, 11.0, [300.0, f64::NAN, f64::NAN, f64::NAN]);
        let stats: serde_json::Value = serde_json::from_str(&s.stats_json()).expect("stats JSON");
        assert_eq!(stats["sensor_events"], 1);
        assert_eq!(stats["ble_observations"], 1);
        assert_eq!(stats["bridge_rejected"], 6);
        assert_eq!(stats["rejected_inputs"], 6);
        assert_eq!(stats["engine"], "recorder");
    }

    /// Passes BLE and GNSS through to a shared log the test can read.
    struct Spy(std::sync::Arc<std::sync::Mutex<Recorder>>);

    impl Engine for Spy {
        fn name(&self) -> &'static str {
            "spy"
        }
        fn on_sensor(&mut self, e: &SensorEvent) {
            self.0.lock().expect("spy").on_sensor(e);
        }
        fn on_ble(&mut self, o: &BleObservation) {
            self.0.lock().expect("spy").on_ble(o);
        }
        fn on_gnss(&mut self, f: &GnssFix) {
            self.0.lock().expect("spy").on_gnss(f);
        }
        fn run_task(&mut self, _: Task, _: i64) {}
        fn task_period_ns(&self, _: Task) -> Option<i64> {
            None
        }
        fn pose(&self) -> Option<Pose> {
            None
        }
        fn stats(&self) -> EngineStats {
            EngineStats::default()
        }
    }

    #[test]
    fn optional_values_map_nan_to_none_and_values_pass_unchanged() {
        let shared = std::sync::Arc::new(std::sync::Mutex::new(Recorder::default()));
        let mut s = Session::from_engine(Box::new(Spy(shared.clone())));
        s.on_ble(1, Some("mac:00:00:00:00:00:01".into()), -70.0, -59.0);
        s.on_ble(2, Some("mac:00:00:00:00:00:01".into()), -71.5, f64::NAN);
        s.on_gnss(3, 49.0, 11.0, [300.0, f64::NAN, 1.5, f64::INFINITY]);
        s.on_sensor(11, 4, Some(&[0.1, 0.2, 0.3, 0.9, 2.0]));
        assert_eq!(s.task_period_ns(Task::Ble), 0);
        let r = shared.lock().expect("spy");
        assert_eq!(r.ble[0].tx_power_dbm, Some(-59.0));
        assert_eq!(r.ble[1].tx_power_dbm, None);
        assert_eq!(r.ble[1].rssi_dbm, -71.5);
        let g = r.gnss[0];
        assert_eq!(
            (g.alt_m, g.accuracy_m, g.speed_mps, g.bearing_deg),
            (Some(300.0), None, Some(1.5), None)
        );
        assert_eq!(
            r.sensors[0].data,
            SensorData::RotationVector([0.1, 0.2, 0.3, 0.9])
        );
    }

    #[test]
    fn task_codes_periods_and_pose_layout() {
        assert_eq!(task_from_code(TASK_GML).expect("gml"), Task::Ble);
        assert_eq!(task_from_code(TASK_FUSION).expect("fusion"), Task::Fusion);
        assert!(matches!(
            task_from_code(2),
            Err(BridgeError::IllegalArgument(_))
        ));
        let mut s = Session::from_engine(Box::new(Recorder::default()));
        assert_eq!(s.task_period_ns(Task::Ble), 0);
        assert_eq!(s.task_period_ns(Task::Fusion), 200_000_000);
        assert!(s.pose().is_none());
        s.run_task(Task::Fusion, 42);
        let p = s.pose().expect("pose after a task");
        assert_eq!(p.t_ns, 42);
        assert_eq!(pose_to_array(&p), [1.0, 2.0, -1.0, 0.5, 3.0]);
    }

    #[test]
    fn initial_position_array() {
        let p = init_from_array(&[1.5, 2.5, -1.0, f64::NAN]).expect("init");
        assert_eq!((p.x_m, p.y_m, p.floor, p.heading_rad), (1.5, 2.5, -1, None));
        let p = init_from_array(&[1.5, 2.5, 0.0, 0.25]).expect("init");
        assert_eq!(p.heading_rad, Some(0.25));
        for bad in [
            &[1.0, 2.0][..],
            &[1.0, 2.0, 0.5, 0.0],
            &[f64::NAN, 2.0, 0.0, 0.0],
            &[1.0, 2.0, 1e12, 0.0],
        ] {
            assert!(
                matches!(init_from_array(bad), Err(BridgeError::IllegalArgument(_))),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn unknown_engine_is_rejected_before_the_site_is_read() {
        let r = Session::start(
            "not json",
            Path::new("/nonexistent"),
            "",
            "no-such-engine",
            None,
            None,
        );
        match r {
            Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("no-such-engine"), "{m}"),
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("started an unknown engine"),
        }
    }

    #[test]
    fn bad_config_names_the_field() {
        let engine = fpbp_core::engine::ENGINE_NAMES
            .first()
            .copied()
            .unwrap_or("fpbp");
        let r = Session::start(
            "{}",
            Path::new("."),
            r#"{"tasks": {"fusion_period_ms": 0}}"#,
            engine,
            None,
            None,
        );
        match r {
            Err(BridgeError::IllegalArgument(m)) => {
                assert!(
                    m.contains("tasks.fusion_period_ms") || m.contains("unknown engine"),
                    "{m}"
                )
            }
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("started with a bad config"),
        }
    }
}
