//! Route planning on a floor map: a coarse planning grid with wall clearance,
//! rooms (walkable regions separated by doors and walls), A* between cells,
//! then string pulling and corner cutting so the route looks walked, while
//! every segment keeps the clearance from walls.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use fpbp_core::Vec2;
use fpbp_core::map::{Feature, FloorMap};

/// Cell class of the planning grid: the worst pixel class inside it.
const WALL: u8 = 2;
const DOOR: u8 = 1;

/// Cost factor per metre of clearance missing below this, so routes keep to
/// the middle of corridors.
const PREFERRED_CLEARANCE_M: f64 = 1.0;
const NEAR_WALL_PENALTY_PER_M: f64 = 1.5;

/// The planning grid of one floor.
#[derive(Debug, Clone)]
pub struct PlanGrid {
    /// Cell size, m.
    pub cell_m: f64,
    pub nx: usize,
    pub ny: usize,
    /// Worst feature per cell (0 walkable, 1 door, 2 wall); row 0 at the bottom (MCS y up).
    class: Vec<u8>,
    /// Distance from the cell centre to the nearest wall, m (approximate, conservative).
    clearance: Vec<f64>,
    /// Room label per cell (usize::MAX when not in a room).
    room: Vec<usize>,
    /// Number of rooms.
    pub rooms: usize,
    /// Clearance the route keeps, m.
    pub clearance_m: f64,
}

impl PlanGrid {
    /// Builds the grid of `map` with cells of `cell_m` metres; routes keep
    /// `clearance_m` from walls. Rooms are the 4-connected regions of
    /// walkable (not door) cells with that clearance.
    pub fn build(map: &FloorMap, cell_m: f64, clearance_m: f64) -> PlanGrid {
        let nx = (map.width_m() / cell_m).ceil().max(1.0) as usize;
        let ny = (map.height_m() / cell_m).ceil().max(1.0) as usize;
        let mut class = vec![0u8; nx * ny];
        let r = map.pixels_per_meter();
        let (w, h) = (map.width_px(), map.height_px());
        let cell_range = |lo_m: f64, hi_m: f64, n: usize| {
            let a = (lo_m / cell_m).floor().max(0.0) as usize;
            let b = ((hi_m / cell_m) - 1e-9).floor().max(0.0) as usize;
            (a.min(n - 1), b.min(n - 1))
        };
        for j in 0..h {
            // Pixel row j covers MCS y in [(H - j - 1) / r, (H - j) / r].
            let (cy0, cy1) = cell_range((h - j - 1) as f64 / r, (h - j) as f64 / r, ny);
            for i in 0..w {
                let f = match map.feature_px(i as isize, j as isize) {
                    Feature::Walkable => 0,
                    Feature::Door => DOOR,
                    Feature::Wall => WALL,
                };
                if f == 0 {
                    continue;
                }
                let (cx0, cx1) = cell_range(i as f64 / r, (i + 1) as f64 / r, nx);
                for cy in cy0..=cy1 {
                    for cx in cx0..=cx1 {
                        let c = &mut class[cy * nx + cx];
                        *c = (*c).max(f);
                    }
                }
            }
        }
        // Cells reaching past the image are walls (outside the plan is Wall).
        for cy in 0..ny {
            for cx in 0..nx {
                if (cx + 1) as f64 * cell_m > map.width_m() + 1e-9
                    || (cy + 1) as f64 * cell_m > map.height_m() + 1e-9
                {
                    class[cy * nx + cx] = WALL;
                }
            }
        }
        let clearance = clearance_transform(&class, nx, ny, cell_m);
        let mut g = PlanGrid {
            cell_m,
            nx,
            ny,
            class,
            clearance,
            room: vec![usize::MAX; nx * ny],
            rooms: 0,
            clearance_m,
        };
        g.label_rooms();
        g
    }

    fn label_rooms(&mut self) {
        let mut next = 0;
        let mut stack = Vec::new();
        for start in 0..self.nx * self.ny {
            if self.room[start] != usize::MAX || !self.is_room_cell(start) {
                continue;
            }
            self.room[start] = next;
            stack.push(start);
            while let Some(c) = stack.pop() {
                let (cx, cy) = (c % self.nx, c / self.nx);
                for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                    if let Some(n) = self.neighbour(cx, cy, dx, dy)
                        && self.room[n] == usize::MAX
                        && self.is_room_cell(n)
                    {
                        self.room[n] = next;
                        stack.push(n);
                    }
                }
            }
            next += 1;
        }
        self.rooms = next;
    }

    fn is_room_cell(&self, c: usize) -> bool {
        self.class[c] == 0 && self.clearance[c] >= self.clearance_m
    }

    fn neighbour(&self, cx: usize, cy: usize, dx: i64, dy: i64) -> Option<usize> {
        let x = cx as i64 + dx;
        let y = cy as i64 + dy;
        (x >= 0 && y >= 0 && (x as usize) < self.nx && (y as usize) < self.ny)
            .then(|| y as usize * self.nx + x as usize)
    }

    /// The cell containing MCS point `p`.
    pub fn cell_of(&self, p: Vec2) -> Option<usize> {
        if !(p.x >= 0.0 && p.y >= 0.0) {
            return None;
        }
        let (cx, cy) = (
            (p.x / self.cell_m).floor() as usize,
            (p.y / self.cell_m).floor() as usize,
        );
        (cx < self.nx && cy < self.ny).then(|| cy * self.nx + cx)
    }

    /// The MCS centre of cell `c`.
    pub fn centre(&self, c: usize) -> Vec2 {
        Vec2::new(
            ((c % self.nx) as f64 + 0.5) * self.cell_m,
            ((c / self.nx) as f64 + 0.5) * self.cell_m,
        )
    }

    /// Clearance of cell `c` from walls, m.
    pub fn clearance_of(&self, c: usize) -> f64 {
        self.clearance[c]
    }

    /// Room label of cell `c`.
    pub fn room_of(&self, c: usize) -> Option<usize> {
        (self.room[c] != usize::MAX).then_some(self.room[c])
    }

    /// Whether the walker may stand in cell `c`.
    pub fn traversable(&self, c: usize) -> bool {
        self.class[c] != WALL && self.clearance[c] >= self.clearance_m
    }

    /// Whether the straight segment a-b stays on traversable cells.
    pub fn segment_clear(&self, a: Vec2, b: Vec2) -> bool {
        let len = (b - a).norm();
        let n = (len / (self.cell_m * 0.25)).ceil().max(1.0) as usize;
        (0..=n).all(|k| {
            let p = a + (b - a) * (k as f64 / n as f64);
            self.cell_of(p).is_some_and(|c| self.traversable(c))
        })
    }

    /// The connected components of traversable cells (8-connected, as A*
    /// moves): one label per cell, usize::MAX for non-traversable cells.
    pub fn components(&self) -> Vec<usize> {
        let mut comp = vec![usize::MAX; self.nx * self.ny];
        let mut next = 0;
        let mut stack = Vec::new();
        for s in 0..self.nx * self.ny {
            if comp[s] != usize::MAX || !self.traversable(s) {
                continue;
            }
            comp[s] = next;
            stack.push(s);
            while let Some(c) = stack.pop() {
                for (n, _) in self.moves(c) {
                    if comp[n] == usize::MAX {
                        comp[n] = next;
                        stack.push(n);
                    }
                }
            }
            next += 1;
        }
        comp
    }

    /// Traversable 8-neighbours of `c` (no corner cutting) with the step length in cells.
    fn moves(&self, c: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (cx, cy) = (c % self.nx, c / self.nx);
        const D: [(i64, i64); 8] = [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ];
        D.iter().filter_map(move |&(dx, dy)| {
            let n = self.neighbour(cx, cy, dx, dy)?;
            if !self.traversable(n) {
                return None;
            }
            if dx != 0 && dy != 0 {
                let a = self.neighbour(cx, cy, dx, 0)?;
                let b = self.neighbour(cx, cy, 0, dy)?;
                if !self.traversable(a) || !self.traversable(b) {
                    return None;
                }
                Some((n, std::f64::consts::SQRT_2))
            } else {
                Some((n, 1.0))
            }
        })
    }

    /// A* from cell `a` to cell `b`; the cell sequence, or None if unreachable.
    pub fn astar(&self, a: usize, b: usize) -> Option<Vec<usize>> {
        if !self.traversable(a) || !self.traversable(b) {
            return None;
        }
        let n = self.nx * self.ny;
        let mut g = vec![f64::INFINITY; n];
        let mut parent = vec![usize::MAX; n];
        let mut closed = vec![false; n];
        let (bx, by) = ((b % self.nx) as f64, (b / self.nx) as f64);
        let h = |c: usize| {
            let dx = ((c % self.nx) as f64 - bx).abs();
            let dy = ((c / self.nx) as f64 - by).abs();
            dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy)
        };
        // Costs in micro-cells as integers: a total order, deterministic ties.
        let key = |f: f64| (f * 1e6) as u64;
        let mut open = BinaryHeap::new();
        g[a] = 0.0;
        open.push(Reverse((key(h(a)), a)));
        while let Some(Reverse((_, c))) = open.pop() {
            if closed[c] {
                continue;
            }
            if c == b {
                let mut path = vec![b];
                let mut k = b;
                while k != a {
                    k = parent[k];
                    path.push(k);
                }
                path.reverse();
                return Some(path);
            }
            closed[c] = true;
            for (m, step) in self.moves(c) {
                if closed[m] {
                    continue;
                }
                let penalty = 1.0
                    + NEAR_WALL_PENALTY_PER_M
                        * (PREFERRED_CLEARANCE_M - self.clearance[m]).max(0.0);
                let cand = g[c] + step * penalty;
                if cand < g[m] {
                    g[m] = cand;
                    parent[m] = c;
                    open.push(Reverse((key(cand + h(m)), m)));
                }
            }
        }
        None
    }

    /// A walkable route from cell `a` to cell `b`: A*, string pulling and
    /// corner cutting (at most `corner_cut_m` from each corner). Every
    /// segment of the result passes [`PlanGrid::segment_clear`].
    pub fn route(&self, a: usize, b: usize, corner_cut_m: f64) -> Option<Vec<Vec2>> {
        let cells = self.astar(a, b)?;
        let pts: Vec<Vec2> = cells.iter().map(|&c| self.centre(c)).collect();
        let pulled = self.string_pull(&pts);
        Some(self.cut_corners(&pulled, corner_cut_m))
    }

    fn string_pull(&self, pts: &[Vec2]) -> Vec<Vec2> {
        let mut out = vec![pts[0]];
        let mut i = 0;
        while i + 1 < pts.len() {
            let mut j = pts.len() - 1;
            while j > i + 1 && !self.segment_clear(pts[i], pts[j]) {
                j -= 1;
            }
            out.push(pts[j]);
            i = j;
        }
        out
    }

    fn cut_corners(&self, pts: &[Vec2], cut_m: f64) -> Vec<Vec2> {
        if pts.len() < 3 || cut_m <= 0.0 {
            return pts.to_vec();
        }
        let mut out = vec![pts[0]];
        for k in 1..pts.len() - 1 {
            let (a, p, b) = (*out.last().unwrap_or(&pts[k - 1]), pts[k], pts[k + 1]);
            let (la, lb) = ((p - a).norm(), (b - p).norm());
            if la < 1e-9 || lb < 1e-9 {
                out.push(p);
                continue;
            }
            let da = cut_m.min(0.3 * la);
            let db = cut_m.min(0.3 * lb);
            let p1 = p + (a - p) * (da / la);
            let p2 = p + (b - p) * (db / lb);
            if self.segment_clear(p1, p2) {
                out.push(p1);
                out.push(p2);
            } else {
                out.push(p);
            }
        }
        out.push(pts[pts.len() - 1]);
        out
    }
}

/// Distance from each cell centre to the nearest wall cell's edge, m, by a
/// two-pass chamfer transform (the grid's outside counts as wall).
fn clearance_transform(class: &[u8], nx: usize, ny: usize, cell_m: f64) -> Vec<f64> {
    let inf = f64::INFINITY;
    let (pw, ph) = (nx + 2, ny + 2);
    let mut d = vec![inf; pw * ph];
    for y in 0..ph {
        for x in 0..pw {
            let wall = x == 0
                || y == 0
                || x == pw - 1
                || y == ph - 1
                || class[(y - 1) * nx + (x - 1)] == WALL;
            if wall {
                d[y * pw + x] = 0.0;
            }
        }
    }
    let s2 = std::f64::consts::SQRT_2;
    for y in 1..ph - 1 {
        for x in 1..pw - 1 {
            let i = y * pw + x;
            let v = d[i]
                .min(d[i - 1] + 1.0)
                .min(d[i - pw] + 1.0)
                .min(d[i - pw - 1] + s2)
                .min(d[i - pw + 1] + s2);
            d[i] = v;
        }
    }
    for y in (1..ph - 1).rev() {
        for x in (1..pw - 1).rev() {
            let i = y * pw + x;
            let v = d[i]
                .min(d[i + 1] + 1.0)
                .min(d[i + pw] + 1.0)
                .min(d[i + pw + 1] + s2)
                .min(d[i + pw - 1] + s2);
            d[i] = v;
        }
    }
    let mut out = vec![0.0; nx * ny];
    for y in 0..ny {
        for x in 0..nx {
            // Centre-to-centre distance minus half a cell: distance to the wall cell's edge.
            let v = d[(y + 1) * pw + x + 1];
            out[y * nx + x] = ((v - 0.5) * cell_m).max(0.0);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testmap::two_rooms;

    #[test]
    fn rooms_are_separated_by_doors() {
        let map = two_rooms();
        let g = PlanGrid::build(&map, 0.1, 0.3);
        assert_eq!(g.rooms, 2, "two rooms joined by one door");
        let a = g.cell_of(Vec2::new(2.0, 3.0)).unwrap();
        let b = g.cell_of(Vec2::new(8.0, 3.0)).unwrap();
        assert_ne!(g.room_of(a), g.room_of(b));
    }

    #[test]
    fn route_goes_through_the_door_and_keeps_clear() {
        let map = two_rooms();
        let g = PlanGrid::build(&map, 0.1, 0.3);
        let a = g.cell_of(Vec2::new(2.0, 1.0)).unwrap();
        let b = g.cell_of(Vec2::new(8.0, 1.0)).unwrap();
        let r = g.route(a, b, 0.6).unwrap();
        for w in r.windows(2) {
            assert!(g.segment_clear(w[0], w[1]));
            let n = ((w[1] - w[0]).norm() / 0.01).ceil() as usize;
            for k in 0..=n {
                let p = w[0] + (w[1] - w[0]) * (k as f64 / n.max(1) as f64);
                assert_ne!(map.feature(p), Feature::Wall, "at {p:?}");
            }
        }
        // The door is at y in [2.5, 3.5] on x = 5: the route must pass there.
        let crosses = r.windows(2).any(|w| {
            let (a, b) = (w[0], w[1]);
            (a.x - 5.0) * (b.x - 5.0) <= 0.0 && {
                let t = (5.0 - a.x) / (b.x - a.x);
                let y = a.y + t * (b.y - a.y);
                (2.5..=3.5).contains(&y)
            }
        });
        assert!(crosses, "{r:?}");
    }
}
