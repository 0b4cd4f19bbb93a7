//! The published track against the walls: the one segment check that
//! `fpbp eval` counts as a wall crossing and that engines use before they
//! publish a point ([`FloorMap::track_crosses_wall`]), and a walk of a
//! point toward another through the doors ([`FloorMap::walk_toward`]) for
//! an engine whose estimate has moved behind a wall.

use std::collections::VecDeque;

use super::{Feature, FloorMap};
use crate::Vec2;

/// Sampling step of [`FloorMap::track_crosses_wall`], metres.
pub const TRACK_WALL_STEP_M: f64 = 0.05;

/// Most lattice nodes one [`FloorMap::walk_toward`] search holds (the
/// lattice spacing grows to stay within it): bounds its time and memory.
pub const WALK_MAX_NODES: usize = 40_000;

/// A node of the search not reached yet.
const UNSEEN: u32 = u32::MAX;

/// One move of [`FloorMap::walk_toward`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WalkStep {
    /// Where the walk goes next: `from` reaches it in a straight line
    /// without crossing a Wall.
    pub next: Vec2,
    /// Whether the walk's path ends at the target (false: the map has no
    /// way there within the search; `next` heads to the node nearest it).
    pub reaches: bool,
}

impl FloorMap {
    /// Whether the straight segment between two consecutive published
    /// points crosses a Wall: [`FloorMap::crosses_wall`] sampled every
    /// [`TRACK_WALL_STEP_M`]. `fpbp eval` counts exactly these segments as
    /// wall crossings.
    pub fn track_crosses_wall(&self, from: Vec2, to: Vec2) -> bool {
        self.crosses_wall(from, to, TRACK_WALL_STEP_M)
    }

    /// The next point of a walk from `from` toward `to` that never crosses
    /// a Wall: a breadth-first search over a square lattice of spacing
    /// `spacing_m` anchored at `from` (nodes off every Wall; moves between
    /// 8-neighbours that do not cross a Wall by
    /// [`FloorMap::track_crosses_wall`]), over the box of the two points
    /// widened by `margin_m`; on the shortest lattice path to `to` (or, when
    /// none reaches it, to the node nearest `to`), the farthest node that
    /// `from` reaches in a straight line without crossing a Wall (`to`
    /// itself when it is the end of that path and in reach).
    ///
    /// `None` when `from` lies on a Wall or no move brings it nearer `to`.
    /// The segment from `from` to the returned point never crosses a Wall.
    /// Deterministic; at most [`WALK_MAX_NODES`] nodes.
    pub fn walk_toward(
        &self,
        from: Vec2,
        to: Vec2,
        spacing_m: f64,
        margin_m: f64,
    ) -> Option<WalkStep> {
        let finite = |p: Vec2| p.x.is_finite() && p.y.is_finite();
        if !(finite(from) && finite(to) && spacing_m > 0.0 && margin_m >= 0.0)
            || self.feature(from) == Feature::Wall
        {
            return None;
        }
        let lo = from.inf(&to) - Vec2::new(margin_m, margin_m);
        let hi = from.sup(&to) + Vec2::new(margin_m, margin_m);
        let span = hi - lo;
        // nodes ~ (span.x / h + 1) (span.y / h + 1) <= WALK_MAX_NODES
        let h_min = (span.x * span.y / WALK_MAX_NODES as f64).sqrt() * 1.2;
        let h = spacing_m.max(h_min).max(1e-3);
        let i0 = ((lo.x - from.x) / h).floor() as i64;
        let j0 = ((lo.y - from.y) / h).floor() as i64;
        let w = (((hi.x - from.x) / h).ceil() as i64 - i0 + 1).max(1);
        let hgt = (((hi.y - from.y) / h).ceil() as i64 - j0 + 1).max(1);
        let n = w.checked_mul(hgt)?;
        if n <= 0 || n as usize > 4 * WALK_MAX_NODES {
            return None;
        }
        let n = n as usize;
        let pos = |k: usize| {
            let (i, j) = ((k as i64 % w) + i0, (k as i64 / w) + j0);
            from + Vec2::new(i as f64 * h, j as f64 * h)
        };
        // `from` is lattice node (0, 0)
        let start = ((-j0) * w + (-i0)) as usize;
        let mut parent = vec![UNSEEN; n];
        parent[start] = start as u32;
        let mut queue = VecDeque::from([start]);
        let (mut best, mut best_d) = (start, (from - to).norm());
        let mut goal = None;
        while let Some(k) = queue.pop_front() {
            let p = pos(k);
            let d = (p - to).norm();
            if d < best_d {
                (best, best_d) = (k, d);
            }
            if d <= 1.5 * h && !self.track_crosses_wall(p, to) {
                goal = Some(k);
                break;
            }
            let (i, j) = (k as i64 % w, k as i64 / w);
            for (di, dj) in [
                (1, 0),
                (-1, 0),
                (0, 1),
                (0, -1),
                (1, 1),
                (-1, 1),
                (1, -1),
                (-1, -1),
            ] {
                let (a, b) = (i + di, j + dj);
                if a < 0 || b < 0 || a >= w || b >= hgt {
                    continue;
                }
                let m = (b * w + a) as usize;
                if parent[m] != UNSEEN {
                    continue;
                }
                let q = pos(m);
                if self.feature(q) == Feature::Wall || self.track_crosses_wall(p, q) {
                    continue;
                }
                parent[m] = k as u32;
                queue.push_back(m);
            }
        }
        let end = goal.unwrap_or(best);
        if end == start && goal.is_none() {
            return None;
        }
        let mut path = Vec::new();
        if goal.is_some() {
            path.push(to);
        }
        let mut k = end;
        while k != start {
            path.push(pos(k));
            k = parent[k] as usize;
        }
        // path runs from the end back to `from`'s neighbour: the first
        // point `from` reaches is the farthest along the path
        let next = path
            .into_iter()
            .find(|q| !self.track_crosses_wall(from, *q))?;
        Some(WalkStep {
            next,
            reaches: goal.is_some(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 20 x 10 m at 10 px/m: a wall at x = 10 m with a door (`door`) at
    /// y in [7, 8) m.
    fn two_rooms(door: bool) -> FloorMap {
        let (w, h, r) = (200usize, 100usize, 10.0);
        let mut f = vec![Feature::Walkable; w * h];
        for j in 0..h {
            for i in 0..w {
                let edge = i == 0 || j == 0 || i == w - 1 || j == h - 1;
                let y = (h - j) as f64 / r;
                let wall = (100..102).contains(&i) && !(door && (7.0..8.0).contains(&y));
                if edge || wall {
                    f[j * w + i] = Feature::Wall;
                }
            }
        }
        FloorMap::from_features(w, h, r, f)
    }

    #[test]
    fn walks_through_the_door_without_crossing_the_wall() {
        let m = two_rooms(true);
        let (a, b) = (Vec2::new(5.0, 2.0), Vec2::new(15.0, 2.0));
        assert!(m.track_crosses_wall(a, b));
        let mut p = a;
        let mut steps = 0;
        while (p - b).norm() > 1e-9 {
            let w = m.walk_toward(p, b, 0.25, 5.0).expect("a path");
            assert!(w.reaches);
            let q = w.next;
            assert!(!m.track_crosses_wall(p, q), "{p:?} -> {q:?}");
            assert!((q - b).norm() < (p - b).norm());
            p = q;
            steps += 1;
            assert!(steps < 10, "stuck at {p:?}");
        }
        // the walk passed the door
        assert!(steps >= 2);
    }

    #[test]
    fn without_a_door_it_gets_as_near_as_the_walls_allow() {
        let m = two_rooms(false);
        let (a, b) = (Vec2::new(5.0, 2.0), Vec2::new(15.0, 2.0));
        let w = m.walk_toward(a, b, 0.25, 5.0).expect("a move");
        assert!(!w.reaches);
        let q = w.next;
        assert!(!m.track_crosses_wall(a, q));
        assert!(q.x > 9.0 && q.x < 10.0, "{q:?}");
        // from there no move brings it nearer
        assert!(
            m.walk_toward(q, b, 0.25, 5.0)
                .is_none_or(|r| (r.next - b).norm() < (q - b).norm())
        );
        // on a wall: no walk
        assert!(m.walk_toward(Vec2::new(10.05, 2.0), b, 0.25, 5.0).is_none());
    }
}
