//! IPIN GetSensorData logfiles (`;`-separated, `%` header).
//!
//! Time: `t_ns = AppTimestamp * 1e9`. AppTimestamp (s since the log started)
//! is the one clock all record kinds share (BLE4, POSI and GNSS rows have no
//! SensorTimestamp, and each sensor's SensorTimestamp has its own origin), so
//! it is the only clock that orders IMU, BLE and truth against each other.
//! Its jitter (set when the app reads the sample) is a few ms.
//!
//! AHRS rows give pitch/roll/yaw (deg) and the vector part q2, q3, q4 of a
//! unit quaternion. With `w = +sqrt(1 - |v|^2)` the quaternion [q2, q3, q4, w]
//! is Android's rotation vector (device -> east-north-up); the logged angles
//! are then `PitchX = asin(R21)`, `RollY = atan2(-R20, R22)`,
//! `YawZ = atan2(-R01, R11)` (R row-major from the quaternion), i.e. Android's
//! `getOrientation` with pitch and azimuth negated (yaw counter-clockwise
//! from north). Checked on every training log (see the dataset tests).

use fpbp_core::events::{BleObservation, GnssFix, LogEvent, SensorData, SensorEvent, TruthPoint};
use fpbp_core::geo::mcs_from_wgs84;
use fpbp_core::site::GeoRef;

use crate::line::{
    LineOutcome, bssid, f64_field, freq_mhz_field, i64_field, ibeacon_id, mac_id, seconds_to_ns,
    str_field, wifi_row,
};

/// Line parser of IPIN GetSensorData logfiles.
#[derive(Debug, Default)]
pub struct IpinParser {
    georef: Option<(GeoRef, f64)>,
    /// Largest disagreement, degrees, between an AHRS row's own angles and the
    /// angles of the quaternion built from it.
    pub ahrs_max_mismatch_deg: Option<f64>,
    /// The phone model of the header's `% Model:` line.
    pub device: Option<String>,
}

impl IpinParser {
    pub fn new(georef: Option<(GeoRef, f64)>) -> Self {
        IpinParser {
            georef,
            ahrs_max_mismatch_deg: None,
            device: None,
        }
    }

    /// Parses one line (without its line break).
    pub fn parse_line(&mut self, line: &str) -> LineOutcome {
        let line = line.trim_end_matches(['\r', '\n']);
        if let Some(model) = line.strip_prefix("% Model:") {
            let model = truncate(model.trim());
            if !model.is_empty() {
                self.device = Some(model.to_string());
            }
        }
        if line.trim().is_empty() || line.starts_with('%') {
            return LineOutcome::Header;
        }
        if line.starts_with("WIFI;") {
            return match parse_wifi(line) {
                Ok(o) => o,
                Err(m) => LineOutcome::MalformedWifi(m),
            };
        }
        match self.parse_row(line) {
            Ok(o) => o,
            Err(m) => LineOutcome::Malformed(m),
        }
    }

    fn parse_row(&mut self, line: &str) -> Result<LineOutcome, String> {
        let f: Vec<&str> = line.split(';').collect();
        let kind = f[0];
        if !is_record_tag(kind) || f.len() < 2 {
            return Err(format!(
                "`{}` is not a GetSensorData record",
                truncate(line)
            ));
        }
        let t_ns = seconds_to_ns(f64_field(&f, 1, "AppTimestamp")?)?;
        let need = |n: usize| -> Result<(), String> {
            if f.len() >= n {
                Ok(())
            } else {
                Err(format!("{kind} needs {} fields, got {}", n, f.len()))
            }
        };
        let v3 = |i: usize| -> Result<[f64; 3], String> {
            Ok([
                f64_field(&f, i, "x")?,
                f64_field(&f, i + 1, "y")?,
                f64_field(&f, i + 2, "z")?,
            ])
        };
        let sensor = |data| {
            Ok(LineOutcome::Event(LogEvent::Sensor(SensorEvent {
                t_ns,
                data,
            })))
        };
        match kind {
            "ACCE" => {
                need(6)?;
                sensor(SensorData::Accelerometer(v3(3)?))
            }
            "GYRO" => {
                need(6)?;
                sensor(SensorData::Gyroscope(v3(3)?))
            }
            "MAGN" => {
                need(6)?;
                sensor(SensorData::Magnetometer(v3(3)?))
            }
            "PRES" => {
                need(4)?;
                sensor(SensorData::Pressure(f64_field(&f, 3, "pressure_hpa")?))
            }
            "AHRS" => {
                need(9)?;
                let angles = v3(3)?;
                let [x, y, z] = v3(6)?;
                let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
                let q = [x, y, z, w];
                let got = ahrs_angles_deg(q);
                let mismatch = (0..3)
                    .map(|i| wrap_deg(got[i] - angles[i]).abs())
                    .fold(0.0f64, f64::max);
                if mismatch.is_finite() {
                    let m = self.ahrs_max_mismatch_deg.get_or_insert(0.0);
                    *m = m.max(mismatch);
                }
                sensor(SensorData::RotationVector(q))
            }
            "GNSS" => {
                need(9)?;
                Ok(LineOutcome::Event(LogEvent::Gnss(GnssFix {
                    t_ns,
                    lat_deg: f64_field(&f, 3, "lat_deg")?,
                    lon_deg: f64_field(&f, 4, "lon_deg")?,
                    alt_m: Some(f64_field(&f, 5, "alt_m")?),
                    bearing_deg: Some(f64_field(&f, 6, "bearing_deg")?),
                    accuracy_m: Some(f64_field(&f, 7, "accuracy_m")?),
                    speed_mps: Some(f64_field(&f, 8, "speed_mps")?),
                })))
            }
            "BLE4" => {
                need(5)?;
                let proto = str_field(&f, 2, "protocol")?;
                let mac = str_field(&f, 3, "mac")?;
                let rssi_dbm = f64_field(&f, 4, "rssi_dbm")?;
                let beacon_id = if proto.eq_ignore_ascii_case("iBeacon") {
                    need(9)?;
                    let major = u16_field(&f, 6, "major")?;
                    let minor = u16_field(&f, 7, "minor")?;
                    let uuid = str_field(&f, 8, "uuid")?;
                    if uuid.is_empty() {
                        return Err("field 9 (uuid) is empty".into());
                    }
                    ibeacon_id(uuid, major.into(), minor.into())
                } else {
                    // Eddystone rows carry no namespace: identify them by MAC.
                    mac_id(mac).map_err(|m| format!("field 4 (mac): {m}"))?
                };
                // The app writes power 0 on every row: never a tx power.
                Ok(LineOutcome::Event(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id,
                    rssi_dbm,
                    tx_power_dbm: None,
                })))
            }
            "POSI" => {
                need(6)?;
                let lat = f64_field(&f, 3, "lat_deg")?;
                let lon = f64_field(&f, 4, "lon_deg")?;
                let floor = i64_field(&f, 5, "floor")?;
                let floor = i32::try_from(floor)
                    .map_err(|_| format!("field 6 (floor): {floor} is out of range"))?;
                match &self.georef {
                    None => Ok(LineOutcome::TruthWithoutGeoref),
                    Some((g, rot)) => {
                        let p = mcs_from_wgs84(g, *rot, lat, lon);
                        Ok(LineOutcome::Event(LogEvent::Truth(TruthPoint {
                            t_ns,
                            x_m: p.x,
                            y_m: p.y,
                            floor: Some(floor),
                        })))
                    }
                }
            }
            _ => Ok(LineOutcome::Ignored),
        }
    }
}

/// `WIFI;AppTs;SensorTs;SSID;BSSID;frequency;RSS`, grouped into scans by
/// AppTs. The SSID may in principle hold a `;`, so the last three fields are
/// taken from the end (a trailing `;` is allowed). GetSensorData gives no
/// per-result age: its SensorTs is the row's write time on the sensor clock
/// (SensorTs - AppTs is the same within 1 ms for every WIFI row of a log),
/// not Android's `ScanResult.timestamp`, so `seen_t_ns` = the scan's `t_ns`.
fn parse_wifi(line: &str) -> Result<LineOutcome, String> {
    let mut f: Vec<&str> = line.split(';').collect();
    if f.len() > 7 && f.last().is_some_and(|l| l.trim().is_empty()) {
        f.pop();
    }
    if f.len() < 7 {
        return Err(format!(
            "WIFI needs 7 fields (WIFI, AppTs, SensorTs, SSID, BSSID, frequency, RSS), got {}",
            f.len()
        ));
    }
    let t_ns = seconds_to_ns(f64_field(&f, 1, "AppTimestamp")?)?;
    let n = f.len();
    let bssid = bssid(f[n - 3].trim()).map_err(|m| format!("field {} (bssid): {m}", n - 2))?;
    let freq_mhz = freq_mhz_field(&f, n - 2)?;
    let rssi_dbm = f64_field(&f, n - 1, "rss_dbm")?;
    Ok(wifi_row(t_ns, bssid, rssi_dbm, freq_mhz, t_ns))
}

fn u16_field(f: &[&str], i: usize, name: &str) -> Result<u16, String> {
    let v = i64_field(f, i, name)?;
    u16::try_from(v).map_err(|_| format!("field {} ({name}): {v} is out of range", i + 1))
}

fn truncate(s: &str) -> &str {
    match s.char_indices().nth(40) {
        Some((i, _)) => &s[..i],
        None => s,
    }
}

fn wrap_deg(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

/// A GetSensorData record tag: four upper-case letters or digits.
fn is_record_tag(s: &str) -> bool {
    s.len() == 4
        && s.bytes()
            .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit())
}

/// The (PitchX, RollY, YawZ) degrees GetSensorData writes for rotation vector
/// `q` = [x, y, z, w] (device -> ENU): see the module doc.
pub fn ahrs_angles_deg(q: [f64; 4]) -> [f64; 3] {
    let [x, y, z, w] = q;
    let r01 = 2.0 * (x * y - w * z);
    let r11 = 1.0 - 2.0 * (x * x + z * z);
    let r20 = 2.0 * (x * z - w * y);
    let r21 = 2.0 * (y * z + w * x);
    let r22 = 1.0 - 2.0 * (x * x + y * y);
    [
        r21.clamp(-1.0, 1.0).asin().to_degrees(),
        (-r20).atan2(r22).to_degrees(),
        (-r01).atan2(r11).to_degrees(),
    ]
}

/// Whether a line looks like a GetSensorData header or record.
pub fn looks_like(line: &str) -> bool {
    line.starts_with('%')
        || line
            .split_once(';')
            .is_some_and(|(tag, _)| is_record_tag(tag))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::events::WifiResult;

    fn ev(p: &mut IpinParser, l: &str) -> LogEvent {
        match p.parse_line(l) {
            LineOutcome::Event(e) => e,
            o => panic!("{l}: {o:?}"),
        }
    }

    #[test]
    fn sensors_use_app_timestamp() {
        let mut p = IpinParser::new(None);
        assert_eq!(p.parse_line("% a header line"), LineOutcome::Header);
        let e = ev(&mut p, "ACCE;1.5000;777.25;0.5;-1.0;9.5;3");
        assert_eq!(
            e,
            LogEvent::Sensor(SensorEvent {
                t_ns: 1_500_000_000,
                data: SensorData::Accelerometer([0.5, -1.0, 9.5])
            })
        );
        let e = ev(&mut p, "PRES;2.0;778.0;976.25;3");
        assert_eq!(
            e,
            LogEvent::Sensor(SensorEvent {
                t_ns: 2_000_000_000,
                data: SensorData::Pressure(976.25)
            })
        );
        assert_eq!(
            p.parse_line("WIFI;0.651;65094.18;SSID;20:23:00:00:00:0A;2437;-60"),
            LineOutcome::WifiRow {
                t_ns: 651_000_000,
                result: WifiResult {
                    bssid: "20:23:00:00:00:0a".into(),
                    rssi_dbm: -60.0,
                    freq_mhz: 2437,
                    seen_t_ns: 651_000_000,
                }
            }
        );
        assert!(matches!(
            p.parse_line("WIFI;0.7;65094.18;a;b;c;20:23:00:00:00:01;5200;-70;"),
            LineOutcome::WifiRow { .. }
        ));
        for bad in [
            "WIFI;0.7;65094.18;SSID;20:23:00:00:00;2437;-60",
            "WIFI;0.7;65094.18;SSID;20:23:00:00:00:01;2437",
            "WIFI;0.7;65094.18;SSID;20:23:00:00:00:01;-5;-60",
            "WIFI;soon;65094.18;SSID;20:23:00:00:00:01;2437;-60",
        ] {
            assert!(
                matches!(p.parse_line(bad), LineOutcome::MalformedWifi(_)),
                "{bad}"
            );
        }
        assert!(matches!(
            p.parse_line("ACCE;x;1;2;3;4;3"),
            LineOutcome::Malformed(_)
        ));
        assert!(matches!(
            p.parse_line("ACCE;1.0;1;2"),
            LineOutcome::Malformed(_)
        ));
        assert!(matches!(
            p.parse_line("hello world"),
            LineOutcome::Malformed(_)
        ));
    }

    #[test]
    fn ahrs_quaternion_matches_its_angles() {
        // A rotation of 50 deg about device x then 30 deg about up, built here
        // (not copied from a log): q = q_z(30) * q_x(50).
        let (hx, hz) = (25f64.to_radians(), 15f64.to_radians());
        let (qx, qz) = (
            [hx.sin(), 0.0, 0.0, hx.cos()],
            [0.0, 0.0, hz.sin(), hz.cos()],
        );
        let mul = |a: [f64; 4], b: [f64; 4]| {
            [
                a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
                a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
                a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
                a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
            ]
        };
        let q = mul(qz, qx);
        let a = ahrs_angles_deg(q);
        assert!(
            (a[0] - 50.0).abs() < 1e-9 && a[1].abs() < 1e-9 && (a[2] - 30.0).abs() < 1e-9,
            "{a:?}"
        );
        let mut p = IpinParser::new(None);
        let line = format!(
            "AHRS;3.0;9.0;{};{};{};{};{};{};3",
            a[0], a[1], a[2], q[0], q[1], q[2]
        );
        let e = ev(&mut p, &line);
        match e {
            LogEvent::Sensor(SensorEvent {
                data: SensorData::RotationVector(r),
                ..
            }) => {
                assert!((r[3] - q[3]).abs() < 1e-12)
            }
            _ => panic!(),
        }
        assert!(p.ahrs_max_mismatch_deg.unwrap() < 1e-6);
    }

    #[test]
    fn ble4_gnss_posi() {
        let mut p = IpinParser::new(None);
        let e = ev(
            &mut p,
            "BLE4;4.25;iBeacon;AA:00:00:00:00:01;-80;0;1;3;aaaa1111-0000-0000-0000-000000000000",
        );
        assert_eq!(
            e,
            LogEvent::Ble(BleObservation {
                t_ns: 4_250_000_000,
                beacon_id: "ibeacon:AAAA1111-0000-0000-0000-000000000000:1:3".into(),
                rssi_dbm: -80.0,
                tx_power_dbm: None
            })
        );
        let e = ev(
            &mut p,
            "GNSS;5.0;1600000000.0;40.5;-3.25;600.0;90.0;12.0;0.5;20;10",
        );
        assert_eq!(
            e,
            LogEvent::Gnss(GnssFix {
                t_ns: 5_000_000_000,
                lat_deg: 40.5,
                lon_deg: -3.25,
                alt_m: Some(600.0),
                accuracy_m: Some(12.0),
                speed_mps: Some(0.5),
                bearing_deg: Some(90.0)
            })
        );
        assert_eq!(
            p.parse_line("POSI;6.0;1;40.5;-3.25;-2;100"),
            LineOutcome::TruthWithoutGeoref
        );
        let g = GeoRef {
            lat_deg: 40.5,
            lon_deg: -3.25,
            x_m: 10.0,
            y_m: 20.0,
        };
        let mut p = IpinParser::new(Some((g, 0.0)));
        let e = ev(&mut p, "POSI;6.0;1;40.5001;-3.25;-2;100");
        match e {
            LogEvent::Truth(t) => {
                assert_eq!(t.floor, Some(-2));
                assert!(
                    (t.x_m - 10.0).abs() < 1e-9 && (t.y_m - 20.0 - 11.1319).abs() < 1e-3,
                    "{t:?}"
                );
            }
            _ => panic!(),
        }
    }
}
