//! After a told start: how far the walker can be from where the steps
//! alone carried the told position (`told_reach_m`). A walker
//! told where it stood (a tap on the map, `InitialPosition`) is within the
//! steps' drift of its dead-reckoned track, whatever a radio biased away
//! from the survey's routes says; re-seeding draws only from there, and
//! (`told_reach_weight`) particles beyond it lose weight at each radio
//! update. The drift is read around the wedge of the steps' displacement
//! (`told_reach_wedge`: a step length wrong alike over the walk scales the
//! displacement, a heading biased alike turns it), or around the
//! dead-reckoned point. Unless the walls say the told position was wrong:
//! then the reach is dropped.

use super::TcpfEngine;
use super::start::Surface;
use crate::Vec2;

/// The told position moved by every step since (no walls, no radio).
#[derive(Debug, Clone, Default)]
pub(super) struct ToldReach {
    /// Floor and dead-reckoned position; `None` after a global start or a
    /// floor change.
    at: Option<(i32, Vec2)>,
    /// The told position itself.
    origin: Vec2,
    /// Distance the steps walked since the told position, m.
    walked_m: f64,
}

/// The shape of the reach (`told_reach_wedge`): the dead-reckoned
/// displacement scaled by `lo` to `hi` and turned by at most `turn_rad`
/// either way, around the told position.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wedge {
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) turn_rad: f64,
}

impl Wedge {
    /// Distance from `v` to the wedge of displacement `d` (both from the
    /// told position), m.
    fn distance(&self, v: Vec2, d: Vec2) -> f64 {
        let rd = d.norm();
        if rd < 1e-9 {
            return v.norm();
        }
        let (lo, hi) = (self.lo * rd, self.hi * rd);
        let rv = v.norm();
        let phi = (d.x * v.y - d.y * v.x).atan2(d.dot(&v));
        if phi.abs() <= self.turn_rad {
            return (lo - rv).max(rv - hi).max(0.0);
        }
        let a = self.turn_rad.copysign(phi);
        let u = d / rd;
        let u = Vec2::new(u.x * a.cos() - u.y * a.sin(), u.x * a.sin() + u.y * a.cos());
        let t = v.dot(&u).clamp(lo, hi);
        (v - u * t).norm()
    }
}

/// The told reach on one floor, for one pass over particles or cells.
struct ReachOn {
    origin: Vec2,
    centre: Vec2,
    reach_m: f64,
    wedge: Option<Wedge>,
}

impl ReachOn {
    /// How far `p` lies beyond the reach, m (at most 0 within).
    fn beyond(&self, p: Vec2) -> f64 {
        let d = match self.wedge {
            Some(w) => w.distance(p - self.origin, self.centre - self.origin),
            None => (p - self.centre).norm(),
        };
        d - self.reach_m
    }
}

impl ToldReach {
    /// A told position `p` on `floor`.
    pub(super) fn restart(&mut self, floor: i32, p: Vec2) {
        self.at = Some((floor, p));
        self.origin = p;
        self.walked_m = 0.0;
    }

    /// A cloud the radio placed, or moved to another floor: no reach.
    pub(super) fn forget(&mut self) {
        self.at = None;
    }

    /// Whether a told position is held: told, and neither a global start
    /// nor the walls have dropped it since (also with the reach off).
    pub(super) fn held(&self) -> bool {
        self.at.is_some()
    }

    /// One step of `length_m` toward `yaw_rad`.
    pub(super) fn on_step(&mut self, length_m: f64, yaw_rad: f64) {
        if let Some((_, p)) = &mut self.at {
            *p += Vec2::new(yaw_rad.cos(), yaw_rad.sin()) * length_m;
            self.walked_m += length_m;
        }
    }

    /// The reach on `floor` resolved once for a pass over many points:
    /// around the dead-reckoned point, or (`wedge`) around the wedge of
    /// the dead-reckoned displacement; `None` as [`Self::reach`].
    fn on(
        &self,
        floor: i32,
        base_m: f64,
        per_walked: f64,
        wedge: Option<Wedge>,
    ) -> Option<ReachOn> {
        let (centre, reach_m) = self.reach(floor, base_m, per_walked)?;
        Some(ReachOn {
            origin: self.origin,
            centre,
            reach_m,
            wedge,
        })
    }

    /// The dead-reckoned point and the reach around it on `floor`, m:
    /// `base_m` + `per_walked` x the distance walked; `None` off
    /// (`base_m` 0), after a global start or on another floor.
    fn reach(&self, floor: i32, base_m: f64, per_walked: f64) -> Option<(Vec2, f64)> {
        match self.at {
            Some((f, p)) if f == floor && base_m > 0.0 => {
                Some((p, base_m + per_walked * self.walked_m))
            }
            _ => None,
        }
    }
}

impl TcpfEngine {
    /// The told reach on `floor`; `None` without one.
    fn told_reach_on(&self, floor: i32) -> Option<ReachOn> {
        let c = &self.cfg;
        let wedge = c.told_reach_wedge.then_some(Wedge {
            lo: c.told_reach_scale_lo,
            hi: c.told_reach_scale_hi,
            turn_rad: c.told_reach_turn_rad,
        });
        self.told_reach
            .on(floor, c.told_reach_m, c.told_reach_per_walked, wedge)
    }

    /// Zeroes the weights of `surf`'s cells on `floor` beyond the told
    /// reach, and returns the log of the largest weight kept (the best
    /// kept cell's log-likelihood less the best cell's, at most 0); `None`
    /// when no cell is within reach. Without a reach `surf` is unchanged
    /// and the result 0.
    pub(super) fn keep_within_told_reach(&self, floor: i32, surf: &mut Surface) -> Option<f64> {
        let Some(r) = self.told_reach_on(floor) else {
            return Some(0.0);
        };
        let mut best = 0.0f64;
        for (c, w) in surf.cells.iter().zip(surf.w.iter_mut()) {
            if r.beyond(*c) > 0.0 {
                *w = 0.0;
            } else {
                best = best.max(*w);
            }
        }
        (best > 0.0).then(|| best.ln())
    }

    /// Takes `told_reach_weight` x ((d - reach) / reach)^2 / 2 off the
    /// log-likelihood of each particle `d` m from the dead-reckoned point
    /// beyond the reach (a soft edge as wide as the reach itself).
    ///
    /// Once the walls say the cloud is lost (the moving share of particles
    /// a step kills at walls at least `recovery_min_wall_kill`, the level
    /// at which the walls let the surface re-seed it), the told position
    /// was wrong: the reach is dropped for good.
    pub(super) fn weigh_by_told_reach(&mut self, floor: i32, log_l: &mut [f64]) {
        if self.walls_say_lost() {
            self.told_reach.forget();
        }
        let w = self.cfg.told_reach_weight;
        if w <= 0.0 {
            return;
        }
        let Some(r) = self.told_reach_on(floor) else {
            return;
        };
        for (u, p) in log_l.iter_mut().zip(self.pf.particles()) {
            let beyond = r.beyond(*p);
            if beyond > 0.0 {
                let z = beyond / r.reach_m;
                *u -= 0.5 * w * z * z;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reach_follows_the_steps_and_grows_with_the_walk() {
        let mut r = ToldReach::default();
        assert!(r.reach(0, 3.0, 0.3).is_none(), "no told position yet");
        assert!(!r.held());
        r.restart(0, Vec2::new(1.0, 2.0));
        assert!(r.held());
        r.on_step(0.5, 0.0);
        r.on_step(0.5, std::f64::consts::FRAC_PI_2);
        let (p, reach) = r.reach(0, 3.0, 0.3).unwrap();
        assert!((p - Vec2::new(1.5, 2.5)).norm() < 1e-12, "{p:?}");
        assert!((reach - 3.3).abs() < 1e-12, "{reach}");
        assert!(r.reach(1, 3.0, 0.3).is_none(), "another floor");
        assert!(r.reach(0, 0.0, 0.3).is_none(), "off");
        assert!(r.held(), "off or on another floor, still told");
        r.forget();
        assert!(!r.held());
        r.on_step(1.0, 0.0);
        assert!(r.reach(0, 3.0, 0.3).is_none(), "forgotten");
    }

    #[test]
    fn the_wedge_is_the_displacement_scaled_and_turned() {
        let w = Wedge {
            lo: 0.8,
            hi: 1.4,
            turn_rad: 0.2,
        };
        let d = Vec2::new(10.0, 0.0);
        let at = |x: f64, y: f64| w.distance(Vec2::new(x, y), d);
        assert_eq!(at(10.0, 0.0), 0.0);
        assert!(
            (at(5.0, 0.0) - 3.0).abs() < 1e-12,
            "short of the shortest scale"
        );
        assert!((at(16.0, 0.0) - 2.0).abs() < 1e-12, "beyond the longest");
        assert_eq!(at(10.0, 1.0), 0.0, "turned by less than the turn");
        // turned by more: the distance to the wedge's edge
        let want = (5.0 * 0.2f64.cos() - 10.0 * 0.2f64.sin()).abs();
        assert!((at(10.0, 5.0) - want).abs() < 1e-12, "{}", at(10.0, 5.0));
        assert!((at(10.0, -5.0) - want).abs() < 1e-12);
        // no displacement: the told position itself
        assert_eq!(w.distance(Vec2::new(3.0, 4.0), Vec2::zeros()), 5.0);
    }
}
