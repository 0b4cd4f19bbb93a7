//! Where the survey walked: per floor, a grid of the distance from each
//! cell to the nearest reference scan (the survey's walked positions),
//! out to a reach; and the weighing that reads it far from the survey
//! (`anchors.far_survey_penalty`).

use std::collections::BTreeMap;

use super::TcpfEngine;
use crate::Vec2;
use crate::map::distance_grid::DistanceGrid;
use crate::radio::derived::get_or_build_in;
use crate::radio::reference_scans::ReferenceScans;

/// At most this many cells per floor: a larger floor gets coarser cells.
const MAX_CELLS: usize = 2_000_000;

/// The distance to the survey per floor, out to `reach_m`.
pub(super) struct SurveyReach {
    floors: BTreeMap<i32, DistanceGrid>,
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
            .filter_map(|(f, pts)| {
                Some((
                    f,
                    DistanceGrid::of_points(&pts, cell_m, reach_m, MAX_CELLS)?,
                ))
            })
            .collect();
        SurveyReach { floors }
    }

    /// Distance from `p` on `floor` to the nearest reference scan, m, to
    /// within a cell; `None` beyond the reach or without scans there.
    pub(super) fn distance_m(&self, floor: i32, p: Vec2) -> Option<f64> {
        self.floors.get(&floor)?.distance_m(p)
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
