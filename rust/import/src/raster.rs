//! Rasterising imported geometry into a stylized plan: polygons in MCS metres
//! -> a label grid (outside / corridor / unit k) -> one map feature per pixel
//! -> an RGB PNG in the site legend (wall black, door red, walkable white).
//!
//! Pixel (i, j) (column, row 0 at the top) covers MCS
//! [i/r, (i+1)/r) x [(H-j-1)/r, (H-j)/r) (FP-BP eq. 23); a pixel belongs to a
//! polygon when its centre does (even-odd rule, so inner rings are holes).

use anyhow::{Context, Result};
use fpbp_core::Vec2;
use fpbp_core::map::{Feature, FloorMap};
use fpbp_core::site::Legend;
use std::path::Path;

/// A polygon with holes: rings of MCS points (first = outer, others = holes).
/// Rings need not repeat their first point at the end.
pub type Polygon = Vec<Vec<Vec2>>;

/// The pixel grid of a plan: `width_px` x `height_px` at `pixels_per_meter`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub width_px: usize,
    pub height_px: usize,
    pub pixels_per_meter: f64,
}

impl Grid {
    /// The smallest grid at `r` px/m whose image covers [0, width_m] x [0, height_m].
    pub fn covering(width_m: f64, height_m: f64, pixels_per_meter: f64) -> Grid {
        Grid {
            width_px: ((width_m * pixels_per_meter).ceil() as usize).max(1),
            height_px: ((height_m * pixels_per_meter).ceil() as usize).max(1),
            pixels_per_meter,
        }
    }

    /// MCS y of the centre of row `j`.
    fn row_centre_y(&self, j: usize) -> f64 {
        (self.height_px as f64 - j as f64 - 0.5) / self.pixels_per_meter
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.width_px * self.height_px
    }

    /// Whether the grid has no pixel.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Calls `fill(i, j)` for every pixel whose centre lies inside `poly`
/// (even-odd rule over all rings).
pub fn scan_polygon(grid: &Grid, poly: &Polygon, mut fill: impl FnMut(usize, usize)) {
    let r = grid.pixels_per_meter;
    let (mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY);
    for ring in poly {
        for p in ring {
            ymin = ymin.min(p.y);
            ymax = ymax.max(p.y);
        }
    }
    if !(ymin.is_finite() && ymax.is_finite()) {
        return;
    }
    // Rows whose centre y lies in [ymin, ymax].
    let h = grid.height_px as f64;
    let j_lo = ((h - ymax * r - 0.5).ceil()).max(0.0) as usize;
    let j_hi = ((h - ymin * r - 0.5).floor()).min(h - 1.0);
    if j_hi < 0.0 {
        return;
    }
    let j_hi = j_hi as usize;
    let mut xs: Vec<f64> = Vec::new();
    for j in j_lo..=j_hi {
        let y = grid.row_centre_y(j);
        xs.clear();
        for ring in poly {
            let n = ring.len();
            for k in 0..n {
                let a = ring[k];
                let b = ring[(k + 1) % n];
                // Half-open rule: an edge counts when y is in [min, max).
                if (a.y <= y && y < b.y) || (b.y <= y && y < a.y) {
                    xs.push(a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x));
                }
            }
        }
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            // Pixel centres (i + 0.5) / r in [x0, x1).
            let i0 = (pair[0] * r - 0.5).ceil().max(0.0);
            let i1 = (pair[1] * r - 0.5).ceil().min(grid.width_px as f64);
            if i1 <= i0 {
                continue;
            }
            for i in i0 as usize..i1 as usize {
                fill(i, j);
            }
        }
    }
}

/// Label of a pixel in a [`LabelGrid`].
pub const OUTSIDE: u32 = 0;
/// Public walkable space inside the floor outline but outside every unit.
pub const CORRIDOR: u32 = 1;

/// One label per pixel: [`OUTSIDE`], [`CORRIDOR`], or `2 + k` for unit k.
#[derive(Debug, Clone)]
pub struct LabelGrid {
    pub grid: Grid,
    pub labels: Vec<u32>,
}

/// How the boundary of a unit is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnitKind {
    /// A shop or room a pedestrian can enter from the corridor: its boundary
    /// is Door where it faces the corridor, Wall elsewhere.
    Enterable,
    /// A unit nobody walks into from the corridor (void, shaft, closed area):
    /// its whole boundary is Wall.
    Closed,
}

impl LabelGrid {
    /// Outline polygons become corridor, then unit k overwrites with `2 + k`
    /// (a later unit wins where units overlap).
    pub fn rasterise(grid: Grid, outline: &[Polygon], units: &[Polygon]) -> LabelGrid {
        let mut labels = vec![OUTSIDE; grid.len()];
        let w = grid.width_px;
        for poly in outline {
            scan_polygon(&grid, poly, |i, j| labels[j * w + i] = CORRIDOR);
        }
        for (k, poly) in units.iter().enumerate() {
            let l = 2 + k as u32;
            scan_polygon(&grid, poly, |i, j| labels[j * w + i] = l);
        }
        LabelGrid { grid, labels }
    }

    fn label(&self, i: isize, j: isize) -> u32 {
        if i < 0 || j < 0 || i as usize >= self.grid.width_px || j as usize >= self.grid.height_px {
            return OUTSIDE;
        }
        self.labels[j as usize * self.grid.width_px + i as usize]
    }

    /// Closes slivers: a corridor pixel in a run of at most `max_gap_px`
    /// corridor pixels along one of the four axes, bounded by a unit (or the
    /// outside) on both ends, at least one a unit, is a digitising gap between polygons that
    /// share an edge, not a corridor; it takes the label of that unit.
    /// Returns the number of pixels relabelled.
    pub fn close_slivers(&mut self, max_gap_px: usize) -> usize {
        let (w, h) = (self.grid.width_px as isize, self.grid.height_px as isize);
        let d = max_gap_px as isize;
        let mut out = self.labels.clone();
        let mut n = 0;
        // First non-corridor label within d steps along (di, dj), and its step.
        let probe = |i: isize, j: isize, di: isize, dj: isize| -> Option<(u32, isize)> {
            (1..=d)
                .map(|k| (self.label(i + k * di, j + k * dj), k))
                .find(|&(l, _)| l != CORRIDOR)
        };
        for j in 0..h {
            for i in 0..w {
                if self.label(i, j) != CORRIDOR {
                    continue;
                }
                for (di, dj) in [(1, 0), (0, 1), (1, 1), (1, -1)] {
                    let (Some((a, ka)), Some((b, kb))) =
                        (probe(i, j, di, dj), probe(i, j, -di, -dj))
                    else {
                        continue;
                    };
                    // The run of corridor pixels between a and b is ka + kb - 1 long.
                    let unit = if a >= 2 { a } else { b };
                    if ka + kb - 1 <= d && unit >= 2 {
                        out[(j * w + i) as usize] = unit;
                        n += 1;
                        break;
                    }
                }
            }
        }
        self.labels = out;
        n
    }

    /// Map features under the storefront rule: outside the outline is Wall;
    /// a unit pixel with an 8-neighbour of another label is a boundary pixel:
    /// Door when every such neighbour is corridor and the unit is
    /// [`UnitKind::Enterable`], Wall otherwise; every other pixel is Walkable.
    /// `kinds[k]` is the kind of unit k.
    pub fn features(&self, kinds: &[UnitKind]) -> Vec<Feature> {
        let (w, h) = (self.grid.width_px, self.grid.height_px);
        let mut out = Vec::with_capacity(w * h);
        for j in 0..h as isize {
            for i in 0..w as isize {
                let l = self.label(i, j);
                let f = match l {
                    OUTSIDE => Feature::Wall,
                    CORRIDOR => Feature::Walkable,
                    _ => {
                        let mut other_corridor = false;
                        let mut other_blocked = false;
                        for dj in -1..=1 {
                            for di in -1..=1 {
                                let n = self.label(i + di, j + dj);
                                if n == l {
                                    continue;
                                }
                                if n == CORRIDOR {
                                    other_corridor = true;
                                } else {
                                    other_blocked = true;
                                }
                            }
                        }
                        let kind = kinds
                            .get((l - 2) as usize)
                            .copied()
                            .unwrap_or(UnitKind::Closed);
                        if other_blocked || (other_corridor && kind == UnitKind::Closed) {
                            Feature::Wall
                        } else if other_corridor {
                            Feature::Door
                        } else {
                            Feature::Walkable
                        }
                    }
                };
                out.push(f);
            }
        }
        out
    }
}

/// The legend colour of a feature.
pub fn colour_of(legend: &Legend, f: Feature) -> [u8; 3] {
    match f {
        Feature::Walkable => legend.walkable,
        Feature::Door => legend.door,
        Feature::Wall => legend.wall,
    }
}

/// Writes `features` (row-major, row 0 at the top) as an RGB PNG in `legend`.
pub fn write_plan_png(
    path: &Path,
    grid: &Grid,
    features: &[Feature],
    legend: &Legend,
) -> Result<()> {
    let mut img = image::RgbImage::new(grid.width_px as u32, grid.height_px as u32);
    for (px, f) in img.pixels_mut().zip(features) {
        *px = image::Rgb(colour_of(legend, *f));
    }
    img.save(path)
        .with_context(|| format!("writing plan {}", path.display()))
}

/// A [`FloorMap`] of the features (for checks before the site is written).
pub fn floor_map(grid: &Grid, features: Vec<Feature>) -> FloorMap {
    FloorMap::from_features(
        grid.width_px,
        grid.height_px,
        grid.pixels_per_meter,
        features,
    )
}

/// Walls crossed by the straight segment a -> b: the number of times the
/// segment, sampled every 1/(4r) metres, enters a Wall pixel from a non-Wall
/// one (a segment starting on a Wall pixel counts that wall once). Doors are
/// free to cross.
pub fn wall_crossings(map: &FloorMap, a: Vec2, b: Vec2) -> usize {
    let step = 0.25 / map.pixels_per_meter();
    let len = (b - a).norm();
    let n = (len / step).ceil().max(1.0) as usize;
    let mut count = 0;
    let mut in_wall = false;
    for k in 0..=n {
        let p = a + (b - a) * (k as f64 / n as f64);
        let wall = map.feature(p) == Feature::Wall;
        if wall && !in_wall {
            count += 1;
        }
        in_wall = wall;
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon {
        vec![vec![
            Vec2::new(x0, y0),
            Vec2::new(x1, y0),
            Vec2::new(x1, y1),
            Vec2::new(x0, y1),
        ]]
    }

    #[test]
    fn square_fills_its_pixel_centres() {
        let grid = Grid::covering(10.0, 10.0, 1.0);
        let mut n = 0;
        scan_polygon(&grid, &rect(2.0, 3.0, 5.0, 7.0), |i, j| {
            // centre x in (2, 5), centre y in (3, 7)
            let x = i as f64 + 0.5;
            let y = 10.0 - j as f64 - 0.5;
            assert!(x > 2.0 && x < 5.0 && y > 3.0 && y < 7.0, "({i},{j})");
            n += 1;
        });
        assert_eq!(n, 3 * 4);
    }

    #[test]
    fn hole_is_left_empty() {
        let grid = Grid::covering(10.0, 10.0, 2.0);
        let mut poly = rect(0.0, 0.0, 10.0, 10.0);
        poly.push(rect(4.0, 4.0, 6.0, 6.0).remove(0));
        let mut n = 0;
        scan_polygon(&grid, &poly, |_, _| n += 1);
        assert_eq!(n, 400 - 16);
    }

    #[test]
    fn storefront_rule_on_two_shops() {
        // Outline 20 x 10; two shops side by side along the top, corridor below.
        let grid = Grid::covering(20.0, 10.0, 2.0);
        let outline = vec![rect(0.0, 0.0, 20.0, 10.0)];
        let units = vec![rect(0.0, 5.0, 10.0, 10.0), rect(10.0, 5.0, 20.0, 10.0)];
        let lg = LabelGrid::rasterise(grid, &outline, &units);
        let f = lg.features(&[UnitKind::Enterable, UnitKind::Enterable]);
        let map = floor_map(&grid, f);
        // Shop front (facing the corridor at y = 5) is a door.
        assert_eq!(map.feature(Vec2::new(5.0, 5.2)), Feature::Door);
        // Party wall between the shops is a wall.
        assert_eq!(map.feature(Vec2::new(9.8, 7.5)), Feature::Wall);
        assert_eq!(map.feature(Vec2::new(10.2, 7.5)), Feature::Wall);
        // Interiors and the corridor are walkable.
        assert_eq!(map.feature(Vec2::new(5.0, 7.5)), Feature::Walkable);
        assert_eq!(map.feature(Vec2::new(5.0, 2.5)), Feature::Walkable);
        // Corridor -> shop crosses no wall; shop -> shop crosses one.
        assert_eq!(
            wall_crossings(&map, Vec2::new(5.0, 2.0), Vec2::new(5.0, 8.0)),
            0
        );
        assert_eq!(
            wall_crossings(&map, Vec2::new(5.0, 8.0), Vec2::new(15.0, 8.0)),
            1
        );
        // A closed unit has no door.
        let f = lg.features(&[UnitKind::Closed, UnitKind::Enterable]);
        let map = floor_map(&grid, f);
        assert_eq!(map.feature(Vec2::new(5.0, 5.2)), Feature::Wall);
        assert_eq!(map.feature(Vec2::new(15.0, 5.2)), Feature::Door);
    }

    #[test]
    fn slivers_close_but_corridors_stay() {
        // Two shops 0.2 m apart (a digitising gap) and a 3 m corridor.
        let grid = Grid::covering(20.0, 10.0, 5.0);
        let outline = vec![rect(0.0, 0.0, 20.0, 10.0)];
        let units = vec![rect(0.0, 0.0, 8.0, 10.0), rect(8.2, 0.0, 12.0, 10.0)];
        let mut lg = LabelGrid::rasterise(grid, &outline, &units);
        let closed = lg.close_slivers(2);
        // The 0.2 m x 10 m gap (50 pixels) plus a few corridor corner pixels.
        assert!((50..=60).contains(&closed), "{closed}");
        let map = floor_map(&grid, lg.features(&[UnitKind::Enterable; 2]));
        // The gap is a wall between the shops, not a door-lined corridor.
        assert_eq!(
            wall_crossings(&map, Vec2::new(4.0, 5.0), Vec2::new(10.0, 5.0)),
            1
        );
        assert_eq!(map.feature(Vec2::new(8.1, 5.0)), Feature::Wall);
        // The corridor x in (12, 20) is untouched, its shop front a door.
        assert_eq!(map.feature(Vec2::new(16.0, 5.0)), Feature::Walkable);
        assert_eq!(map.feature(Vec2::new(11.9, 5.0)), Feature::Door);
    }

    #[test]
    fn diagonal_walls_are_not_skipped() {
        // A thin diagonal unit boundary must stop a crossing segment.
        let grid = Grid::covering(20.0, 20.0, 5.0);
        let outline = vec![rect(0.0, 0.0, 20.0, 20.0)];
        let tri_a = vec![vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(20.0, 0.0),
            Vec2::new(0.0, 20.0),
        ]];
        let tri_b = vec![vec![
            Vec2::new(20.0, 0.0),
            Vec2::new(20.0, 20.0),
            Vec2::new(0.0, 20.0),
        ]];
        let mut lg = LabelGrid::rasterise(grid, &outline, &[tri_a, tri_b]);
        lg.close_slivers(2);
        let map = floor_map(&grid, lg.features(&[UnitKind::Enterable; 2]));
        for k in 0..50 {
            let t = 1.0 + k as f64 * 0.28;
            let a = Vec2::new(t, t * 0.3);
            let b = Vec2::new(19.0 - t * 0.2, 19.5 - t * 0.1);
            assert_eq!(wall_crossings(&map, a, b), 1, "{a:?} -> {b:?}");
        }
    }
}
