//! What a format parser makes of one line, and small field helpers.

use fpbp_core::events::{LogEvent, WifiResult};

/// The result of parsing one line.
#[derive(Debug, Clone, PartialEq)]
pub enum LineOutcome {
    /// A header, comment or empty line.
    Header,
    /// One event.
    Event(LogEvent),
    /// A well-formed record of a kind fpbp does not use.
    Ignored,
    /// A lat/lon truth point that needs the site georeference, which was not given.
    TruthWithoutGeoref,
    /// A malformed line; the message says what is wrong.
    Malformed(String),
    /// One access point of a WiFi scan (ILC `TYPE_WIFI`, IPIN `WIFI`: one
    /// row per result). The reader groups consecutive rows of one `t_ns`
    /// into one [`fpbp_core::events::WifiScan`].
    WifiRow { t_ns: i64, result: WifiResult },
    /// A malformed WiFi row (counted as malformed and, separately, as a
    /// malformed WiFi row).
    MalformedWifi(String),
}

/// Parses field `i` of `fields` as f64, naming it in the error.
pub fn f64_field(fields: &[&str], i: usize, name: &str) -> Result<f64, String> {
    let s = fields
        .get(i)
        .ok_or_else(|| format!("missing field {} ({name})", i + 1))?;
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("field {} ({name}): `{s}` is not a number", i + 1))
}

/// Parses field `i` as i64.
pub fn i64_field(fields: &[&str], i: usize, name: &str) -> Result<i64, String> {
    let s = fields
        .get(i)
        .ok_or_else(|| format!("missing field {} ({name})", i + 1))?;
    s.trim()
        .parse::<i64>()
        .map_err(|_| format!("field {} ({name}): `{s}` is not an integer", i + 1))
}

/// Field `i` as a trimmed string.
pub fn str_field<'a>(fields: &[&'a str], i: usize, name: &str) -> Result<&'a str, String> {
    fields
        .get(i)
        .map(|s| s.trim())
        .ok_or_else(|| format!("missing field {} ({name})", i + 1))
}

/// Seconds -> ns, rejecting non-finite or out-of-range times.
pub fn seconds_to_ns(s: f64) -> Result<i64, String> {
    let ns = (s * 1e9).round();
    if ns.is_finite() && ns.abs() < 9.0e18 {
        Ok(ns as i64)
    } else {
        Err(format!("time {s} s is out of range"))
    }
}

/// `ibeacon:UUID:major:minor` with the UUID in upper case.
pub fn ibeacon_id(uuid: &str, major: u32, minor: u32) -> String {
    format!("ibeacon:{}:{major}:{minor}", uuid.to_ascii_uppercase())
}

/// Whether `mac` has the shape `aa:bb:cc:dd:ee:ff` (hex digits, any case).
fn is_mac(mac: &str) -> bool {
    mac.len() == 17
        && mac.split(':').count() == 6
        && mac
            .split(':')
            .all(|b| b.len() == 2 && b.chars().all(|c| c.is_ascii_hexdigit()))
}

/// `mac:AA:BB:CC:DD:EE:FF` in upper case; checks the shape.
pub fn mac_id(mac: &str) -> Result<String, String> {
    if is_mac(mac) {
        Ok(format!("mac:{}", mac.to_ascii_uppercase()))
    } else {
        Err(format!("`{mac}` is not a MAC address"))
    }
}

/// A WiFi BSSID normalised to lower case `aa:bb:cc:dd:ee:ff` (`:` or `-`
/// separated in the log); checks the shape.
pub fn bssid(mac: &str) -> Result<String, String> {
    fpbp_core::wifi::normalize_bssid(mac)
        .ok_or_else(|| format!("`{mac}` is not a BSSID (aa:bb:cc:dd:ee:ff)"))
}

/// One WiFi row's outcome.
pub fn wifi_row(
    t_ns: i64,
    bssid: String,
    rssi_dbm: f64,
    freq_mhz: u32,
    seen_t_ns: i64,
) -> LineOutcome {
    LineOutcome::WifiRow {
        t_ns,
        result: WifiResult {
            bssid,
            rssi_dbm,
            freq_mhz,
            seen_t_ns,
        },
    }
}

/// Parses field `i` as a WiFi channel frequency in MHz (1..=100000).
pub fn freq_mhz_field(fields: &[&str], i: usize) -> Result<u32, String> {
    let v = i64_field(fields, i, "frequency_mhz")?;
    u32::try_from(v)
        .ok()
        .filter(|f| (1..=100_000).contains(f))
        .ok_or_else(|| {
            format!(
                "field {} (frequency_mhz): {v} is not in 1..=100000 MHz",
                i + 1
            )
        })
}

/// Whether every number in the event is finite.
pub fn is_finite(e: &LogEvent) -> bool {
    use fpbp_core::events::SensorData as S;
    let fin = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let opt = |v: Option<f64>| v.is_none_or(f64::is_finite);
    match e {
        LogEvent::Sensor(s) => match &s.data {
            S::Accelerometer(v) | S::Gyroscope(v) | S::Magnetometer(v) => fin(v),
            S::RotationVector(q) | S::GameRotationVector(q) => fin(q),
            S::Pressure(p) => p.is_finite(),
        },
        LogEvent::Ble(b) => b.rssi_dbm.is_finite() && opt(b.tx_power_dbm),
        LogEvent::Gnss(g) => {
            fin(&[g.lat_deg, g.lon_deg])
                && opt(g.alt_m)
                && opt(g.accuracy_m)
                && opt(g.speed_mps)
                && opt(g.bearing_deg)
        }
        LogEvent::Wifi(w) => w.results.iter().all(|r| r.rssi_dbm.is_finite()),
        LogEvent::Truth(t) => t.x_m.is_finite() && t.y_m.is_finite(),
    }
}

/// A BLE tx power is plausible in [-127, 0) dBm (ILC logs a +68 byte now and then).
pub fn valid_tx_power(tx_dbm: f64) -> bool {
    (-127.0..0.0).contains(&tx_dbm)
}
