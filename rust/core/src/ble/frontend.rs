//! The BLE front end: takes raw observations, keeps one RSSI Kalman filter per
//! registered beacon, and yields the current filtered set.

use super::config::BleConfig;
use super::kalman::RssiKalman;
use super::pathloss::PathLoss;
use super::registry::BeaconRegistry;
use crate::Vec2;
use crate::events::BleObservation;
use crate::site::Site;

/// One beacon of the current filtered set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilteredBeacon {
    /// Index in the registry.
    pub index: usize,
    pub floor: i32,
    /// Position in the MCS of `floor`, metres.
    pub pos: Vec2,
    /// Beacon height minus phone height, metres (vertical leg of the range).
    pub dz_m: f64,
    pub model: PathLoss,
    /// Kalman-filtered RSSI, dBm.
    pub rssi_dbm: f64,
    /// Predicted variance of the filtered RSSI at the query time, dBm^2.
    pub var_dbm2: f64,
    /// Observations absorbed since the filter was (re)started.
    pub samples: u32,
    pub last_t_ns: i64,
}

impl FilteredBeacon {
    /// Range implied by the filtered RSSI (eq. 10b), metres.
    pub fn range_m(&self) -> f64 {
        self.model.distance(self.rssi_dbm)
    }
}

/// Counters of the front end.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrontEndCounts {
    pub accepted: u64,
    /// Ids the registry does not list (or cannot parse).
    pub unknown: u64,
    /// RSSI >= 0 dBm, below `min_rssi_dbm`, or non-finite.
    pub rejected: u64,
}

/// Per-beacon Kalman filtering of the observations of known beacons.
#[derive(Debug, Clone)]
pub struct BleFrontEnd {
    cfg: BleConfig,
    registry: BeaconRegistry,
    filters: Vec<Option<RssiKalman>>,
    counts: FrontEndCounts,
}

impl BleFrontEnd {
    /// A front end for the beacons of `site`.
    pub fn new(cfg: &BleConfig, site: &Site) -> Self {
        Self::with_registry(cfg, BeaconRegistry::new(&site.spec.beacons))
    }

    /// A front end over an explicit registry.
    pub fn with_registry(cfg: &BleConfig, registry: BeaconRegistry) -> Self {
        BleFrontEnd {
            cfg: cfg.clone(),
            filters: vec![None; registry.len()],
            registry,
            counts: FrontEndCounts::default(),
        }
    }

    pub fn registry(&self) -> &BeaconRegistry {
        &self.registry
    }

    pub fn counts(&self) -> FrontEndCounts {
        self.counts
    }

    /// Absorbs one observation. Returns true when it was used (a known beacon
    /// with a valid RSSI); unknown ids and invalid RSSI are counted.
    pub fn on_observation(&mut self, obs: &BleObservation) -> bool {
        let rssi = obs.rssi_dbm;
        let Some(index) = self.registry.lookup(&obs.beacon_id) else {
            self.counts.unknown += 1;
            return false;
        };
        if !rssi.is_finite() || rssi >= 0.0 || rssi < self.cfg.min_rssi_dbm {
            self.counts.rejected += 1;
            return false;
        }
        let k = &self.cfg.kalman;
        let stale_ns = (k.staleness_s * 1e9) as i64;
        let slot = &mut self.filters[index];
        match slot {
            Some(f) if obs.t_ns - f.last_t_ns <= stale_ns => f.update(
                obs.t_ns,
                rssi,
                k.process_noise_dbm2_per_s,
                k.measurement_noise_dbm2,
            ),
            _ => *slot = Some(RssiKalman::new(obs.t_ns, rssi, k.measurement_noise_dbm2)),
        }
        self.counts.accepted += 1;
        true
    }

    /// The beacons heard within the staleness timeout before `t_ns` with at
    /// least `min_samples` observations, strongest filtered RSSI first (ties by id).
    pub fn current(&self, t_ns: i64) -> Vec<FilteredBeacon> {
        let k = &self.cfg.kalman;
        let stale_ns = (k.staleness_s * 1e9) as i64;
        let mut out: Vec<FilteredBeacon> = self
            .filters
            .iter()
            .enumerate()
            .filter_map(|(index, f)| {
                let f = f.as_ref()?;
                if f.samples < k.min_samples || t_ns - f.last_t_ns > stale_ns {
                    return None;
                }
                let b = self.registry.get(index)?;
                Some(FilteredBeacon {
                    index,
                    floor: b.floor,
                    pos: b.pos,
                    dz_m: b.z_m - self.cfg.phone_height_m,
                    model: b.model,
                    rssi_dbm: f.rssi_dbm,
                    var_dbm2: f.predicted_var(t_ns, k.process_noise_dbm2_per_s),
                    samples: f.samples,
                    last_t_ns: f.last_t_ns,
                })
            })
            .collect();
        out.sort_by(|a, b| {
            b.rssi_dbm.total_cmp(&a.rssi_dbm).then_with(|| {
                let ia = self.registry.get(a.index).map(|r| r.id.as_str());
                let ib = self.registry.get(b.index).map(|r| r.id.as_str());
                ia.cmp(&ib)
            })
        });
        out
    }

    /// The floor a filtered BLE set (strongest first) votes for, by the
    /// floor tracker's `floor.vote` rule.
    pub fn floor_vote(
        cfg: &crate::floor::FloorConfig,
        beacons: &[FilteredBeacon],
        top_n: usize,
    ) -> Option<i32> {
        match cfg.vote {
            crate::floor::FloorVote::Likely => Self::likely_floor(beacons, top_n),
            crate::floor::FloorVote::Strongest => beacons
                .iter()
                .max_by(|a, b| {
                    a.rssi_dbm
                        .total_cmp(&b.rssi_dbm)
                        .then(b.index.cmp(&a.index))
                })
                .map(|b| b.floor),
        }
    }

    /// The floor the current set points to: the most common floor among the
    /// `top_n` strongest beacons, ties broken by the strongest beacon's floor.
    pub fn likely_floor(beacons: &[FilteredBeacon], top_n: usize) -> Option<i32> {
        let top = &beacons[..beacons.len().min(top_n.max(1))];
        let mut best: Option<(usize, i32)> = None;
        for b in top {
            let count = top.iter().filter(|c| c.floor == b.floor).count();
            if best.is_none_or(|(c, _)| count > c) {
                best = Some((count, b.floor));
            }
        }
        best.map(|(_, f)| f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::site::BeaconSpec;

    fn registry() -> BeaconRegistry {
        let spec = |id: &str, x: f64| BeaconSpec {
            id: id.into(),
            floor: 0,
            x_m: x,
            y_m: 0.0,
            z_m: 1.2,
            rssi_1m_dbm: -59.0,
            path_loss_exponent: 2.0,
        };
        BeaconRegistry::new(&[
            spec("mac:00:00:00:00:00:01", 0.0),
            spec("mac:00:00:00:00:00:02", 5.0),
        ])
    }

    fn obs(t_s: f64, id: &str, rssi: f64) -> BleObservation {
        BleObservation {
            t_ns: (t_s * 1e9) as i64,
            beacon_id: id.into(),
            rssi_dbm: rssi,
            tx_power_dbm: None,
        }
    }

    #[test]
    fn counts_unknown_and_rejected_and_sorts_by_rssi() {
        let mut fe = BleFrontEnd::with_registry(&BleConfig::default(), registry());
        assert!(fe.on_observation(&obs(0.0, "mac:00:00:00:00:00:01", -80.0)));
        assert!(fe.on_observation(&obs(0.1, "MAC:000000000002", -60.0)));
        assert!(!fe.on_observation(&obs(0.2, "mac:00:00:00:00:00:09", -60.0)));
        assert!(!fe.on_observation(&obs(0.2, "garbage", -60.0)));
        assert!(!fe.on_observation(&obs(0.3, "mac:00:00:00:00:00:01", 0.0)));
        assert!(!fe.on_observation(&obs(0.3, "mac:00:00:00:00:00:01", 5.0)));
        assert!(!fe.on_observation(&obs(0.3, "mac:00:00:00:00:00:01", f64::NAN)));
        assert!(!fe.on_observation(&obs(0.3, "mac:00:00:00:00:00:01", -150.0)));
        let c = fe.counts();
        assert_eq!((c.accepted, c.unknown, c.rejected), (2, 2, 4));
        let cur = fe.current((0.5e9) as i64);
        assert_eq!(cur.iter().map(|b| b.index).collect::<Vec<_>>(), vec![1, 0]);
    }

    #[test]
    fn stale_beacons_drop_out_and_restart() {
        let mut cfg = BleConfig::default();
        cfg.kalman.staleness_s = 3.0;
        let mut fe = BleFrontEnd::with_registry(&cfg, registry());
        fe.on_observation(&obs(0.0, "mac:00:00:00:00:00:01", -80.0));
        fe.on_observation(&obs(1.0, "mac:00:00:00:00:00:01", -70.0));
        assert_eq!(fe.current(3_500_000_000).len(), 1);
        assert_eq!(fe.current(4_500_000_000).len(), 0);
        fe.on_observation(&obs(10.0, "mac:00:00:00:00:00:01", -50.0));
        let cur = fe.current(10_000_000_000);
        assert_eq!(cur[0].samples, 1);
        assert_eq!(cur[0].rssi_dbm, -50.0);
    }
}
