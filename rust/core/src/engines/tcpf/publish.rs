//! The published point and pose: the cloud's estimate, held or walked
//! through the doors rather than jumping through a wall, and its accuracy
//! radius (the cloud, the anchors, the survey distance, the integrity).

use std::sync::Arc;

use super::TcpfEngine;
use crate::Vec2;
use crate::engine::{Pose, PoseSource};
use crate::fusion::recovery::dominant_room;
use crate::fusion::weighted_quantile::weighted_quantile;

/// Lattice spacing and search margin of the published point's walk
/// through the doors ([`crate::map::FloorMap::walk_toward`]), metres: a door is at
/// least ~0.8 m wide, so several lattice columns pass it.
const WALK_SPACING_M: f64 = 0.25;

const WALK_MARGIN_M: f64 = 15.0;

/// The published point and pose.
#[derive(Debug, Default)]
pub(super) struct Publisher {
    /// The last published point (the start of the next one's walk).
    pub(super) published: Option<Vec2>,
    /// Consecutive fusion runs the point was held.
    pub(super) hold_runs: u32,
    pub(super) heading_rad: f64,
    pub(super) pose: Option<Pose>,
    /// The last pose's accuracy radius from the cloud and the anchors
    /// alone (without the survey-distance term): what `hold_max_accuracy_m`
    /// compares.
    pub(super) cloud_accuracy_m: Option<f64>,
    /// The last radio update (the pose is `Fused` for a while after it).
    pub(super) last_radio_t_ns: Option<i64>,
    /// The last global start: its time and its cloud's RMS spread, m
    /// (`start_accuracy_share`); `None` after a told start.
    pub(super) global_start: Option<(i64, f64)>,
}

impl TcpfEngine {
    /// `r` widened by the memory of the last global start's width
    /// (`start_accuracy_share`, `start_accuracy_decay_s`), in quadrature.
    fn accuracy_with_start(&self, t_ns: i64, r: f64) -> f64 {
        let (share, decay_s) = (
            self.cfg.start_accuracy_share,
            self.cfg.start_accuracy_decay_s,
        );
        match self.publisher.global_start {
            Some((t0, spread_m)) if share > 0.0 => {
                let age_s = ((t_ns - t0) as f64 / 1e9).max(0.0);
                r.hypot(share * spread_m * (-age_s / decay_s).exp())
            }
            _ => r,
        }
    }

    /// The point to publish: the weighted mean, or the heaviest room's
    /// mean, or the heaviest particles, whichever the last published point
    /// reaches without crossing a wall; held up to `max_hold_runs`.
    pub(super) fn estimate(&mut self) -> Option<Vec2> {
        let mean = self.pf.mean()?;
        let site = Arc::clone(&self.site);
        let Some(map) = site.floor(self.floor) else {
            return Some(mean);
        };
        let (ps, ws) = (self.pf.particles(), self.pf.weights());
        let Some(prev) = self.publisher.published else {
            // the first point: the mean of a cloud spread over two wings
            // can lie in the void between them
            if map.is_walkable(mean) {
                return Some(mean);
            }
            let room = dominant_room(ps, ws, |p| map.room_of(p)).map(|r| r.mean);
            if let Some(r) = room.filter(|r| map.is_walkable(*r)) {
                return Some(r);
            }
            let best = (0..ps.len()).max_by(|a, b| ws[*a].total_cmp(&ws[*b]).then(b.cmp(a)));
            return best.map(|i| ps[i]).or(Some(mean));
        };
        let broad = self.cfg.hold_max_accuracy_m > 0.0
            && self
                .publisher
                .cloud_accuracy_m
                .is_some_and(|a| a > self.cfg.hold_max_accuracy_m);
        let ok = |q: Vec2| map.is_walkable(q) && !map.track_crosses_wall(prev, q);
        if ok(mean) {
            self.publisher.hold_runs = 0;
            return Some(mean);
        }
        if let Some(r) = dominant_room(ps, ws, |p| map.room_of(p))
            && ok(r.mean)
        {
            self.publisher.hold_runs = 0;
            return Some(r.mean);
        }
        let mut idx: Vec<usize> = (0..ps.len()).collect();
        idx.sort_by(|a, b| ws[*b].total_cmp(&ws[*a]).then(a.cmp(b)));
        if let Some(i) = idx.iter().take(32).find(|i| ok(ps[**i])) {
            self.publisher.hold_runs = 0;
            return Some(ps[*i]);
        }
        if self.publisher.hold_runs < self.cfg.max_hold_runs && !broad {
            self.publisher.hold_runs += 1;
            self.counts.held += 1;
            return Some(prev);
        }
        // the hold ran out: walk toward the cloud through the doors (the
        // hold is not reset, so the walk goes on run after run until the
        // cloud is in reach); where the map has no way there (a door it
        // lacks: the cloud got there through a wall the walker did not
        // cross), jump as before
        let r = dominant_room(ps, ws, |p| map.room_of(p)).map(|r| r.mean);
        let target = r.filter(|q| map.is_walkable(*q)).unwrap_or(mean);
        match map.walk_toward(prev, target, WALK_SPACING_M, WALK_MARGIN_M) {
            Some(w) if w.reaches => {
                self.counts.walked += 1;
                Some(w.next)
            }
            _ => {
                self.publisher.hold_runs = 0;
                self.counts.jumps_no_way += 1;
                Some(target)
            }
        }
    }

    /// The `accuracy_quantile` of the weighted distances from `at`
    /// ([`weighted_quantile`]: the sorted cloud's value without sorting it).
    pub(super) fn accuracy_m(&self, at: Vec2) -> f64 {
        let (ps, ws) = (self.pf.particles(), self.pf.weights());
        let mut d: Vec<(f64, f64)> = ps
            .iter()
            .zip(ws)
            .map(|(p, w)| ((p - at).norm(), *w))
            .collect();
        let r = weighted_quantile(&mut d, self.cfg.accuracy_quantile).unwrap_or(0.0);
        (r * self.cfg.accuracy_scale).max(self.cfg.accuracy_min_m)
    }

    /// [`Self::accuracy_m`] widened by the distance to the last anchors'
    /// mean on the track's floor (`anchors.accuracy_share`).
    pub(super) fn accuracy_with_anchors(&self, at: Vec2) -> f64 {
        let r = self.accuracy_m(at);
        let share = self.cfg.anchors.accuracy_share;
        match self.anchors.mean {
            Some((f, m)) if share > 0.0 && f == self.floor => r.hypot(share * (m - at).norm()),
            _ => r,
        }
    }

    /// The published radius `r` widened, in quadrature, by the readings'
    /// misfit (`integrity.fit_accuracy_m_per_z2`).
    pub(super) fn accuracy_with_integrity(&self, r: f64) -> f64 {
        r.hypot(self.integrity.fit_accuracy_m(&self.cfg.integrity))
    }

    /// Publishes the pose at `t_ns` from the cloud ([`Self::estimate`]).
    pub(super) fn publish(&mut self, t_ns: i64) {
        let Some(pos) = self.estimate() else { return };
        if let Some(prev) = self.publisher.published {
            let d = pos - prev;
            if d.norm() > 0.2 {
                self.publisher.heading_rad = d.y.atan2(d.x);
            }
        }
        self.publisher.published = Some(pos);
        let max_age = 3 * self.ble_period_ns.max(1);
        let source = match self.publisher.last_radio_t_ns {
            Some(t) if t_ns - t <= max_age => PoseSource::Fused,
            _ => PoseSource::DeadReckoning,
        };
        let floor_prob = if self.site.spec.floors.len() < 2 {
            1.0
        } else if self.votes.other_floor.is_some() {
            0.6
        } else {
            0.9
        };
        let cloud_m = self.accuracy_with_anchors(pos);
        self.publisher.cloud_accuracy_m = Some(cloud_m);
        self.publisher.pose = Some(Pose {
            t_ns,
            x_m: pos.x,
            y_m: pos.y,
            floor: self.floor,
            heading_rad: self.publisher.heading_rad,
            accuracy_m: self.accuracy_with_start(t_ns, self.accuracy_with_integrity(cloud_m)),
            floor_prob,
            source,
        });
    }
}
