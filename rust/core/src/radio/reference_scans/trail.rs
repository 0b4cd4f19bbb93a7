//! The phone's trailing window of readings, cut as the reference scans
//! were.

use std::collections::BTreeMap;

use super::ReferenceScans;
use crate::radio::model::TxKind;

/// A phone's trailing window of readings, as the reference scans were cut:
/// readings of the last `window_s`, mean per transmitter.
#[derive(Debug, Clone, Default)]
pub struct ScanTrail {
    readings: std::collections::VecDeque<(i64, u32, f64)>,
    /// Reference-scan index of each beacon id as heard (cached).
    ble_ids: BTreeMap<String, Option<u32>>,
}

/// Most readings a trail keeps (a flood of adverts cannot grow it).
const MAX_TRAIL: usize = 20_000;
/// Most beacon ids whose index is cached.
const MAX_ID_CACHE: usize = 4096;

impl ScanTrail {
    /// A BLE advert of beacon `raw_id` (any spelling), if `scans` knows it.
    pub fn push_ble(&mut self, scans: &ReferenceScans, raw_id: &str, t_ns: i64, rssi_dbm: f64) {
        let j = match self.ble_ids.get(raw_id) {
            Some(j) => *j,
            None => {
                let j = crate::radio_id::normalize_beacon_id(raw_id)
                    .ok()
                    .and_then(|id| scans.index_of(TxKind::Ble, &id));
                if self.ble_ids.len() < MAX_ID_CACHE {
                    self.ble_ids.insert(raw_id.to_string(), j);
                }
                j
            }
        };
        if let Some(j) = j {
            self.push(t_ns, j, rssi_dbm);
        }
    }

    /// A WiFi result of `bssid` heard at `t_ns`, if `scans` knows it.
    pub fn push_wifi(&mut self, scans: &ReferenceScans, bssid: &str, t_ns: i64, rssi_dbm: f64) {
        if let Some(j) = scans.index_of(TxKind::Wifi, &crate::wifi::canonical_bssid(bssid)) {
            self.push(t_ns, j, rssi_dbm);
        }
    }

    /// One reading of transmitter `j` at `t_ns`.
    pub fn push(&mut self, t_ns: i64, j: u32, rssi_dbm: f64) {
        if !rssi_dbm.is_finite() {
            return;
        }
        if self.readings.len() >= MAX_TRAIL {
            self.readings.pop_front();
        }
        self.readings.push_back((t_ns, j, rssi_dbm));
    }

    /// The mean per transmitter of the readings in (now - window, now],
    /// minus `offset_db`, sorted by index; older readings are dropped.
    pub fn vector(&mut self, now_ns: i64, window_s: f64, offset_db: f64) -> Vec<(u32, f64)> {
        let from = now_ns - (window_s * 1e9) as i64;
        while self.readings.front().is_some_and(|r| r.0 <= from) {
            self.readings.pop_front();
        }
        // by transmitter, each one's readings in the trail's order (a
        // stable sort), summed in that order
        let mut rs: Vec<(u32, f64)> = self
            .readings
            .iter()
            .filter(|r| r.0 <= now_ns)
            .map(|&(_, j, r)| (j, r))
            .collect();
        rs.sort_by_key(|r| r.0);
        let mut out: Vec<(u32, f64)> = Vec::new();
        let mut k = 0;
        while k < rs.len() {
            let j = rs[k].0;
            let (mut s, mut n) = (0.0, 0usize);
            while k < rs.len() && rs[k].0 == j {
                s += rs[k].1;
                n += 1;
                k += 1;
            }
            out.push((j, s / n as f64 - offset_db));
        }
        out
    }
}
