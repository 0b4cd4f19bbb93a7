//! The proximity-PF paper's models on the generic particle filter
//! ([`crate::fusion::Cloud`]): the move of Step 2 with the floormap's wall
//! penalty ([`ProxMotion`], eq. 9) and the proximity likelihood of Step 3
//! with the wall rule ([`ProxWeights`], eqs. 1, 5-8, Sec. III-C2), plus
//! their map helpers and Step 1's uniform draws on the walkable area.

use rand::RngExt;
use rand_pcg::Pcg64;

use super::ProxPfConfig;
use crate::Vec2;
use crate::ble::FilteredBeacon;
use crate::ble::proximity::near_probability;
use crate::fusion::random::{in_disc, symmetric};
use crate::fusion::{Cloud, MeasurementModel, MotionModel};
use crate::map::{Feature, FloorMap};
use crate::pdr::Step;
use crate::site::Site;

/// Cloud column of each particle's wall penalty over the current
/// interval, Delta w_f (eq. 9), added to its weight by [`ProxWeights`].
pub const WALL_PENALTY: usize = 0;
/// Number of cloud columns the models use.
pub const COLUMNS: usize = 1;

/// An empty cloud for `n` particles with the models' columns (the wall
/// penalties, recomputed every interval, do not travel with copies).
pub fn new_cloud(n: usize) -> Cloud {
    let mut cloud = Cloud::new(n, COLUMNS);
    cloud.set_carried(WALL_PENALTY, false);
    cloud
}

/// The map of floor `id` (`None` when the site has none; unlike
/// `Site::floor` this does not index past a short `floors` vector).
pub(crate) fn floor_map(site: &Site, id: i32) -> Option<&FloorMap> {
    site.spec
        .floors
        .iter()
        .position(|f| f.id == id)
        .and_then(|i| site.floors.get(i))
}

/// Draws a point uniformly on the walkable part of `map` (within `radius`
/// of `centre` when given: [`in_disc`]). `None` after `tries` misses.
pub(crate) fn sample_walkable(
    rng: &mut Pcg64,
    map: &FloorMap,
    disc: Option<(Vec2, f64)>,
    tries: usize,
) -> Option<Vec2> {
    for _ in 0..tries {
        let p = match disc {
            Some((c, r)) => in_disc(rng, c, r),
            None => Vec2::new(
                map.width_m() * rng.random::<f64>(),
                map.height_m() * rng.random::<f64>(),
            ),
        };
        if map.feature(p) != Feature::Wall {
            return Some(p);
        }
    }
    None
}
/// First Wall sample on the segment from `from` to `to` (samples every
/// `step_m`, both ends included), as `FloorMap::raycast` but stopping only at
/// walls: doors are enterable areas for the proximity-PF paper, and an open
/// door does not block the radio path.
pub fn first_wall(map: &FloorMap, from: Vec2, to: Vec2, step_m: f64) -> Option<Vec2> {
    let d = to - from;
    let len = d.norm();
    if !len.is_finite() {
        return None;
    }
    let step = if step_m > 0.0 { step_m } else { 0.05 };
    let n = (len / step).round() as usize;
    let dir = if len > 0.0 { d / len } else { Vec2::zeros() };
    (0..=n)
        .map(|k| from + dir * (k as f64 * step).min(len))
        .find(|&x| map.feature(x) == Feature::Wall)
}

/// Moves `from` by `delta` on `map`. Returns the new position and whether it
/// ran into an un-enterable area; in that case it stops one raycast step
/// before the wall (or stays at `from` when that point is a wall). Doors are enterable.
pub fn move_with_map(map: &FloorMap, from: Vec2, delta: Vec2, step_m: f64) -> (Vec2, bool) {
    let to = from + delta;
    let len = delta.norm();
    if !(len.is_finite() && to.x.is_finite() && to.y.is_finite()) {
        return (from, false);
    }
    match first_wall(map, from, to, step_m) {
        None => (to, false),
        Some(hit) => {
            let back = if len > 0.0 {
                delta / len * step_m
            } else {
                Vec2::zeros()
            };
            let before = hit - back;
            if (before - from).dot(&delta) > 0.0 && map.feature(before) != Feature::Wall {
                (before, true)
            } else {
                (from, true)
            }
        }
    }
}

/// Delta w_b of one particle (eqs. 6-8 with the wall rule): sum of P(d) over
/// the Near beacons with no wall between particle and beacon.
pub fn proximity_gain(
    map: Option<&FloorMap>,
    p: Vec2,
    near: &[FilteredBeacon],
    cfg: &ProxPfConfig,
) -> f64 {
    let mut gain = 0.0;
    for b in near {
        let d = (p - b.pos).norm();
        let pd = near_probability(d);
        if pd <= 0.0 {
            continue;
        }
        if cfg.wall_rule
            && let Some(map) = map
        {
            let end = if d > cfg.wall_rule_beacon_margin_m {
                b.pos + (p - b.pos) / d * cfg.wall_rule_beacon_margin_m
            } else {
                p
            };
            if first_wall(map, p, end, cfg.raycast_step_m).is_some() {
                continue;
            }
        }
        gain += pd;
    }
    gain
}
/// The PDR steps of one interval on a floor: [`ProxMotion`]'s control.
#[derive(Debug, Clone, Copy)]
pub struct ProxMoves<'a> {
    /// The steps detected since the last run (non-finite ones are skipped).
    pub steps: &'a [Step],
    /// The floor's map; `None` = Algorithm C (no floormap: free moves).
    pub map: Option<&'a FloorMap>,
}

/// Step 2: for every step, each particle moves along the step's yaw +/-
/// U(`heading_noise_deg`) by the step length (`step_length_m`, or the PDR
/// step's with `use_pdr_step_length`) +/- U(`step_length_noise_m`). A move
/// that meets a wall stops just before it ([`move_with_map`]) and adds
/// `wall_penalty` to the particle's [`WALL_PENALTY`] column (zeroed first).
///
/// Draws per step, particle by particle: the heading noise, then the
/// length noise.
#[derive(Debug, Clone)]
pub struct ProxMotion {
    step_length_m: f64,
    step_length_noise_m: f64,
    heading_noise_rad: f64,
    use_pdr_step_length: bool,
    wall_penalty: f64,
    raycast_step_m: f64,
}

impl ProxMotion {
    /// The model of `cfg`.
    pub fn new(cfg: &ProxPfConfig) -> Self {
        ProxMotion {
            step_length_m: cfg.step_length_m,
            step_length_noise_m: cfg.step_length_noise_m,
            heading_noise_rad: cfg.heading_noise_deg.to_radians(),
            use_pdr_step_length: cfg.use_pdr_step_length,
            wall_penalty: cfg.wall_penalty,
            raycast_step_m: cfg.raycast_step_m,
        }
    }
}

impl MotionModel<ProxMoves<'_>> for ProxMotion {
    fn propagate(&mut self, cloud: &mut Cloud, rng: &mut Pcg64, moves: &ProxMoves<'_>) {
        let m = cloud.len();
        let penalty = cloud.column_vec_mut(WALL_PENALTY);
        penalty.clear();
        penalty.resize(m, 0.0);
        let (particles, [dw]) = cloud.positions_and_columns_mut([WALL_PENALTY]);
        for s in moves.steps {
            if !(s.yaw_rad.is_finite() && s.length_m.is_finite()) {
                continue;
            }
            let base = if self.use_pdr_step_length {
                s.length_m
            } else {
                self.step_length_m
            };
            for (p, d) in particles.iter_mut().zip(dw.iter_mut()) {
                let yaw = s.yaw_rad + symmetric(self.heading_noise_rad, rng.random::<f64>());
                let len =
                    (base + symmetric(self.step_length_noise_m, rng.random::<f64>())).max(0.0);
                let delta = Vec2::new(len * yaw.cos(), len * yaw.sin());
                match moves.map {
                    Some(map) => {
                        let (q, blocked) = move_with_map(map, *p, delta, self.raycast_step_m);
                        *p = q;
                        if blocked {
                            *d += self.wall_penalty;
                        }
                    }
                    None => *p += delta,
                }
            }
        }
    }
}

/// The beacons of one interval: [`ProxWeights`]' measurement.
#[derive(Debug, Clone, Copy)]
pub struct ProxReadings<'a> {
    /// The floor's map (the wall rule); `None` = no floormap.
    pub map: Option<&'a FloorMap>,
    /// The beacons whose proximity is Near (or Immediate).
    pub near: &'a [FilteredBeacon],
}

/// Step 3 and eq. 1: w = max(w + Delta w_b + Delta w_f, 0), Delta w_b the
/// [`proximity_gain`] of the particle and Delta w_f its [`WALL_PENALTY`]
/// column. No draws.
#[derive(Debug, Clone)]
pub struct ProxWeights {
    cfg: ProxPfConfig,
    /// Whether the last update raised some particle's weight (a gain > 0).
    evidence: bool,
}

impl ProxWeights {
    /// The model of `cfg`.
    pub fn new(cfg: &ProxPfConfig) -> Self {
        ProxWeights {
            cfg: cfg.clone(),
            evidence: false,
        }
    }

    /// Whether the last update gave some particle a positive gain.
    pub fn saw_evidence(&self) -> bool {
        self.evidence
    }
}

impl MeasurementModel<ProxReadings<'_>> for ProxWeights {
    fn update(&mut self, cloud: &mut Cloud, z: &ProxReadings<'_>) {
        self.evidence = false;
        let (particles, columns, weights) = cloud.parts_for_weighting();
        // no penalty column (no propagation yet): Delta w_f = 0
        let penalties = columns
            .get(WALL_PENALTY)
            .iter()
            .copied()
            .chain(std::iter::repeat(0.0));
        for ((p, w), d) in particles.iter().zip(weights.iter_mut()).zip(penalties) {
            let gain = proximity_gain(z.map, *p, z.near, &self.cfg);
            self.evidence |= gain > 0.0;
            *w = (*w + gain + d).max(0.0);
        }
    }
}
