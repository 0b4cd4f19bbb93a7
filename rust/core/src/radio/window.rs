//! Turns raw BLE advertisements and WiFi results into one measurement set
//! per radio update: every transmitter heard since the last update, with
//! the mean of its readings.

use std::collections::BTreeMap;

use super::likelihood::Measurement;

/// Bound on distinct transmitters pending between two updates (a flood of
/// unknown ids cannot grow it: only model transmitters are pushed).
const MAX_PENDING: usize = 4096;

/// Readings per transmitter since the last [`ScanWindow::take`].
#[derive(Debug, Clone, Default)]
pub struct ScanWindow {
    /// tx index -> (sum dBm, count, strongest dBm)
    pending: BTreeMap<usize, (f64, u32, f64)>,
}

impl ScanWindow {
    /// One reading of model transmitter `tx`.
    pub fn push(&mut self, tx: usize, rssi_dbm: f64) {
        if !rssi_dbm.is_finite()
            || (self.pending.len() >= MAX_PENDING && !self.pending.contains_key(&tx))
        {
            return;
        }
        let e = self
            .pending
            .entry(tx)
            .or_insert((0.0, 0, f64::NEG_INFINITY));
        e.0 += rssi_dbm;
        e.1 += 1;
        e.2 = e.2.max(rssi_dbm);
    }

    /// Whether nothing is pending.
    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// The pending measurements, strongest mean first (ties by index), at
    /// most `max` of them; clears the window.
    pub fn take(&mut self, max: usize) -> Vec<Measurement> {
        let mut v: Vec<Measurement> = std::mem::take(&mut self.pending)
            .into_iter()
            .map(|(tx, (s, n, _))| Measurement {
                tx,
                rssi_dbm: s / f64::from(n),
                readings: n,
            })
            .collect();
        v.sort_by(|a, b| b.rssi_dbm.total_cmp(&a.rssi_dbm).then(a.tx.cmp(&b.tx)));
        v.truncate(max);
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_per_transmitter_strongest_first() {
        let mut w = ScanWindow::default();
        w.push(3, -70.0);
        w.push(3, -80.0);
        w.push(1, -60.0);
        w.push(2, f64::NAN);
        let m = w.take(8);
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].tx, m[0].rssi_dbm, m[0].readings), (1, -60.0, 1));
        assert_eq!((m[1].tx, m[1].rssi_dbm, m[1].readings), (3, -75.0, 2));
        assert!(w.is_empty());
        w.push(1, -60.0);
        w.push(2, -50.0);
        assert_eq!(w.take(1)[0].tx, 2);
    }
}
