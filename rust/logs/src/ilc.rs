//! Microsoft Indoor Location Competition 2.0 traces (tab-separated, ms epoch).
//!
//! Time: ILC rows carry Unix epoch milliseconds and no elapsedRealtime, so
//! `t_ns = (t_ms - origin_ms) * 1e6` where `origin_ms` is the header's
//! `startTime` (or the first data row's time when the header is missing).
//! Waypoints are metres in the floor image frame (bottom-left origin, y up),
//! which is the MCS of a site built from that image, so they pass through.

use fpbp_core::events::{BleObservation, LogEvent, SensorData, SensorEvent, TruthPoint};

use crate::line::{
    LineOutcome, bssid, f64_field, freq_mhz_field, i64_field, ibeacon_id, mac_id, str_field,
    valid_tx_power, wifi_row,
};

/// Line parser of ILC traces.
#[derive(Debug, Default)]
pub struct IlcParser {
    origin_ms: Option<i64>,
    default_floor: Option<i32>,
    /// `FloorName` from the header, when present.
    pub floor_name: Option<String>,
    /// Tx power values replaced by None because they were implausible.
    pub invalid_tx_power: u64,
}

impl IlcParser {
    pub fn new(default_floor: Option<i32>) -> Self {
        IlcParser {
            default_floor,
            ..Default::default()
        }
    }

    /// The epoch time (ms) that t_ns = 0 stands for, once known.
    pub fn origin_ms(&self) -> Option<i64> {
        self.origin_ms
    }

    /// Parses one line (without its line break).
    pub fn parse_line(&mut self, line: &str) -> LineOutcome {
        let line = line.trim_end_matches(['\r', '\n']);
        if line.split('\t').nth(1) == Some("TYPE_WIFI") {
            return match self.parse_wifi(line) {
                Ok(o) => o,
                Err(m) => LineOutcome::MalformedWifi(m),
            };
        }
        if line.trim().is_empty() {
            return LineOutcome::Header;
        }
        if let Some(rest) = line.strip_prefix('#') {
            for kv in rest.split('\t') {
                if let Some((k, v)) = kv.split_once(':') {
                    match k.trim() {
                        "startTime" if self.origin_ms.is_none() => {
                            if let Ok(t) = v.trim().parse::<i64>() {
                                self.origin_ms = Some(t);
                            }
                        }
                        "FloorName" => self.floor_name = Some(v.trim().to_string()),
                        _ => {}
                    }
                }
            }
            return LineOutcome::Header;
        }
        match self.parse_row(line) {
            Ok(o) => o,
            Err(m) => LineOutcome::Malformed(m),
        }
    }

    /// `(t_ms - origin_ms) * 1e6`, the origin set by the first row when the
    /// header gave none.
    fn t_ns_of(&mut self, t_ms: i64) -> Result<i64, String> {
        let origin = *self.origin_ms.get_or_insert(t_ms);
        t_ms.checked_sub(origin)
            .and_then(|d| d.checked_mul(1_000_000))
            .ok_or_else(|| format!("time {t_ms} ms is out of range"))
    }

    /// `t_ms TYPE_WIFI SSID BSSID RSSI frequency last_seen_ms`. The SSID may
    /// be empty (or, in principle, hold a tab), so the other four are taken
    /// from the end. `seen_t_ns` is on the same clock as `t_ns`; a last-seen
    /// time after the row's own time is malformed.
    fn parse_wifi(&mut self, line: &str) -> Result<LineOutcome, String> {
        let f: Vec<&str> = line.split('\t').collect();
        let t_ms = i64_field(&f, 0, "t_ms")?;
        if f.len() < 7 {
            return Err(format!(
                "TYPE_WIFI needs 5 fields after the type (ssid, bssid, rssi, frequency, last-seen ms), got {}",
                f.len() - 2
            ));
        }
        let n = f.len();
        let bssid = bssid(f[n - 4].trim()).map_err(|m| format!("field {} (bssid): {m}", n - 3))?;
        let rssi_dbm = f64_field(&f, n - 3, "rssi_dbm")?;
        let freq_mhz = freq_mhz_field(&f, n - 2)?;
        let seen_ms = i64_field(&f, n - 1, "last_seen_ms")?;
        if seen_ms > t_ms {
            return Err(format!(
                "field {n} (last_seen_ms): {seen_ms} is after the row's time {t_ms}"
            ));
        }
        let t_ns = self.t_ns_of(t_ms)?;
        let seen_t_ns = self.t_ns_of(seen_ms)?;
        Ok(wifi_row(t_ns, bssid, rssi_dbm, freq_mhz, seen_t_ns))
    }

    fn parse_row(&mut self, line: &str) -> Result<LineOutcome, String> {
        let f: Vec<&str> = line.split('\t').collect();
        let t_ms = i64_field(&f, 0, "t_ms")?;
        let kind = str_field(&f, 1, "type")?;
        if !kind.starts_with("TYPE_") {
            return Err(format!("field 2: `{kind}` is not a TYPE_ record"));
        }
        let t_ns = self.t_ns_of(t_ms)?;
        let need = |n: usize| -> Result<(), String> {
            if f.len() >= n {
                Ok(())
            } else {
                Err(format!(
                    "{kind} needs {} fields after the type, got {}",
                    n - 2,
                    f.len() - 2
                ))
            }
        };
        let v3 = || -> Result<[f64; 3], String> {
            Ok([
                f64_field(&f, 2, "x")?,
                f64_field(&f, 3, "y")?,
                f64_field(&f, 4, "z")?,
            ])
        };
        let sensor = |data| {
            Ok(LineOutcome::Event(LogEvent::Sensor(SensorEvent {
                t_ns,
                data,
            })))
        };
        match kind {
            "TYPE_ACCELEROMETER" => {
                need(5)?;
                sensor(SensorData::Accelerometer(v3()?))
            }
            "TYPE_GYROSCOPE" => {
                need(5)?;
                sensor(SensorData::Gyroscope(v3()?))
            }
            "TYPE_MAGNETIC_FIELD" => {
                need(5)?;
                sensor(SensorData::Magnetometer(v3()?))
            }
            "TYPE_ROTATION_VECTOR" => {
                need(5)?;
                let [x, y, z] = v3()?;
                let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
                sensor(SensorData::RotationVector([x, y, z, w]))
            }
            "TYPE_BEACON" => {
                need(7)?;
                let uuid = str_field(&f, 2, "uuid")?;
                let major = u32_field(&f, 3, "major")?;
                let minor = u32_field(&f, 4, "minor")?;
                let tx = f64_field(&f, 5, "tx_power_dbm")?;
                let rssi_dbm = f64_field(&f, 6, "rssi_dbm")?;
                if uuid.is_empty() {
                    return Err("field 3 (uuid) is empty".into());
                }
                let tx_power_dbm = if valid_tx_power(tx) {
                    Some(tx)
                } else {
                    self.invalid_tx_power += 1;
                    None
                };
                Ok(LineOutcome::Event(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: ibeacon_id(uuid, major, minor),
                    rssi_dbm,
                    tx_power_dbm,
                })))
            }
            "TYPE_BLUE" => {
                // name (may be empty), MAC, RSSI: take the last two fields so a
                // device name holding a tab cannot shift them.
                need(5)?;
                let n = f.len();
                let mac =
                    mac_id(f[n - 2].trim()).map_err(|m| format!("field {} (mac): {m}", n - 1))?;
                let rssi_dbm = f64_field(&f, n - 1, "rssi_dbm")?;
                Ok(LineOutcome::Event(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: mac,
                    rssi_dbm,
                    tx_power_dbm: None,
                })))
            }
            "TYPE_WAYPOINT" => {
                need(4)?;
                Ok(LineOutcome::Event(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: f64_field(&f, 2, "x_m")?,
                    y_m: f64_field(&f, 3, "y_m")?,
                    floor: self.default_floor,
                })))
            }
            _ => Ok(LineOutcome::Ignored),
        }
    }
}

fn u32_field(f: &[&str], i: usize, name: &str) -> Result<u32, String> {
    let v = i64_field(f, i, name)?;
    u32::try_from(v).map_err(|_| format!("field {} ({name}): {v} is out of range", i + 1))
}

/// Whether a line looks like an ILC header or data row.
pub fn looks_like(line: &str) -> bool {
    if line.starts_with("#\tstartTime") {
        return true;
    }
    let mut it = line.split('\t');
    matches!((it.next(), it.next()), (Some(t), Some(k)) if t.trim().parse::<i64>().is_ok() && k.starts_with("TYPE_"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::events::WifiResult;

    fn ev(p: &mut IlcParser, l: &str) -> LogEvent {
        match p.parse_line(l) {
            LineOutcome::Event(e) => e,
            o => panic!("{l}: {o:?}"),
        }
    }

    #[test]
    fn header_sets_origin_and_rows_convert() {
        let mut p = IlcParser::new(Some(4));
        assert_eq!(
            p.parse_line("#\tstartTime:1000000000000"),
            LineOutcome::Header
        );
        assert_eq!(
            p.parse_line("#\tSiteID:abc\tSiteName:x\tFloorId:y\tFloorName:F4"),
            LineOutcome::Header
        );
        assert_eq!(p.floor_name.as_deref(), Some("F4"));
        let e = ev(
            &mut p,
            "1000000000250\tTYPE_ACCELEROMETER\t0.5\t-1.25\t9.75\t3",
        );
        assert_eq!(
            e,
            LogEvent::Sensor(SensorEvent {
                t_ns: 250_000_000,
                data: SensorData::Accelerometer([0.5, -1.25, 9.75])
            })
        );
        let e = ev(&mut p, "1000000000300\tTYPE_ROTATION_VECTOR\t0.6\t0\t0\t3");
        match e {
            LogEvent::Sensor(SensorEvent {
                data: SensorData::RotationVector(q),
                ..
            }) => {
                assert!((q[3] - 0.8).abs() < 1e-12)
            }
            _ => panic!(),
        }
        let e = ev(&mut p, "1000000000400\tTYPE_WAYPOINT\t12.5\t7.25");
        assert_eq!(
            e,
            LogEvent::Truth(TruthPoint {
                t_ns: 400_000_000,
                x_m: 12.5,
                y_m: 7.25,
                floor: Some(4)
            })
        );
    }

    #[test]
    fn beacons_and_blue_rows() {
        let mut p = IlcParser::new(None);
        let e = ev(
            &mut p,
            "5000\tTYPE_BEACON\tabcd0000-0000-0000-0000-000000000001\t7\t9\t-59\t-81\t3.2\t01:02:03:04:05:06\t5000",
        );
        assert_eq!(
            e,
            LogEvent::Ble(BleObservation {
                t_ns: 0,
                beacon_id: "ibeacon:ABCD0000-0000-0000-0000-000000000001:7:9".into(),
                rssi_dbm: -81.0,
                tx_power_dbm: Some(-59.0)
            })
        );
        let e = ev(
            &mut p,
            "5010\tTYPE_BEACON\tabcd\t7\t9\t68\t-90\t3.2\t01:02:03:04:05:06\t5010",
        );
        assert!(matches!(
            e,
            LogEvent::Ble(BleObservation {
                tx_power_dbm: None,
                ..
            })
        ));
        assert_eq!(p.invalid_tx_power, 1);
        let e = ev(&mut p, "5020\tTYPE_BLUE\t\taa:bb:cc:dd:ee:0f\t-77");
        assert_eq!(
            e,
            LogEvent::Ble(BleObservation {
                t_ns: 20_000_000,
                beacon_id: "mac:AA:BB:CC:DD:EE:0F".into(),
                rssi_dbm: -77.0,
                tx_power_dbm: None
            })
        );
        let e = ev(&mut p, "5030\tTYPE_BLUE\tmy\tlamp\taa:bb:cc:dd:ee:0f\t-70");
        assert!(matches!(
            e,
            LogEvent::Ble(BleObservation {
                rssi_dbm: -70.0,
                ..
            })
        ));
    }

    #[test]
    fn unused_and_malformed_rows() {
        let mut p = IlcParser::new(None);
        assert_eq!(
            p.parse_line("10\tTYPE_GYROSCOPE_UNCALIBRATED\t1\t2\t3\t4\t5\t6\t3"),
            LineOutcome::Ignored
        );
        assert!(matches!(
            p.parse_line("10\tTYPE_GYROSCOPE\t1\t2"),
            LineOutcome::Malformed(_)
        ));
        assert!(matches!(
            p.parse_line("x\tTYPE_GYROSCOPE\t1\t2\t3\t0"),
            LineOutcome::Malformed(_)
        ));
        assert!(matches!(
            p.parse_line("10\tTYPE_BLUE\t\tnot-a-mac\t-70"),
            LineOutcome::Malformed(_)
        ));
        assert!(matches!(
            p.parse_line("10\tGARBAGE"),
            LineOutcome::Malformed(_)
        ));
        assert!(matches!(
            p.parse_line("10\tTYPE_BEACON\tu\t70000000000\t1\t-59\t-80"),
            LineOutcome::Malformed(_)
        ));
    }

    #[test]
    fn wifi_rows_keep_their_own_last_seen_time() {
        let mut p = IlcParser::new(None);
        assert_eq!(p.parse_line("#\tstartTime:1000000"), LineOutcome::Header);
        // an SSID with a space, an upper-case BSSID, a result 2.5 s old
        assert_eq!(
            p.parse_line("1003000\tTYPE_WIFI\tmy net\tA8:0C:CA:03:9D:D7\t-49\t5785\t1000500"),
            LineOutcome::WifiRow {
                t_ns: 3_000_000_000,
                result: WifiResult {
                    bssid: "a8:0c:ca:03:9d:d7".into(),
                    rssi_dbm: -49.0,
                    freq_mhz: 5785,
                    seen_t_ns: 500_000_000,
                }
            }
        );
        // empty SSID; last seen before the trace started
        match p.parse_line("1003000\tTYPE_WIFI\t\t04:33:89:79:fc:7c\t-70\t2412\t990000") {
            LineOutcome::WifiRow { result, .. } => {
                assert_eq!(result.seen_t_ns, -10_000_000_000)
            }
            o => panic!("{o:?}"),
        }
        for (bad, what) in [
            (
                "1003000\tTYPE_WIFI\tx\tnot-a-bssid\t-70\t2412\t1000000",
                "bssid",
            ),
            (
                "1003000\tTYPE_WIFI\tx\t04:33:89:79:fc:7c\tloud\t2412\t1000000",
                "rssi_dbm",
            ),
            (
                "1003000\tTYPE_WIFI\tx\t04:33:89:79:fc:7c\t-70\t0\t1000000",
                "frequency_mhz",
            ),
            (
                "1003000\tTYPE_WIFI\tx\t04:33:89:79:fc:7c\t-70\t2412\t1004000",
                "after the row",
            ),
            (
                "1003000\tTYPE_WIFI\t04:33:89:79:fc:7c\t-70\t2412",
                "needs 5 fields",
            ),
        ] {
            match p.parse_line(bad) {
                LineOutcome::MalformedWifi(m) => assert!(m.contains(what), "{bad}: {m}"),
                o => panic!("{bad}: {o:?}"),
            }
        }
    }

    #[test]
    fn detection() {
        assert!(looks_like("#\tstartTime:1574149352216"));
        assert!(looks_like("1574149352369\tTYPE_ACCELEROMETER\t1\t2\t3\t2"));
        assert!(!looks_like("ACCE;0.1;0.1;1;2;3;3"));
    }
}
