//! How much of a floor's walkable area lies near the survey: the distance
//! from each walkable cell to the nearest surveyed position (a radio map's
//! reference scans, one per second of survey walk; to within a cell,
//! [`super::distance_grid::DistanceGrid`]), in the bands of
//! docs/tcpf.md "Survey density: what a survey buys". A site engineer reads
//! it to see where the survey is thin before users walk there.

use super::FloorMap;
use super::distance_grid::DistanceGrid;
use crate::Vec2;

/// The bands' upper edges, metres: under 2 m, 2-5 m, 5-10 m, 10 m and more.
pub const SURVEY_BANDS_M: [f64; 3] = [2.0, 5.0, 10.0];

/// At most this many cells per floor: a larger floor gets coarser cells.
const MAX_CELLS: usize = 4_000_000;

/// The finest cell, metres.
const MIN_CELL_M: f64 = 0.5;

/// The distance band of every walkable cell of one floor.
#[derive(Debug, Clone)]
pub struct SurveyCoverage {
    cell_m: f64,
    nx: usize,
    ny: usize,
    /// Per cell (row-major from the MCS origin): the band index 0-3, or
    /// `None` where the cell's centre is not walkable.
    band: Vec<Option<u8>>,
    /// Walkable cells per band.
    counts: [usize; 4],
}

impl SurveyCoverage {
    /// The bands of `map`'s walkable cells against the surveyed positions
    /// `points` (MCS metres, this floor's only; non-finite ones are left
    /// out). With no points every walkable cell is in the last band.
    pub fn of(map: &FloorMap, points: &[Vec2]) -> Self {
        let (w, h) = (map.width_m(), map.height_m());
        let cell_m = MIN_CELL_M.max((w * h / MAX_CELLS as f64).sqrt());
        let nx = ((w / cell_m).ceil() as usize).max(1);
        let ny = ((h / cell_m).ceil() as usize).max(1);
        let pts: Vec<Vec2> = points
            .iter()
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .copied()
            .collect();
        let grid = DistanceGrid::of_points(&pts, cell_m, SURVEY_BANDS_M[2], MAX_CELLS);
        let mut band = Vec::with_capacity(nx * ny);
        let mut counts = [0usize; 4];
        for j in 0..ny {
            for i in 0..nx {
                let c = Vec2::new((i as f64 + 0.5) * cell_m, (j as f64 + 0.5) * cell_m);
                if !map.is_walkable(c) {
                    band.push(None);
                    continue;
                }
                // beyond the grid's reach: the last band
                let d = grid
                    .as_ref()
                    .and_then(|g| g.distance_m(c))
                    .unwrap_or(f64::INFINITY);
                let b = SURVEY_BANDS_M.iter().take_while(|e| d >= **e).count() as u8;
                counts[b as usize] += 1;
                band.push(Some(b));
            }
        }
        SurveyCoverage {
            cell_m,
            nx,
            ny,
            band,
            counts,
        }
    }

    /// The cell size, metres.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    /// The band of the cell holding `p` (MCS metres): 0 under 2 m, 1 2-5 m,
    /// 2 5-10 m, 3 10 m and more; `None` off the floor or not walkable.
    pub fn band_at(&self, p: Vec2) -> Option<u8> {
        let (fx, fy) = ((p.x / self.cell_m).floor(), (p.y / self.cell_m).floor());
        if !(fx >= 0.0 && fy >= 0.0 && fx < self.nx as f64 && fy < self.ny as f64) {
            return None;
        }
        self.band[fy as usize * self.nx + fx as usize]
    }

    /// The share of the walkable cells in each band (zeros on a floor
    /// without walkable cells).
    pub fn shares(&self) -> [f64; 4] {
        let n: usize = self.counts.iter().sum();
        self.counts
            .map(|c| if n == 0 { 0.0 } else { c as f64 / n as f64 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::Feature;

    /// An open floor of `w` x `h` m without walls, 4 px per metre.
    fn open_floor(w: f64, h: f64) -> FloorMap {
        let (nx, ny) = ((w * 4.0) as usize, (h * 4.0) as usize);
        FloorMap::from_features(nx, ny, 4.0, vec![Feature::Walkable; nx * ny])
    }

    #[test]
    fn bands_follow_the_distance_to_the_nearest_surveyed_point() {
        // a 40 m x 10 m open floor surveyed along y = 5 from x = 0 to 10
        let map = open_floor(40.0, 10.0);
        let pts: Vec<Vec2> = (0..=10).map(|x| Vec2::new(x as f64, 5.0)).collect();
        let cov = SurveyCoverage::of(&map, &pts);
        assert_eq!(cov.band_at(Vec2::new(5.0, 6.0)), Some(0));
        assert_eq!(cov.band_at(Vec2::new(13.0, 5.0)), Some(1));
        assert_eq!(cov.band_at(Vec2::new(18.0, 5.0)), Some(2));
        assert_eq!(cov.band_at(Vec2::new(30.0, 5.0)), Some(3));
        assert_eq!(cov.band_at(Vec2::new(-1.0, 5.0)), None);
        let s = cov.shares();
        assert!((s.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        // within 2 m: y 3-7 for x up to 12 m, about 48 of 400 m2; 10 m
        // and more: x beyond about 20 m, half the floor
        assert!(s[0] > 0.1 && s[0] < 0.14, "{s:?}");
        assert!(s[3] > 0.45 && s[3] < 0.55, "{s:?}");
        // no survey: everything far; non-finite points are ignored
        let none = SurveyCoverage::of(&map, &[Vec2::new(f64::NAN, 1.0)]);
        assert_eq!(none.shares(), [0.0, 0.0, 0.0, 1.0]);
    }
}
