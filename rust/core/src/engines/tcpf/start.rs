//! The start: at a told position, or globally from the first measurement
//! set over the likelihood surface of the most likely floor.

use std::sync::Arc;

use super::TcpfEngine;
use super::anchors::{Anchor, anchor_mix};
use super::cells::WithCells;
use crate::Vec2;
use crate::engine::InitialPosition;
use crate::radio::likelihood::profiled_many;
use crate::radio::{Measurement, RadioModel, TxKind};

/// What the global start waits for.
pub(super) struct StartState {
    /// First radio update before the start.
    pub(super) first_radio_t_ns: Option<i64>,
    /// How many floors have beacons.
    pub(super) beacon_floors: usize,
}

impl StartState {
    /// Not started, with `model`'s beacons.
    pub(super) fn new(model: &dyn RadioModel) -> Self {
        StartState {
            first_radio_t_ns: None,
            beacon_floors: model
                .transmitters()
                .iter()
                .filter(|t| t.kind == TxKind::Ble)
                .map(|t| t.floor)
                .collect::<std::collections::BTreeSet<_>>()
                .len(),
        }
    }
}

/// A likelihood surface over the cells of a floor (tempered): cell
/// weights exp(alpha l - max), their log-sum-exp, the weighted mean of the
/// offsets profiled per cell, and per cell that offset and its sd (dB).
pub(super) struct Surface {
    pub(super) cells: Vec<Vec2>,
    pub(super) w: Vec<f64>,
    pub(super) lse: f64,
    pub(super) offset_db: f64,
    pub(super) cell_offset_db: Vec<f64>,
    pub(super) cell_offset_sd_db: Vec<f64>,
}

impl TcpfEngine {
    /// Starts the cloud at a told position (a point on a wall line: the
    /// nearest walkable point within 5 m).
    pub(super) fn start_at(&mut self, at: InitialPosition) {
        self.floor = at.floor;
        self.floors.reset_to_floor(at.floor);
        if let Some(h) = at.heading_rad {
            self.publisher.heading_rad = h;
        }
        let site = Arc::clone(&self.site);
        let map = site.floor(at.floor);
        // a tap on a wall line starts at the nearest walkable point (5 m)
        let p = Vec2::new(at.x_m, at.y_m);
        let p = match map {
            Some(m) if !m.is_walkable(p) => {
                crate::engines::fpbp::nearest_walkable(m, p, 5.0).unwrap_or(p)
            }
            _ => p,
        };
        self.set_init_count(false);
        self.pf
            .init_at(p, 0.5, |q| map.is_none_or(|m| m.is_walkable(q)));
        self.recovery.told_start = true;
        self.told_reach.restart(at.floor, p);
        self.publisher.global_start = None;
        self.integrity.restart(&self.cfg.integrity, true);
        self.draw_offsets_from_belief();
        self.recovery.monitor.reset();
        self.publisher.published = Some(p);
        self.publisher.hold_runs = 0;
    }

    /// Likelihood surface of `meas` over the cells of `floor`, tempered,
    /// with the offset profiled per cell under N(`prior.0`, `prior.1`^2)
    /// (dB).
    pub(super) fn surface(
        &mut self,
        floor: i32,
        meas: &[Measurement],
        anchors: &[Anchor],
        prior: (f64, f64),
    ) -> Option<Surface> {
        let cells = self.cells.by_floor.get(&floor)?;
        if cells.is_empty() || meas.is_empty() {
            return None;
        }
        let model = self.model.as_ref();
        self.cells.expected.fill(model, floor, cells, meas);
        let lc = &self.cfg.likelihood;
        let alpha = lc.alpha(meas.len());
        let (o0, sd0) = prior;
        let (mut offs, mut sds, mut ll) = (Vec::new(), Vec::new(), Vec::new());
        let cached = WithCells {
            model,
            floor,
            cells,
            cache: &self.cells.expected,
        };
        profiled_many(
            &cached, lc, meas, floor, cells, o0, sd0, &mut offs, &mut sds, &mut ll,
        );
        for l in ll.iter_mut() {
            *l *= alpha;
        }
        let ac = &self.cfg.anchors;
        if !anchors.is_empty() {
            for (l, c) in ll.iter_mut().zip(cells) {
                let a = anchor_mix(anchors, floor, *c, ac.sigma_m);
                *l += ((ac.floor + a) / (ac.floor + 1.0)).ln();
            }
        }
        let max = ll.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !max.is_finite() {
            return None;
        }
        let w: Vec<f64> = ll.iter().map(|l| (l - max).exp()).collect();
        let sum: f64 = w.iter().sum();
        let offset_db = w.iter().zip(&offs).map(|(w, o)| w * o).sum::<f64>() / sum;
        Some(Surface {
            cells: cells.clone(),
            w,
            lse: max + sum.ln(),
            offset_db,
            cell_offset_db: offs,
            cell_offset_sd_db: sds,
        })
    }

    /// An upper bound on the recovery check's gap (the surface's
    /// log-sum-exp over its cells' weights, less the cloud's tempered log
    /// mean likelihood `cloud_ll`) for `meas` on `floor`, without the
    /// surface: every factor 1 + z^2/nu is at least 1, the offset's prior
    /// term and the misses' at most 0, so a cell's tempered log-likelihood
    /// is at most alpha times -`sd_norm_weight` times the sum of ln sd, and
    /// sd at least the smallest over the floor's cells ([`CellExpected`]).
    /// With a small slack for the rounding of [`fast_ln`] and the products.
    /// `None` when a heard transmitter's cells are not held (cache full, or
    /// unknown to the model there): the surface must be computed.
    pub(super) fn surface_gap_bound(
        &mut self,
        floor: i32,
        meas: &[Measurement],
        cloud_ll: f64,
    ) -> Option<f64> {
        let cells = self.cells.by_floor.get(&floor)?;
        self.cells
            .expected
            .fill(self.model.as_ref(), floor, cells, meas);
        let mut ln_sd = 0.0;
        for m in meas {
            ln_sd += self.cells.expected.by.get(&(floor, m.tx))?.min_sd.ln();
        }
        let lc = &self.cfg.likelihood;
        let best = lc.alpha(meas.len()) * -(lc.sd_norm_weight * ln_sd);
        Some(best - cloud_ll + 1e-6 * (1.0 + best.abs() + cloud_ll.abs()))
    }

    /// Global start from `meas` on `floor` (or the most likely floor).
    pub(super) fn global_start(
        &mut self,
        t_ns: i64,
        meas: &[Measurement],
        anchors: &[Anchor],
        floor: Option<i32>,
    ) -> bool {
        let floors: Vec<i32> = match floor {
            Some(f) => vec![f],
            None => self.site.spec.floors.iter().map(|f| f.id).collect(),
        };
        let prior = self.profile_prior(false);
        let best = floors
            .into_iter()
            .filter_map(|f| self.surface(f, meas, anchors, prior).map(|s| (f, s)))
            .max_by(|a, b| a.1.lse.total_cmp(&b.1.lse).then(b.0.cmp(&a.0)));
        let Some((f, surf)) = best else {
            return false;
        };
        self.floor = f;
        self.floors.reset_to_floor(f);
        self.votes.other_floor = None;
        let site = Arc::clone(&self.site);
        let map = site.floor(f);
        self.set_init_count(true);
        self.pf
            .init_from_cells(&surf.cells, &surf.w, self.cfg.cell_m, |q| {
                map.is_none_or(|m| m.is_walkable(q))
            });
        self.offset
            .phone
            .set(surf.offset_db, self.offset.phone.sd_db());
        self.publisher.global_start = Some((t_ns, self.pf.spread_m()));
        self.draw_offsets_from_cells(&surf);
        self.summarise_offsets();
        self.recovery.monitor.reset();
        self.publisher.published = None;
        self.publisher.hold_runs = 0;
        self.counts.global_starts += 1;
        self.recovery.told_start = false;
        self.told_reach.forget();
        self.integrity.restart(&self.cfg.integrity, false);
        self.publisher.last_radio_t_ns = Some(t_ns);
        true
    }
}
