//! fpbp native log v2 (and v1): text, one event per line, `t_ns` first
//! (docs/logs.md "Native log"). v2 adds `WIFI` lines (one scan per line);
//! v1 files are still read, and can still be written for readers that know
//! only v1 ([`NativeWriter::with_version`]).
//!
//! ```text
//! #fpbp-log 2
//! #meta device=Pixel 7
//! #meta seed=42
//! 1000000 ACC 0.1 0.2 9.81
//! 1000000 BLE ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:2 -71 -59
//! 1500000 WIFI 2 a8:0c:ca:03:9d:d7 -49 2422 1400000 a8:0c:ca:83:9d:d7 -59 5785 1500000
//! 2000000 TRUTH 12.5 3.25 0
//! ```

use std::collections::BTreeMap;
use std::io::Write;

use fpbp_core::events::{
    BleObservation, GnssFix, LogEvent, SensorData, SensorEvent, TruthPoint, WifiResult, WifiScan,
};

use crate::line::{LineOutcome, bssid, f64_field, i64_field, str_field};
use crate::wifi_group::MAX_RESULTS_PER_SCAN;

/// First line of every native log (followed by a space and the version).
pub const MAGIC: &str = "#fpbp-log";
/// The version [`NativeWriter::new`] writes.
pub const VERSION: u32 = 2;
/// The versions this module reads (and [`NativeWriter::with_version`] writes).
pub const READ_VERSIONS: [u32; 2] = [1, 2];

/// The header of a native log: version and free `key=value` metadata
/// (device, site, seed, ...). Keys have no whitespace and no `=`; values are
/// one line.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NativeHeader {
    pub meta: BTreeMap<String, String>,
}

impl NativeHeader {
    /// A header with no metadata.
    pub fn new() -> Self {
        NativeHeader::default()
    }

    /// Adds one metadata entry (builder style).
    pub fn with(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.meta.insert(key.into(), value.into());
        self
    }
}

/// Writes a native log (v2 unless asked for v1).
pub struct NativeWriter<W: Write> {
    w: W,
    line: String,
    version: u32,
}

fn invalid(msg: String) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, msg)
}

impl<W: Write> NativeWriter<W> {
    /// Writes the header lines of a v2 log. Fails if a metadata key or value
    /// cannot be written on one line.
    pub fn new(w: W, header: &NativeHeader) -> std::io::Result<Self> {
        Self::with_version(w, header, VERSION)
    }

    /// [`NativeWriter::new`] for a given version of [`READ_VERSIONS`]: a v1
    /// writer (for readers that know only v1) refuses WiFi scans.
    pub fn with_version(mut w: W, header: &NativeHeader, version: u32) -> std::io::Result<Self> {
        if !READ_VERSIONS.contains(&version) {
            return Err(invalid(format!(
                "native log version {version} is not one of {READ_VERSIONS:?}"
            )));
        }
        writeln!(w, "{MAGIC} {version}")?;
        for (k, v) in &header.meta {
            if k.is_empty() || k.contains(char::is_whitespace) || k.contains('=') {
                return Err(invalid(format!("native header: bad metadata key `{k}`")));
            }
            if v.contains(['\n', '\r']) {
                return Err(invalid(format!(
                    "native header: value of `{k}` has a line break"
                )));
            }
            writeln!(w, "#meta {k}={v}")?;
        }
        Ok(NativeWriter {
            w,
            line: String::new(),
            version,
        })
    }

    /// Writes one event. Floats use Rust's shortest round-trip representation,
    /// so a write -> read round trip is exact.
    pub fn write(&mut self, e: &LogEvent) -> std::io::Result<()> {
        use std::fmt::Write as _;
        let l = &mut self.line;
        l.clear();
        let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x}"));
        // Writing into a String cannot fail.
        let _ = match e {
            LogEvent::Sensor(s) => match s.data {
                SensorData::Accelerometer(v) => {
                    write!(l, "{} ACC {} {} {}", s.t_ns, v[0], v[1], v[2])
                }
                SensorData::Gyroscope(v) => write!(l, "{} GYR {} {} {}", s.t_ns, v[0], v[1], v[2]),
                SensorData::Magnetometer(v) => {
                    write!(l, "{} MAG {} {} {}", s.t_ns, v[0], v[1], v[2])
                }
                SensorData::RotationVector(q) => {
                    write!(l, "{} ROT {} {} {} {}", s.t_ns, q[0], q[1], q[2], q[3])
                }
                SensorData::GameRotationVector(q) => {
                    write!(l, "{} GRV {} {} {} {}", s.t_ns, q[0], q[1], q[2], q[3])
                }
                SensorData::Pressure(p) => write!(l, "{} PRS {}", s.t_ns, p),
            },
            LogEvent::Ble(b) => {
                if b.beacon_id.is_empty() || b.beacon_id.contains(char::is_whitespace) {
                    return Err(invalid(format!(
                        "native log: beacon id `{}` is empty or has whitespace",
                        b.beacon_id
                    )));
                }
                write!(
                    l,
                    "{} BLE {} {} {}",
                    b.t_ns,
                    b.beacon_id,
                    b.rssi_dbm,
                    opt(b.tx_power_dbm)
                )
            }
            LogEvent::Gnss(g) => write!(
                l,
                "{} GNSS {} {} {} {} {} {}",
                g.t_ns,
                g.lat_deg,
                g.lon_deg,
                opt(g.alt_m),
                opt(g.accuracy_m),
                opt(g.speed_mps),
                opt(g.bearing_deg)
            ),
            LogEvent::Wifi(w) => {
                if self.version < 2 {
                    return Err(invalid("native log v1 has no WiFi lines".to_string()));
                }
                write_wifi(l, w)?;
                Ok(())
            }
            LogEvent::Truth(t) => write!(
                l,
                "{} TRUTH {} {} {}",
                t.t_ns,
                t.x_m,
                t.y_m,
                t.floor.map_or("-".to_string(), |f| f.to_string())
            ),
        };
        l.push('\n');
        self.w.write_all(l.as_bytes())
    }

    /// Flushes and returns the inner writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.w.flush()?;
        Ok(self.w)
    }
}

/// `t WIFI n` then `bssid rssi freq_mhz seen_t_ns` per result. BSSIDs must
/// be canonical (lower-case `aa:bb:cc:dd:ee:ff`, what the readers produce),
/// so that a write -> read round trip is exact.
fn write_wifi(l: &mut String, w: &WifiScan) -> std::io::Result<()> {
    use std::fmt::Write as _;
    if w.results.len() > MAX_RESULTS_PER_SCAN {
        return Err(invalid(format!(
            "native log: WiFi scan at {} has {} results (at most {MAX_RESULTS_PER_SCAN})",
            w.t_ns,
            w.results.len()
        )));
    }
    let _ = write!(l, "{} WIFI {}", w.t_ns, w.results.len());
    for r in &w.results {
        if bssid(&r.bssid).as_deref() != Ok(r.bssid.as_str()) {
            return Err(invalid(format!(
                "native log: BSSID `{}` is not lower-case aa:bb:cc:dd:ee:ff",
                r.bssid
            )));
        }
        let _ = write!(
            l,
            " {} {} {} {}",
            r.bssid, r.rssi_dbm, r.freq_mhz, r.seen_t_ns
        );
    }
    Ok(())
}

/// Parses a `WIFI` line's fields (`f[0]` = t_ns, `f[1]` = `WIFI`). The count
/// is checked against the line's length before anything is allocated.
fn parse_wifi(f: &[&str], t_ns: i64) -> Result<WifiScan, String> {
    let n = i64_field(f, 2, "n_results")?;
    let n = usize::try_from(n)
        .ok()
        .filter(|n| *n <= MAX_RESULTS_PER_SCAN)
        .ok_or_else(|| format!("field 3 (n_results): {n} is not in 0..={MAX_RESULTS_PER_SCAN}"))?;
    if f.len() != 3 + 4 * n {
        return Err(format!(
            "WIFI with {n} results needs {} values, got {}",
            1 + 4 * n,
            f.len() - 2
        ));
    }
    let mut results = Vec::with_capacity(n);
    for k in 0..n {
        let i = 3 + 4 * k;
        let freq = i64_field(f, i + 2, "freq_mhz")?;
        let seen_t_ns = i64_field(f, i + 3, "seen_t_ns")?;
        if seen_t_ns > t_ns {
            return Err(format!(
                "field {} (seen_t_ns): {seen_t_ns} is after the scan's time {t_ns}",
                i + 4
            ));
        }
        results.push(WifiResult {
            bssid: bssid(f[i]).map_err(|m| format!("field {} (bssid): {m}", i + 1))?,
            rssi_dbm: f64_field(f, i + 1, "rssi_dbm")?,
            freq_mhz: u32::try_from(freq)
                .map_err(|_| format!("field {} (freq_mhz): {freq} is out of range", i + 3))?,
            seen_t_ns,
        });
    }
    Ok(WifiScan { t_ns, results })
}

/// Parses the header line; `Ok(version)` when it is a native header.
pub fn parse_magic(line: &str) -> Option<&str> {
    let rest = line.trim_end().strip_prefix(MAGIC)?;
    let v = rest.trim();
    (rest.starts_with(char::is_whitespace) && !v.is_empty()).then_some(v)
}

/// Line parser of native v1 and v2 logs.
#[derive(Debug, Default)]
pub struct NativeParser {
    /// Metadata gathered from `#meta` lines.
    pub header: NativeHeader,
    /// The version of the header line, once read.
    pub version: Option<u32>,
    default_floor: Option<i32>,
}

impl NativeParser {
    pub fn new(default_floor: Option<i32>) -> Self {
        NativeParser {
            header: NativeHeader::new(),
            version: None,
            default_floor,
        }
    }

    /// Parses one line (without its line break).
    pub fn parse_line(&mut self, line: &str) -> LineOutcome {
        let line = line.trim_end_matches(['\r', '\n']);
        if line.trim().is_empty() {
            return LineOutcome::Header;
        }
        if self.version.is_none()
            && let Some(v) = parse_magic(line.trim_start_matches('\u{feff}'))
        {
            self.version = v.parse().ok();
            return LineOutcome::Header;
        }
        if let Some(rest) = line.strip_prefix('#') {
            if let Some(kv) = rest.strip_prefix("meta ")
                && let Some((k, v)) = kv.split_once('=')
            {
                self.header.meta.insert(k.trim().to_string(), v.to_string());
            }
            return LineOutcome::Header;
        }
        match self.parse_event(line) {
            Ok(e) => LineOutcome::Event(e),
            Err(m) if line.split_whitespace().nth(1) == Some("WIFI") => {
                LineOutcome::MalformedWifi(m)
            }
            Err(m) => LineOutcome::Malformed(m),
        }
    }

    fn parse_event(&self, line: &str) -> Result<LogEvent, String> {
        let f: Vec<&str> = line.split_whitespace().collect();
        let t_ns = i64_field(&f, 0, "t_ns")?;
        let kind = str_field(&f, 1, "kind")?;
        let need = |n: usize| -> Result<(), String> {
            if f.len() == n {
                Ok(())
            } else {
                Err(format!(
                    "{kind} needs {} values, got {}",
                    n - 2,
                    f.len().saturating_sub(2)
                ))
            }
        };
        let num = |i: usize, name: &str| f64_field(&f, i, name);
        let opt = |i: usize, name: &str| -> Result<Option<f64>, String> {
            if f.get(i) == Some(&"-") {
                Ok(None)
            } else {
                num(i, name).map(Some)
            }
        };
        let v3 = || -> Result<[f64; 3], String> { Ok([num(2, "x")?, num(3, "y")?, num(4, "z")?]) };
        let q4 = || -> Result<[f64; 4], String> {
            Ok([num(2, "x")?, num(3, "y")?, num(4, "z")?, num(5, "w")?])
        };
        let sensor = |data| Ok(LogEvent::Sensor(SensorEvent { t_ns, data }));
        match kind {
            "ACC" => {
                need(5)?;
                sensor(SensorData::Accelerometer(v3()?))
            }
            "GYR" => {
                need(5)?;
                sensor(SensorData::Gyroscope(v3()?))
            }
            "MAG" => {
                need(5)?;
                sensor(SensorData::Magnetometer(v3()?))
            }
            "ROT" => {
                need(6)?;
                sensor(SensorData::RotationVector(q4()?))
            }
            "GRV" => {
                need(6)?;
                sensor(SensorData::GameRotationVector(q4()?))
            }
            "PRS" => {
                need(3)?;
                sensor(SensorData::Pressure(num(2, "pressure_hpa")?))
            }
            "BLE" => {
                need(5)?;
                Ok(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: f[2].to_string(),
                    rssi_dbm: num(3, "rssi_dbm")?,
                    tx_power_dbm: opt(4, "tx_power_dbm")?,
                }))
            }
            "GNSS" => {
                need(8)?;
                Ok(LogEvent::Gnss(GnssFix {
                    t_ns,
                    lat_deg: num(2, "lat_deg")?,
                    lon_deg: num(3, "lon_deg")?,
                    alt_m: opt(4, "alt_m")?,
                    accuracy_m: opt(5, "accuracy_m")?,
                    speed_mps: opt(6, "speed_mps")?,
                    bearing_deg: opt(7, "bearing_deg")?,
                }))
            }
            "TRUTH" => {
                need(5)?;
                let floor =
                    if f[4] == "-" {
                        self.default_floor
                    } else {
                        Some(f[4].parse::<i32>().map_err(|_| {
                            format!("field 5 (floor): `{}` is not an integer", f[4])
                        })?)
                    };
                Ok(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: num(2, "x_m")?,
                    y_m: num(3, "y_m")?,
                    floor,
                }))
            }
            "WIFI" if self.version.is_some_and(|v| v < 2) => {
                Err("WIFI lines need native log version 2 (this file is version 1)".into())
            }
            "WIFI" => Ok(LogEvent::Wifi(parse_wifi(&f, t_ns)?)),
            other => Err(format!("unknown event kind `{other}`")),
        }
    }
}
