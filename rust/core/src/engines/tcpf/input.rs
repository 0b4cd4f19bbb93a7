//! The radio input: BLE readings and WiFi scans into the scan window, and
//! the radio task that turns them into one measurement set.

use super::TcpfEngine;
use super::anchors::Anchor;
use crate::events::{BleObservation, WifiScan};
use crate::radio::{Measurement, ScanWindow, TxKind};
use crate::wifi::FreshResults;

/// The radio readings since the last radio task.
pub(super) struct RadioInput {
    window: ScanWindow,
    fresh_wifi: FreshResults,
    /// Measurement set of the last radio task, not yet used by fusion.
    pub(super) pending: Option<RadioSet>,
}

impl RadioInput {
    /// Nothing heard yet.
    pub(super) fn new() -> Self {
        RadioInput {
            window: ScanWindow::default(),
            fresh_wifi: FreshResults::default(),
            pending: None,
        }
    }
}

/// One radio task's output: the heard transmitters and the anchors of
/// the scan window.
pub(super) struct RadioSet {
    pub(super) meas: Vec<Measurement>,
    pub(super) anchors: Vec<Anchor>,
}

impl TcpfEngine {
    /// The radio task: the readings since the last run become the
    /// pending measurement set, with the anchors of the scan window.
    pub(super) fn radio_task(&mut self, t_ns: i64) {
        if self.input.window.is_empty() {
            return;
        }
        let meas = self.input.window.take(self.cfg.likelihood.max_transmitters);
        let anchors = self.query_anchors(t_ns);
        self.input.pending = Some(RadioSet { meas, anchors });
    }

    /// The offset of the phone model (`EngineConfig::device`) on radio
    /// `kind` that the radio map knows, dB (0: none).
    pub(super) fn device_offset_db(&self, kind: TxKind) -> f64 {
        match kind {
            TxKind::Ble => self.device_offsets_db[0],
            TxKind::Wifi => self.device_offsets_db[1],
        }
        .unwrap_or(0.0)
    }

    /// One BLE reading, corrected by the phone model's offset: into the
    /// scan window and the anchors' trail.
    pub(super) fn hear_ble(&mut self, obs: &BleObservation) {
        if !(obs.rssi_dbm.is_finite() && obs.rssi_dbm < 0.0) {
            self.stats.rejected_inputs += 1;
            return;
        }
        let corrected = obs.rssi_dbm - self.device_offset_db(TxKind::Ble);
        if let Some(scans) = self.model.reference_scans()
            && obs.rssi_dbm >= self.cfg.min_rssi_dbm
        {
            self.anchors
                .trail
                .push_ble(scans, &obs.beacon_id, obs.t_ns, corrected);
        }
        match self.model.lookup(TxKind::Ble, &obs.beacon_id) {
            Some(tx) => {
                if obs.rssi_dbm >= self.cfg.min_rssi_dbm {
                    self.input.window.push(tx, corrected);
                }
            }
            None => self.stats.unknown_beacons += 1,
        }
    }

    /// One WiFi scan: its fresh results, corrected by the phone model's
    /// offset, into the scan window and the anchors' trail.
    pub(super) fn hear_wifi(&mut self, scan: &WifiScan) {
        let max_age = (self.cfg.wifi_max_age_s * 1e9) as i64;
        for r in self.input.fresh_wifi.of(scan, max_age) {
            if !(r.rssi_dbm.is_finite() && r.rssi_dbm < 0.0) {
                self.stats.rejected_inputs += 1;
                continue;
            }
            if r.rssi_dbm < self.cfg.min_rssi_dbm {
                continue;
            }
            let corrected = r.rssi_dbm - self.device_offset_db(TxKind::Wifi);
            if let Some(scans) = self.model.reference_scans() {
                self.anchors.trail.push_wifi(
                    scans,
                    &r.bssid,
                    r.seen_t_ns.min(scan.t_ns),
                    corrected,
                );
            }
            if let Some(tx) = self.model.lookup(TxKind::Wifi, &r.bssid) {
                self.input.window.push(tx, corrected);
            }
        }
    }
}
