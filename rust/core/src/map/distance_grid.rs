//! The distance from a grid's cells to the nearest of a set of points
//! (the survey's walked positions), out to a reach: what tcpf's far-from-
//! survey penalty reads per particle and `fpbp map check --radio-map`
//! reads per walkable cell.

use crate::Vec2;

/// A grid over the points' box plus the reach: per cell the distance
/// from its centre to the nearest point, m (`f32::INFINITY` beyond the
/// reach), to within a cell.
#[derive(Debug, Clone)]
pub struct DistanceGrid {
    origin: Vec2,
    cell_m: f64,
    nx: usize,
    ny: usize,
    d: Vec<f32>,
}

impl DistanceGrid {
    /// `pts` stamped onto a grid of `cell_m` cells over their box plus
    /// `reach_m`, the cells doubled until there are at most `max_cells`;
    /// `None` without points.
    pub fn of_points(pts: &[Vec2], cell_m: f64, reach_m: f64, max_cells: usize) -> Option<Self> {
        let first = *pts.first()?;
        let (mut lo, mut hi) = (first, first);
        for p in pts {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let lo = lo - Vec2::new(reach_m, reach_m);
        let hi = hi + Vec2::new(reach_m, reach_m);
        let mut cell_m = cell_m;
        let cells = |c: f64| ((hi.x - lo.x) / c).ceil() * ((hi.y - lo.y) / c).ceil();
        while cells(cell_m) > max_cells as f64 {
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
        Some(DistanceGrid {
            origin: lo,
            cell_m,
            nx,
            ny,
            d,
        })
    }

    /// The cell size, m.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    /// Distance from `p` to the nearest point, m, to within a cell;
    /// `None` beyond the reach or off the grid.
    pub fn distance_m(&self, p: Vec2) -> Option<f64> {
        let fx = ((p.x - self.origin.x) / self.cell_m).floor();
        let fy = ((p.y - self.origin.y) / self.cell_m).floor();
        if !(fx >= 0.0 && fy >= 0.0 && fx < self.nx as f64 && fy < self.ny as f64) {
            return None;
        }
        let d = self.d[fy as usize * self.nx + fx as usize];
        d.is_finite().then_some(f64::from(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAX_CELLS: usize = 2_000_000;

    #[test]
    fn the_grid_gives_the_distance_to_the_nearest_scan_within_a_cell() {
        let pts: Vec<Vec2> = (0..40)
            .map(|i| Vec2::new(10.0 + 0.5 * f64::from(i), 5.0 + 0.1 * f64::from(i)))
            .chain([Vec2::new(3.0, 30.0)])
            .collect();
        let r = DistanceGrid::of_points(&pts, 1.0, 12.0, MAX_CELLS).unwrap();
        for &(x, y) in &[
            (0.0, 0.0),
            (12.3, 9.9),
            (3.5, 29.0),
            (20.0, 20.0),
            (31.0, 5.0),
        ] {
            let p = Vec2::new(x, y);
            let exact = pts.iter().map(|q| (p - q).norm()).fold(f64::MAX, f64::min);
            match r.distance_m(p) {
                Some(d) => assert!((d - exact).abs() <= 0.75, "{p:?}: {d} against {exact}"),
                None => assert!(exact > 12.0 - 0.75, "{p:?}: none within {exact}"),
            }
        }
        assert_eq!(r.distance_m(Vec2::new(-100.0, 0.0)), None);
        assert!(DistanceGrid::of_points(&[], 1.0, 12.0, MAX_CELLS).is_none());
    }

    #[test]
    fn a_huge_floor_gets_coarser_cells_not_more_memory() {
        let g =
            DistanceGrid::of_points(&[Vec2::zeros(), Vec2::new(1e5, 1e5)], 1.0, 12.0, MAX_CELLS)
                .unwrap();
        assert!(g.d.len() <= 4 * MAX_CELLS, "{} cells", g.d.len());
        assert!(g.cell_m > 1.0);
    }
}
