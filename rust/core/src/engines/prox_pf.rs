//! Engine `prox-pf`: the particle filter of the proximity-PF paper
//! (proximity of BLE beacons + floormap, ../shared/papers/proximity-pf-floormap.txt).
//!
//! One Fusion task every `prox_pf.period_s` (t_s, default 0.5 s):
//! 1. Initialise (once, and again when the beacons point to another floor):
//!    n particles uniformly over the walkable area of the floor, w = 0. When
//!    the harness hands a start (`--init truth`), uniformly within
//!    `init_radius_m` of it instead.
//! 2. Move: for every PDR step detected since the last run, each particle
//!    moves along the step's yaw +/- U(15 deg) by 0.65 +/- U(0.10) m (or the
//!    PDR step length +/- U(0.10) m with `use_pdr_step_length`). A move that
//!    meets a wall or door (map raycast) stops just before it and costs the
//!    penalty Delta w_f = -5 (eq. 9 with its footnote value).
//! 3. Likelihood: for every beacon whose proximity is Near (Immediate counts
//!    as Near, see docs/engines-nlos.md), Delta w_b += P(d) (eqs. 5-8, d the
//!    horizontal particle-beacon distance), except when the map raycast finds
//!    a wall between the particle and the beacon (Sec. III-C2).
//!    w = max(w + Delta w, 0) (eq. 1).
//! 4. Estimate: weighted mean (eqs. 2-3). While every weight is 0 there is no
//!    information: no fix (or the plain mean when a start was handed over).
//! 5. Stratified resampling; copies keep the weight of their source (Step 5).

use std::sync::Arc;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::ble::proximity::{Proximity, ProximityConfig, near_probability};
use crate::ble::{BleFrontEnd, FilteredBeacon};
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorEvent};
use crate::map::{Feature, FloorMap};
use crate::pdr::Pdr;
use crate::site::Site;
use crate::{Error, Result, Vec2};

/// Parameters of `prox-pf` (`EngineConfig::prox_pf`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProxPfConfig {
    /// n, number of particles. Default 500 (paper Sec. IV).
    pub n_particles: usize,
    /// t_s, period of the filter, seconds. Default 0.5 (paper Sec. IV).
    pub period_s: f64,
    /// Step length when `use_pdr_step_length` is false, metres. Default 0.65 (paper Step 2).
    pub step_length_m: f64,
    /// Half-width of the uniform step-length noise, metres. Default 0.10 (paper Step 2).
    pub step_length_noise_m: f64,
    /// Half-width of the uniform heading noise, degrees. Default 15 (paper Step 2).
    pub heading_noise_deg: f64,
    /// Use each PDR step's own length (eq. 31) instead of `step_length_m`. Default false.
    pub use_pdr_step_length: bool,
    /// Delta w_f when a particle runs into an un-enterable area (eq. 9). Default -5
    /// (paper footnote 2).
    pub wall_penalty: f64,
    /// Apply the wall-between-particle-and-beacon rule (Sec. III-C2). Default true.
    pub wall_rule: bool,
    /// The wall rule's ray stops this far short of the beacon (beacons are often
    /// mounted on a wall pixel), metres. Default 0.3.
    pub wall_rule_beacon_margin_m: f64,
    /// Raycast sampling step, metres. Default 0.05.
    pub raycast_step_m: f64,
    /// Radius of the initial cloud around a handed-over start, metres. Default 2.
    pub init_radius_m: f64,
    /// w_i(0), the likelihood every particle starts with. The paper uses 0;
    /// then, until a Near reading arrives, every weight stays 0, resampling
    /// cannot remove particles stopped at walls and the cloud stays stuck in
    /// rooms the user left (16 m mean error on demo-walk-1 with no BLE vs
    /// 2.4 m for plain PDR). With w(0) > 0 the wall penalty removes them.
    /// Default 1 (see docs/engines-nlos.md).
    pub initial_weight: f64,
    /// Proximity class boundaries.
    pub proximity: ProximityConfig,
    /// Use the floormap in Steps 2-3 (moves stop at walls with the penalty,
    /// the wall rule). False is the paper's Algorithm C ("our proposed
    /// algorithm without using a floormap", Table I): particles move
    /// freely, no penalty, no wall rule. Default true.
    pub floormap: bool,
    /// When every weight has fallen to 0 (eq. 1's max(., 0) after wall
    /// penalties: the whole cloud ran into walls, e.g. behind the walker at
    /// a turn), start again from Step 1 (particles uniform over the
    /// enterable area). The paper names this state ("we cannot estimate the
    /// user's current position", footnote 2) but not a way out: without
    /// one the cloud is stuck at the wall for good and the pose frozen.
    /// Default false (the paper as printed; docs/reproduction.md).
    pub restart_when_all_zero: bool,
}

impl Default for ProxPfConfig {
    fn default() -> Self {
        ProxPfConfig {
            n_particles: 500,
            period_s: 0.5,
            step_length_m: 0.65,
            step_length_noise_m: 0.10,
            heading_noise_deg: 15.0,
            use_pdr_step_length: false,
            wall_penalty: -5.0,
            wall_rule: true,
            wall_rule_beacon_margin_m: 0.3,
            raycast_step_m: 0.05,
            init_radius_m: 2.0,
            initial_weight: 1.0,
            proximity: ProximityConfig::default(),
            floormap: true,
            restart_when_all_zero: false,
        }
    }
}

impl ProxPfConfig {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<()> {
        let pos = |f: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("prox_pf.{f}"),
                    format!("must be finite and > 0, got {v}"),
                ))
            }
        };
        let nonneg = |f: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("prox_pf.{f}"),
                    format!("must be finite and >= 0, got {v}"),
                ))
            }
        };
        if self.n_particles == 0 || self.n_particles > 1_000_000 {
            return Err(Error::config(
                "prox_pf.n_particles",
                "must be in 1..=1000000",
            ));
        }
        crate::bounds::check_range("prox_pf.period_s", self.period_s, 0.01, 3600.0)?;
        pos("step_length_m", self.step_length_m)?;
        nonneg("step_length_noise_m", self.step_length_noise_m)?;
        nonneg("heading_noise_deg", self.heading_noise_deg)?;
        if !(self.wall_penalty.is_finite() && self.wall_penalty <= 0.0) {
            return Err(Error::config(
                "prox_pf.wall_penalty",
                "must be finite and <= 0",
            ));
        }
        nonneg("wall_rule_beacon_margin_m", self.wall_rule_beacon_margin_m)?;
        crate::bounds::check_ray_step("prox_pf.raycast_step_m", self.raycast_step_m)?;
        crate::bounds::check_range(
            "prox_pf.init_radius_m",
            self.init_radius_m,
            0.0,
            crate::bounds::MAX_FLOOR_SIDE_M,
        )?;
        pos("init_radius_m", self.init_radius_m)?;
        nonneg("initial_weight", self.initial_weight)?;
        self.proximity.validate("prox_pf.proximity")
    }
}

/// One particle: position and accumulated likelihood w.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Particle {
    pub pos: Vec2,
    pub w: f64,
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
/// of `centre` when given). `None` after `tries` misses.
pub(crate) fn sample_walkable(
    rng: &mut Pcg64,
    map: &FloorMap,
    disc: Option<(Vec2, f64)>,
    tries: usize,
) -> Option<Vec2> {
    for _ in 0..tries {
        let p = match disc {
            Some((c, r)) => {
                let rho = r * rng.random::<f64>().sqrt();
                let th = std::f64::consts::TAU * rng.random::<f64>();
                c + Vec2::new(rho * th.cos(), rho * th.sin())
            }
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

/// Stratified resampling (Kitagawa): one uniform draw in each of n equal
/// strata of the cumulative weight. Copies keep their source's weight.
/// Leaves the set unchanged when the weights sum to 0 or are not finite.
pub fn stratified_resample(rng: &mut Pcg64, particles: &mut Vec<Particle>) {
    let n = particles.len();
    let total: f64 = particles.iter().map(|p| p.w).sum();
    if n == 0 || !(total.is_finite() && total > 0.0) {
        return;
    }
    let mut out = Vec::with_capacity(n);
    let mut cum = particles[0].w;
    let mut i = 0;
    for k in 0..n {
        let u = (k as f64 + rng.random::<f64>()) / n as f64 * total;
        while cum < u && i + 1 < n {
            i += 1;
            cum += particles[i].w;
        }
        out.push(particles[i]);
    }
    *particles = out;
}

/// The proximity-PF engine.
pub struct ProxPfEngine {
    cfg: ProxPfConfig,
    site: Arc<Site>,
    pdr: Pdr,
    front: BleFrontEnd,
    top_n: usize,
    rng: Pcg64,
    particles: Vec<Particle>,
    floor: Option<i32>,
    init: Option<InitialPosition>,
    /// A start was handed over: the plain mean is a valid estimate.
    informed: bool,
    /// A Near reading has raised some weight since the last initialisation.
    evidence: bool,
    heading_rad: f64,
    period_ns: i64,
    pose: Option<Pose>,
    stats: EngineStats,
}

impl ProxPfEngine {
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        config.validate()?;
        let cfg = config.prox_pf.clone();
        let init = init.filter(|i| i.x_m.is_finite() && i.y_m.is_finite());
        Ok(ProxPfEngine {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            front: BleFrontEnd::new(&config.ble, &site),
            top_n: config.ble.gml.top_n,
            rng: Pcg64::seed_from_u64(config.seed),
            particles: Vec::new(),
            floor: None,
            informed: init.is_some(),
            evidence: false,
            heading_rad: init
                .and_then(|i| i.heading_rad)
                .filter(|h| h.is_finite())
                .unwrap_or(0.0),
            init,
            period_ns: ((cfg.period_s * 1e9).round() as i64).max(1),
            cfg,
            site,
            pose: None,
            stats: EngineStats::default(),
        })
    }

    /// The particles (tests, plots).
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    fn initialise(&mut self, floor: i32) {
        self.particles.clear();
        self.evidence = false;
        self.floor = Some(floor);
        let Some(map) = floor_map(&self.site, floor) else {
            return;
        };
        let disc = self
            .init
            .take()
            .filter(|i| i.floor == floor)
            .map(|i| (Vec2::new(i.x_m, i.y_m), self.cfg.init_radius_m));
        if disc.is_none() {
            self.informed = false;
        }
        for _ in 0..self.cfg.n_particles {
            let p = sample_walkable(&mut self.rng, map, disc, 200)
                .or_else(|| disc.map(|(c, _)| c))
                .or_else(|| sample_walkable(&mut self.rng, map, None, 200));
            match p {
                Some(pos) => self.particles.push(Particle {
                    pos,
                    w: self.cfg.initial_weight,
                }),
                None => break,
            }
        }
    }

    fn step_once(&mut self, t_ns: i64) {
        let beacons = self.front.current(t_ns);
        let likely = BleFrontEnd::likely_floor(&beacons, self.top_n);
        let want = match (self.floor, likely) {
            (None, _) => Some(
                self.init
                    .map(|i| i.floor)
                    .or(likely)
                    .unwrap_or_else(|| self.site.default_floor()),
            ),
            (Some(f), Some(l)) if l != f => Some(l),
            _ => None,
        };
        if let Some(f) = want {
            self.initialise(f);
        }
        let steps = self.pdr.take_steps();
        self.stats.steps += steps.len() as u64;
        let Some(floor) = self.floor else {
            self.stats.no_fix += 1;
            return;
        };
        let site = Arc::clone(&self.site);
        let map = if self.cfg.floormap {
            floor_map(&site, floor)
        } else {
            None
        };
        if self.particles.is_empty() {
            self.stats.no_fix += 1;
            return;
        }
        let mut dw = vec![0.0; self.particles.len()];
        // Step 2: move
        let noise_rad = self.cfg.heading_noise_deg.to_radians();
        for s in &steps {
            if !(s.yaw_rad.is_finite() && s.length_m.is_finite()) {
                continue;
            }
            self.heading_rad = s.yaw_rad;
            let base = if self.cfg.use_pdr_step_length {
                s.length_m
            } else {
                self.cfg.step_length_m
            };
            for (p, d) in self.particles.iter_mut().zip(dw.iter_mut()) {
                let yaw = s.yaw_rad + noise_rad * (2.0 * self.rng.random::<f64>() - 1.0);
                let len = (base
                    + self.cfg.step_length_noise_m * (2.0 * self.rng.random::<f64>() - 1.0))
                    .max(0.0);
                let delta = Vec2::new(len * yaw.cos(), len * yaw.sin());
                match map {
                    Some(m) => {
                        let (q, blocked) = move_with_map(m, p.pos, delta, self.cfg.raycast_step_m);
                        p.pos = q;
                        if blocked {
                            *d += self.cfg.wall_penalty;
                        }
                    }
                    None => p.pos += delta,
                }
            }
        }
        // Step 3: likelihood
        let near: Vec<FilteredBeacon> = beacons
            .iter()
            .filter(|b| b.floor == floor)
            .filter(|b| {
                matches!(
                    self.cfg.proximity.classify(b),
                    Proximity::Near | Proximity::Immediate
                )
            })
            .copied()
            .collect();
        for (p, d) in self.particles.iter_mut().zip(dw.iter()) {
            let gain = proximity_gain(map, p.pos, &near, &self.cfg);
            self.evidence |= gain > 0.0;
            p.w = (p.w + gain + d).max(0.0);
        }
        // Step 4: estimate
        let total: f64 = self.particles.iter().map(|p| p.w).sum();
        // dead: weights were positive (w(0) > 0 or a Near reading) and all fell to 0
        let had_weight = self.evidence || self.cfg.initial_weight > 0.0;
        if total == 0.0 && had_weight && self.cfg.restart_when_all_zero {
            // every likelihood is 0: no estimate now, start again from Step 1
            self.stats.no_fix += 1;
            self.initialise(floor);
            return;
        }
        let n = self.particles.len() as f64;
        let (mean, weights_used) = if !(self.informed || self.evidence) {
            (None, false)
        } else if total > 0.0 && total.is_finite() {
            let m = self
                .particles
                .iter()
                .fold(Vec2::zeros(), |a, p| a + p.pos * p.w)
                / total;
            (Some(m), true)
        } else if self.informed {
            let m = self.particles.iter().fold(Vec2::zeros(), |a, p| a + p.pos) / n;
            (Some(m), false)
        } else {
            (None, false)
        };
        match mean.filter(|m| m.x.is_finite() && m.y.is_finite()) {
            Some(m) => {
                let var = self
                    .particles
                    .iter()
                    .map(|p| {
                        let w = if weights_used { p.w / total } else { 1.0 / n };
                        w * (p.pos - m).norm_squared()
                    })
                    .sum::<f64>();
                self.pose = Some(Pose {
                    t_ns,
                    x_m: m.x,
                    y_m: m.y,
                    floor,
                    heading_rad: self.heading_rad,
                    accuracy_m: var.sqrt(),
                    floor_prob: 1.0,
                    source: crate::engine::PoseSource::Fused,
                });
            }
            None => self.stats.no_fix += 1,
        }
        // Step 5: resample
        stratified_resample(&mut self.rng, &mut self.particles);
    }
}

impl Engine for ProxPfEngine {
    fn name(&self) -> &'static str {
        "prox-pf"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.pdr.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        self.front.on_observation(obs);
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        if task == Task::Fusion {
            self.step_once(t_ns);
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        (task == Task::Fusion).then_some(self.period_ns)
    }

    fn pose(&self) -> Option<Pose> {
        self.pose
    }

    fn stats(&self) -> EngineStats {
        let pdr = self.pdr.stats().rejected();
        self.stats.with_stages(self.front.counts(), pdr)
    }
}

/// Synthetic sites and walks shared by the `prox-pf` and `ppsa` tests.
#[cfg(test)]
pub(crate) mod testkit {
    use std::sync::Arc;

    use nalgebra::{UnitQuaternion, Vector3};

    use crate::Vec2;
    use crate::ble::pathloss::{PathLoss, range_m};
    use crate::events::{BleObservation, LogEvent, SensorData, SensorEvent, TruthPoint};
    use crate::map::{Feature, FloorMap};
    use crate::pdr::orientation::to_android;
    use crate::site::Site;
    use crate::site::testkit::beacon_site;

    pub const MODEL: PathLoss = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };
    /// Step length the PDR measures on [`walk_north`]'s signal (see engines::pdr tests).
    pub const STEP_M: f64 = 0.616;
    pub const STEP_HZ: f64 = 1.8;

    /// A 20 x 40 m floor (2 px/m) with a full-height wall at x in [10, 10.5).
    pub fn walled_map() -> FloorMap {
        let (w, h) = (40usize, 80usize);
        let mut f = vec![Feature::Walkable; w * h];
        for j in 0..h {
            f[j * w + 20] = Feature::Wall;
        }
        FloorMap::from_features(w, h, 2.0, f)
    }

    /// Beacons along x = 5 (left room) every 4 m from y = 2, plus one at
    /// (12, 20) behind the wall; all at phone height (dz = 0).
    pub fn beacons() -> Vec<Vec2> {
        let mut v: Vec<Vec2> = (0..10)
            .map(|k| Vec2::new(5.0, 2.0 + 4.0 * k as f64))
            .collect();
        v.push(Vec2::new(12.0, 20.0));
        v
    }

    pub fn site() -> Arc<Site> {
        let bs: Vec<(f64, f64)> = beacons().iter().map(|p| (p.x, p.y)).collect();
        beacon_site("nlos-test", vec![walled_map()], &bs, MODEL)
    }

    /// `seconds` of walking north along x = 7 from y = 4 (phone flat, top
    /// north), sensors at 50 Hz, adverts of every beacon every 0.2 s
    /// (noise-free model RSSI, or `rssi(i, t)` when given), truth every second.
    pub fn walk_north(seconds: i64, rssi: Option<&dyn Fn(usize, f64) -> f64>) -> Vec<LogEvent> {
        let q = UnitQuaternion::identity();
        let bs = beacons();
        let mut ev = Vec::new();
        let truth = |t: f64| Vec2::new(7.0, 4.0 + STEP_HZ * STEP_M * t);
        for i in 0..seconds * 50 {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let acc = Vector3::new(
                0.0,
                0.0,
                9.81 + 2.5 * (std::f64::consts::TAU * STEP_HZ * t).sin(),
            );
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::Accelerometer(acc.into()),
            }));
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::RotationVector(to_android(&q)),
            }));
            if i % 10 == 0 {
                let p = truth(t);
                for (k, b) in bs.iter().enumerate() {
                    let r = match rssi {
                        Some(f) => f(k, t),
                        None => MODEL.rssi_at(range_m(p, *b, 0.0, 0.5), 0.5),
                    };
                    ev.push(LogEvent::Ble(BleObservation {
                        t_ns,
                        beacon_id: format!("mac:00:00:00:00:00:{k:02X}"),
                        rssi_dbm: r,
                        tx_power_dbm: None,
                    }));
                }
            }
            if i % 50 == 0 {
                let p = truth(t);
                ev.push(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                }));
            }
        }
        ev
    }
}

#[cfg(test)]
mod tests {
    use super::testkit::*;
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use crate::engine::replay::{ReplayOutput, replay};
    use crate::engines::build_engine;
    use crate::events::LogEvent;

    fn near_beacon(x: f64, y: f64) -> FilteredBeacon {
        FilteredBeacon {
            index: 0,
            floor: 0,
            pos: Vec2::new(x, y),
            dz_m: 0.0,
            model: PathLoss {
                rssi_1m_dbm: -59.0,
                exponent: 2.0,
            },
            rssi_dbm: -65.0,
            var_dbm2: 1.0,
            samples: 3,
            last_t_ns: 0,
        }
    }

    #[test]
    fn a_move_into_a_wall_stops_just_before_it() {
        let map = walled_map();
        let (q, blocked) = move_with_map(&map, Vec2::new(9.0, 5.0), Vec2::new(2.0, 0.0), 0.05);
        assert!(blocked);
        assert!(q.x < 10.0 && q.x > 9.8 && map.is_walkable(q), "{q:?}");
        assert!((q.y - 5.0).abs() < 1e-12);
        let (q, blocked) = move_with_map(&map, Vec2::new(5.0, 5.0), Vec2::new(0.5, 0.6), 0.05);
        assert!(!blocked);
        assert!((q - Vec2::new(5.5, 5.6)).norm() < 1e-12);
        // a door is enterable: no stop, no penalty
        let mut f = vec![Feature::Walkable; 40 * 80];
        for j in 0..80 {
            f[j * 40 + 20] = Feature::Door;
        }
        let doors = FloorMap::from_features(40, 80, 2.0, f);
        let (q, blocked) = move_with_map(&doors, Vec2::new(9.5, 5.0), Vec2::new(1.0, 0.0), 0.05);
        assert!(!blocked && (q - Vec2::new(10.5, 5.0)).norm() < 1e-12);
        // non-finite move: stays
        let (q, blocked) = move_with_map(&map, Vec2::new(5.0, 5.0), Vec2::new(f64::NAN, 0.0), 0.05);
        assert!(!blocked && q == Vec2::new(5.0, 5.0));
    }

    #[test]
    fn wall_penalty_lowers_the_weight_and_clamps_at_zero() {
        // a particle pushed into the wall on every step loses 5 per step; w >= 0
        let cfg = ProxPfConfig::default();
        let map = walled_map();
        let mut w = 7.0;
        let mut p = Vec2::new(9.7, 5.0);
        let mut hits = 0;
        for _ in 0..3 {
            let (q, blocked) = move_with_map(&map, p, Vec2::new(0.65, 0.0), cfg.raycast_step_m);
            p = q;
            let dw = if blocked { cfg.wall_penalty } else { 0.0 };
            hits += usize::from(blocked);
            w = f64::max(w + dw, 0.0);
        }
        assert_eq!(hits, 3);
        assert_eq!(w, 0.0);
        assert!(p.x < 10.0);
    }

    #[test]
    fn proximity_gain_follows_eq_5_and_the_wall_rule() {
        let cfg = ProxPfConfig::default();
        let map = walled_map();
        let b = [near_beacon(12.0, 5.0)];
        // same room, 1.5 m away: P(1.5)
        let g = proximity_gain(Some(&map), Vec2::new(12.0, 6.5), &b, &cfg);
        assert!((g - (1.1077 - 0.3053 * 1.5)).abs() < 1e-12, "{g}");
        // 3 m away across the wall: 0 with the rule, P(3) without
        let p = Vec2::new(9.0, 5.0);
        assert_eq!(proximity_gain(Some(&map), p, &b, &cfg), 0.0);
        let off = ProxPfConfig {
            wall_rule: false,
            ..ProxPfConfig::default()
        };
        let g = proximity_gain(Some(&map), p, &b, &off);
        assert!((g - (1.1077 - 0.3053 * 3.0)).abs() < 1e-12);
        // two Near beacons add up (eq. 8); far particles get nothing
        let two = [near_beacon(12.0, 5.0), near_beacon(12.0, 7.0)];
        let g = proximity_gain(Some(&map), Vec2::new(12.0, 6.0), &two, &cfg);
        assert!((g - 2.0 * (1.1077 - 0.3053)).abs() < 1e-12);
        assert_eq!(
            proximity_gain(Some(&map), Vec2::new(18.0, 30.0), &two, &cfg),
            0.0
        );
        // a beacon mounted on the wall itself is still seen from its own room
        let on_wall = [near_beacon(10.2, 20.0)];
        assert!(proximity_gain(Some(&map), Vec2::new(8.5, 20.0), &on_wall, &cfg) > 0.0);
    }

    #[test]
    fn stratified_resampling_copies_in_proportion() {
        let mut rng = Pcg64::seed_from_u64(3);
        let mut ps: Vec<Particle> = (0..100)
            .map(|i| Particle {
                pos: Vec2::new(i as f64, 0.0),
                w: if i == 10 {
                    3.0
                } else if i == 20 {
                    1.0
                } else {
                    0.0
                },
            })
            .collect();
        stratified_resample(&mut rng, &mut ps);
        assert_eq!(ps.len(), 100);
        let n10 = ps.iter().filter(|p| p.pos.x == 10.0).count();
        let n20 = ps.iter().filter(|p| p.pos.x == 20.0).count();
        assert_eq!(n10 + n20, 100);
        assert_eq!(n10, 75, "stratified: exactly n w_i / W copies here");
        assert!(ps.iter().all(|p| p.w == 3.0 || p.w == 1.0));
        // all-zero weights: unchanged
        let mut zero: Vec<Particle> = (0..5)
            .map(|i| Particle {
                pos: Vec2::new(i as f64, 0.0),
                w: 0.0,
            })
            .collect();
        let before = zero.clone();
        stratified_resample(&mut rng, &mut zero);
        assert_eq!(zero, before);
    }

    #[test]
    fn a_dead_cloud_restarts_from_step_1_only_when_asked() {
        // every particle against the wall with weight 0 (the replica's seed
        // 5 after a turn): as printed the cloud stays there for good; with
        // `restart_when_all_zero` it is spread over the floor again
        for restart in [false, true] {
            let mut cfg = EngineConfig::default();
            cfg.prox_pf.restart_when_all_zero = restart;
            let mut e = ProxPfEngine::new(site(), &cfg, None).unwrap();
            e.floor = Some(0);
            e.evidence = true;
            e.particles = vec![
                Particle {
                    pos: Vec2::new(9.9, 5.0),
                    w: 0.0,
                };
                500
            ];
            e.step_once(1_000_000_000);
            let xs: Vec<f64> = e.particles.iter().map(|p| p.pos.x).collect();
            let spread = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - xs.iter().cloned().fold(f64::INFINITY, f64::min);
            if restart {
                assert_eq!(e.particles.len(), 500);
                assert!(spread > 10.0, "{spread}");
                assert!(
                    e.particles
                        .iter()
                        .all(|p| p.w == cfg.prox_pf.initial_weight)
                );
            } else {
                assert_eq!(spread, 0.0);
                assert!(e.particles.iter().all(|p| p.w == 0.0));
            }
        }
    }

    fn run(events: Vec<LogEvent>, seed: u64) -> ReplayOutput {
        let cfg = EngineConfig {
            seed,
            ..EngineConfig::default()
        };
        let mut e = build_engine("prox-pf", site(), &cfg, None).unwrap();
        replay(e.as_mut(), events)
    }

    #[test]
    fn tracks_a_walk_from_a_uniform_start_and_is_deterministic() {
        let out = run(walk_north(25, None), 7);
        let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
        assert!(errs.len() >= 20, "{} fixes", errs.len());
        let tail = &errs[errs.len() - 10..];
        let mean = tail.iter().sum::<f64>() / tail.len() as f64;
        assert!(mean < 2.0, "mean error of the last 10 s {mean}: {errs:?}");
        assert!(out.stats.steps > 30);
        let again = run(walk_north(25, None), 7);
        assert_eq!(out.track, again.track);
        let other = run(walk_north(25, None), 8);
        assert_ne!(out.track, other.track);
    }

    #[test]
    fn bad_input_gives_no_fix_and_no_nan() {
        for r in [0.0, 5.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let f = move |_: usize, _: f64| r;
            let out = run(walk_north(5, Some(&f)), 1);
            assert!(out.track.is_empty(), "rssi {r}");
            assert!(
                out.stats.no_fix > 0 && out.stats.rejected_inputs > 0,
                "rssi {r}"
            );
        }
        // unknown beacons only
        let ev: Vec<LogEvent> = walk_north(5, None)
            .into_iter()
            .map(|e| match e {
                LogEvent::Ble(mut b) => {
                    b.beacon_id = "mac:11:11:11:11:11:11".into();
                    LogEvent::Ble(b)
                }
                e => e,
            })
            .collect();
        let out = run(ev, 1);
        assert!(out.track.is_empty() && out.stats.unknown_beacons > 0);
        // a site without floor maps: no particles, no fix, no panic
        let mut s = (*site()).clone();
        s.floors.clear();
        let mut e = build_engine("prox-pf", Arc::new(s), &EngineConfig::default(), None).unwrap();
        let out = replay(e.as_mut(), walk_north(3, None));
        assert!(out.track.is_empty() && out.stats.no_fix > 0);
        // bad config names its field
        let mut cfg = EngineConfig::default();
        cfg.prox_pf.n_particles = 0;
        let err = build_engine("prox-pf", site(), &cfg, None)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("prox_pf.n_particles"), "{err}");
    }
}
