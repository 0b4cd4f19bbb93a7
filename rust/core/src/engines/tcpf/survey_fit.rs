//! How well the radio map fits its own survey, place by place: per floor,
//! a grid of the mean z^2 of the survey's reference scans against the
//! model where they were read (each reading's residual less the scan's
//! mean residual, the walk's phone offset, over the model's spread, each
//! capped as the fit check caps it). Where the survey's own scans misfit
//! the map, a walk's readings misfit it as much without the map being
//! wrong there; the fit check reads its z^2 relative to this level
//! (`integrity.fit_local_cell_m`).
//!
//! In-sample (the map was smoothed from these scans): the level's absolute
//! value is below what a new walk meets, so only its ratio to the site's
//! median is used.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::Vec2;
use crate::radio::RadioModel;
use crate::radio::derived::get_or_build_in;
use crate::radio::radio_map::tenths;

/// Fewest readings of a scan for its z^2.
const MIN_READINGS: usize = 3;
/// Fewest scans around a place for its level.
const MIN_SCANS: u32 = 5;
/// At most this many cells per floor: a larger floor gets coarser cells.
const MAX_CELLS: usize = 1_000_000;

struct FloorGrid {
    origin: Vec2,
    cell_m: f64,
    nx: usize,
    ny: usize,
    /// Per cell: sum of the scans' z^2 and their count.
    acc: Vec<(f64, u32)>,
}

/// The survey's fit to the map per place.
pub(super) struct SurveyFit {
    floors: BTreeMap<i32, FloorGrid>,
    /// The median of the scans' z^2 over the site.
    median_z2: f64,
}

impl SurveyFit {
    /// The grid of `model`'s reference scans in cells of `cell_m`; `None`
    /// without scans or with too few readable ones.
    pub(super) fn of_model(model: &dyn RadioModel, cell_m: f64, cap: f64) -> Option<Self> {
        let scans = model.reference_scans()?;
        let tx_of: Vec<Option<usize>> = scans
            .ids()
            .iter()
            .map(|(k, id)| model.lookup(*k, id))
            .collect();
        let mut z2s: BTreeMap<i32, Vec<(Vec2, f64)>> = BTreeMap::new();
        let mut res: Vec<(f64, f64)> = Vec::new();
        for s in scans.scans() {
            let p = Vec2::new(s.x_m, s.y_m);
            if !(p.x.is_finite() && p.y.is_finite()) {
                continue;
            }
            res.clear();
            for &(j, r10) in &s.tx {
                let Some(Some(tx)) = tx_of.get(j as usize) else {
                    continue;
                };
                if let Some((mu, sd)) = model.expected(*tx, s.floor, p)
                    && sd > 0.0
                {
                    res.push((tenths(r10) - mu, sd));
                }
            }
            if res.len() < MIN_READINGS {
                continue;
            }
            let mean = res.iter().map(|r| r.0).sum::<f64>() / res.len() as f64;
            let z2 = res
                .iter()
                .map(|(r, sd)| {
                    let z = (r - mean) / sd;
                    (z * z).min(cap)
                })
                .sum::<f64>()
                / res.len() as f64;
            z2s.entry(s.floor).or_default().push((p, z2));
        }
        let mut all: Vec<f64> = z2s.values().flatten().map(|(_, z)| *z).collect();
        if all.len() < MIN_SCANS as usize {
            return None;
        }
        all.sort_by(f64::total_cmp);
        let median_z2 = all[all.len() / 2];
        if median_z2 <= 0.0 {
            return None;
        }
        let floors = z2s
            .into_iter()
            .map(|(f, pts)| (f, FloorGrid::of_points(&pts, cell_m)))
            .collect();
        Some(SurveyFit { floors, median_z2 })
    }

    /// The survey's mean z^2 over the 3 x 3 cells around `p` on `floor`,
    /// over the site's median; `None` where fewer than [`MIN_SCANS`]
    /// scans lie there.
    pub(super) fn relative_level(&self, floor: i32, p: Vec2) -> Option<f64> {
        let g = self.floors.get(&floor)?;
        let cx = ((p.x - g.origin.x) / g.cell_m).floor();
        let cy = ((p.y - g.origin.y) / g.cell_m).floor();
        if !(cx.is_finite() && cy.is_finite()) {
            return None;
        }
        // far outside the grid: clamped so that the neighbourhood is empty
        let cx = cx.clamp(-2.0, g.nx as f64 + 2.0) as i64;
        let cy = cy.clamp(-2.0, g.ny as f64 + 2.0) as i64;
        let (mut sum, mut n) = (0.0, 0u32);
        for iy in (cy - 1).max(0)..=(cy + 1).min(g.ny as i64 - 1) {
            for ix in (cx - 1).max(0)..=(cx + 1).min(g.nx as i64 - 1) {
                let (s, c) = g.acc[iy as usize * g.nx + ix as usize];
                sum += s;
                n += c;
            }
        }
        (n >= MIN_SCANS).then(|| sum / f64::from(n) / self.median_z2)
    }
}

impl super::TcpfEngine {
    /// The survey's relative misfit around the cloud's mean on `floor`
    /// (`integrity.fit_local_cell_m`; 1 when off, without reference scans
    /// or where too few lie). The grid is built at the first use.
    pub(super) fn survey_fit_level(&mut self, floor: i32) -> f64 {
        let ic = &self.cfg.integrity;
        let cell_m = ic.fit_local_cell_m;
        if cell_m <= 0.0 {
            return 1.0;
        }
        let cap = ic.fit_z2_cap;
        let model = &self.model;
        // shared by the engines on the model
        let fit = self.survey_fit.get_or_insert_with(|| {
            Option::clone(&get_or_build_in(model.derived(), &[cell_m, cap], || {
                SurveyFit::of_model(model.as_ref(), cell_m, cap).map(Arc::new)
            }))
        });
        match (fit, self.pf.mean()) {
            (Some(f), Some(p)) => f.relative_level(floor, p).unwrap_or(1.0),
            _ => 1.0,
        }
    }
}

impl FloorGrid {
    /// `pts` (not empty) summed into the cells over their box.
    fn of_points(pts: &[(Vec2, f64)], cell_m: f64) -> Self {
        let (mut lo, mut hi) = (pts[0].0, pts[0].0);
        for (p, _) in pts {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let mut cell_m = cell_m;
        let cells = |c: f64| ((hi.x - lo.x) / c + 1.0) * ((hi.y - lo.y) / c + 1.0);
        while cells(cell_m) > MAX_CELLS as f64 {
            cell_m *= 2.0;
        }
        let nx = ((hi.x - lo.x) / cell_m).floor() as usize + 1;
        let ny = ((hi.y - lo.y) / cell_m).floor() as usize + 1;
        let mut acc = vec![(0.0, 0u32); nx * ny];
        for (p, z2) in pts {
            let ix = (((p.x - lo.x) / cell_m).floor() as usize).min(nx - 1);
            let iy = (((p.y - lo.y) / cell_m).floor() as usize).min(ny - 1);
            let a = &mut acc[iy * nx + ix];
            a.0 += z2;
            a.1 += 1;
        }
        FloorGrid {
            origin: lo,
            cell_m,
            nx,
            ny,
            acc,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_is_the_local_mean_over_the_site_median_where_scans_lie() {
        // a noisy strip (z^2 4) beside a quiet one (z^2 1), 40 scans each
        let mut pts: Vec<(Vec2, f64)> = (0..40)
            .map(|i| (Vec2::new(0.5 * f64::from(i), 0.0), 1.0))
            .collect();
        pts.extend((0..40).map(|i| (Vec2::new(0.5 * f64::from(i), 30.0), 4.0)));
        let fit = SurveyFit {
            floors: [(0, FloorGrid::of_points(&pts, 4.0))].into(),
            median_z2: 1.0,
        };
        let quiet = fit.relative_level(0, Vec2::new(10.0, 0.0)).unwrap();
        let noisy = fit.relative_level(0, Vec2::new(10.0, 30.0)).unwrap();
        assert!((quiet - 1.0).abs() < 1e-9, "{quiet}");
        assert!((noisy - 4.0).abs() < 1e-9, "{noisy}");
        assert_eq!(fit.relative_level(0, Vec2::new(10.0, 15.0)), None);
        assert_eq!(fit.relative_level(1, Vec2::new(10.0, 0.0)), None);
        assert_eq!(fit.relative_level(0, Vec2::new(f64::NAN, 0.0)), None);
        assert_eq!(fit.relative_level(0, Vec2::new(1e300, -1e300)), None);
    }

    #[test]
    fn a_huge_floor_gets_coarser_cells_not_more_memory() {
        let g = FloorGrid::of_points(&[(Vec2::zeros(), 1.0), (Vec2::new(1e6, 1e6), 1.0)], 4.0);
        assert!(g.acc.len() <= 4 * MAX_CELLS, "{} cells", g.acc.len());
        let far = FloorGrid::of_points(
            &[(Vec2::new(-1e308, 0.0), 1.0), (Vec2::new(1e308, 0.0), 1.0)],
            4.0,
        );
        assert!(far.acc.len() <= 4 * MAX_CELLS, "{} cells", far.acc.len());
    }
}
