//! Reference-scan anchors: the closest survey scans of the phone's
//! trailing window (the query, its reuse while walking, candidates too far
//! from the window dropped), their mixture over the cloud, re-seeding
//! around them, and the RSSI distance to the survey.

use std::sync::Arc;

use super::TcpfEngine;
use crate::Vec2;
use crate::fast_math::{exp_many, fast_exp};
use crate::radio::fast_ln::fast_ln;
use crate::radio::reference_scans::{ScanTrail, WeightedCandidate, candidate_fix};

/// The anchors' state between radio tasks.
#[derive(Default)]
pub(super) struct AnchorState {
    /// The phone's trailing window for the reference-scan query.
    pub(super) trail: ScanTrail,
    /// The weighted mean of the last anchors on their heaviest floor.
    pub(super) mean: Option<(i32, Vec2)>,
    /// The anchors' mixture per particle (reused buffer).
    mix: Vec<f64>,
    /// RSSI distance of the closest reference scan at the last anchor
    /// query (`None`: no scan shares a heard transmitter, or no query).
    pub(super) survey_dist_db: Option<f64>,
}

/// One candidate place of the reference-scan query, with its weight
/// (the weights of one query sum to 1).
pub(super) type Anchor = WeightedCandidate;

/// The anchors' mixture at `p` on `floor`: sum of w exp(-d^2 / 2 sigma^2)
/// ([`fast_exp`]).
pub(super) fn anchor_mix(anchors: &[Anchor], floor: i32, p: Vec2, sigma_m: f64) -> f64 {
    let k = -0.5 / (sigma_m * sigma_m);
    anchors
        .iter()
        .filter(|a| a.floor == floor)
        .map(|a| a.w * fast_exp((p - a.pos).norm_squared() * k))
        .sum()
}

/// [`anchor_mix`] at every point of `ps`, appended to `out`: anchor by
/// anchor over the cloud, the exponentials by [`exp_many`] (vectorises;
/// [`fast_exp`]'s values, added per point in the same order, so the same
/// sums).
pub(super) fn anchor_mix_many(
    anchors: &[Anchor],
    floor: i32,
    ps: &[Vec2],
    sigma_m: f64,
    out: &mut Vec<f64>,
) {
    let k = -0.5 / (sigma_m * sigma_m);
    let start = out.len();
    // -0.0: where `Iterator::sum` of f64 starts (no anchor: the same -0.0)
    out.resize(start + ps.len(), -0.0);
    let (mut xs, mut e) = (Vec::with_capacity(ps.len()), vec![0.0; ps.len()]);
    for a in anchors.iter().filter(|a| a.floor == floor) {
        xs.clear();
        xs.extend(ps.iter().map(|p| (p - a.pos).norm_squared() * k));
        exp_many(&xs, &mut e);
        for (o, e) in out[start..].iter_mut().zip(&e) {
            *o += a.w * e;
        }
    }
}

impl TcpfEngine {
    /// Whether the phone is far from the survey: the model has reference
    /// scans, the far level in force is set, and the last query's closest
    /// scan was farther than that (or shared no transmitter).
    pub(super) fn far_from_survey(&self) -> bool {
        let ac = &self.cfg.anchors;
        let far_db = ac.far_db;
        ac.k > 0
            && far_db > 0.0
            && self.model.reference_scans().is_some()
            && self.anchors.survey_dist_db.is_none_or(|d| d > far_db)
    }

    /// The anchors of the trailing scan window: the `k` closest reference
    /// scans of the model, weighted by their RSSI distance.
    pub(super) fn query_anchors(&mut self, t_ns: i64) -> Vec<Anchor> {
        let model = Arc::clone(&self.model);
        let ac = &self.cfg.anchors;
        let Some(scans) = model.reference_scans() else {
            return Vec::new();
        };
        if ac.k == 0 {
            return Vec::new();
        }
        let off = self.offset.phone.mean_db();
        let q = self
            .anchors
            .trail
            .vector(t_ns, scans.config().window_s, off);
        if q.len() < ac.min_transmitters {
            return Vec::new();
        }
        let out = scans.weighted_query(&q, ac.k, ac.tau(), ac.metric);
        self.anchors.survey_dist_db = out.first().map(|a| a.dist_db);
        // the offset was learned where the cloud is: a cloud in the wrong
        // place has a wrong offset, and the window then looks far from a
        // survey it is on; as heard, it may be near (`anchors.far_db`)
        let far_db = ac.far_db;
        if off != 0.0 && far_db > 0.0 && self.anchors.survey_dist_db.is_none_or(|d| d > far_db) {
            let heard = self
                .anchors
                .trail
                .vector(t_ns, scans.config().window_s, 0.0);
            let near = scans.weighted_query(&heard, 1, ac.tau(), ac.metric);
            if let Some(d) = near.first().map(|a| a.dist_db) {
                self.anchors.survey_dist_db =
                    Some(self.anchors.survey_dist_db.map_or(d, |e| e.min(d)));
            }
        }
        if out.is_empty() {
            return out;
        }
        self.counts.anchor_queries += 1;
        out
    }

    /// The anchors' part of a radio update on `floor`: their mean becomes
    /// the last anchors' mean; their mixture at each particle gives the
    /// weak extra likelihood added to `log_l`, tempered by `trust`.
    pub(super) fn weigh_by_anchors(
        &mut self,
        anchors: &[Anchor],
        floor: i32,
        trust: f64,
        log_l: &mut [f64],
    ) {
        if let Some(fix) = candidate_fix(anchors) {
            self.anchors.mean = Some((fix.floor, fix.mean));
        }
        let ac = &self.cfg.anchors;
        let on_floor = anchors.iter().any(|a| a.floor == floor);
        if on_floor && ac.weight > 0.0 {
            let mix = &mut self.anchors.mix;
            mix.clear();
            anchor_mix_many(anchors, floor, self.pf.particles(), ac.sigma_m, mix);
            let norm = (ac.floor + 1.0).ln();
            let weight = ac.weight * trust;
            for (u, a) in log_l.iter_mut().zip(mix.iter()) {
                *u += weight * (fast_ln(ac.floor + a) - norm);
            }
        }
    }
}
