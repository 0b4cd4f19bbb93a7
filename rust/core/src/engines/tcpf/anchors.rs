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
    /// Consecutive radio updates with the cloud away from the anchors.
    pub(super) low_support: u32,
    /// The weighted mean of the last anchors on their heaviest floor.
    pub(super) mean: Option<(i32, Vec2)>,
    /// The anchors' mixture per particle (reused buffer).
    mix: Vec<f64>,
    /// RSSI distance of the closest reference scan at the last anchor
    /// query (`None`: no scan shares a heard transmitter, or no query).
    pub(super) survey_dist_db: Option<f64>,
    /// The last query's candidates were dropped as too far from the
    /// phone's window (`anchors.drop_far_db`).
    pub(super) dropped_far: bool,
    /// The last query that gave candidates: its time, the walked sum then,
    /// and its candidates (reused until `anchors.query_period_s` has passed).
    last_query: Option<(i64, Vec2, Vec<Anchor>)>,
    /// The steps' summed displacement (length along the step's yaw, MCS
    /// m): reused anchors move by what was walked since their query.
    pub(super) walked: Vec2,
}

/// One candidate place of the reference-scan query, with its weight
/// (the weights of one query sum to 1).
pub(super) type Anchor = WeightedCandidate;

/// The cloud's weighted mean of the anchors' mixture (`mix`, one value
/// per particle) over the mixture's highest value at a candidate of
/// `floor` (1: the cloud sits on the best candidates; 0: far from all).
/// `None` without anchors there.
pub(super) fn anchor_support(
    anchors: &[Anchor],
    floor: i32,
    sigma_m: f64,
    mix: &[f64],
    weights: &[f64],
) -> Option<f64> {
    let peak = anchors
        .iter()
        .filter(|a| a.floor == floor)
        .map(|a| anchor_mix(anchors, floor, a.pos, sigma_m))
        .fold(0.0, f64::max);
    let wsum: f64 = weights.iter().sum();
    if peak <= 0.0 || wsum <= 0.0 {
        return None;
    }
    let s: f64 = mix.iter().zip(weights).map(|(a, w)| a * w).sum();
    Some(s / wsum / peak)
}

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
    /// The far level in force: `anchors.far_db_told` while the cloud
    /// comes from a told position, else `anchors.far_db`.
    fn far_db(&self) -> f64 {
        let ac = &self.cfg.anchors;
        if self.recovery.told_start {
            ac.far_db_told
        } else {
            ac.far_db
        }
    }

    /// Whether the phone is far from the survey: the model has reference
    /// scans, the far level in force is set, and the last query's closest
    /// scan was farther than that (or shared no transmitter).
    pub(super) fn far_from_survey(&self) -> bool {
        let ac = &self.cfg.anchors;
        let far_db = self.far_db();
        ac.k > 0
            && far_db > 0.0
            && self.model.reference_scans().is_some()
            && self.anchors.survey_dist_db.is_none_or(|d| d > far_db)
    }

    /// Re-seeds part of the cloud around the anchors of `floor` when its
    /// support has stayed low for `reseed_after` updates.
    pub(super) fn anchor_reseed(&mut self, anchors: &[Anchor], floor: i32, support: Option<f64>) {
        let ac = self.cfg.anchors.clone();
        let Some(s) = support else { return };
        if ac.reseed_fraction <= 0.0 || ac.reseed_after == 0 {
            return;
        }
        if s >= ac.reseed_support {
            self.anchors.low_support = 0;
            return;
        }
        self.anchors.low_support += 1;
        if self.anchors.low_support < ac.reseed_after {
            return;
        }
        self.anchors.low_support = 0;
        let (cells, w): (Vec<Vec2>, Vec<f64>) = anchors
            .iter()
            .filter(|a| a.floor == floor)
            .map(|a| (a.pos, a.w))
            .unzip();
        let site = Arc::clone(&self.site);
        let map = site.floor(floor);
        self.resample_now();
        let n = self
            .pf
            .inject_from_cells(ac.reseed_fraction, &cells, &w, 2.0 * ac.sigma_m, |q| {
                map.is_none_or(|m| m.is_walkable(q))
            });
        if self.per_particle_offset() && !self.pf.state().is_empty() {
            let belief = (self.offset.phone.mean_db(), self.offset.phone.sd_db());
            self.draw_offsets_of_cell_draws(|_| belief);
        }
        self.counts.anchor_reseeded += n as u64;
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
        // the queries of the first full window are all fresh: the start
        // waits for anchors, and those of its short windows are poor
        let window_ns = (scans.config().window_s * 1e9) as i64;
        if let Some((t0, w0, last)) = &self.anchors.last_query
            && self.pf.is_initialized()
            && self
                .start
                .first_radio_t_ns
                .is_some_and(|t| t0 - t >= window_ns)
            && ((t_ns - t0) as f64) < ac.query_period_s * 1e9
        {
            let shift = self.anchors.walked - w0;
            let mut out = last.clone();
            out.iter_mut().for_each(|a| a.pos += shift);
            return out;
        }
        self.anchors.last_query = None;
        let off = if ac.use_offset {
            self.offset.phone.mean_db()
        } else {
            0.0
        };
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
        let far_db = self.far_db();
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
        self.anchors.dropped_far = ac.drop_far_db > 0.0
            && self
                .anchors
                .survey_dist_db
                .is_some_and(|d| d > ac.drop_far_db);
        if self.anchors.dropped_far {
            self.counts.anchors_dropped_far += 1;
            self.anchors.mean = None;
            return Vec::new();
        }
        if out.is_empty() {
            return out;
        }
        self.counts.anchor_queries += 1;
        if ac.query_period_s > 0.0 {
            self.anchors.last_query = Some((t_ns, self.anchors.walked, out.clone()));
        }
        out
    }

    /// The anchors' part of a radio update on `floor`: their mean becomes
    /// the last anchors' mean; their mixture at each particle (once) gives
    /// the cloud's support (before this update's weights, the return) and
    /// the weak extra likelihood added to `log_l`, tempered by `trust`.
    pub(super) fn weigh_by_anchors(
        &mut self,
        anchors: &[Anchor],
        floor: i32,
        trust: f64,
        log_l: &mut [f64],
    ) -> Option<f64> {
        if let Some(fix) = candidate_fix(anchors) {
            self.anchors.mean = Some((fix.floor, fix.mean));
        }
        let ac = &self.cfg.anchors;
        let on_floor = anchors.iter().any(|a| a.floor == floor);
        let mut support = None;
        if on_floor {
            let mix = &mut self.anchors.mix;
            mix.clear();
            anchor_mix_many(anchors, floor, self.pf.particles(), ac.sigma_m, mix);
            support = anchor_support(anchors, floor, ac.sigma_m, mix, self.pf.weights());
            if ac.weight > 0.0 {
                let norm = (ac.floor + 1.0).ln();
                let weight = ac.weight * trust;
                for (u, a) in log_l.iter_mut().zip(mix.iter()) {
                    *u += weight * (fast_ln(ac.floor + a) - norm);
                }
            }
        }
        support
    }
}
