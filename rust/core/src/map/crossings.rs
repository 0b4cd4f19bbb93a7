//! How many walls and doors a straight line crosses on the plan: the
//! wall count of a multi-wall radio propagation model
//! ([`crate::radio::wall_prior`]).
//!
//! The line is clipped to the image and every pixel it passes through is
//! visited in order (Amanatides and Woo's grid traversal), so a wall one
//! pixel thick is never stepped over, diagonal ones included. Each maximal
//! run of obstacle pixels along the line is one crossing: a wall when the
//! run holds a Wall pixel, else a door. A run that holds the first or the
//! last pixel is not counted (a transmitter mounted on a wall, a phone on
//! a plan's boundary line), and the outside of the image counts as open.
//! The cost is one lookup per pixel passed: at most width + height + 2.

use super::{Feature, FloorMap};
use crate::Vec2;

/// Walls and doors crossed by a straight line (module doc).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Crossings {
    pub walls: u32,
    pub doors: u32,
}

impl FloorMap {
    /// The walls and doors the segment `a` -> `b` crosses (module doc);
    /// none for a segment off the image or with a non-finite end.
    pub fn crossings(&self, a: Vec2, b: Vec2) -> Crossings {
        let mut out = Crossings::default();
        let (q0, q1) = (self.mcs_to_ics(a), self.mcs_to_ics(b));
        let d = q1 - q0;
        if !(q0.x.is_finite() && q0.y.is_finite() && q1.x.is_finite() && q1.y.is_finite()) {
            return out;
        }
        // clip to [0, W] x [0, H] (Liang-Barsky)
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-d.x, q0.x),
            (d.x, self.width_f - q0.x),
            (-d.y, q0.y),
            (d.y, self.height_f - q0.y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return out;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if t0 > t1 {
            return out;
        }
        let (s, e) = (q0 + d * t0, q0 + d * t1);
        let (w, h) = (self.width_px as i64, self.height_px as i64);
        let cell = |v: f64, n: i64| (v.floor() as i64).clamp(0, n - 1);
        let (mut i, mut j) = (cell(s.x, w), cell(s.y, h));
        let (ie, je) = (cell(e.x, w), cell(e.y, h));
        let steps = (ie - i).abs() + (je - j).abs();
        let (si, sj) = (d.x.signum() as i64, d.y.signum() as i64);
        let next = |v: f64, c: i64, dv: f64| {
            if dv > 0.0 {
                (c as f64 + 1.0 - v) / dv
            } else if dv < 0.0 {
                (v - c as f64) / -dv
            } else {
                f64::INFINITY
            }
        };
        let de = e - s;
        let (mut tx, mut ty) = (next(s.x, i, de.x), next(s.y, j, de.y));
        let (dtx, dty) = (
            if de.x != 0.0 {
                1.0 / de.x.abs()
            } else {
                f64::INFINITY
            },
            if de.y != 0.0 {
                1.0 / de.y.abs()
            } else {
                f64::INFINITY
            },
        );
        let feature = |i: i64, j: i64| self.features[j as usize * self.width_px + i as usize];
        // the run in progress: (has a Wall pixel, started at the first pixel)
        let mut run: Option<(bool, bool)> = match feature(i, j) {
            Feature::Walkable => None,
            f => Some((f == Feature::Wall, true)),
        };
        for _ in 0..steps {
            if tx < ty {
                i += si;
                tx += dtx;
            } else {
                j += sj;
                ty += dty;
            }
            // rounding may step past the last pixel: stay on the image
            if !(0..w).contains(&i) || !(0..h).contains(&j) {
                break;
            }
            match (feature(i, j), run.as_mut()) {
                (Feature::Walkable, Some((wall, at_start))) => {
                    if !*at_start {
                        if *wall {
                            out.walls += 1;
                        } else {
                            out.doors += 1;
                        }
                    }
                    run = None;
                }
                (Feature::Walkable, None) => {}
                (f, Some((wall, _))) => *wall |= f == Feature::Wall,
                (f, None) => run = Some((f == Feature::Wall, false)),
            }
        }
        // a run still open holds the last pixel: not counted
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w` x `h` px plan at `r` px/m with the feature of pixel (i, j).
    fn test_plan(w: usize, h: usize, r: f64, f: impl Fn(usize, usize) -> Feature) -> FloorMap {
        let features = (0..w * h).map(|k| f(k % w, k / w)).collect();
        FloorMap::from_features(w, h, r, features)
    }

    /// A 20 x 10 m plan at 10 px/m, open, with `lines` drawn: (x in metres,
    /// feature), vertical lines one pixel wide.
    fn plan(lines: &[(f64, Feature)]) -> FloorMap {
        test_plan(200, 100, 10.0, |i, _j| {
            lines
                .iter()
                .find(|(x, _)| (x * 10.0) as usize == i)
                .map_or(Feature::Walkable, |(_, f)| *f)
        })
    }

    #[test]
    fn counts_each_wall_and_door_run_once() {
        let m = plan(&[
            (5.0, Feature::Wall),
            (8.0, Feature::Door),
            (12.0, Feature::Wall),
        ]);
        let c = m.crossings(Vec2::new(1.0, 5.0), Vec2::new(19.0, 5.0));
        assert_eq!(c, Crossings { walls: 2, doors: 1 });
        // the other way, and a steep diagonal through the same lines
        assert_eq!(m.crossings(Vec2::new(19.0, 5.0), Vec2::new(1.0, 5.0)), c);
        assert_eq!(m.crossings(Vec2::new(1.0, 0.5), Vec2::new(19.0, 9.5)), c);
        // short of the second wall
        let c = m.crossings(Vec2::new(1.0, 5.0), Vec2::new(10.0, 7.0));
        assert_eq!(c, Crossings { walls: 1, doors: 1 });
    }

    #[test]
    fn a_diagonal_wall_one_pixel_wide_is_not_stepped_over() {
        // the 8-connected diagonal i == j
        let m = test_plan(100, 100, 10.0, |i, j| {
            if i == j {
                Feature::Wall
            } else {
                Feature::Walkable
            }
        });
        for k in 0..40 {
            let off = 0.013 * f64::from(k);
            let c = m.crossings(Vec2::new(1.0 + off, 2.0), Vec2::new(8.0, 9.0 - off));
            assert_eq!(c.walls, 1, "ray {k}");
        }
    }

    #[test]
    fn end_runs_and_the_outside_do_not_count() {
        let m = plan(&[(5.0, Feature::Wall)]);
        // a transmitter on the wall, a phone on it
        assert_eq!(
            m.crossings(Vec2::new(5.05, 5.0), Vec2::new(15.0, 5.0))
                .walls,
            0
        );
        assert_eq!(
            m.crossings(Vec2::new(1.0, 5.0), Vec2::new(5.05, 5.0)).walls,
            0
        );
        // off the image, across it from outside, non-finite ends
        assert_eq!(
            m.crossings(Vec2::new(-5.0, 50.0), Vec2::new(30.0, 50.0)),
            Crossings::default()
        );
        assert_eq!(
            m.crossings(Vec2::new(-50.0, 5.0), Vec2::new(1e9, 5.0))
                .walls,
            1
        );
        assert_eq!(
            m.crossings(Vec2::new(f64::NAN, 5.0), Vec2::new(9.0, 5.0)),
            Crossings::default()
        );
        assert_eq!(
            m.crossings(Vec2::new(3.0, 5.0), Vec2::new(3.0, 5.0)),
            Crossings::default()
        );
    }
}
