//! One started engine and the conversions of every entry point, in plain Rust
//! (no JNI types), so they are unit-tested without a JVM.

use std::path::Path;
use std::sync::Arc;

use fpbp_core::Vec2;
use fpbp_core::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use fpbp_core::engines::{EngineConfig, EngineData, build_engine_with};
use fpbp_core::events::{BleObservation, GnssFix, SensorData, SensorEvent, WifiResult, WifiScan};
use fpbp_core::site::GeoRef;

use crate::error::BridgeError;
use crate::site_loader;

/// Task codes of the Kotlin side (`NativeBridge.TASK_GML`, `TASK_FUSION`).
pub const TASK_GML: i32 = 0;
pub const TASK_FUSION: i32 = 1;

/// Layout of the pose array `getPose` writes (`NativeBridge.POSE_*` in Kotlin).
pub mod pose_index {
    pub const X_M: usize = 0;
    pub const Y_M: usize = 1;
    pub const FLOOR: usize = 2;
    pub const HEADING_RAD: usize = 3;
    pub const ACCURACY_M: usize = 4;
    /// Probability that the floor is right, [0, 1].
    pub const FLOOR_PROB: usize = 5;
    /// `PoseSource::code()`: 0 radio, 1 dead reckoning, 2 fused.
    pub const SOURCE: usize = 6;
    /// WGS-84 through the site's georef; NaN when the site has none.
    pub const LAT_DEG: usize = 7;
    pub const LON_DEG: usize = 8;
    /// Heading as a bearing from true north, degrees clockwise, [0, 360).
    pub const BEARING_DEG: usize = 9;
}

/// Number of doubles `getPose` writes (the `pose_index` layout).
pub const POSE_LEN: usize = 10;

/// Most results one WiFi scan may carry (a dense office hears a few hundred).
pub const MAX_WIFI_RESULTS: usize = 512;

/// Longest BSSID text read from Java, bytes (`aa:bb:cc:dd:ee:ff` is 17).
pub const MAX_BSSID_BYTES: usize = 64;

/// What the bridge itself counted (beside the engine's counters).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BridgeCounters {
    /// Samples rejected before they reached the engine (unknown sensor
    /// type, too few or non-finite values, missing array or id, bad WiFi
    /// entries, WiFi scans with mismatched or oversized arrays).
    pub rejected: u64,
    /// WiFi scans handed to the engine, and the results they carried.
    pub wifi_scans: u64,
    pub wifi_results: u64,
}

/// The site's tie to WGS-84 and north, for lat/lon and bearings.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MapFrame {
    pub georef: Option<GeoRef>,
    pub map_from_enu_rad: f64,
}

/// What readers see without the engine's lock: the latest pose, x_B and
/// counters, published after every call that holds the engine.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    pub engine: &'static str,
    /// `task_period_ns` of `Task::Ble` and `Task::Fusion` (0 = no such task).
    pub periods_ns: [i64; 2],
    pub pose: Option<Pose>,
    pub ble_position: Option<Pose>,
    pub stats: EngineStats,
    pub bridge: BridgeCounters,
    pub frame: MapFrame,
}

/// A running engine plus what the bridge itself counted.
pub struct Session {
    engine: Box<dyn Engine>,
    frame: MapFrame,
    counters: BridgeCounters,
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
    /// `engine`. `fingerprints_json` is optional engine data, told apart by
    /// its `format` ([`EngineData::from_json`]): an `fpbp-fingerprints` file
    /// (docs/fingerprints.md, `fpbp fingerprint build`) for `robust-ekf`, or
    /// an `fpbp-radio-map` (docs/formats.md, `fpbp calibrate --radio-map`)
    /// for `tcpf`; the other engines ignore it.
    pub fn start(
        site_json: &str,
        site_dir: &Path,
        config_json: &str,
        engine: &str,
        init: Option<InitialPosition>,
        fingerprints_json: Option<&str>,
    ) -> Result<Session, BridgeError> {
        // the entry point's error policy clips an echoed engine name (clip_echoes)
        let config = Self::config_for(config_json, engine)?;
        let site = site_loader::load_site(site_json, site_dir)?;
        let data = match fingerprints_json.filter(|t| !t.trim().is_empty()) {
            Some(text) => EngineData::from_json(text, &site, &config.ble)?,
            None => EngineData::default(),
        };
        Self::build(site, &config, engine, init, &data)
    }

    /// Starts `engine` from a site bundle (`fpbp bundle`,
    /// `fpbp_core::bundle`): its site, plans and radio map (if any; for
    /// `tcpf` and `scan-knn`), all read from `bundle` without copying the
    /// map into a string. Errors name the bundle's field or entry.
    pub fn start_bundle(
        bundle: &[u8],
        config_json: &str,
        engine: &str,
        init: Option<InitialPosition>,
    ) -> Result<Session, BridgeError> {
        let config = Self::config_for(config_json, engine)?;
        let b = fpbp_core::bundle::Bundle::parse(bundle)?;
        let site = b.build_site()?;
        let data = EngineData {
            radio_map: b.radio_map(&site)?.map(Arc::new),
            ..EngineData::default()
        };
        Self::build(site, &config, engine, init, &data)
    }

    /// The text of a bundle's site.json (the whole bundle is checked first:
    /// manifest, sizes, hashes), for an app's scan filters.
    pub fn bundle_site_json(bundle: &[u8]) -> Result<String, BridgeError> {
        let b = fpbp_core::bundle::Bundle::parse(bundle)?;
        String::from_utf8(b.site_json().to_vec()).map_err(|e| {
            BridgeError::IllegalArgument(format!("bundle: entry site.json: not UTF-8: {e}"))
        })
    }

    /// Checks the engine name and parses the config (empty text = defaults).
    fn config_for(config_json: &str, engine: &str) -> Result<EngineConfig, BridgeError> {
        if !fpbp_core::engines::ENGINE_NAMES.contains(&engine) {
            return Err(fpbp_core::Error::UnknownEngine(
                engine.to_string(),
                fpbp_core::engines::ENGINE_NAMES.join(", "),
            )
            .into());
        }
        Ok(if config_json.trim().is_empty() {
            EngineConfig::default()
        } else {
            EngineConfig::from_json(config_json)?
        })
    }

    fn build(
        site: fpbp_core::site::Site,
        config: &EngineConfig,
        engine: &str,
        init: Option<InitialPosition>,
        data: &EngineData,
    ) -> Result<Session, BridgeError> {
        let frame = MapFrame {
            georef: site.spec.georef,
            map_from_enu_rad: site.spec.map_from_enu_rad,
        };
        let engine = build_engine_with(engine, Arc::new(site), config, init, data)?;
        Ok(Session {
            frame,
            ..Session::from_engine(engine)
        })
    }

    /// Wraps an already built engine (no georef, MCS = ENU).
    pub fn from_engine(engine: Box<dyn Engine>) -> Session {
        Session {
            engine,
            frame: MapFrame::default(),
            counters: BridgeCounters::default(),
        }
    }

    /// What readers may see now (copied into the published snapshot after
    /// every call that holds the engine).
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            engine: self.engine.name(),
            periods_ns: [
                self.task_period_ns(Task::Ble),
                self.task_period_ns(Task::Fusion),
            ],
            pose: self.engine.pose(),
            ble_position: self.engine.ble_position(),
            stats: self.engine.stats(),
            bridge: self.counters,
            frame: self.frame,
        }
    }

    /// Moves the engine to `at` now. An engine that refuses (the core's
    /// default) gives `Unsupported`, a bad point `IllegalArgument`.
    pub fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<(), BridgeError> {
        self.engine.set_position(t_ns, at).map_err(|e| match e {
            fpbp_core::Error::Unsupported(m) => BridgeError::Unsupported(m),
            other => other.into(),
        })
    }

    /// Hands one WiFi scan to the engine: the entries [`wifi_results`]
    /// accepts; the others are counted. A scan whose every entry was bad is
    /// not forwarded (an empty input scan is: it says nothing was heard).
    pub fn on_wifi(&mut self, t_ns: i64, entries: &WifiEntries<'_>) {
        let (results, rejected) = wifi_results(t_ns, entries);
        self.counters.rejected += rejected;
        if results.is_empty() && !entries.bssids.is_empty() {
            return;
        }
        self.counters.wifi_scans += 1;
        self.counters.wifi_results += results.len() as u64;
        self.engine.on_wifi(&WifiScan { t_ns, results });
    }

    /// Counts a WiFi scan the bridge could not read at all (null or
    /// mismatched arrays, more than [`MAX_WIFI_RESULTS`] results).
    pub fn reject_wifi_scan(&mut self, why: &str) {
        self.reject(why);
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

    /// The latest pose (readers use the published [`Snapshot`] instead).
    pub fn pose(&self) -> Option<Pose> {
        self.engine.pose()
    }

    /// The engine's name.
    pub fn engine_name(&self) -> &'static str {
        self.engine.name()
    }

    fn reject(&mut self, why: &str) {
        self.counters.rejected += 1;
        if self.counters.rejected.is_power_of_two() {
            log::debug!("rejected input #{}: {why}", self.counters.rejected);
        }
    }
}

impl Snapshot {
    /// Engine counters plus the bridge's own, as JSON.
    pub fn stats_json(&self) -> String {
        let stats = &self.stats;
        serde_json::json!({
            "engine": self.engine,
            "sensor_events": stats.sensor_events,
            "ble_observations": stats.ble_observations,
            "unknown_beacons": stats.unknown_beacons,
            "rejected_inputs": stats.rejected_inputs + self.bridge.rejected,
            "bridge_rejected": self.bridge.rejected,
            "wifi_scans": self.bridge.wifi_scans,
            "wifi_results": self.bridge.wifi_results,
            "steps": stats.steps,
            "no_fix": stats.no_fix,
            // null for engines that estimate none
            "rssi_offset_db": stats.rssi_offset_db,
            "step_scale": stats.step_scale,
            "radio_trust": stats.radio_trust,
        })
        .to_string()
    }
}

/// One WiFi scan as the Java arrays gave it (same lengths, checked by the caller).
pub struct WifiEntries<'a> {
    /// BSSIDs; `None` for a null element or one longer than [`MAX_BSSID_BYTES`].
    pub bssids: &'a [Option<String>],
    pub rssi_dbm: &'a [f64],
    pub freq_mhz: &'a [i32],
    pub seen_t_ns: &'a [i64],
}

use fpbp_core::wifi::normalize_bssid;

/// The valid results of a scan at `t_ns` and the number of bad entries:
/// a BSSID that is not six hex pairs, a non-finite RSSI, a frequency <= 0
/// MHz, or a last-seen time after the scan.
pub fn wifi_results(t_ns: i64, e: &WifiEntries<'_>) -> (Vec<WifiResult>, u64) {
    let n = e
        .bssids
        .len()
        .min(e.rssi_dbm.len())
        .min(e.freq_mhz.len())
        .min(e.seen_t_ns.len());
    let mut out = Vec::with_capacity(n);
    let mut rejected = 0;
    for i in 0..n {
        let bssid = e.bssids[i].as_deref().and_then(normalize_bssid);
        let (rssi, freq, seen) = (e.rssi_dbm[i], e.freq_mhz[i], e.seen_t_ns[i]);
        match bssid {
            Some(bssid) if rssi.is_finite() && freq > 0 && seen <= t_ns => out.push(WifiResult {
                bssid,
                rssi_dbm: rssi,
                freq_mhz: freq as u32,
                seen_t_ns: seen,
            }),
            _ => rejected += 1,
        }
    }
    (out, rejected)
}

/// Writes `pose` in the [`pose_index`] layout; lat/lon through `frame`'s
/// georef (NaN without one), the heading also as a bearing from north.
pub fn pose_to_array(pose: &Pose, frame: &MapFrame) -> [f64; POSE_LEN] {
    let (lat, lon) = match &frame.georef {
        Some(g) => {
            fpbp_core::geo::wgs84_from_mcs(g, frame.map_from_enu_rad, Vec2::new(pose.x_m, pose.y_m))
        }
        None => (f64::NAN, f64::NAN),
    };
    let mut a = [0.0; POSE_LEN];
    a[pose_index::X_M] = pose.x_m;
    a[pose_index::Y_M] = pose.y_m;
    a[pose_index::FLOOR] = f64::from(pose.floor);
    a[pose_index::HEADING_RAD] = pose.heading_rad;
    a[pose_index::ACCURACY_M] = pose.accuracy_m;
    a[pose_index::FLOOR_PROB] = pose.floor_prob;
    a[pose_index::SOURCE] = f64::from(pose.source.code());
    a[pose_index::LAT_DEG] = lat;
    a[pose_index::LON_DEG] = lon;
    a[pose_index::BEARING_DEG] =
        fpbp_core::geo::bearing_deg_from_mcs(pose.heading_rad, frame.map_from_enu_rad);
    a
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
        wifi: Vec<WifiScan>,
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
        let stats: serde_json::Value =
            serde_json::from_str(&s.snapshot().stats_json()).expect("stats JSON");
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
        fn on_wifi(&mut self, w: &WifiScan) {
            self.0.lock().expect("spy").wifi.push(w.clone());
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
        let a = pose_to_array(&p, &MapFrame::default());
        assert_eq!(a[..7], [1.0, 2.0, -1.0, 0.5, 3.0, 1.0, 2.0]);
        assert!(a[pose_index::LAT_DEG].is_nan() && a[pose_index::LON_DEG].is_nan());
        // heading 0.5 rad from the MCS x axis (east here): bearing 90 - 28.6 deg
        assert!((a[pose_index::BEARING_DEG] - (90.0 - 0.5f64.to_degrees())).abs() < 1e-12);
        assert_eq!(s.snapshot().pose, Some(p));
    }

    #[test]
    fn lat_lon_and_bearing_follow_the_site_frame() {
        let g = GeoRef {
            lat_deg: 48.0,
            lon_deg: 11.0,
            x_m: 10.0,
            y_m: 20.0,
        };
        let frame = MapFrame {
            georef: Some(g),
            map_from_enu_rad: 0.3,
        };
        let pose = Pose {
            t_ns: 1,
            x_m: 35.0,
            y_m: -4.0,
            floor: 0,
            heading_rad: 0.3 + std::f64::consts::FRAC_PI_2,
            accuracy_m: 1.0,
            floor_prob: 0.75,
            source: fpbp_core::engine::PoseSource::DeadReckoning,
        };
        let a = pose_to_array(&pose, &frame);
        let (lat, lon) = fpbp_core::geo::wgs84_from_mcs(&g, 0.3, Vec2::new(35.0, -4.0));
        assert_eq!((a[pose_index::LAT_DEG], a[pose_index::LON_DEG]), (lat, lon));
        let back = fpbp_core::geo::mcs_from_wgs84(&g, 0.3, lat, lon);
        assert!((back - Vec2::new(35.0, -4.0)).norm() < 1e-6);
        // MCS heading = ENU north rotated into the MCS: bearing 0
        assert!(a[pose_index::BEARING_DEG].abs() < 1e-9 || a[pose_index::BEARING_DEG] > 359.999);
        assert_eq!(
            (a[pose_index::FLOOR_PROB], a[pose_index::SOURCE]),
            (0.75, 1.0)
        );
    }

    #[test]
    fn wifi_entries_are_normalized_and_bad_ones_counted() {
        let bssids = [
            Some("AA:BB:CC:DD:EE:01".to_string()),
            Some("aa-bb-cc-dd-ee-02".to_string()),
            None,
            Some("not a bssid".to_string()),
            Some("aa:bb:cc:dd:ee:05".to_string()),
            Some("aa:bb:cc:dd:ee:06".to_string()),
            Some("aa:bb:cc:dd:ee:07".to_string()),
        ];
        let rssi = [-60.0, -70.5, -50.0, -50.0, f64::NAN, -80.0, -81.0];
        let freq = [2412, 5180, 2412, 2412, 2412, 0, 2437];
        let seen = [90, 100, 100, 100, 100, 100, 101];
        let e = WifiEntries {
            bssids: &bssids,
            rssi_dbm: &rssi,
            freq_mhz: &freq,
            seen_t_ns: &seen,
        };
        let (r, bad) = wifi_results(100, &e);
        assert_eq!(bad, 5);
        assert_eq!(r.len(), 2);
        assert_eq!(
            (
                r[0].bssid.as_str(),
                r[0].rssi_dbm,
                r[0].freq_mhz,
                r[0].seen_t_ns
            ),
            ("aa:bb:cc:dd:ee:01", -60.0, 2412, 90)
        );
        assert_eq!(r[1].bssid, "aa:bb:cc:dd:ee:02");
        let shared = std::sync::Arc::new(std::sync::Mutex::new(Recorder::default()));
        let mut s = Session::from_engine(Box::new(Spy(shared.clone())));
        s.on_wifi(100, &e);
        let none: [Option<String>; 1] = [None];
        let all_bad = WifiEntries {
            bssids: &none,
            rssi_dbm: &rssi[..1],
            freq_mhz: &freq[..1],
            seen_t_ns: &seen[..1],
        };
        s.on_wifi(200, &all_bad);
        let empty = WifiEntries {
            bssids: &[],
            rssi_dbm: &[],
            freq_mhz: &[],
            seen_t_ns: &[],
        };
        s.on_wifi(300, &empty);
        s.reject_wifi_scan("lengths differ");
        let r = shared.lock().expect("spy");
        assert_eq!(
            r.wifi
                .iter()
                .map(|w| (w.t_ns, w.results.len()))
                .collect::<Vec<_>>(),
            [(100, 2), (300, 0)]
        );
        let stats: serde_json::Value =
            serde_json::from_str(&s.snapshot().stats_json()).expect("stats JSON");
        assert_eq!(stats["wifi_scans"], 2);
        assert_eq!(stats["wifi_results"], 2);
        assert_eq!(stats["bridge_rejected"], 5 + 1 + 1);
    }

    #[test]
    fn set_position_refused_by_an_engine_is_unsupported() {
        let mut s = Session::from_engine(Box::new(Recorder::default()));
        let at = InitialPosition {
            x_m: 1.0,
            y_m: 2.0,
            floor: 0,
            heading_rad: None,
        };
        match s.set_position(5, at) {
            Err(BridgeError::Unsupported(m)) => assert!(m.contains("recorder"), "{m}"),
            other => panic!("unexpected {other:?}"),
        }
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
        let engine = fpbp_core::engines::ENGINE_NAMES
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

    /// The stats JSON carries the engine's online phone RSSI offset and
    /// step scale (issue 16: "reported in stats"): the same values as the
    /// engine's own `stats` for the same input; null for an engine that
    /// estimates none.
    #[test]
    fn stats_report_the_phone_offset_the_engine_estimates() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
        let site_json = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
        let site = Arc::new(site_loader::load_site(&site_json, &dir).expect("site"));
        let at = InitialPosition {
            x_m: 12.0,
            y_m: 8.0,
            floor: 0,
            heading_rad: None,
        };
        let cfg = EngineConfig::default();
        let mut e =
            fpbp_core::engines::tcpf::TcpfEngine::new(site.clone(), &cfg, Some(at)).expect("tcpf");
        let mut s = Session::start(&site_json, &dir, "", "tcpf", Some(at), None).expect("session");
        // every beacon heard 9 dB weaker than the site's model says at `at`
        let p = Vec2::new(at.x_m, at.y_m);
        let heard: Vec<(String, f64)> = (e.model().transmitters().iter().enumerate())
            .filter_map(|(k, t)| Some((t.id.clone(), e.model().expected(k, 0, p)?.0 - 9.0)))
            .collect();
        assert!(heard.len() >= 4, "demo beacons: {}", heard.len());
        for second in 1..=30i64 {
            let t_ns = second * 1_000_000_000;
            for (id, rssi) in &heard {
                e.on_ble(&BleObservation {
                    t_ns,
                    beacon_id: id.clone(),
                    rssi_dbm: *rssi,
                    tx_power_dbm: None,
                });
                s.on_ble(t_ns, Some(id.clone()), *rssi, f64::NAN);
            }
            for task in [Task::Ble, Task::Fusion] {
                e.run_task(task, t_ns);
                s.run_task(task, t_ns);
            }
        }
        let stats: serde_json::Value =
            serde_json::from_str(&s.snapshot().stats_json()).expect("stats JSON");
        let core = e.stats();
        let offset = stats["rssi_offset_db"].as_f64().expect("an offset");
        assert_eq!(Some(offset), core.rssi_offset_db);
        assert!(offset < -4.0, "9 dB weaker, estimated {offset} dB");
        assert_eq!(stats["step_scale"].as_f64(), core.step_scale);
        // the radio's trust as the engine reports it (1: integrity off)
        assert_eq!(stats["radio_trust"].as_f64(), core.radio_trust);
        assert_eq!(core.radio_trust, Some(1.0));
        let other = Session::from_engine(Box::new(Recorder::default()));
        let stats: serde_json::Value =
            serde_json::from_str(&other.snapshot().stats_json()).expect("stats JSON");
        assert!(stats["rssi_offset_db"].is_null() && stats["step_scale"].is_null());
        assert!(stats["radio_trust"].is_null());
    }

    /// `start`'s data JSON is told apart by its `format`: a radio map goes
    /// to `tcpf`, and its errors name the field.
    #[test]
    fn start_takes_a_radio_map_in_the_data_json() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
        let site = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
        let map = r#"{"format": "fpbp-radio-map", "version": 1, "transmitters": [
            {"id": "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:1", "kind": "ble",
             "floor": 0, "x_m": 3.5, "y_m": 3.5,
             "grids": [{"floor": 0, "x0_m": 0.0, "y0_m": 0.0, "cell_m": 2.0, "nx": 2, "ny": 1,
                        "mean_dbm_x10": [-600, -650], "sd_dbm_x10": [40, 45]}]}]}"#;
        let s = Session::start(&site, &dir, "", "tcpf", None, Some(map));
        assert!(s.is_ok(), "{:?}", s.err().map(|e| e.to_string()));
        let bad = map.replace("\"nx\": 2", "\"nx\": 3");
        match Session::start(&site, &dir, "", "tcpf", None, Some(&bad)) {
            Err(BridgeError::IllegalArgument(m)) => {
                assert!(m.contains("transmitters[0].grids[0].mean_dbm_x10"), "{m}")
            }
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("started with a bad radio map"),
        }
        // a fingerprint file still goes to the fingerprint parser
        let fp = r#"{"format": "fpbp-fingerprints", "version": 9}"#;
        match Session::start(&site, &dir, "", "robust-ekf", None, Some(fp)) {
            Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("fingerprint"), "{m}"),
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("started with a bad fingerprint file"),
        }
    }

    /// A bundle of the demo site and a radio map starts the engine the
    /// site and map texts start: the same poses on the same inputs; a
    /// damaged bundle is an IllegalArgument naming the entry.
    #[test]
    fn start_bundle_equals_start_with_the_same_files() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
        let site = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
        let plan = std::fs::read(dir.join("plan.png")).expect("demo plan");
        let map = r#"{"format": "fpbp-radio-map", "version": 1, "transmitters": [
            {"id": "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:1", "kind": "ble",
             "floor": 0, "x_m": 3.5, "y_m": 3.5,
             "grids": [{"floor": 0, "x0_m": 0.0, "y0_m": 0.0, "cell_m": 2.0, "nx": 2, "ny": 1,
                        "mean_dbm_x10": [-600, -650], "sd_dbm_x10": [40, 45]}]}]}"#;
        let spec =
            fpbp_core::site::SiteSpec::from_json(site.as_bytes(), "site.json").expect("demo spec");
        let plan_name = spec.floors[0].plan.clone().expect("a plan");
        let plans = [(plan_name.as_str(), plan.as_slice())];
        let bytes = fpbp_core::bundle::write(&fpbp_core::bundle::BundleInput {
            site_json: site.as_bytes(),
            plans: &plans,
            radio_map_json: Some(map.as_bytes()),
            writer: "test",
        })
        .expect("bundle");
        assert_eq!(Session::bundle_site_json(&bytes).expect("site text"), site);
        let init = Some(InitialPosition {
            x_m: 5.0,
            y_m: 5.0,
            floor: 0,
            heading_rad: Some(0.0),
        });
        let mut a = Session::start(&site, &dir, "", "tcpf", init, Some(map)).expect("start");
        let mut b = Session::start_bundle(&bytes, "", "tcpf", init).expect("start bundle");
        for k in 0..40i64 {
            let t = k * 100_000_000;
            for s in [&mut a, &mut b] {
                s.on_sensor(1, t, Some(&[0.1, 0.2, 9.8]));
                s.on_ble(
                    t,
                    Some("ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:1".into()),
                    -65.0 - (k % 5) as f64,
                    f64::NAN,
                );
                s.run_task(Task::Fusion, t);
            }
            assert_eq!(a.snapshot(), b.snapshot(), "at {t}");
        }
        assert!(a.snapshot().pose.is_some());
        // a changed byte in the map entry: refused, naming it
        let mut bad = bytes.clone();
        let n = bad.len();
        bad[n - 20] ^= 0x55;
        match Session::start_bundle(&bad, "", "tcpf", None) {
            Err(BridgeError::IllegalArgument(m)) => {
                assert!(
                    m.contains("bundle") && m.contains("radio-map.json.gz"),
                    "{m}"
                )
            }
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("started from a damaged bundle"),
        }
        // the engine name is checked before the bundle is read
        match Session::start_bundle(&[], "", "nope", None) {
            Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("unknown engine"), "{m}"),
            _ => panic!("expected an unknown engine error"),
        }
    }
}
