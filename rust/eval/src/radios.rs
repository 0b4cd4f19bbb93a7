//! `fpbp eval --radios ble,wifi`: which radios' events an engine is given,
//! so the gain of each radio is measured on the same logs. `wifi-throttled`
//! keeps WiFi thinned as Android 9+ throttles a foreground app's scans: a
//! scan is kept only when fewer than 4 were kept in the 2 minutes before it.

use fpbp_core::events::LogEvent;

/// A radio whose events can be left out of a replay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Radio {
    Ble,
    Wifi,
    /// WiFi with Android's foreground throttle applied to the log.
    WifiThrottled,
}

/// Android 9+ foreground throttle: scans per window.
pub const THROTTLE_MAX_SCANS: usize = 4;
pub const THROTTLE_WINDOW_NS: i64 = 120_000_000_000;

/// Drops the events of the radios not in `keep` (sensors, GNSS and truth stay).
pub fn keep_radios(events: &mut Vec<LogEvent>, keep: &[Radio]) {
    let throttled = keep.contains(&Radio::WifiThrottled) && !keep.contains(&Radio::Wifi);
    let mut kept: Vec<i64> = Vec::new();
    events.retain(|e| match e {
        LogEvent::Ble(_) => keep.contains(&Radio::Ble),
        LogEvent::Wifi(w) if throttled => {
            let recent = kept
                .iter()
                .filter(|t| w.t_ns - **t < THROTTLE_WINDOW_NS)
                .count();
            let ok = recent < THROTTLE_MAX_SCANS;
            if ok {
                kept.push(w.t_ns);
            }
            ok
        }
        LogEvent::Wifi(_) => keep.contains(&Radio::Wifi),
        _ => true,
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::events::{BleObservation, TruthPoint, WifiScan};

    #[test]
    fn only_the_named_radios_stay() {
        let all = vec![
            LogEvent::Ble(BleObservation {
                t_ns: 1,
                beacon_id: "mac:00:00:00:00:00:01".into(),
                rssi_dbm: -70.0,
                tx_power_dbm: None,
            }),
            LogEvent::Wifi(WifiScan {
                t_ns: 2,
                results: vec![],
            }),
            LogEvent::Truth(TruthPoint {
                t_ns: 3,
                x_m: 0.0,
                y_m: 0.0,
                floor: None,
            }),
        ];
        let kinds = |keep: &[Radio]| {
            let mut v = all.clone();
            keep_radios(&mut v, keep);
            v.iter().map(|e| e.t_ns()).collect::<Vec<_>>()
        };
        assert_eq!(kinds(&[Radio::Ble, Radio::Wifi]), vec![1, 2, 3]);
        assert_eq!(kinds(&[Radio::Ble]), vec![1, 3]);
        assert_eq!(kinds(&[Radio::Wifi]), vec![2, 3]);
        assert_eq!(kinds(&[]), vec![3]);
    }

    #[test]
    fn throttled_wifi_keeps_at_most_4_scans_in_2_minutes() {
        // a scan every 2 s for 5 minutes
        let mut v: Vec<LogEvent> = (0..150)
            .map(|k| {
                LogEvent::Wifi(WifiScan {
                    t_ns: k * 2_000_000_000,
                    results: vec![],
                })
            })
            .collect();
        keep_radios(&mut v, &[Radio::WifiThrottled]);
        let t: Vec<i64> = v.iter().map(|e| e.t_ns() / 1_000_000_000).collect();
        assert_eq!(t, vec![0, 2, 4, 6, 120, 122, 124, 126, 240, 242, 244, 246]);
    }
}
