//! The walker: legs between random goals in different rooms, planned on the
//! map (see [`crate::plan`]), walked step by step at human speeds with
//! pauses and turns. The result is a [`Trajectory`]: a polyline, a timeline
//! of still and stepping phases along it, and the true steps.

use fpbp_core::map::FloorMap;
use fpbp_core::{Error, Result, Vec2};
use rand::RngExt;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::noise::{chance, normal, uniform};
use crate::plan::PlanGrid;
use crate::profile::{ImuConfig, WalkConfig};

/// Largest distance a corner is cut by the route smoother, m.
const CORNER_CUT_M: f64 = 0.6;
/// How often a goal is redrawn when it cannot be reached or is too close.
const GOAL_TRIES: usize = 50;

/// One true step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrueStep {
    /// Start of the step, s from the log start.
    pub t_start_s: f64,
    /// End of the step (the next heel strike), s.
    pub t_end_s: f64,
    /// Step length, m.
    pub length_m: f64,
    /// Vertical acceleration peak-to-peak of the step after the PDR's low-pass,
    /// m/s^2 (Weinberg: length = beta * pp^(1/4)); the raw signal's is larger
    /// by 1 / |H(f_step)| (see `ImuConfig::weinberg_lowpass_hz`).
    pub accel_pp_mps2: f64,
    /// Index of the step in the walk (0, 1, ...).
    pub index: usize,
    /// Index of the step within its leg, and the leg's number of steps.
    pub leg_step: usize,
    pub leg_steps: usize,
}

/// A span of time: standing still, or one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phase {
    pub t0_s: f64,
    pub t1_s: f64,
    /// Arc length along the route at t0 and t1, m.
    pub s0_m: f64,
    pub s1_m: f64,
    /// The step this phase is, if any (index into `Trajectory::steps`).
    pub step: Option<usize>,
}

/// Where the walker is at every moment.
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// Route polyline (MCS, m) and cumulative arc length at each vertex.
    pub route: Vec<Vec2>,
    pub cum_m: Vec<f64>,
    /// Contiguous phases covering [0, duration] and a little beyond.
    pub phases: Vec<Phase>,
    pub steps: Vec<TrueStep>,
    /// Simulated duration, s.
    pub duration_s: f64,
    /// `ImuConfig::weinberg_lowpass_hz` of the walk (the sensors boost the
    /// generated peak-to-peak by the inverse low-pass gain).
    pub weinberg_lowpass_hz: f64,
}

impl Trajectory {
    /// The phase at time `t_s` (clamped to the timeline).
    pub fn phase_at(&self, t_s: f64) -> &Phase {
        let k = self.phases.partition_point(|p| p.t1_s <= t_s);
        &self.phases[k.min(self.phases.len() - 1)]
    }

    /// Arc length at time `t_s`, m.
    pub fn arc_at(&self, t_s: f64) -> f64 {
        let p = self.phase_at(t_s);
        let span = p.t1_s - p.t0_s;
        let u = if span > 0.0 {
            ((t_s - p.t0_s) / span).clamp(0.0, 1.0)
        } else {
            1.0
        };
        p.s0_m + (p.s1_m - p.s0_m) * u
    }

    /// Position on the route at arc length `s_m`.
    pub fn point_at_arc(&self, s_m: f64) -> Vec2 {
        let n = self.route.len();
        if n == 1 {
            return self.route[0];
        }
        let k = self.cum_m.partition_point(|&c| c <= s_m).clamp(1, n - 1);
        let (a, b) = (self.route[k - 1], self.route[k]);
        let (ca, cb) = (self.cum_m[k - 1], self.cum_m[k]);
        if cb - ca <= 0.0 {
            return b;
        }
        a + (b - a) * ((s_m - ca) / (cb - ca)).clamp(0.0, 1.0)
    }

    /// Direction (MCS, rad) of the route going forward from arc length `s_m`.
    pub fn heading_at_arc(&self, s_m: f64) -> f64 {
        let n = self.route.len();
        let mut k = self
            .cum_m
            .partition_point(|&c| c <= s_m + 1e-9)
            .clamp(1, n - 1);
        // Skip zero-length segments.
        while k < n - 1 && self.cum_m[k] - self.cum_m[k - 1] < 1e-9 {
            k += 1;
        }
        let d = self.route[k] - self.route[k - 1];
        if d.norm() < 1e-12 {
            0.0
        } else {
            d.y.atan2(d.x)
        }
    }

    /// Position at time `t_s`.
    pub fn position_at(&self, t_s: f64) -> Vec2 {
        self.point_at_arc(self.arc_at(t_s))
    }

    /// Steps that end within the simulated duration.
    pub fn steps_in_log(&self) -> impl Iterator<Item = &TrueStep> {
        self.steps.iter().filter(|s| s.t_end_s <= self.duration_s)
    }
}

/// Plans and walks a trajectory of `duration_s` seconds on `map`.
pub fn walk(
    map: &FloorMap,
    cfg: &WalkConfig,
    imu: &ImuConfig,
    duration_s: f64,
    rng: &mut Pcg64,
) -> Result<Trajectory> {
    let grid = PlanGrid::build(map, cfg.grid_cell_m, cfg.clearance_m);
    let comps = grid.components();
    // The walk happens in the largest traversable component.
    let mut sizes: Vec<usize> = Vec::new();
    for &c in &comps {
        if c != usize::MAX {
            if sizes.len() <= c {
                sizes.resize(c + 1, 0);
            }
            sizes[c] += 1;
        }
    }
    let Some((main, _)) = sizes
        .iter()
        .enumerate()
        .max_by_key(|&(i, &n)| (n, std::cmp::Reverse(i)))
    else {
        return Err(Error::Input(format!(
            "simulator: no walkable area with {} m clearance from walls on this floor",
            cfg.clearance_m
        )));
    };
    // Goal candidates, grouped by room (cells outside rooms go to a catch-all group).
    let mut by_room: Vec<Vec<usize>> = vec![Vec::new(); grid.rooms + 1];
    for (c, &comp) in comps.iter().enumerate() {
        if comp == main && grid.clearance_of(c) >= cfg.goal_clearance_m {
            let r = grid.room_of(c).unwrap_or(grid.rooms);
            by_room[r].push(c);
        }
    }
    let rooms: Vec<usize> = (0..by_room.len())
        .filter(|&r| !by_room[r].is_empty())
        .collect();
    if rooms.is_empty() {
        return Err(Error::Input(format!(
            "simulator: no goal cell with {} m clearance from walls (walk.goal_clearance_m)",
            cfg.goal_clearance_m
        )));
    }
    // A fixed route: every waypoint snapped to the nearest cell of the main
    // component (at most 1 m away).
    let fixed: Vec<usize> = cfg
        .waypoints_m
        .iter()
        .enumerate()
        .map(|(k, w)| snap_waypoint(&grid, &comps, main, Vec2::new(w[0], w[1]), k))
        .collect::<Result<_>>()?;
    let mut next_waypoint = 1;
    let mut cur = if let Some(&first) = fixed.first() {
        first
    } else {
        let r = rooms[rng.random_range(0..rooms.len())];
        by_room[r][rng.random_range(0..by_room[r].len())]
    };
    let mut route = vec![grid.centre(cur)];
    let mut cum = vec![0.0];
    let mut phases = Vec::new();
    let mut steps: Vec<TrueStep> = Vec::new();
    let mut t = 0.0;
    let mut s = 0.0;
    if cfg.initial_still_s > 0.0 {
        phases.push(Phase {
            t0_s: 0.0,
            t1_s: cfg.initial_still_s,
            s0_m: 0.0,
            s1_m: 0.0,
            step: None,
        });
        t = cfg.initial_still_s;
    }
    while t < duration_s {
        let cur_room = grid.room_of(cur);
        let mut leg = None;
        if !fixed.is_empty() {
            let goal = fixed[next_waypoint % fixed.len()];
            next_waypoint += 1;
            let Some(pts) = grid.route(cur, goal, CORNER_CUT_M) else {
                return Err(Error::config(
                    "walk.waypoints_m",
                    format!(
                        "no route from waypoint {} to waypoint {}",
                        (next_waypoint - 2) % fixed.len(),
                        (next_waypoint - 1) % fixed.len()
                    ),
                ));
            };
            leg = Some((goal, pts));
        }
        for _ in 0..GOAL_TRIES {
            if leg.is_some() {
                break;
            }
            let others: Vec<usize> = rooms
                .iter()
                .copied()
                .filter(|&r| Some(r) != cur_room || rooms.len() == 1)
                .collect();
            let r = others[rng.random_range(0..others.len())];
            let goal = by_room[r][rng.random_range(0..by_room[r].len())];
            if (grid.centre(goal) - grid.centre(cur)).norm() < cfg.min_goal_distance_m {
                continue;
            }
            if let Some(pts) = grid.route(cur, goal, CORNER_CUT_M) {
                leg = Some((goal, pts));
                break;
            }
        }
        let Some((goal, pts)) = leg else {
            return Err(Error::Input(format!(
                "simulator: found no reachable goal at least {} m away after {GOAL_TRIES} tries \
                 (walk.min_goal_distance_m)",
                cfg.min_goal_distance_m
            )));
        };
        for p in pts.into_iter().skip(1) {
            let last = route[route.len() - 1];
            cum.push(cum[cum.len() - 1] + (p - last).norm());
            route.push(p);
        }
        let s_end = cum[cum.len() - 1];
        // Leg gait: a step frequency, and the step length that goes with it.
        let f_hz = uniform(rng, cfg.step_freq_min_hz, cfg.step_freq_max_hz);
        let span = cfg.step_freq_max_hz - cfg.step_freq_min_hz;
        let u = if span > 0.0 {
            (f_hz - cfg.step_freq_min_hz) / span
        } else {
            0.5
        };
        let len_mean = cfg.step_len_at_min_freq_m
            + u * (cfg.step_len_at_max_freq_m - cfg.step_len_at_min_freq_m);
        // Steps of about the mean length that add up to the leg exactly.
        let leg_m = s_end - s;
        let n_steps = (leg_m / len_mean).round().max(1.0) as usize;
        let weights: Vec<f64> = (0..n_steps)
            .map(|_| (1.0 + normal(rng, 0.0, cfg.step_len_cv)).clamp(0.5, 1.5))
            .collect();
        let w_sum: f64 = weights.iter().sum();
        for (leg_step, w) in weights.into_iter().enumerate() {
            let len = leg_m * w / w_sum;
            let dur = (1.0 + normal(rng, 0.0, cfg.step_time_cv)).clamp(0.7, 1.3) / f_hz;
            let index = steps.len();
            steps.push(TrueStep {
                t_start_s: t,
                t_end_s: t + dur,
                length_m: len,
                accel_pp_mps2: (len / imu.weinberg_beta).powi(4),
                index,
                leg_step,
                leg_steps: n_steps,
            });
            phases.push(Phase {
                t0_s: t,
                t1_s: t + dur,
                s0_m: s,
                s1_m: (s + len).min(s_end),
                step: Some(index),
            });
            t += dur;
            s += len;
        }
        s = s_end;
        cur = goal;
        let pause = if chance(rng, cfg.pause_probability) {
            uniform(rng, cfg.pause_min_s, cfg.pause_max_s)
        } else {
            // A short stop to turn towards the next goal.
            0.5
        };
        phases.push(Phase {
            t0_s: t,
            t1_s: t + pause,
            s0_m: s,
            s1_m: s,
            step: None,
        });
        t += pause;
    }
    // Pad so that every time up to the duration has a phase.
    phases.push(Phase {
        t0_s: t,
        t1_s: t.max(duration_s) + 1.0,
        s0_m: s,
        s1_m: s,
        step: None,
    });
    Ok(Trajectory {
        route,
        cum_m: cum,
        phases,
        steps,
        duration_s,
        weinberg_lowpass_hz: imu.weinberg_lowpass_hz,
    })
}

/// The cell of the main component nearest to waypoint `p` (number `k`),
/// at most 1 m away.
fn snap_waypoint(
    grid: &PlanGrid,
    comps: &[usize],
    main: usize,
    p: Vec2,
    k: usize,
) -> Result<usize> {
    let best = comps
        .iter()
        .enumerate()
        .filter(|&(_, &comp)| comp == main)
        .map(|(c, _)| (c, (grid.centre(c) - p).norm()))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((c, d)) if d <= 1.0 => Ok(c),
        _ => Err(Error::config(
            format!("walk.waypoints_m[{k}]"),
            format!(
                "({:.2}, {:.2}) is more than 1 m from any place the walker can stand",
                p.x, p.y
            ),
        )),
    }
}

/// The walker's body yaw (MCS, rad) at each of `times_s` (ascending): it
/// follows the route direction with a first-order lag and a turn-rate limit.
pub fn body_yaw_series(traj: &Trajectory, cfg: &WalkConfig, times_s: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(times_s.len());
    let Some(&t_first) = times_s.first() else {
        return out;
    };
    let mut yaw = traj.heading_at_arc(traj.arc_at(t_first));
    let mut t_prev = t_first;
    for &t in times_s {
        let dt = (t - t_prev).max(0.0);
        t_prev = t;
        let target = traj.heading_at_arc(traj.arc_at(t));
        let err = fpbp_core::geometry::wrap_angle(target - yaw);
        let gain = if cfg.yaw_time_constant_s > 0.0 {
            (dt / cfg.yaw_time_constant_s).min(1.0)
        } else {
            1.0
        };
        let max = cfg.max_turn_rate_rad_s * dt;
        yaw = fpbp_core::geometry::wrap_angle(yaw + (err * gain).clamp(-max, max));
        out.push(yaw);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testmap::two_rooms;
    use fpbp_core::map::Feature;
    use rand::SeedableRng;

    #[test]
    fn walk_stays_on_walkable_space_and_visits_both_rooms() {
        let map = two_rooms();
        let mut rng = Pcg64::seed_from_u64(3);
        let cfg = WalkConfig {
            min_goal_distance_m: 2.0,
            ..WalkConfig::default()
        };
        let tr = walk(&map, &cfg, &ImuConfig::default(), 120.0, &mut rng).unwrap();
        let (mut left, mut right) = (0, 0);
        for w in tr.route.windows(2) {
            let n = ((w[1] - w[0]).norm() / 0.01).ceil().max(1.0) as usize;
            for k in 0..=n {
                let p = w[0] + (w[1] - w[0]) * (k as f64 / n as f64);
                assert_ne!(
                    map.feature(p),
                    Feature::Wall,
                    "route touches a wall at {p:?}"
                );
            }
            if w[0].x < 4.9 {
                left += 1;
            } else {
                right += 1;
            }
        }
        assert!(left > 0 && right > 0);
    }

    #[test]
    fn gait_is_human() {
        let map = two_rooms();
        let mut rng = Pcg64::seed_from_u64(5);
        let cfg = WalkConfig {
            min_goal_distance_m: 2.0,
            ..WalkConfig::default()
        };
        let tr = walk(&map, &cfg, &ImuConfig::default(), 200.0, &mut rng).unwrap();
        assert!(tr.steps.len() > 100);
        for s in &tr.steps {
            let f = 1.0 / (s.t_end_s - s.t_start_s);
            assert!((1.0..3.0).contains(&f), "step frequency {f}");
            assert!(s.length_m > 0.0 && s.length_m < 1.2, "{}", s.length_m);
            let beta = ImuConfig::default().weinberg_beta;
            assert!((beta * s.accel_pp_mps2.powf(0.25) - s.length_m).abs() < 1e-9);
        }
        // Speed over full steps (not the shortened last steps of a leg).
        let speeds: Vec<f64> = tr
            .steps
            .iter()
            .filter(|s| s.length_m > 0.45)
            .map(|s| s.length_m / (s.t_end_s - s.t_start_s))
            .collect();
        let mean = speeds.iter().sum::<f64>() / speeds.len() as f64;
        assert!((0.8..1.6).contains(&mean), "mean speed {mean}");
    }
}
