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

/// Task codes of the Kotlin side (`NativeBridge.TASK_RADIO`, `TASK_FUSION`).
pub const TASK_RADIO: i32 = 0;
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
    /// `task_period_ns` of `Task::Radio` and `Task::Fusion` (0 = no such task).
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
        TASK_RADIO => Ok(Task::Radio),
        TASK_FUSION => Ok(Task::Fusion),
        other => Err(BridgeError::IllegalArgument(format!(
            "task code {other} (known: {TASK_RADIO} = gml, {TASK_FUSION} = fusion)"
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
                self.task_period_ns(Task::Radio),
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
    /// default, `Error::Unsupported`) gives `Unsupported`, a bad point
    /// `IllegalArgument` (the exception table, error.rs).
    pub fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<(), BridgeError> {
        Ok(self.engine.set_position(t_ns, at)?)
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
            // the phone model's offsets the radio map gave; null: none
            "device_ble_offset_db": stats.device_ble_offset_db,
            "device_wifi_offset_db": stats.device_wifi_offset_db,
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
#[path = "session_tests.rs"]
mod tests;
