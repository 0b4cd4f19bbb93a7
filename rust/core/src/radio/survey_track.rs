//! The survey walker's position between two truth points, shaped by the
//! walk's own PDR instead of a straight line at constant speed.
//!
//! Survey truth is sparse (ILC waypoints ~6 s apart, IPIN points up to
//! ~20 s apart) and walkers pause, speed up and turn between them. The
//! readings of a survey are placed by interpolating the truth
//! ([`super::survey`]); with a straight line at constant speed a reading
//! taken during a pause at a waypoint lands metres down the corridor. The
//! PDR track of the same walk knows when the walker stood and where it
//! turned, but drifts. So between two truth points the PDR displacement is
//! mapped onto the truth's by a similarity (one rotation and one scale per
//! segment, which removes the drift), and the PDR's intermediate positions,
//! mapped the same way, become extra truth points. A segment whose PDR
//! disagrees with the truth too much (a missed turn, steps not detected)
//! keeps the straight line.
//!
//! Pure: takes the truth and the PDR track, returns the denser truth.

use crate::Vec2;
use crate::events::{LogEvent, TruthPoint};
use crate::geometry::{rotate, wrap_angle};

/// When a segment takes the PDR's shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeLimits {
    /// Shortest truth displacement shaped, metres (below it a pause and a
    /// metre of PDR noise are indistinguishable).
    pub min_truth_m: f64,
    /// Shortest PDR displacement shaped, metres.
    pub min_pdr_m: f64,
    /// Largest ratio (either way) of truth to PDR length.
    pub max_scale_ratio: f64,
    /// Largest turn from the PDR displacement to the truth's, radians.
    pub max_turn_rad: f64,
    /// No shaping across truth points further apart than this, ns.
    pub max_gap_ns: i64,
}

impl Default for ShapeLimits {
    fn default() -> Self {
        ShapeLimits {
            min_truth_m: 1.0,
            min_pdr_m: 0.5,
            max_scale_ratio: 2.0,
            max_turn_rad: 60f64.to_radians(),
            max_gap_ns: 30_000_000_000,
        }
    }
}

/// What [`pdr_shaped_truth`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShapeCounts {
    /// Consecutive truth pairs on one floor within `max_gap_ns`.
    pub segments: usize,
    /// Of those, shaped by the PDR.
    pub shaped: usize,
    /// Truth points added.
    pub added: usize,
}

impl std::ops::AddAssign for ShapeCounts {
    /// Field by field (the counts of several logs).
    fn add_assign(&mut self, o: ShapeCounts) {
        self.segments += o.segments;
        self.shaped += o.shaped;
        self.added += o.added;
    }
}

/// The PDR track's position at `t_ns` (linear between its samples; the
/// track is time-sorted), if `t_ns` lies within it.
fn track_at(track: &[(i64, Vec2)], t_ns: i64) -> Option<Vec2> {
    let i = track.partition_point(|(t, _)| *t <= t_ns);
    let (ta, pa) = *track.get(i.checked_sub(1)?)?;
    if ta == t_ns {
        return Some(pa);
    }
    let (tb, pb) = *track.get(i)?;
    let f = (t_ns - ta) as f64 / (tb - ta) as f64;
    Some(pa + (pb - pa) * f)
}

/// `events` (time-ordered) with their truth points replaced by `truth`
/// (time-sorted, e.g. [`pdr_shaped_truth`]'s), merged in time order (a
/// truth point goes before the other events of its time).
pub fn with_truth(events: Vec<LogEvent>, truth: Vec<TruthPoint>) -> Vec<LogEvent> {
    let mut out = Vec::with_capacity(events.len() + truth.len());
    let mut truth = truth.into_iter().peekable();
    for e in events {
        if matches!(e, LogEvent::Truth(_)) {
            continue;
        }
        let t = e.t_ns();
        while let Some(p) = truth.next_if(|p| p.t_ns <= t) {
            out.push(LogEvent::Truth(p));
        }
        out.push(e);
    }
    out.extend(truth.map(LogEvent::Truth));
    out
}

/// `truth` (time-sorted) with extra points between consecutive ones, at
/// the PDR `track`'s samples, where the segment takes the PDR's shape
/// ([`ShapeLimits`]); the input points are all kept.
pub fn pdr_shaped_truth(
    truth: &[TruthPoint],
    track: &[(i64, Vec2)],
    limits: &ShapeLimits,
) -> (Vec<TruthPoint>, ShapeCounts) {
    let mut out = Vec::with_capacity(truth.len());
    let mut counts = ShapeCounts::default();
    for (i, a) in truth.iter().enumerate() {
        out.push(*a);
        let Some(b) = truth.get(i + 1) else { break };
        if a.floor != b.floor || b.t_ns <= a.t_ns || b.t_ns - a.t_ns > limits.max_gap_ns {
            continue;
        }
        counts.segments += 1;
        let (Some(pa), Some(pb)) = (track_at(track, a.t_ns), track_at(track, b.t_ns)) else {
            continue;
        };
        let ta = Vec2::new(a.x_m, a.y_m);
        let e = Vec2::new(b.x_m, b.y_m) - ta;
        let d = pb - pa;
        let (le, ld) = (e.norm(), d.norm());
        if !(le >= limits.min_truth_m && ld >= limits.min_pdr_m) {
            continue;
        }
        let scale = le / ld;
        let turn = wrap_angle(e.y.atan2(e.x) - d.y.atan2(d.x));
        if scale > limits.max_scale_ratio
            || scale < 1.0 / limits.max_scale_ratio
            || turn.abs() > limits.max_turn_rad
        {
            continue;
        }
        counts.shaped += 1;
        let from = track.partition_point(|(t, _)| *t <= a.t_ns);
        for &(t, p) in &track[from..] {
            if t >= b.t_ns {
                break;
            }
            let q = ta + rotate(p - pa, turn) * scale;
            out.push(TruthPoint {
                t_ns: t,
                x_m: q.x,
                y_m: q.y,
                floor: a.floor,
            });
            counts.added += 1;
        }
    }
    (out, counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tp(t_s: f64, x: f64, y: f64) -> TruthPoint {
        TruthPoint {
            t_ns: (t_s * 1e9) as i64,
            x_m: x,
            y_m: y,
            floor: Some(1),
        }
    }

    fn at(pts: &[TruthPoint], t_s: f64) -> Vec2 {
        let p = pts
            .iter()
            .find(|p| p.t_ns == (t_s * 1e9) as i64)
            .expect("point");
        Vec2::new(p.x_m, p.y_m)
    }

    #[test]
    fn a_pause_and_a_turn_follow_the_pdr_with_its_drift_removed() {
        // truth: (0,0) at 0 s, (10,10) at 10 s; the walker stood for 4 s,
        // then went 10 m east and 10 m north. The PDR saw the same walk
        // turned by 10 degrees and 20 % short.
        let truth = [tp(0.0, 0.0, 0.0), tp(10.0, 10.0, 10.0)];
        let walk = |t: f64| -> Vec2 {
            if t <= 4.0 {
                Vec2::zeros()
            } else if t <= 7.0 {
                Vec2::new(10.0 * (t - 4.0) / 3.0, 0.0)
            } else {
                Vec2::new(10.0, 10.0 * (t - 7.0) / 3.0)
            }
        };
        let track: Vec<(i64, Vec2)> = (0..=10)
            .map(|s| {
                let t = s as f64;
                (
                    (t * 1e9) as i64,
                    rotate(walk(t), 0.17) * 0.8 + Vec2::new(3.0, -2.0),
                )
            })
            .collect();
        let (out, c) = pdr_shaped_truth(&truth, &track, &ShapeLimits::default());
        assert_eq!((c.segments, c.shaped, c.added), (1, 1, 9));
        assert_eq!(out.len(), 11);
        assert!(out.windows(2).all(|w| w[0].t_ns < w[1].t_ns));
        for s in 1..10 {
            let t = s as f64;
            assert!((at(&out, t) - walk(t)).norm() < 1e-9, "at {t} s");
        }
        // the straight line would have put the pause's end at (4, 4)
        assert!((at(&out, 4.0) - Vec2::zeros()).norm() < 1e-9);
    }

    #[test]
    fn a_pdr_that_disagrees_keeps_the_straight_line() {
        let truth = [tp(0.0, 0.0, 0.0), tp(10.0, 10.0, 0.0)];
        let line = |k: f64| -> Vec<(i64, Vec2)> {
            (0..=10)
                .map(|s| ((s as f64 * 1e9) as i64, Vec2::new(0.0, k * s as f64)))
                .collect()
        };
        // turned 90 degrees
        let (out, c) = pdr_shaped_truth(&truth, &line(1.0), &ShapeLimits::default());
        assert_eq!((c.segments, c.shaped, out.len()), (1, 0, 2));
        // no steps detected
        let (out, c) = pdr_shaped_truth(&truth, &line(0.0), &ShapeLimits::default());
        assert_eq!((c.shaped, out.len()), (0, 2));
    }

    #[test]
    fn floor_changes_gaps_and_a_short_track_are_left_alone() {
        let mut b = tp(10.0, 10.0, 0.0);
        b.floor = Some(2);
        let track: Vec<(i64, Vec2)> = (0..=30)
            .map(|s| ((s as f64 * 1e9) as i64, Vec2::new(s as f64, 0.0)))
            .collect();
        let (out, c) = pdr_shaped_truth(&[tp(0.0, 0.0, 0.0), b], &track, &ShapeLimits::default());
        assert_eq!((c.segments, out.len()), (0, 2));
        let limits = ShapeLimits {
            max_gap_ns: 5_000_000_000,
            ..Default::default()
        };
        let (out, c) = pdr_shaped_truth(&[tp(0.0, 0.0, 0.0), tp(10.0, 10.0, 0.0)], &track, &limits);
        assert_eq!((c.segments, out.len()), (0, 2));
        // the truth outlasts the track
        let (out, c) = pdr_shaped_truth(
            &[tp(20.0, 0.0, 0.0), tp(40.0, 20.0, 0.0)],
            &track,
            &ShapeLimits::default(),
        );
        assert_eq!((c.segments, c.shaped, out.len()), (1, 0, 2));
    }

    #[test]
    fn counts_add_field_by_field() {
        let mut c = ShapeCounts {
            segments: 3,
            shaped: 2,
            added: 10,
        };
        c += ShapeCounts {
            segments: 4,
            shaped: 1,
            added: 5,
        };
        assert_eq!(
            c,
            ShapeCounts {
                segments: 7,
                shaped: 3,
                added: 15
            }
        );
    }
}
