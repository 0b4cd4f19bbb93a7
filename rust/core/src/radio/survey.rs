//! Radio samples of a walked survey log with ground truth: every BLE
//! reading and every new WiFi result ([`crate::wifi::FreshResults`]) placed
//! at the walker's position at its time, keyed as the engines key them
//! (BLE by canonical beacon id, [`normalize_beacon_id`]; WiFi by lower-case
//! BSSID). Positions come from linear interpolation between two truth
//! points on one floor ([`crate::ble::calibrate`]'s interpolation, within
//! runs of truth points on the same floor); readings outside the truth's
//! time span, across long truth gaps or across a floor change get none.
//!
//! Pure: takes one log's events, returns its samples.

use std::collections::BTreeMap;

use super::model::TxKind;
use crate::Vec2;
use crate::ble::calibrate::interpolate;
use crate::events::{LogEvent, TruthPoint};
use crate::radio_id::normalize_beacon_id;
use crate::wifi::FreshResults;

/// What [`survey_samples`] keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurveyOptions {
    /// Floor of truth points without one (single-floor sites), if any.
    pub default_floor: Option<i32>,
    /// No position across truth points further apart than this, ns.
    pub max_truth_gap_ns: i64,
    /// WiFi results older than this (vs their scan) are dropped, ns.
    pub wifi_max_age_ns: i64,
    /// Readings weaker than this are dropped, dBm.
    pub min_rssi_dbm: f64,
}

/// One reading placed on the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct RadioSample {
    pub kind: TxKind,
    /// Canonical id (beacon id or lower-case BSSID).
    pub id: String,
    pub floor: i32,
    /// Walker's position in the MCS, metres.
    pub pos: Vec2,
    pub rssi_dbm: f64,
    /// When it was heard (a WiFi result: its last-seen time), ns.
    pub t_ns: i64,
}

/// Counters of one log.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SurveyCounts {
    /// Readings seen (BLE adverts and new WiFi results).
    pub readings: usize,
    /// Readings placed (with a position).
    pub placed: usize,
    /// Readings without a position (no truth around them, floor change, gap).
    pub without_truth: usize,
    /// Unparsable beacon ids, non-finite or too weak RSSI.
    pub invalid: usize,
}

/// Truth points with a floor, split into time-sorted runs on one floor.
fn floor_runs(events: &[LogEvent], default_floor: Option<i32>) -> Vec<Vec<TruthPoint>> {
    let mut truth: Vec<TruthPoint> = events
        .iter()
        .filter_map(|e| match e {
            LogEvent::Truth(t) if t.x_m.is_finite() && t.y_m.is_finite() => {
                let floor = t.floor.or(default_floor)?;
                Some(TruthPoint {
                    floor: Some(floor),
                    ..*t
                })
            }
            _ => None,
        })
        .collect();
    truth.sort_by_key(|t| t.t_ns);
    let mut runs: Vec<Vec<TruthPoint>> = Vec::new();
    for t in truth {
        match runs.last_mut() {
            Some(r) if r.last().is_some_and(|l| l.floor == t.floor) => r.push(t),
            _ => runs.push(vec![t]),
        }
    }
    runs
}

/// The walker's (position, floor) at `t_ns`: inside one same-floor run.
fn position_at(runs: &[Vec<TruthPoint>], t_ns: i64, max_gap_ns: i64) -> Option<(Vec2, i32)> {
    let i = runs.partition_point(|r| r.first().is_some_and(|p| p.t_ns <= t_ns));
    let run = runs.get(i.checked_sub(1)?)?;
    interpolate(run, t_ns, max_gap_ns)
}

/// The placed readings of one log (time-ordered events), handed to `sink`
/// one by one (a survey can hold millions), and the log's counters.
pub fn survey_samples(
    events: &[LogEvent],
    opts: &SurveyOptions,
    mut sink: impl FnMut(RadioSample),
) -> SurveyCounts {
    let runs = floor_runs(events, opts.default_floor);
    let mut counts = SurveyCounts::default();
    let mut fresh = FreshResults::default();
    let mut ids: BTreeMap<String, Option<String>> = BTreeMap::new();
    let mut place = |kind: TxKind, id: String, t_ns: i64, rssi_dbm: f64, c: &mut SurveyCounts| {
        match position_at(&runs, t_ns, opts.max_truth_gap_ns) {
            Some((pos, floor)) => {
                c.placed += 1;
                sink(RadioSample {
                    kind,
                    id,
                    floor,
                    pos,
                    rssi_dbm,
                    t_ns,
                });
            }
            None => c.without_truth += 1,
        }
    };
    let usable = |r: f64| r.is_finite() && r < 0.0 && r >= opts.min_rssi_dbm;
    for e in events {
        match e {
            LogEvent::Ble(o) => {
                counts.readings += 1;
                let canon = ids
                    .entry(o.beacon_id.clone())
                    .or_insert_with(|| normalize_beacon_id(&o.beacon_id).ok())
                    .clone();
                match canon {
                    Some(id) if usable(o.rssi_dbm) => {
                        place(TxKind::Ble, id, o.t_ns, o.rssi_dbm, &mut counts);
                    }
                    _ => counts.invalid += 1,
                }
            }
            LogEvent::Wifi(scan) => {
                for r in fresh.of(scan, opts.wifi_max_age_ns) {
                    counts.readings += 1;
                    if !usable(r.rssi_dbm) {
                        counts.invalid += 1;
                        continue;
                    }
                    let id = r.bssid.to_ascii_lowercase();
                    // where the AP was really heard (results can be seconds old)
                    let t = r.seen_t_ns.min(scan.t_ns);
                    place(TxKind::Wifi, id, t, r.rssi_dbm, &mut counts);
                }
            }
            LogEvent::Sensor(_) | LogEvent::Gnss(_) | LogEvent::Truth(_) => {}
        }
    }
    counts
}

/// The calibrated magnetometer samples of one log placed like the radio
/// readings (truth runs of one floor, no gap over `max_truth_gap_ns`):
/// `sink(floor, position, |B| uT)` for each; returns (seen, placed).
/// Samples that are not finite or read more than
/// [`super::magnetic_map::MAX_FIELD_UT`] are seen but not placed.
pub fn magnetic_samples(
    events: &[LogEvent],
    opts: &SurveyOptions,
    mut sink: impl FnMut(i32, Vec2, f64),
) -> (usize, usize) {
    let runs = floor_runs(events, opts.default_floor);
    let (mut seen, mut placed) = (0, 0);
    for e in events {
        if let LogEvent::Sensor(s) = e
            && let crate::events::SensorData::Magnetometer(b) = s.data
        {
            seen += 1;
            let ut = super::magnetic_map::magnitude_ut(b);
            if !(ut.is_finite() && ut <= super::magnetic_map::MAX_FIELD_UT) {
                continue;
            }
            if let Some((pos, floor)) = position_at(&runs, s.t_ns, opts.max_truth_gap_ns) {
                placed += 1;
                sink(floor, pos, ut);
            }
        }
    }
    (seen, placed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::{BleObservation, WifiResult, WifiScan};

    fn truth(t_s: f64, x: f64, floor: Option<i32>) -> LogEvent {
        LogEvent::Truth(TruthPoint {
            t_ns: (t_s * 1e9) as i64,
            x_m: x,
            y_m: 0.0,
            floor,
        })
    }

    fn ble(t_s: f64, rssi: f64) -> LogEvent {
        LogEvent::Ble(BleObservation {
            t_ns: (t_s * 1e9) as i64,
            beacon_id: "MAC:AA:BB:CC:DD:EE:01".into(),
            rssi_dbm: rssi,
            tx_power_dbm: None,
        })
    }

    #[test]
    fn readings_are_placed_between_truth_points_of_one_floor() {
        let opts = SurveyOptions {
            default_floor: Some(0),
            max_truth_gap_ns: 20_000_000_000,
            wifi_max_age_ns: 4_000_000_000,
            min_rssi_dbm: -100.0,
        };
        let scan = LogEvent::Wifi(WifiScan {
            t_ns: 6_000_000_000,
            results: vec![WifiResult {
                bssid: "0A:00:00:00:00:01".into(),
                rssi_dbm: -70.0,
                freq_mhz: 2412,
                seen_t_ns: 5_000_000_000,
            }],
        });
        let events = vec![
            truth(0.0, 0.0, None),
            ble(2.5, -60.0),
            scan,
            truth(10.0, 10.0, Some(0)),
            ble(12.0, -61.0),
            truth(14.0, 0.0, Some(1)),
            ble(15.0, f64::NAN),
            ble(16.0, -62.0),
            truth(18.0, 4.0, Some(1)),
        ];
        let mut got = Vec::new();
        let c = survey_samples(&events, &opts, |s| got.push(s));
        assert_eq!(c.readings, 5);
        assert_eq!((c.placed, c.without_truth, c.invalid), (3, 1, 1));
        assert_eq!(got[0].kind, TxKind::Ble);
        assert!(
            got[0].id.starts_with("mac:") || got[0].id.contains("aa:bb"),
            "{}",
            got[0].id
        );
        assert!((got[0].pos.x - 2.5).abs() < 1e-9 && got[0].floor == 0);
        // the WiFi result at its last-seen time, lower-case BSSID
        assert_eq!(got[1].id, "0a:00:00:00:00:01");
        assert!((got[1].pos.x - 5.0).abs() < 1e-9);
        // across the floor change (10 s -> 14 s): no position; on floor 1: yes
        assert!((got[2].pos.x - 2.0).abs() < 1e-9 && got[2].floor == 1);
    }
}
