//! Writes the events of a log as the engine receives them, every f64 as
//! the hex of its bits, for the JVM host tests (host-tests/jvm
//! `FacadeReplayTest`): the Kotlin side feeds them through the library
//! exactly as read by fpbp-logs (native, ILC or IPIN; the reader `fpbp
//! eval` uses), so its track can be compared bit for bit with `fpbp eval
//! --tracks`. Truth points are written as time marks only (they run the
//! due tasks, as in `fpbp_core::engine::replay`, and are never fed).
//!
//! ```text
//! # fpbp-events 1 events=12345
//! S <t_ns> <android sensor type> <value bits>...
//! B <t_ns> <beacon id> <rssi bits> <tx power bits (NaN = none)>
//! W <t_ns> <n> (<bssid> <rssi bits> <freq MHz> <seen t_ns>) x n
//! G <t_ns> <lat bits> <lon bits> <alt bits> <accuracy bits> <speed bits> <bearing bits>
//! T <t_ns>
//! ```
//!
//! Usage: `events_dump LOG OUT`

use std::io::Write;
use std::process::ExitCode;

use fpbp_core::events::{LogEvent, SensorData};

fn bits(v: f64) -> String {
    format!("{:016x}", v.to_bits())
}

fn opt(v: Option<f64>) -> String {
    bits(v.unwrap_or(f64::NAN))
}

fn values(d: &SensorData) -> Vec<f64> {
    match d {
        SensorData::Accelerometer(v) | SensorData::Gyroscope(v) | SensorData::Magnetometer(v) => {
            v.to_vec()
        }
        SensorData::RotationVector(q) | SensorData::GameRotationVector(q) => q.to_vec(),
        SensorData::Pressure(p) => vec![*p],
    }
}

fn run() -> Result<usize, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output] = args.as_slice() else {
        return Err("usage: events_dump LOG OUT".into());
    };
    let opts = fpbp_logs::ReadOptions::default();
    let (events, _report) =
        fpbp_logs::read_all(std::path::Path::new(input), &opts).map_err(|e| e.to_string())?;
    let file = std::fs::File::create(output).map_err(|e| format!("{output}: {e}"))?;
    let mut w = std::io::BufWriter::new(file);
    let mut put = || -> std::io::Result<()> {
        writeln!(w, "# fpbp-events 1 events={}", events.len())?;
        for e in &events {
            match e {
                LogEvent::Sensor(s) => {
                    write!(w, "S {} {}", s.t_ns, s.data.android_type())?;
                    for v in values(&s.data) {
                        write!(w, " {}", bits(v))?;
                    }
                    writeln!(w)?;
                }
                LogEvent::Ble(b) => writeln!(
                    w,
                    "B {} {} {} {}",
                    b.t_ns,
                    b.beacon_id,
                    bits(b.rssi_dbm),
                    opt(b.tx_power_dbm)
                )?,
                LogEvent::Wifi(s) => {
                    write!(w, "W {} {}", s.t_ns, s.results.len())?;
                    for r in &s.results {
                        write!(
                            w,
                            " {} {} {} {}",
                            r.bssid,
                            bits(r.rssi_dbm),
                            r.freq_mhz,
                            r.seen_t_ns
                        )?;
                    }
                    writeln!(w)?;
                }
                LogEvent::Gnss(g) => writeln!(
                    w,
                    "G {} {} {} {} {} {} {}",
                    g.t_ns,
                    bits(g.lat_deg),
                    bits(g.lon_deg),
                    opt(g.alt_m),
                    opt(g.accuracy_m),
                    opt(g.speed_mps),
                    opt(g.bearing_deg)
                )?,
                LogEvent::Truth(t) => writeln!(w, "T {}", t.t_ns)?,
            }
        }
        w.flush()
    };
    put().map_err(|e| format!("{output}: {e}"))?;
    Ok(events.len())
}

fn main() -> ExitCode {
    match run() {
        Ok(n) => {
            eprintln!("events_dump: {n} events");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("events_dump: {e}");
            ExitCode::FAILURE
        }
    }
}
