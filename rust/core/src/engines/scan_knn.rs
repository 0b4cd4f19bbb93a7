//! Engine `scan-knn`: weighted k-nearest-neighbour fingerprinting over the
//! reference scans of a radio map ([`crate::radio::reference_scans`]), no
//! motion, no map: the yardstick of what the scan vectors alone carry (the
//! causal kNN baseline of issue 16), and the anchors `tcpf` uses, seen on
//! their own. Every radio period the trailing window's vector is compared
//! with every reference scan; the pose is the weighted mean of the `k`
//! closest on their heaviest floor (weights exp(-(d - d_best) / tau)).
//! Settings: `tcpf.anchors` (k, min_transmitters, metric, tau_db /
//! tau_powed) and the
//! reference scans' own window. Without a radio map that carries
//! reference scans it gives no pose.

use std::sync::Arc;

use crate::engine::{Engine, EngineStats, Pose, PoseSource, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, WifiScan};
use crate::radio::RadioModel;
use crate::radio::reference_scans::{CandidateFix, ScanMetric, ScanTrail, candidate_fix};
use crate::wifi::FreshResults;

/// The engine.
pub struct ScanKnnEngine {
    model: Arc<dyn RadioModel>,
    trail: ScanTrail,
    fresh_wifi: FreshResults,
    k: usize,
    min_transmitters: usize,
    tau: f64,
    metric: ScanMetric,
    wifi_max_age_s: f64,
    period_ns: i64,
    pose: Option<Pose>,
    stats: EngineStats,
}

impl ScanKnnEngine {
    /// The engine over `model`'s reference scans.
    pub fn new(config: &EngineConfig, model: Arc<dyn RadioModel>) -> crate::Result<Self> {
        config.validate()?;
        let a = &config.tcpf.anchors;
        Ok(ScanKnnEngine {
            model,
            trail: ScanTrail::default(),
            fresh_wifi: FreshResults::default(),
            k: a.k.max(1),
            min_transmitters: a.min_transmitters,
            tau: a.tau(),
            metric: a.metric,
            wifi_max_age_s: config.tcpf.wifi_max_age_s,
            period_ns: i64::from(config.tasks.radio_period_ms) * 1_000_000,
            pose: None,
            stats: EngineStats::default(),
        })
    }

    fn fix(&mut self, t_ns: i64) {
        let model = Arc::clone(&self.model);
        let Some(scans) = model.reference_scans() else {
            self.stats.no_fix += 1;
            return;
        };
        let q = self.trail.vector(t_ns, scans.config().window_s, 0.0);
        if q.len() < self.min_transmitters {
            self.stats.no_fix += 1;
            return;
        }
        let c = scans.weighted_query(&q, self.k, self.tau, self.metric);
        let Some(fix) = candidate_fix(&c) else {
            self.stats.no_fix += 1;
            return;
        };
        self.pose = Some(pose_of(t_ns, &fix));
    }
}

/// The pose of a candidate fix. The floor's share is a sum of normalised
/// weights and can round past 1 (1.0000000000000002): the probability is
/// clamped to the documented [0, 1].
fn pose_of(t_ns: i64, fix: &CandidateFix) -> Pose {
    Pose {
        t_ns,
        x_m: fix.mean.x,
        y_m: fix.mean.y,
        floor: fix.floor,
        heading_rad: 0.0,
        accuracy_m: fix.spread_m.max(1.0),
        floor_prob: fix.share.clamp(0.0, 1.0),
        source: PoseSource::Radio,
    }
}

impl Engine for ScanKnnEngine {
    fn name(&self) -> &'static str {
        "scan-knn"
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        if !(obs.rssi_dbm.is_finite() && obs.rssi_dbm < 0.0) {
            self.stats.rejected_inputs += 1;
            return;
        }
        if let Some(scans) = self.model.reference_scans() {
            self.trail
                .push_ble(scans, &obs.beacon_id, obs.t_ns, obs.rssi_dbm);
        }
    }

    fn on_wifi(&mut self, scan: &WifiScan) {
        let max_age = (self.wifi_max_age_s * 1e9) as i64;
        let Some(scans) = self.model.reference_scans() else {
            return;
        };
        for r in self.fresh_wifi.of(scan, max_age) {
            if r.rssi_dbm.is_finite() && r.rssi_dbm < 0.0 {
                self.trail
                    .push_wifi(scans, &r.bssid, r.seen_t_ns.min(scan.t_ns), r.rssi_dbm);
            } else {
                self.stats.rejected_inputs += 1;
            }
        }
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        if task == Task::Radio {
            self.fix(t_ns);
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        (task == Task::Radio).then_some(self.period_ns)
    }

    fn pose(&self) -> Option<Pose> {
        self.pose
    }

    fn stats(&self) -> EngineStats {
        self.stats.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec2;
    use crate::radio::reference_scans::WeightedCandidate;

    /// Weights that sum past 1 in f64 (0.2 + 0.4 + 0.3 + 0.1): the fix's share
    /// is 1.0000000000000002, the pose's floor probability stays 1. Fails
    /// without the clamp in `pose_of`.
    #[test]
    fn floor_probability_never_exceeds_one() {
        let c: Vec<WeightedCandidate> = [0.2, 0.4, 0.3, 0.1]
            .iter()
            .enumerate()
            .map(|(i, &w)| WeightedCandidate {
                floor: 1,
                pos: Vec2::new(i as f64, 2.0),
                w,
                dist_db: 1.0,
            })
            .collect();
        let fix = candidate_fix(&c).expect("a fix");
        assert!(
            fix.share > 1.0,
            "the case needs a share past 1: {}",
            fix.share
        );
        let p = pose_of(5, &fix);
        assert!((0.0..=1.0).contains(&p.floor_prob), "{}", p.floor_prob);
        assert_eq!(p.floor_prob, 1.0);
    }
}
