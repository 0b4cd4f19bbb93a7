//! Where the survey walked: per floor, a grid of the distance from each
//! cell to the nearest reference scan (the survey's walked positions),
//! out to a reach; and the weighing that reads it far from the survey
//! (`anchors.far_survey_penalty`).

use std::collections::BTreeMap;

use super::TcpfEngine;
use crate::Vec2;
use crate::radio::derived::get_or_build_in;
use crate::radio::reference_scans::ReferenceScans;

/// At most this many cells per floor: a larger floor gets coarser cells.
const MAX_CELLS: usize = 2_000_000;

/// One floor's grid.
struct FloorGrid {
    origin: Vec2,
    cell_m: f64,
    nx: usize,
    ny: usize,
    /// Distance to the nearest scan, m (`f32::INFINITY` beyond the reach).
    d: Vec<f32>,
}

/// The distance to the survey per floor, out to `reach_m`.
pub(super) struct SurveyReach {
    floors: BTreeMap<i32, FloorGrid>,
}

impl SurveyReach {
    /// The grids of `scans`' positions with `cell_m` cells (coarser on a
    /// floor that would need more than 2 M), out to `reach_m`.
    pub(super) fn of_scans(scans: &ReferenceScans, cell_m: f64, reach_m: f64) -> Self {
        let mut by_floor: BTreeMap<i32, Vec<Vec2>> = BTreeMap::new();
        for s in scans.scans() {
            if s.x_m.is_finite() && s.y_m.is_finite() {
                by_floor
                    .entry(s.floor)
                    .or_default()
                    .push(Vec2::new(s.x_m, s.y_m));
            }
        }
        let floors = by_floor
            .into_iter()
            .map(|(f, pts)| (f, FloorGrid::of_points(&pts, cell_m, reach_m)))
            .collect();
        SurveyReach { floors }
    }

    /// Distance from `p` on `floor` to the nearest reference scan, m, to
    /// within a cell; `None` beyond the reach or without scans there.
    pub(super) fn distance_m(&self, floor: i32, p: Vec2) -> Option<f64> {
        let g = self.floors.get(&floor)?;
        let fx = ((p.x - g.origin.x) / g.cell_m).floor();
        let fy = ((p.y - g.origin.y) / g.cell_m).floor();
        if !(fx >= 0.0 && fy >= 0.0 && fx < g.nx as f64 && fy < g.ny as f64) {
            return None;
        }
        let d = g.d[fy as usize * g.nx + fx as usize];
        d.is_finite().then_some(f64::from(d))
    }
}

impl FloorGrid {
    /// `pts` (not empty) stamped onto a grid over their box plus `reach_m`.
    fn of_points(pts: &[Vec2], cell_m: f64, reach_m: f64) -> Self {
        let (mut lo, mut hi) = (pts[0], pts[0]);
        for p in pts {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let lo = lo - Vec2::new(reach_m, reach_m);
        let hi = hi + Vec2::new(reach_m, reach_m);
        let mut cell_m = cell_m;
        let cells = |c: f64| ((hi.x - lo.x) / c).ceil() * ((hi.y - lo.y) / c).ceil();
        while cells(cell_m) > MAX_CELLS as f64 {
            cell_m *= 2.0;
        }
        let nx = ((hi.x - lo.x) / cell_m).ceil() as usize + 1;
        let ny = ((hi.y - lo.y) / cell_m).ceil() as usize + 1;
        let mut d = vec![f32::INFINITY; nx * ny];
        // one scan per cell stamps (the survey's scans come one a second,
        // several to a cell); the others are within a cell of it
        let mut stamped = vec![false; nx * ny];
        let r = (reach_m / cell_m).ceil() as i64;
        let cell_of = |p: Vec2| {
            (
                ((p.x - lo.x) / cell_m).floor() as i64,
                ((p.y - lo.y) / cell_m).floor() as i64,
            )
        };
        for p in pts {
            let (cx, cy) = cell_of(*p);
            let k = cy as usize * nx + cx as usize;
            if std::mem::replace(&mut stamped[k], true) {
                continue;
            }
            for iy in (cy - r).max(0)..=(cy + r).min(ny as i64 - 1) {
                for ix in (cx - r).max(0)..=(cx + r).min(nx as i64 - 1) {
                    let c = Vec2::new(
                        lo.x + (ix as f64 + 0.5) * cell_m,
                        lo.y + (iy as f64 + 0.5) * cell_m,
                    );
                    let dist = (c - p).norm();
                    if dist <= reach_m {
                        let k = iy as usize * nx + ix as usize;
                        d[k] = d[k].min(dist as f32);
                    }
                }
            }
        }
        FloorGrid {
            origin: lo,
            cell_m,
            nx,
            ny,
            d,
        }
    }
}

impl TcpfEngine {
    /// Far from the survey (`anchors.far_db`), takes
    /// `anchors.far_survey_penalty` x `trust` x exp(-d^2 / (2 sigma^2))
    /// off each particle's `log_l`, `d` its distance on `floor` to the
    /// nearest reference scan: a window unlike every survey scan was not
    /// heard on the survey's lines. The grid is built at the first use.
    pub(super) fn weigh_by_survey_reach(&mut self, floor: i32, trust: f64, log_l: &mut [f64]) {
        let ac = &self.cfg.anchors;
        let (penalty, sigma) = (ac.far_survey_penalty * trust, ac.far_survey_sigma_m);
        if penalty <= 0.0 || !self.far_from_survey() {
            return;
        }
        let model = &self.model;
        let Some(scans) = model.reference_scans() else {
            return;
        };
        // beyond 3 sigma the penalty is 1 % of its peak: not stored;
        // shared by the engines on the model
        let reach = self.reach.get_or_insert_with(|| {
            get_or_build_in(model.derived(), &[1.0, 3.0 * sigma], || {
                SurveyReach::of_scans(scans, 1.0, 3.0 * sigma)
            })
        });
        let k = -0.5 / (sigma * sigma);
        for (u, p) in log_l.iter_mut().zip(self.pf.particles()) {
            if let Some(d) = reach.distance_m(floor, *p) {
                *u -= penalty * (k * d * d).exp();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reach_of(pts: &[Vec2], reach_m: f64) -> SurveyReach {
        SurveyReach {
            floors: [(0, FloorGrid::of_points(pts, 1.0, reach_m))].into(),
        }
    }

    #[test]
    fn the_grid_gives_the_distance_to_the_nearest_scan_within_a_cell() {
        let pts: Vec<Vec2> = (0..40)
            .map(|i| Vec2::new(10.0 + 0.5 * f64::from(i), 5.0 + 0.1 * f64::from(i)))
            .chain([Vec2::new(3.0, 30.0)])
            .collect();
        let r = reach_of(&pts, 12.0);
        for &(x, y) in &[
            (0.0, 0.0),
            (12.3, 9.9),
            (3.5, 29.0),
            (20.0, 20.0),
            (31.0, 5.0),
        ] {
            let p = Vec2::new(x, y);
            let exact = pts.iter().map(|q| (p - q).norm()).fold(f64::MAX, f64::min);
            match r.distance_m(0, p) {
                Some(d) => assert!((d - exact).abs() <= 0.75, "{p:?}: {d} against {exact}"),
                None => assert!(exact > 12.0 - 0.75, "{p:?}: none within {exact}"),
            }
        }
        assert_eq!(r.distance_m(0, Vec2::new(-100.0, 0.0)), None);
        assert_eq!(r.distance_m(1, Vec2::new(10.0, 5.0)), None);
    }

    #[test]
    fn a_huge_floor_gets_coarser_cells_not_more_memory() {
        let g = FloorGrid::of_points(&[Vec2::zeros(), Vec2::new(1e5, 1e5)], 1.0, 12.0);
        assert!(g.d.len() <= 4 * MAX_CELLS, "{} cells", g.d.len());
        assert!(g.cell_m > 1.0);
    }
}
