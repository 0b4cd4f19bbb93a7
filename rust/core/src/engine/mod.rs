//! Engines: the narrow entry point every positioning algorithm sits behind.
//!
//! Inputs are sensor events, BLE observations and GNSS fixes; outputs are
//! poses. Each engine has up to two periodic tasks, as in the FP-BP paper's
//! Runnables: [`Task::Radio`] (GML for FP-BP, every T_gml) and [`Task::Fusion`]
//! (particle filter + PPC for FP-BP, every T_fusion). On a phone they run on
//! their own executors; in replay [`replay::Replayer`] drives them at their
//! nominal periods by the log's clock, so a replay is deterministic.

pub mod config;
pub mod inputs;
pub mod replay;
pub mod start;

use serde::{Deserialize, Serialize};

use crate::events::{BleObservation, GnssFix, SensorEvent, WifiScan};

pub use config::TaskConfig;
pub use inputs::CountedInputs;
pub use start::check_initial_position;

/// The periodic tasks of an engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Task {
    /// The radio task (BLE and WiFi: GML in FP-BP, the measurement set in
    /// tcpf), every `tasks.radio_period_ms` (the paper's T_gml).
    Radio,
    /// Fusion task (PF + PPC in FP-BP), every `tasks.fusion_period_ms`.
    Fusion,
}

impl Task {
    /// Both tasks, in the order they run when due at the same instant.
    pub const ALL: [Task; 2] = [Task::Radio, Task::Fusion];

    /// Short name used in metrics ("radio", "fusion"; metrics.json version 2
    /// called the radio task "gml").
    pub fn metric_name(self) -> &'static str {
        match self {
            Task::Radio => "radio",
            Task::Fusion => "fusion",
        }
    }
}

/// An engine's output at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub t_ns: i64,
    /// Position in the MCS of `floor`, metres.
    pub x_m: f64,
    pub y_m: f64,
    pub floor: i32,
    /// Walking heading in the MCS, radians, atan2(dy, dx) (eq. 33).
    pub heading_rad: f64,
    /// Radius within which the engine believes the user is (about 68 %), metres.
    pub accuracy_m: f64,
    /// Probability that `floor` is right, in [0, 1] (1 on a one-floor site
    /// or for an engine without a floor model).
    pub floor_prob: f64,
    /// What the pose rests on.
    pub source: PoseSource,
}

/// Whether the segment between two consecutive poses of a published track
/// crosses a Wall: both on one floor of `site` and
/// [`crate::map::FloorMap::track_crosses_wall`] between them. `fpbp eval`
/// counts these segments as wall crossings; a segment between floors is
/// none.
pub fn track_segment_crosses_wall(site: &crate::site::Site, a: &Pose, b: &Pose) -> bool {
    a.floor == b.floor
        && site.floor(a.floor).is_some_and(|m| {
            m.track_crosses_wall(
                crate::Vec2::new(a.x_m, a.y_m),
                crate::Vec2::new(b.x_m, b.y_m),
            )
        })
}

/// What a [`Pose`] rests on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseSource {
    /// Radio only (BLE/WiFi positioning without motion).
    Radio,
    /// Motion sensors from a start, no radio correction yet / lately.
    DeadReckoning,
    /// Radio and motion (and the map) fused.
    #[default]
    Fused,
}

impl PoseSource {
    /// Stable integer code (JNI, CSV): 0 radio, 1 dead reckoning, 2 fused.
    pub fn code(self) -> i32 {
        match self {
            PoseSource::Radio => 0,
            PoseSource::DeadReckoning => 1,
            PoseSource::Fused => 2,
        }
    }
}

/// A start position handed to an engine (a tap on the map, a QR code, or the
/// first truth point under `--init truth`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InitialPosition {
    pub x_m: f64,
    pub y_m: f64,
    pub floor: i32,
    /// Walking heading in the MCS when known, radians.
    pub heading_rad: Option<f64>,
}

/// Counters an engine keeps about its input and output (surfaced, never thrown).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EngineStats {
    pub sensor_events: u64,
    pub ble_observations: u64,
    /// BLE observations of beacons the site does not list.
    pub unknown_beacons: u64,
    /// Observations rejected as invalid (RSSI >= 0 dBm, non-finite values, ...).
    pub rejected_inputs: u64,
    pub steps: u64,
    /// Task runs that could not produce a position.
    pub no_fix: u64,
    /// WiFi scans received (used or ignored: an engine without WiFi counts
    /// them and drops them, never an error).
    #[serde(default)]
    pub wifi_scans: u64,
    /// Access-point results in those scans.
    #[serde(default)]
    pub wifi_results: u64,
    /// The phone's RSSI offset the engine estimates online (heard minus
    /// model, dB), for engines that estimate one (`tcpf`).
    #[serde(default)]
    pub rssi_offset_db: Option<f64>,
    /// The factor the engine multiplies the PDR's step lengths by, for an
    /// engine that learns one online (none does today: `None`).
    #[serde(default)]
    pub step_scale: Option<f64>,
    /// How far the engine trusts its radio in [0, 1] (`tcpf`: 1 unless
    /// its `integrity` checks found the radio misfitting its model or
    /// pulling the track beyond what the walk allows).
    #[serde(default)]
    pub radio_trust: Option<f64>,
    /// The phone model's BLE offset the radio map gave the engine
    /// (`EngineConfig::device`, subtracted from every reading), dB; `None`
    /// when the map knows none for the model, or the engine uses none.
    #[serde(default)]
    pub device_ble_offset_db: Option<f64>,
    /// The same for WiFi, dB.
    #[serde(default)]
    pub device_wifi_offset_db: Option<f64>,
}

/// A positioning algorithm behind the common interface.
///
/// Recording calls (`on_sensor`, `on_ble`, `on_gnss`, `on_wifi`) never fail:
/// bad samples are counted in [`EngineStats`]. An input an engine does not
/// use is ignored (the defaults); [`CountedInputs`], which every engine from
/// [`crate::engines::build_engine`] is wrapped in, counts the inputs handed to it. Engines
/// own their RNGs, seeded from the config, so the same inputs give the same
/// poses.
pub trait Engine: Send {
    /// The engine's name as used by `fpbp eval --engine`.
    fn name(&self) -> &'static str;
    /// One sensor event. Engines that do not use the motion sensors ignore
    /// it (the default).
    fn on_sensor(&mut self, _event: &SensorEvent) {}
    /// One BLE advertisement. Engines that do not use BLE ignore it (the
    /// default).
    fn on_ble(&mut self, _obs: &BleObservation) {}
    fn on_gnss(&mut self, _fix: &GnssFix) {}
    /// One WiFi scan. Engines that do not use WiFi ignore it (the default).
    fn on_wifi(&mut self, _scan: &WifiScan) {}
    /// Moves the engine to a known position now (a tap on the map, a QR
    /// code) without a restart. The default refuses: engines that support it
    /// override it.
    fn set_position(&mut self, _t_ns: i64, _at: InitialPosition) -> crate::Result<()> {
        Err(crate::Error::Unsupported(format!(
            "engine `{}` does not support set_position",
            self.name()
        )))
    }
    /// Runs one periodic task at `t_ns`.
    fn run_task(&mut self, task: Task, t_ns: i64);
    /// Nominal period of `task` in ns, or `None` when the engine has no such task.
    fn task_period_ns(&self, task: Task) -> Option<i64>;
    /// The latest pose, `None` before the first fix.
    fn pose(&self) -> Option<Pose>;
    /// The last BLE-only position (x_B), for engines that have one.
    fn ble_position(&self) -> Option<Pose> {
        None
    }
    fn stats(&self) -> EngineStats;
    /// The engine's own diagnostic counters by name (re-seedings, wall
    /// kills, ...), for research tools: `fpbp eval` and `replay` write them
    /// per log (`engine_counters`). Read once at the end of a run, never on
    /// the hot path; the default has none.
    fn diagnostics(&self) -> Vec<(&'static str, u64)> {
        Vec::new()
    }
}
