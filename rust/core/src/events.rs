//! The inputs every engine consumes and the truth the harness scores against.
//!
//! Time is `t_ns`: nanoseconds on the phone's elapsedRealtime clock (Android's
//! SensorEvent.timestamp and ScanResult.getTimestampNanos share it). Log readers
//! convert their own clocks to it. Sensor vectors are in the Android device
//! frame (x right, y up the screen, z out of the screen).

use serde::{Deserialize, Serialize};

/// A 3-vector in the device frame.
pub type Vec3 = [f64; 3];

/// One motion or environment sensor sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SensorEvent {
    pub t_ns: i64,
    pub data: SensorData,
}

/// The sensor kinds fpbp uses, with their units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum SensorData {
    /// Accelerometer including gravity, m/s^2 (TYPE_ACCELEROMETER).
    Accelerometer(Vec3),
    /// Calibrated gyroscope, rad/s (TYPE_GYROSCOPE).
    Gyroscope(Vec3),
    /// Calibrated magnetometer, microtesla (TYPE_MAGNETIC_FIELD).
    Magnetometer(Vec3),
    /// Rotation vector, device -> east-north-up, as a unit quaternion [x, y, z, w]
    /// (TYPE_ROTATION_VECTOR; w = sqrt(1 - x^2 - y^2 - z^2) when the phone omits it).
    RotationVector([f64; 4]),
    /// Game rotation vector (no magnetometer, arbitrary yaw origin), [x, y, z, w].
    GameRotationVector([f64; 4]),
    /// Barometric pressure, hPa (TYPE_PRESSURE).
    Pressure(f64),
}

impl SensorData {
    /// Android's `Sensor.TYPE_*` constant of this kind (the JNI surface uses it).
    pub fn android_type(&self) -> i32 {
        match self {
            SensorData::Accelerometer(_) => 1,
            SensorData::Magnetometer(_) => 2,
            SensorData::Gyroscope(_) => 4,
            SensorData::Pressure(_) => 6,
            SensorData::RotationVector(_) => 11,
            SensorData::GameRotationVector(_) => 15,
        }
    }

    /// Builds a sample from Android's sensor type and its `values` array.
    /// Returns a message naming what is wrong for an unknown type, too few
    /// values, or a non-finite value.
    pub fn from_android(sensor_type: i32, values: &[f64]) -> Result<SensorData, String> {
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "sensor type {sensor_type}: value {bad} is not finite"
            ));
        }
        let need = |n: usize| -> Result<(), String> {
            if values.len() < n {
                Err(format!(
                    "sensor type {sensor_type}: needs {n} values, got {}",
                    values.len()
                ))
            } else {
                Ok(())
            }
        };
        let v3 = || [values[0], values[1], values[2]];
        let quat = || {
            let (x, y, z) = (values[0], values[1], values[2]);
            let w = if values.len() >= 4 {
                values[3]
            } else {
                (1.0 - x * x - y * y - z * z).max(0.0).sqrt()
            };
            [x, y, z, w]
        };
        match sensor_type {
            1 => need(3).map(|_| SensorData::Accelerometer(v3())),
            2 => need(3).map(|_| SensorData::Magnetometer(v3())),
            4 => need(3).map(|_| SensorData::Gyroscope(v3())),
            6 => need(1).map(|_| SensorData::Pressure(values[0])),
            11 => need(3).map(|_| SensorData::RotationVector(quat())),
            15 => need(3).map(|_| SensorData::GameRotationVector(quat())),
            other => Err(format!("sensor type {other} is not used by fpbp")),
        }
    }
}

/// One BLE advertisement as reported by the phone's scanner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BleObservation {
    pub t_ns: i64,
    /// `ibeacon:UUID:major:minor`, `eddystone:NAMESPACE:INSTANCE` or `mac:AA:BB:CC:DD:EE:FF`.
    pub beacon_id: String,
    pub rssi_dbm: f64,
    /// Advertised measured power at 1 m, when the frame carries one.
    pub tx_power_dbm: Option<f64>,
}

/// One WiFi scan as delivered to the app (Android's `getScanResults()` after
/// `SCAN_RESULTS_AVAILABLE_ACTION`, ILC `TYPE_WIFI` rows of one arrival time,
/// IPIN `WIFI` rows of one time).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WifiScan {
    /// When the scan's results reached the app, ns.
    pub t_ns: i64,
    pub results: Vec<WifiResult>,
}

/// One access point in a [`WifiScan`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WifiResult {
    /// BSSID, lower-case `aa:bb:cc:dd:ee:ff`.
    pub bssid: String,
    pub rssi_dbm: f64,
    /// Channel centre frequency, MHz (2412..2484: 2.4 GHz, 5160..5885: 5 GHz).
    pub freq_mhz: u32,
    /// When this AP was last seen, ns on the same clock (Android's
    /// `ScanResult.timestamp`, ILC's last-seen field): a result can be
    /// seconds older than its scan. `seen_t_ns <= t_ns` of its scan.
    pub seen_t_ns: i64,
}

/// A GNSS fix in WGS-84.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GnssFix {
    pub t_ns: i64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub alt_m: Option<f64>,
    /// Horizontal accuracy (68 %), metres.
    pub accuracy_m: Option<f64>,
    pub speed_mps: Option<f64>,
    pub bearing_deg: Option<f64>,
}

/// A ground-truth point: where the walker was at `t_ns`, in the site's MCS.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TruthPoint {
    pub t_ns: i64,
    pub x_m: f64,
    pub y_m: f64,
    /// Floor id as in site.json, when known.
    pub floor: Option<i32>,
}

/// Everything a log can hold, in time order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum LogEvent {
    Sensor(SensorEvent),
    Ble(BleObservation),
    Gnss(GnssFix),
    Wifi(WifiScan),
    Truth(TruthPoint),
}

impl LogEvent {
    /// The event's time, ns.
    pub fn t_ns(&self) -> i64 {
        match self {
            LogEvent::Sensor(e) => e.t_ns,
            LogEvent::Ble(e) => e.t_ns,
            LogEvent::Gnss(e) => e.t_ns,
            LogEvent::Wifi(e) => e.t_ns,
            LogEvent::Truth(e) => e.t_ns,
        }
    }

    /// The ground-truth point, if the event is one (`events.iter()
    /// .filter_map(LogEvent::as_truth)`: a log's truth).
    pub fn as_truth(&self) -> Option<&TruthPoint> {
        match self {
            LogEvent::Truth(t) => Some(t),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn as_truth_is_the_truth_point_only() {
        let t = TruthPoint {
            t_ns: 5,
            x_m: 1.0,
            y_m: 2.0,
            floor: Some(0),
        };
        assert_eq!(LogEvent::Truth(t).as_truth(), Some(&t));
        let g = LogEvent::Gnss(GnssFix {
            t_ns: 5,
            lat_deg: 0.0,
            lon_deg: 0.0,
            alt_m: None,
            accuracy_m: None,
            speed_mps: None,
            bearing_deg: None,
        });
        assert_eq!(g.as_truth(), None);
    }
}
