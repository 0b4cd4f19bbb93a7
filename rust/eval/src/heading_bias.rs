//! A site's heading bias, measured on survey walks with truth: the angle
//! that turns the PDR track's displacement onto the truth's between
//! consecutive truth points (`SiteSpec::heading_bias_rad`).
//!
//! A phone's heading is magnetic; a plan is drawn to true north or to no
//! north at all, and a building's steel turns the field. Each walk's PDR is
//! then turned by a few degrees against the plan, the same way for every
//! phone in that building (ILC site1/F1 even paths: -4 deg, per path sd
//! 11 deg; IPIN even logs: -4 deg). Every engine's PDR starts from that
//! error; the filters' per-particle heading offsets only learn it while
//! the radio holds them.

use fpbp_core::Vec2;
use fpbp_core::engine::replay::ScoredPoint;
use fpbp_core::geometry::wrap_angle;

/// Shortest truth displacement a segment needs, metres: below it the
/// truth's own quantisation and a step or two of PDR noise turn the angle.
pub const MIN_SEGMENT_M: f64 = 3.0;

/// Segments turned further than this from the first estimate are left
/// out (a turn between two truth points the PDR took late, a step burst),
/// radians (45 deg).
pub const MAX_RESIDUAL_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Fewest segments a bias is reported from.
pub const MIN_SEGMENTS: usize = 10;

/// Standard errors a bias must stand from 0 to be applied
/// ([`HeadingBias::significant`]).
pub const SIGNIFICANT_SE: f64 = 2.0;

/// One displacement between consecutive truth points, and the PDR's over
/// the same time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadingSegment {
    pub truth: Vec2,
    pub pdr: Vec2,
}

impl HeadingSegment {
    /// Counter-clockwise angle from the PDR displacement to the truth's.
    pub fn angle_rad(&self) -> f64 {
        let (t, p) = (self.truth, self.pdr);
        (p.x * t.y - p.y * t.x).atan2(p.x * t.x + p.y * t.y)
    }
}

/// What [`heading_bias`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadingBias {
    /// Angle to add to the PDR heading, radians, counter-clockwise.
    pub rad: f64,
    /// Segments used (after the residual cut).
    pub segments: usize,
    /// Segments left out by [`MAX_RESIDUAL_RAD`].
    pub left_out: usize,
    /// Length-weighted RMS of the used segments' angles about `rad`.
    pub sd_rad: f64,
}

impl HeadingBias {
    /// Standard error of `rad`: `sd_rad` over the root of the segments
    /// (optimistic: segments of one walk share its phone's own offset).
    pub fn se_rad(&self) -> f64 {
        self.sd_rad / (self.segments as f64).sqrt()
    }

    /// Whether the bias stands out of its noise: more than
    /// [`SIGNIFICANT_SE`] standard errors from 0. A site whose bias does
    /// not keep the one it had (ILC F4 even: -0.7 deg at 2.0 deg standard
    /// error; IPIN even -0.1 at 1.1; ILC F1 even +3.7 at 0.9 is kept).
    pub fn significant(&self) -> bool {
        self.rad.abs() > SIGNIFICANT_SE * self.se_rad()
    }
}

/// Segments of one replay of a PDR-only engine started at the truth: from
/// each truth point to the next one at least [`MIN_SEGMENT_M`] from it
/// (consecutive waypoints on ILC, a few metres of a dense truth track
/// elsewhere), both on one floor with an estimate on that floor; a floor
/// change or a missing estimate starts a new chain.
pub fn segments(scored: &[ScoredPoint]) -> Vec<HeadingSegment> {
    let mut out = Vec::new();
    let mut from: Option<&ScoredPoint> = None;
    for b in scored {
        let Some(eb) = b.estimate else {
            from = None;
            continue;
        };
        let Some(a) = from.filter(|a| {
            a.truth.floor == b.truth.floor && a.estimate.is_some_and(|e| e.floor == eb.floor)
        }) else {
            from = Some(b);
            continue;
        };
        let ea = a.estimate.expect("chains start at points with an estimate");
        let truth = Vec2::new(b.truth.x_m - a.truth.x_m, b.truth.y_m - a.truth.y_m);
        if truth.norm() < MIN_SEGMENT_M {
            continue;
        }
        let pdr = Vec2::new(eb.x_m - ea.x_m, eb.y_m - ea.y_m);
        if pdr.norm() > 0.0 {
            out.push(HeadingSegment { truth, pdr });
        }
        from = Some(b);
    }
    out
}

/// The truth-length-weighted circular mean of the segments' angles, once
/// over all of them and again over those within [`MAX_RESIDUAL_RAD`] of
/// the first mean. `None` with fewer than [`MIN_SEGMENTS`] left.
pub fn heading_bias(segs: &[HeadingSegment]) -> Option<HeadingBias> {
    let mean = |keep: &dyn Fn(f64) -> bool| {
        let (mut s, mut c, mut n) = (0.0, 0.0, 0);
        for g in segs {
            let a = g.angle_rad();
            if keep(a) {
                let w = g.truth.norm();
                s += w * a.sin();
                c += w * a.cos();
                n += 1;
            }
        }
        (n > 0 && (s != 0.0 || c != 0.0)).then(|| (s.atan2(c), n))
    };
    let (first, _) = mean(&|_| true)?;
    let near = |a: f64| wrap_angle(a - first).abs() <= MAX_RESIDUAL_RAD;
    let (rad, used) = mean(&near)?;
    if used < MIN_SEGMENTS {
        return None;
    }
    let (mut ss, mut ws) = (0.0, 0.0);
    for g in segs.iter().filter(|g| near(g.angle_rad())) {
        let w = g.truth.norm();
        ss += w * wrap_angle(g.angle_rad() - rad).powi(2);
        ws += w;
    }
    Some(HeadingBias {
        rad,
        segments: used,
        left_out: segs.len() - used,
        sd_rad: (ss / ws).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::engine::{Pose, PoseSource};
    use fpbp_core::events::TruthPoint;
    use fpbp_core::geometry::rotate;

    /// Segments of a square-ish walk whose PDR is turned by `-bias` (so
    /// `bias` turns it back), with a deterministic +-`jitter` per segment.
    fn walk(bias: f64, jitter: f64, n: usize) -> Vec<HeadingSegment> {
        (0..n)
            .map(|k| {
                let truth = rotate(Vec2::new(4.0 + (k % 3) as f64, 0.0), 0.7 * k as f64);
                let j = if k % 2 == 0 { jitter } else { -jitter };
                HeadingSegment {
                    truth,
                    pdr: rotate(truth, -bias + j) * 0.9,
                }
            })
            .collect()
    }

    #[test]
    fn finds_the_turn_of_the_pdr() {
        let b = heading_bias(&walk(0.07, 0.0, 20)).unwrap();
        assert!((b.rad - 0.07).abs() < 1e-12, "{b:?}");
        assert_eq!((b.segments, b.left_out), (20, 0));
        assert!(b.sd_rad < 1e-12);
        let b = heading_bias(&walk(-0.3, 0.1, 20)).unwrap();
        assert!((b.rad + 0.3).abs() < 0.01, "{b:?}");
        assert!((b.sd_rad - 0.1).abs() < 0.01, "{b:?}");
        assert!((b.se_rad() - b.sd_rad / 20f64.sqrt()).abs() < 1e-15);
        assert!(b.significant());
    }

    #[test]
    fn a_bias_within_its_noise_is_not_significant() {
        // +-0.2 rad per segment about 0.05: se 0.045, 0.05 < 2 se
        let b = heading_bias(&walk(0.05, 0.2, 20)).unwrap();
        assert!((b.rad - 0.05).abs() < 0.01, "{b:?}");
        assert!(!b.significant(), "{b:?}");
        let b = heading_bias(&walk(0.05, 0.02, 20)).unwrap();
        assert!(b.significant(), "{b:?}");
    }

    #[test]
    fn a_late_turn_is_left_out() {
        let mut s = walk(0.05, 0.0, 20);
        // the PDR took a 90-degree turn one segment late
        s.push(HeadingSegment {
            truth: Vec2::new(5.0, 0.0),
            pdr: Vec2::new(0.0, -5.0),
        });
        let b = heading_bias(&s).unwrap();
        assert!((b.rad - 0.05).abs() < 1e-12, "{b:?}");
        assert_eq!(b.left_out, 1);
    }

    #[test]
    fn too_few_segments_give_nothing() {
        assert_eq!(heading_bias(&walk(0.1, 0.0, MIN_SEGMENTS - 1)), None);
        assert!(heading_bias(&walk(0.1, 0.0, MIN_SEGMENTS)).is_some());
        assert_eq!(heading_bias(&[]), None);
    }

    #[test]
    fn angles_wrap_across_pi() {
        let b = heading_bias(&walk(3.1, 0.05, 20)).unwrap();
        assert!(wrap_angle(b.rad - 3.1).abs() < 0.01, "{b:?}");
    }

    #[test]
    fn segments_join_short_moves_and_break_at_floor_changes_and_missing_poses() {
        let pt = |t: i64, x: f64, y: f64, floor: i32, est: Option<(f64, f64)>| ScoredPoint {
            truth: TruthPoint {
                t_ns: t,
                x_m: x,
                y_m: y,
                floor: Some(floor),
            },
            estimate: est.map(|(ex, ey)| Pose {
                t_ns: t,
                x_m: ex,
                y_m: ey,
                floor,
                heading_rad: 0.0,
                accuracy_m: 1.0,
                floor_prob: 1.0,
                source: PoseSource::DeadReckoning,
            }),
        };
        let scored = [
            pt(0, 0.0, 0.0, 0, Some((0.0, 0.0))),
            pt(1, 5.0, 0.0, 0, Some((4.0, 1.0))),
            pt(2, 6.0, 0.0, 0, Some((5.0, 1.0))), // 1 m on: the chain goes on
            pt(3, 9.0, 0.0, 0, Some((8.0, 1.0))), // 4 m from point 1
            pt(4, 9.0, 5.0, 1, Some((8.0, 6.0))), // floor change: a new chain
            pt(5, 9.0, 10.0, 1, None),            // no estimate: a new chain
            pt(6, 9.0, 15.0, 1, Some((8.0, 15.0))),
            pt(7, 9.0, 20.0, 1, Some((7.0, 20.0))),
        ];
        let seg = |t: (f64, f64), p: (f64, f64)| HeadingSegment {
            truth: Vec2::new(t.0, t.1),
            pdr: Vec2::new(p.0, p.1),
        };
        assert_eq!(
            segments(&scored),
            vec![
                seg((5.0, 0.0), (4.0, 1.0)),
                seg((4.0, 0.0), (4.0, 0.0)),
                seg((0.0, 5.0), (-1.0, 5.0)),
            ]
        );
    }
}
