//! `fpbp eval --radios ble,wifi`: which radios' events an engine is given,
//! so the gain of each radio is measured on the same logs.

use fpbp_core::events::LogEvent;

/// A radio whose events can be left out of a replay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Radio {
    Ble,
    Wifi,
}

/// Drops the events of the radios not in `keep` (sensors, GNSS and truth stay).
pub fn keep_radios(events: &mut Vec<LogEvent>, keep: &[Radio]) {
    events.retain(|e| match e {
        LogEvent::Ble(_) => keep.contains(&Radio::Ble),
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
}
