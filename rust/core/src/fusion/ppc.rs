//! Post-position correction, FP-BP Sec. IV-D and Algorithm 2.
//!
//! Given the previous output position x^(k-1) and the filter's estimate x̂,
//! [`correct`] raycasts from x^(k-1) to x̂ (Function 1). Without a hit the
//! estimate stands. A Wall hit corrects the yaw: the step ŝ = x̂ - x^(k-1) is
//! rotated through Phi = [+phi, -phi, +2phi, -2phi, ...] and the first angle
//! whose scaled test step (eq. 39, factor f) is free wins (Case 1, eq. 41);
//! when none is free the step is cut back to just before the hit point (Case
//! 2, eq. 42). A Door hit first measures the incident angle alpha (eq. 37)
//! against the door's normal: above alpha_0 the step is deflected like a wall
//! hit, but only towards the side of increasing incident angle (alpha+ vs
//! alpha-); otherwise the room of x_B decides (eq. 43): still the previous
//! room -> blocked (Case 2), another room -> the step passes the door and
//! lands just beyond its far side x_c (Case 3). [`apply_to_particles`] then
//! shifts the particles by x^(k) - x̂ (eq. 44).

use super::{config::PpcConfig, particle_filter::ParticleFilter};
use crate::{
    Vec2,
    geometry::{included_angle, rotate},
    map::{Feature, FloorMap, RayHit},
};

/// The map queries PPC needs. Implemented for [`FloorMap`].
pub trait PlanQueries {
    /// M(x) as a class (eq. 25); outside the plan is Wall.
    fn feature_at(&self, p: Vec2) -> Feature;
    /// Function 1: first obstacle sample from `from` towards `to`.
    fn raycast_from(&self, from: Vec2, to: Vec2, step_m: f64) -> Option<RayHit>;
    /// Unit normal of the obstacle at `p` (image gradient of eq. 24 in the
    /// MCS), pointing out of the obstacle; `None` where it is undefined.
    /// PPC orients it towards the side the step comes from.
    fn obstacle_normal(&self, p: Vec2) -> Option<Vec2>;
    /// The room (walkable contour) containing `p`, `None` on obstacles.
    fn room_id(&self, p: Vec2) -> Option<u32>;
    /// Centres of the Door cells within `radius_m` of `p` (for the door-snap
    /// extension).
    fn doors_near(&self, p: Vec2, radius_m: f64) -> Vec<Vec2>;
    /// Whether no obstacle lies within `radius_m` of `p` (a conservative
    /// answer: `false` when unsure). Lets [`crosses_wall`] settle a short
    /// move with one lookup; the default never knows.
    fn obstacle_free_within(&self, _p: Vec2, _radius_m: f64) -> bool {
        false
    }
    /// Whether the straight move `from` -> `to` meets a Wall pixel (Doors do
    /// not count), sampled at from + d (k / n), k = 0..=n, d = to - from,
    /// n = ceil(|d| / step_m) (0.05 m when `step_m` is not > 0). The default
    /// evaluates every sample (after the [`PlanQueries::obstacle_free_within`]
    /// early exit); [`FloorMap`] skips samples by its Wall clearance table
    /// ([`FloorMap::crosses_wall`], same answer).
    fn crosses_wall(&self, from: Vec2, to: Vec2, step_m: f64) -> bool {
        let d = to - from;
        let len = d.norm();
        // every sample lies within |d| of `from`
        if self.obstacle_free_within(from, len) {
            return false;
        }
        crate::map::crosses_wall_sampled(|p| self.feature_at(p), from, to, step_m)
    }
    /// [`PlanQueries::crosses_wall`] of every move `from[i]` -> `to[i]` into
    /// `out[i]` (`out` resized to the shorter slice's length). The default
    /// asks `crosses_wall` move by move; [`FloorMap`] runs its midpoint test
    /// over blocks of moves first ([`FloorMap::crosses_wall_each`]).
    fn crosses_wall_each(&self, from: &[Vec2], to: &[Vec2], step_m: f64, out: &mut Vec<bool>) {
        out.clear();
        out.extend(
            from.iter()
                .zip(to)
                .map(|(a, b)| self.crosses_wall(*a, *b, step_m)),
        );
    }
}

/// Whether a particle standing on `f` is invalid (replaced after PPC):
/// Walls always, Doors unless particles may stand on them (`doors_ok`).
pub fn blocks_particle(f: Feature, doors_ok: bool) -> bool {
    match f {
        Feature::Walkable => false,
        Feature::Door => !doors_ok,
        Feature::Wall => true,
    }
}

/// Which branch of Algorithm 2 produced the position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PpcCase {
    /// No obstacle between x^(k-1) and x̂: no correction.
    Free,
    /// The previous position itself is on an obstacle (h = x^(k-1)): no correction (line 3).
    StartOnObstacle,
    /// Case 1: the step was rotated by `phi_rad` (eq. 41); `hit` is what it met.
    YawCorrected { phi_rad: f64, hit: Feature },
    /// Case 2 by eq. 42: no candidate angle was free; the step stops before the hit.
    Blocked { hit: Feature },
    /// Case 2 by eq. 43: the step met a door head-on but x_B is still in the previous room.
    DoorBlockedSameRoom,
    /// Case 3 by eq. 43: the step passes the door.
    DoorPassed,
    /// Extension (not in the paper, `door_snap_m > 0`): a step blocked by a
    /// wall (Case 2) passes a door within `door_snap_m` of the hit point that
    /// it meets head-on (alpha <= alpha_0).
    DoorSnapped,
}

/// Result of [`correct`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PpcOutcome {
    /// x^(k): the corrected position.
    pub position: Vec2,
    pub case: PpcCase,
    /// Incident angle alpha of eq. 37 when the step met a door, rad.
    pub alpha_rad: Option<f64>,
}

/// Algorithm 2: corrects the estimate `x_hat` given the previous position
/// `prev` (x^(k-1)) and the latest BLE position `x_b` (for the room test;
/// without it, or when it lies on no room, a head-on door step passes).
pub fn correct<M: PlanQueries + ?Sized>(
    map: &M,
    prev: Vec2,
    x_hat: Vec2,
    x_b: Option<Vec2>,
    cfg: &PpcConfig,
) -> PpcOutcome {
    let s_hat = x_hat - prev;
    let free = PpcOutcome {
        position: x_hat,
        case: PpcCase::Free,
        alpha_rad: None,
    };
    // Function 1 may stop short of x̂ (N is rounded): test x̂ itself too.
    let hit = map
        .raycast_from(prev, x_hat, cfg.raycast_step_m)
        .or_else(|| {
            let f = map.feature_at(x_hat);
            f.is_obstacle().then_some(RayHit {
                point: x_hat,
                feature: f,
            })
        });
    let Some(hit) = hit else {
        return free;
    };
    if hit.point == prev {
        return PpcOutcome {
            case: PpcCase::StartOnObstacle,
            ..free
        };
    }
    let n = cfg.n_angles as i32;
    // Phi in ascending |phi|: +phi, -phi, +2phi, -2phi, ...
    let mut phis: Vec<f64> = (1..=n)
        .flat_map(|j| [j as f64 * cfg.phi_rad, -(j as f64) * cfg.phi_rad])
        .collect();
    let mut alpha_rad = None;
    let correct_yaw = if hit.feature == Feature::Door {
        let normal = map
            .obstacle_normal(hit.point)
            .map(|nv| if nv.dot(&(-s_hat)) < 0.0 { -nv } else { nv });
        match normal {
            Some(nh) => {
                let alpha = included_angle(nh, -s_hat);
                alpha_rad = Some(alpha);
                if alpha > cfg.alpha0_rad {
                    let a_plus = included_angle(nh, -rotate(s_hat, cfg.phi_rad));
                    let a_minus = included_angle(nh, -rotate(s_hat, -cfg.phi_rad));
                    let positive = a_plus > a_minus;
                    phis.retain(|p| (*p > 0.0) == positive);
                    true
                } else {
                    false
                }
            }
            // No normal (an isolated door pixel): treat the door like a wall.
            None => true,
        }
    } else {
        true
    };

    if correct_yaw {
        // Eq. 40: the smallest |phi'| whose scaled test step is free.
        for &phi in &phis {
            let x_t = prev + rotate(s_hat, phi) * cfg.scale_f;
            if map.raycast_from(prev, x_t, cfg.raycast_step_m).is_none()
                && map.feature_at(x_t) == Feature::Walkable
            {
                let pos = prev + rotate(s_hat, phi);
                return PpcOutcome {
                    position: if map.feature_at(pos) == Feature::Walkable {
                        pos
                    } else {
                        back_off(map, prev, s_hat, hit.point, cfg)
                    },
                    case: PpcCase::YawCorrected {
                        phi_rad: phi,
                        hit: hit.feature,
                    },
                    alpha_rad,
                };
            }
        }
        if hit.feature == Feature::Wall
            && cfg.door_snap_m > 0.0
            && let Some(pos) = snap_through_door(map, prev, s_hat, hit.point, cfg)
        {
            return PpcOutcome {
                position: pos,
                case: PpcCase::DoorSnapped,
                alpha_rad,
            };
        }
        return PpcOutcome {
            position: back_off(map, prev, s_hat, hit.point, cfg),
            case: PpcCase::Blocked { hit: hit.feature },
            alpha_rad,
        };
    }

    // Door met head-on: has the room changed (eq. 43)?
    let room_prev = map.room_id(prev);
    let room_b = x_b
        .filter(|_| cfg.door_room_test)
        .and_then(|b| map.room_id(b));
    let same_room = room_prev.is_some() && room_b == room_prev;
    if !same_room && let Some(x_c) = far_side_of_door(map, hit.point, s_hat, cfg) {
        let pos = x_c + s_hat * cfg.epsilon;
        return PpcOutcome {
            position: if map.feature_at(pos) == Feature::Walkable {
                pos
            } else {
                x_c
            },
            case: PpcCase::DoorPassed,
            alpha_rad,
        };
    }
    PpcOutcome {
        position: back_off(map, prev, s_hat, hit.point, cfg),
        case: if same_room {
            PpcCase::DoorBlockedSameRoom
        } else {
            PpcCase::Blocked { hit: hit.feature }
        },
        alpha_rad,
    }
}

/// Eq. 42: h - epsilon ŝ; when that is not walkable (a thin corner), the last
/// walkable raycast sample before h, else `prev`.
fn back_off<M: PlanQueries + ?Sized>(
    map: &M,
    prev: Vec2,
    s_hat: Vec2,
    h: Vec2,
    cfg: &PpcConfig,
) -> Vec2 {
    let p = h - s_hat * cfg.epsilon;
    if map.feature_at(p) == Feature::Walkable
        && map.raycast_from(prev, p, cfg.raycast_step_m).is_none()
    {
        return p;
    }
    let len = s_hat.norm();
    if len > 0.0 {
        let dir = s_hat / len;
        let dist = (h - prev).norm();
        let mut d = dist - cfg.raycast_step_m;
        while d > 0.0 {
            let q = prev + dir * d;
            if map.feature_at(q) == Feature::Walkable {
                return q;
            }
            d -= cfg.raycast_step_m;
        }
    }
    prev
}

/// The door-snap extension: among the door pixels within `door_snap_m` of
/// the wall hit `h`, the nearest one that the step direction meets head-on
/// (incident angle <= alpha_0 against its normal), that is reachable from
/// `prev` and has a walkable far side; the position lands epsilon ŝ beyond
/// that far side.
fn snap_through_door<M: PlanQueries + ?Sized>(
    map: &M,
    prev: Vec2,
    s_hat: Vec2,
    h: Vec2,
    cfg: &PpcConfig,
) -> Option<Vec2> {
    let len = s_hat.norm();
    if len == 0.0 {
        return None;
    }
    let dir = s_hat / len;
    let mut doors = map.doors_near(h, cfg.door_snap_m);
    doors.sort_by(|a, b| (a - h).norm_squared().total_cmp(&(b - h).norm_squared()));
    for d in doors.into_iter().take(64) {
        let Some(n) = map.obstacle_normal(d) else {
            continue;
        };
        let n = if n.dot(&(-dir)) < 0.0 { -n } else { n };
        if included_angle(n, -dir) > cfg.alpha0_rad {
            continue;
        }
        // The near side of the door must be reachable from prev.
        let near = d - dir * cfg.raycast_step_m * 2.0;
        if map.feature_at(near) != Feature::Walkable
            || map.raycast_from(prev, near, cfg.raycast_step_m).is_some()
        {
            continue;
        }
        if let Some(x_c) = far_side_of_door(map, d, s_hat, cfg) {
            let pos = x_c + s_hat * cfg.epsilon;
            return Some(if map.feature_at(pos) == Feature::Walkable {
                pos
            } else {
                x_c
            });
        }
    }
    None
}

/// x_c of eq. 43: the first walkable point beyond the door along ŝ, searched
/// up to `door_search_m` past the hit point.
fn far_side_of_door<M: PlanQueries + ?Sized>(
    map: &M,
    h: Vec2,
    s_hat: Vec2,
    cfg: &PpcConfig,
) -> Option<Vec2> {
    let len = s_hat.norm();
    if len == 0.0 {
        return None;
    }
    let dir = s_hat / len;
    let n = (cfg.door_search_m / cfg.raycast_step_m).ceil() as usize;
    (1..=n)
        .map(|k| h + dir * (k as f64 * cfg.raycast_step_m))
        .take_while(|q| map.feature_at(*q) != Feature::Wall)
        .find(|q| map.feature_at(*q) == Feature::Walkable)
}

/// Eq. 44 plus the wall rule: shifts every particle by x^(k) - x̂ (when
/// `shift`), then replaces each particle left on an obstacle (Wall or Door)
/// by a copy of a random walkable particle (or by x^(k) when none is
/// walkable), so no particle ends inside a wall. Returns how many particles
/// were replaced.
pub fn apply_to_particles<M: PlanQueries + ?Sized>(
    map: &M,
    pf: &mut ParticleFilter,
    x_hat: Vec2,
    outcome: &PpcOutcome,
    shift: bool,
) -> usize {
    apply_to_particles_with_doors(map, pf, x_hat, outcome, shift, false)
}

/// [`apply_to_particles`] where particles on Door pixels may stay when
/// `doors_ok` (only those on Wall pixels are replaced).
pub fn apply_to_particles_with_doors<M: PlanQueries + ?Sized>(
    map: &M,
    pf: &mut ParticleFilter,
    x_hat: Vec2,
    outcome: &PpcOutcome,
    shift: bool,
    doors_ok: bool,
) -> usize {
    let delta = outcome.position - x_hat;
    if shift && delta != Vec2::zeros() {
        pf.shift(delta);
    }
    pf.replace_invalid(
        |p| blocks_particle(map.feature_at(p), doors_ok),
        outcome.position,
    )
}

/// Whether the straight move `from` -> `to` meets a Wall pixel (Doors do
/// not count), sampled at most `step_m` apart as Function 1 does, both ends
/// included: the particle wall check with `particles_pass_doors`
/// ([`PlanQueries::crosses_wall`]).
pub fn crosses_wall<M: PlanQueries + ?Sized>(map: &M, from: Vec2, to: Vec2, step_m: f64) -> bool {
    map.crosses_wall(from, to, step_m)
}

/// [`crosses_wall`] of every particle move `from[i]` -> `to[i]` into
/// `out[i]` (resized): the engine's particle wall check, one call per step
/// ([`PlanQueries::crosses_wall_each`]).
pub fn crosses_wall_each<M: PlanQueries + ?Sized>(
    map: &M,
    from: &[Vec2],
    to: &[Vec2],
    step_m: f64,
    out: &mut Vec<bool>,
) {
    map.crosses_wall_each(from, to, step_m, out)
}

impl PlanQueries for FloorMap {
    #[inline]
    fn feature_at(&self, p: Vec2) -> Feature {
        self.feature(p)
    }

    fn raycast_from(&self, from: Vec2, to: Vec2, step_m: f64) -> Option<RayHit> {
        self.raycast(from, to, step_m)
    }

    fn obstacle_normal(&self, p: Vec2) -> Option<Vec2> {
        self.normal_at(p)
            .or_else(|| principal_axes::obstacle_normal(self, p))
    }

    fn room_id(&self, p: Vec2) -> Option<u32> {
        self.room_of(p)
    }

    fn obstacle_free_within(&self, p: Vec2, radius_m: f64) -> bool {
        FloorMap::obstacle_free_within(self, p, radius_m)
    }

    fn crosses_wall(&self, from: Vec2, to: Vec2, step_m: f64) -> bool {
        FloorMap::crosses_wall(self, from, to, step_m)
    }

    fn crosses_wall_each(&self, from: &[Vec2], to: &[Vec2], step_m: f64, out: &mut Vec<bool>) {
        FloorMap::crosses_wall_each(self, from, to, step_m, out)
    }

    fn doors_near(&self, p: Vec2, radius_m: f64) -> Vec<Vec2> {
        let mut out = Vec::new();
        if self.door_pixel_count() == 0 {
            return out;
        }
        let r = self.pixels_per_meter();
        let q = self.mcs_to_ics(p);
        let rp = (radius_m * r).ceil() as isize;
        let (ci, cj) = (q.x.floor() as isize, q.y.floor() as isize);
        let r2 = (radius_m * r) * (radius_m * r);
        for j in cj - rp..=cj + rp {
            for i in ci - rp..=ci + rp {
                let (dx, dy) = (i as f64 + 0.5 - q.x, j as f64 + 0.5 - q.y);
                if dx * dx + dy * dy <= r2 && self.feature_px(i, j) == Feature::Door {
                    out.push(self.ics_to_mcs(Vec2::new(i as f64 + 0.5, j as f64 + 0.5)));
                }
            }
        }
        out
    }
}

/// Fallback normal where the image gradient vanishes (a one-pixel door in a
/// one-pixel wall line is symmetric, so its gradient is zero).
mod principal_axes {
    use super::*;
    /// Normal from the principal axes of the obstacle pixels of the same
    /// feature near `p` (radius 3 px): the minor axis is the normal.
    pub fn obstacle_normal(map: &FloorMap, p: Vec2) -> Option<Vec2> {
        let (ci, cj) = map.pixel_of(p)?;
        let f = map.feature_px(ci as isize, cj as isize);
        if !f.is_obstacle() {
            return None;
        }
        let r = 3isize;
        let (mut n, mut sx, mut sy) = (0.0, 0.0, 0.0);
        let mut pts = Vec::new();
        for dj in -r..=r {
            for di in -r..=r {
                let (i, j) = (ci as isize + di, cj as isize + dj);
                if di * di + dj * dj <= r * r && map.feature_px(i, j) == f {
                    // MCS orientation: x right, y up.
                    let (x, y) = (di as f64, -(dj as f64));
                    pts.push((x, y));
                    n += 1.0;
                    sx += x;
                    sy += y;
                }
            }
        }
        if n < 2.0 {
            return None;
        }
        let (mx, my) = (sx / n, sy / n);
        let (mut cxx, mut cxy, mut cyy) = (0.0, 0.0, 0.0);
        for (x, y) in pts {
            cxx += (x - mx) * (x - mx);
            cxy += (x - mx) * (y - my);
            cyy += (y - my) * (y - my);
        }
        // Major axis angle of the 2x2 covariance; the normal is perpendicular.
        let theta = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
        Some(Vec2::new(-theta.sin(), theta.cos()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fusion::FusionConfig;
    use proptest::prelude::*;

    /// 10 m x 6 m at 10 px/m: border walls (2 px), a wall at x in [5.0, 5.2)
    /// splitting room A (left) from room B (right), with a door in it for
    /// y in [2.5, 3.5).
    fn two_rooms() -> FloorMap {
        let (w, h, r) = (100usize, 60usize, 10.0);
        let mut f = vec![Feature::Walkable; w * h];
        for j in 0..h {
            for i in 0..w {
                let y_m = (h - j) as f64 / r - 0.05; // pixel centre, MCS
                let border = i < 2 || i >= w - 2 || j < 2 || j >= h - 2;
                let mid = i == 50 || i == 51;
                f[j * w + i] = if border {
                    Feature::Wall
                } else if mid {
                    if (2.5..3.5).contains(&y_m) {
                        Feature::Door
                    } else {
                        Feature::Wall
                    }
                } else {
                    Feature::Walkable
                };
            }
        }
        FloorMap::from_features(w, h, r, f)
    }

    /// The paper's PPC (no extension) for the paper's cases.
    fn cfg() -> PpcConfig {
        PpcConfig::paper()
    }

    fn step(len: f64, deg: f64) -> Vec2 {
        let a = deg.to_radians();
        Vec2::new(len * a.cos(), len * a.sin())
    }

    fn close(a: Vec2, b: Vec2) -> bool {
        (a - b).norm() < 1e-9
    }

    #[test]
    fn plan_is_what_the_tests_assume() {
        let m = two_rooms();
        assert_eq!(m.feature(Vec2::new(5.1, 1.0)), Feature::Wall);
        assert_eq!(m.feature(Vec2::new(5.1, 3.0)), Feature::Door);
        assert_eq!(m.feature(Vec2::new(4.9, 3.0)), Feature::Walkable);
        assert_eq!(m.feature(Vec2::new(5.25, 3.0)), Feature::Walkable);
        let a = m.room_id(Vec2::new(2.0, 2.0));
        assert!(a.is_some());
        assert_eq!(a, m.room_id(Vec2::new(4.9, 5.0)));
        assert_ne!(a, m.room_id(Vec2::new(7.0, 2.0)));
        // The door's normal is horizontal (either sign).
        let n = m.obstacle_normal(Vec2::new(5.05, 3.0)).unwrap();
        assert!(n.x.abs() > 0.99, "{n:?}");
    }

    #[test]
    fn free_step_is_not_corrected() {
        let m = two_rooms();
        let prev = Vec2::new(2.0, 2.0);
        let x_hat = prev + step(0.7, 30.0);
        let o = correct(&m, prev, x_hat, None, &cfg());
        assert_eq!(o.case, PpcCase::Free);
        assert_eq!(o.position, x_hat);
    }

    /// Fig. 5(a), Case 1: a step meeting a wall at a grazing angle is rotated
    /// by the smallest free angle of Phi (here +30 degrees, away from the wall)
    /// and keeps its length (eq. 41).
    #[test]
    fn case1_wall_grazing_step_is_rotated() {
        let m = two_rooms();
        let prev = Vec2::new(4.7, 1.0);
        let s = step(0.7, 40.0);
        let o = correct(&m, prev, prev + s, None, &cfg());
        let PpcCase::YawCorrected { phi_rad, hit } = o.case else {
            panic!("expected Case 1, got {:?}", o.case)
        };
        assert_eq!(hit, Feature::Wall);
        // Only 0.3 m of room before the wall: 1.5 * 0.7 * cos(heading) must
        // stay below it, which first holds at +40 degrees (heading 80 degrees).
        assert!((phi_rad - 40f64.to_radians()).abs() < 1e-9, "{phi_rad}");
        let expect = prev + rotate(s, phi_rad);
        assert!(close(o.position, expect));
        assert!(
            phi_rad > 0.0,
            "rotates away from the wall (towards +y), got {phi_rad}"
        );
        // Every smaller candidate was blocked, this one is free at scale f.
        let c = cfg();
        assert!(
            m.raycast(
                prev,
                prev + rotate(s, phi_rad) * c.scale_f,
                c.raycast_step_m
            )
            .is_none()
        );
        assert!(
            m.raycast(
                prev,
                prev + rotate(s, phi_rad - c.phi_rad) * c.scale_f,
                c.raycast_step_m
            )
            .is_some()
        );
        assert!(m.is_walkable(o.position));
        assert!((o.position - prev).norm() - 0.7 < 1e-9);
    }

    /// Fig. 5(b), Case 2: a step straight into a wall finds no free angle
    /// within Phi and is cut back to h - epsilon ŝ (eq. 42).
    #[test]
    fn case2_wall_head_on_step_is_blocked() {
        let m = two_rooms();
        let prev = Vec2::new(4.5, 1.0);
        let s = step(0.8, 0.0);
        let o = correct(&m, prev, prev + s, None, &cfg());
        assert_eq!(o.case, PpcCase::Blocked { hit: Feature::Wall });
        // h is the first raycast sample on the wall: x = 5.0.
        assert!(
            close(o.position, Vec2::new(5.0 - 0.1 * 0.8, 1.0)),
            "{:?}",
            o.position
        );
        assert!(m.is_walkable(o.position));
    }

    /// Fig. 6(a), Case 2 at a door: head-on (alpha < alpha_0) but x_B is still
    /// in the previous room, so the step stops before the door (eq. 43, first line).
    #[test]
    fn case2_door_head_on_same_room_is_blocked() {
        let m = two_rooms();
        let prev = Vec2::new(4.5, 3.0);
        let s = step(0.8, 10.0);
        let x_b = Vec2::new(3.0, 3.0);
        let o = correct(&m, prev, prev + s, Some(x_b), &cfg());
        assert_eq!(o.case, PpcCase::DoorBlockedSameRoom);
        assert!(o.alpha_rad.unwrap() < cfg().alpha0_rad);
        let h = m.raycast(prev, prev + s, 0.05).unwrap();
        assert_eq!(h.feature, Feature::Door);
        assert!(close(o.position, h.point - s * 0.1));
        assert!(o.position.x < 5.0);
    }

    /// Fig. 6(b), Case 3: head-on at the door and x_B in the next room: the
    /// step passes and lands epsilon ŝ beyond the door's far side x_c (eq. 43).
    #[test]
    fn case3_door_head_on_room_changed_passes() {
        let m = two_rooms();
        let prev = Vec2::new(4.5, 3.0);
        let s = step(0.8, 10.0);
        let x_b = Vec2::new(6.5, 3.0);
        let o = correct(&m, prev, prev + s, Some(x_b), &cfg());
        assert_eq!(o.case, PpcCase::DoorPassed);
        assert!(o.position.x > 5.2, "{:?}", o.position);
        assert!(
            o.position.x < 5.2 + 0.05 + 0.1 * 0.8 + 1e-9,
            "{:?}",
            o.position
        );
        assert!(m.is_walkable(o.position));
        assert_eq!(m.room_id(o.position), m.room_id(x_b));
    }

    /// A door met at a grazing angle (alpha > alpha_0) is not passed: the
    /// step is deflected towards increasing incident angle (into the room).
    #[test]
    fn door_grazing_step_is_deflected_into_the_room() {
        let m = two_rooms();
        let prev = Vec2::new(4.8, 2.6);
        let s = step(0.8, 70.0);
        let x_b = Vec2::new(6.5, 3.0);
        let o = correct(&m, prev, prev + s, Some(x_b), &cfg());
        assert!(o.alpha_rad.unwrap() > cfg().alpha0_rad);
        let PpcCase::YawCorrected { phi_rad, hit } = o.case else {
            panic!("expected a deflection, got {:?}", o.case)
        };
        assert_eq!(hit, Feature::Door);
        assert!(
            phi_rad > 0.0,
            "rotates towards +y (away from the door), got {phi_rad}"
        );
        assert!(o.position.x < 5.0);
        assert_eq!(m.room_id(o.position), m.room_id(prev));
    }

    #[test]
    fn without_ble_a_head_on_door_step_passes() {
        let m = two_rooms();
        let prev = Vec2::new(4.5, 3.0);
        let o = correct(&m, prev, prev + step(0.8, 0.0), None, &cfg());
        assert_eq!(o.case, PpcCase::DoorPassed);
    }

    /// Extension: a head-on step into the wall 1.5 m beside a door passes
    /// that door when door snapping is on, and is blocked when it is off.
    #[test]
    fn door_snap_passes_a_nearby_door() {
        let m = two_rooms();
        let prev = Vec2::new(4.5, 1.6);
        let x_hat = prev + step(0.8, 0.0);
        let off = correct(&m, prev, x_hat, None, &cfg());
        assert_eq!(off.case, PpcCase::Blocked { hit: Feature::Wall });
        let snap = PpcConfig {
            door_snap_m: 3.0,
            ..cfg()
        };
        let on = correct(&m, prev, x_hat, None, &snap);
        assert_eq!(on.case, PpcCase::DoorSnapped);
        assert!(
            on.position.x > 5.2 && (2.5..3.5).contains(&on.position.y),
            "{:?}",
            on.position
        );
        assert!(m.is_walkable(on.position));
    }

    /// Particles may cross a door but not a wall.
    #[test]
    fn crosses_wall_ignores_doors() {
        let m = two_rooms();
        let (a, through_door, through_wall) = (
            Vec2::new(4.6, 3.0),
            Vec2::new(5.6, 3.0),
            Vec2::new(5.6, 1.5),
        );
        assert!(!crosses_wall(&m, a, through_door, 0.05));
        assert!(m.raycast(a, through_door, 0.05).is_some());
        assert!(crosses_wall(&m, Vec2::new(4.6, 1.5), through_wall, 0.05));
        assert!(!crosses_wall(&m, a, Vec2::new(4.0, 2.0), 0.05));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// The clearance early exit of `crosses_wall` never changes its answer:
        /// same result as testing every sample.
        #[test]
        fn crosses_wall_matches_every_sample(
            ax in 0.0f64..10.0, ay in 0.0f64..6.0,
            len in 0.0f64..3.0, deg in -180.0f64..180.0,
        ) {
            let m = two_rooms();
            let (a, b) = (Vec2::new(ax, ay), Vec2::new(ax, ay) + step(len, deg));
            let d = b - a;
            let n = (d.norm() / 0.05).ceil() as usize;
            let every = (0..=n).any(|k| {
                let t = if n == 0 { 0.0 } else { k as f64 / n as f64 };
                m.feature(a + d * t) == Feature::Wall
            });
            prop_assert_eq!(crosses_wall(&m, a, b, 0.05), every);
        }
    }

    /// The map through the trait's default methods only (no clearance).
    struct Plain<'a>(&'a FloorMap);

    impl PlanQueries for Plain<'_> {
        fn feature_at(&self, p: Vec2) -> Feature {
            self.0.feature(p)
        }
        fn raycast_from(&self, from: Vec2, to: Vec2, step_m: f64) -> Option<RayHit> {
            self.0.raycast(from, to, step_m)
        }
        fn obstacle_normal(&self, p: Vec2) -> Option<Vec2> {
            self.0.obstacle_normal(p)
        }
        fn room_id(&self, p: Vec2) -> Option<u32> {
            self.0.room_of(p)
        }
        fn doors_near(&self, p: Vec2, radius_m: f64) -> Vec<Vec2> {
            PlanQueries::doors_near(self.0, p, radius_m)
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        /// The trait's default particle wall check (every sample) and the
        /// FloorMap one (clearance tables, blocks) answer alike.
        #[test]
        fn default_and_floor_map_crosses_wall_each_agree(
            seed in 0u64..1000, count in 0usize..200,
        ) {
            use rand::{RngExt, SeedableRng};
            let m = two_rooms();
            let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
            let from: Vec<Vec2> = (0..count)
                .map(|_| Vec2::new(rng.random::<f64>() * 10.0, rng.random::<f64>() * 6.0))
                .collect();
            let to: Vec<Vec2> = from
                .iter()
                .map(|a| a + step(rng.random::<f64>() * 1.5, rng.random::<f64>() * 360.0))
                .collect();
            let (mut fast, mut plain) = (Vec::new(), Vec::new());
            crosses_wall_each(&m, &from, &to, 0.05, &mut fast);
            crosses_wall_each(&Plain(&m), &from, &to, 0.05, &mut plain);
            prop_assert_eq!(&fast, &plain);
            for i in 0..count {
                prop_assert_eq!(fast[i], crosses_wall(&Plain(&m), from[i], to[i], 0.05));
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Whatever the step, the cloud and x_B, PPC leaves the position and
        /// every particle on walkable ground.
        #[test]
        fn particles_never_end_in_a_wall(
            px in 0.3f64..9.7, py in 0.3f64..5.7,
            len in 0.0f64..2.0, deg in -180.0f64..180.0,
            spread in 0.0f64..3.0,
            bx in 0.0f64..10.0, by in 0.0f64..6.0,
            seed in 0u64..1000,
            extensions in any::<bool>(),
            shift in any::<bool>(),
            doors_ok in any::<bool>(),
        ) {
            let m = two_rooms();
            let prev = Vec2::new(px, py);
            prop_assume!(m.is_walkable(prev));
            let mut fc = FusionConfig { particle_count: 200, ..FusionConfig::default() };
            if !extensions {
                fc.ppc = PpcConfig::paper();
            }
            let mut pf = ParticleFilter::new(&fc, seed);
            pf.init_at(prev, spread, |_| true);
            pf.predict(len, deg.to_radians());
            pf.weight(Vec2::new(bx, by));
            let x_hat = pf.mean().unwrap();
            pf.resample();
            let o = correct(&m, prev, x_hat, Some(Vec2::new(bx, by)), &fc.ppc);
            prop_assert!(m.is_walkable(o.position), "{:?} -> {:?}", prev, o);
            let before = pf.particles().to_vec();
            apply_to_particles_with_doors(&m, &mut pf, x_hat, &o, shift, doors_ok);
            prop_assert_eq!(pf.particles().len(), 200);
            if !shift {
                // without eq. 44 particles on walkable ground stay where they were
                for (a, b) in before.iter().zip(pf.particles()) {
                    let kept = m.is_walkable(*a) || (doors_ok && m.feature(*a) == Feature::Door);
                    prop_assert!(!kept || a == b, "{:?} moved to {:?}", a, b);
                }
            }
            for p in pf.particles() {
                prop_assert!(m.feature(*p) != Feature::Wall, "particle {:?} in a wall", p);
                prop_assert!(doors_ok || m.is_walkable(*p));
            }
        }
    }
}
