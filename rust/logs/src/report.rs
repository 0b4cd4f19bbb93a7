//! What a reader saw: counts of lines, events per kind and every anomaly.

use fpbp_core::events::{LogEvent, SensorData};
use serde::{Deserialize, Serialize};

use crate::LogFormat;

/// Events emitted, per kind.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct KindCounts {
    pub acc: u64,
    pub gyr: u64,
    pub mag: u64,
    pub rot: u64,
    pub grv: u64,
    pub prs: u64,
    pub ble: u64,
    pub gnss: u64,
    /// WiFi scans (not results).
    #[serde(default)]
    pub wifi: u64,
    pub truth: u64,
}

impl KindCounts {
    /// Counts one event.
    pub fn add(&mut self, e: &LogEvent) {
        match e {
            LogEvent::Sensor(s) => match s.data {
                SensorData::Accelerometer(_) => self.acc += 1,
                SensorData::Gyroscope(_) => self.gyr += 1,
                SensorData::Magnetometer(_) => self.mag += 1,
                SensorData::RotationVector(_) => self.rot += 1,
                SensorData::GameRotationVector(_) => self.grv += 1,
                SensorData::Pressure(_) => self.prs += 1,
            },
            LogEvent::Ble(_) => self.ble += 1,
            LogEvent::Gnss(_) => self.gnss += 1,
            LogEvent::Wifi(_) => self.wifi += 1,
            LogEvent::Truth(_) => self.truth += 1,
        }
    }

    /// All events.
    pub fn total(&self) -> u64 {
        self.acc
            + self.gyr
            + self.mag
            + self.rot
            + self.grv
            + self.prs
            + self.ble
            + self.gnss
            + self.wifi
            + self.truth
    }
}

/// Counters of one read. Everything odd is counted here, never thrown
/// (except malformed lines in strict mode and I/O errors).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ReadReport {
    /// The file (or stream name) read.
    pub file: String,
    /// The detected (or forced) format.
    pub format: Option<LogFormat>,
    /// Lines read, including header and empty lines.
    pub lines: u64,
    /// Header, comment and empty lines.
    pub header_lines: u64,
    /// Events handed out, per kind.
    pub events: KindCounts,
    /// Well-formed records of kinds fpbp does not use (uncalibrated IMU, light, sound, ...).
    pub ignored_records: u64,
    /// Malformed lines skipped (lenient mode).
    pub malformed_skipped: u64,
    /// `file:line: message` of the first malformed line, when any.
    pub first_malformed: Option<String>,
    /// WiFi rows read (one access point each; `events.wifi` counts the scans
    /// they were grouped into).
    #[serde(default)]
    pub wifi_rows: u64,
    /// Malformed WiFi rows, skipped (also counted in `malformed_skipped`).
    #[serde(default)]
    pub malformed_wifi_rows: u64,
    /// `file:line: message` of the first malformed WiFi row, when any.
    #[serde(default)]
    pub first_malformed_wifi: Option<String>,
    /// Rows whose time is earlier than an earlier row's (before reordering).
    pub backwards_timestamps: u64,
    /// Rows that arrived later than the reorder window allows, dropped.
    pub late_dropped: u64,
    /// Exact duplicates (same time, same content) dropped.
    pub duplicates_dropped: u64,
    /// Events with a NaN or infinite value, dropped.
    pub non_finite_dropped: u64,
    /// Lat/lon truth points skipped because no site georeference was given.
    pub truth_without_georef: u64,
    /// BLE tx power values outside [-127, 0) dBm, replaced by None.
    pub invalid_tx_power: u64,
    /// Largest disagreement, degrees, between a log's own orientation angles and
    /// the quaternion read from it (IPIN AHRS rows); None for other formats.
    pub orientation_check_max_deg: Option<f64>,
    /// The phone model that recorded the log, when the log says (native
    /// `#meta device=`, IPIN `% Model:`); the engine corrects its readings
    /// by this model's offsets when the radio map knows them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// Gaps between consecutive events longer than `ReadOptions::gap_threshold_s`.
    pub gaps_over_threshold: u64,
    /// Longest gap between consecutive events, seconds.
    pub max_gap_s: f64,
    /// Time of the first and last event handed out, ns.
    pub first_t_ns: Option<i64>,
    pub last_t_ns: Option<i64>,
    /// An I/O error that ended the read early (lenient mode keeps what came before).
    pub io_error: Option<String>,
}

impl ReadReport {
    /// Seconds between the first and last event.
    pub fn duration_s(&self) -> f64 {
        match (self.first_t_ns, self.last_t_ns) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
            _ => 0.0,
        }
    }
}
