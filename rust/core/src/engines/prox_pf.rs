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
//!
//! The particles are a [`crate::fusion::Cloud`]; Steps 2 and 3 are the
//! [`models`] [`ProxMotion`] and [`ProxWeights`] (the generic
//! [`MotionModel`] and [`MeasurementModel`]), Step 5 is
//! [`Cloud::resample_stratified_keeping_weights`]. `testkit` holds the
//! synthetic site and walk other engines' tests share.

use std::sync::Arc;

use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::ble::proximity::{Proximity, ProximityConfig};
use crate::ble::{BleFrontEnd, FilteredBeacon};
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorEvent};
use crate::fusion::{Cloud, MeasurementModel, MotionModel};
use crate::pdr::Pdr;
use crate::site::Site;
use crate::{Error, Result, Vec2};

pub mod models;
#[cfg(test)]
pub(crate) mod testkit;
#[cfg(test)]
mod tests;

pub use models::{
    ProxMotion, ProxMoves, ProxReadings, ProxWeights, first_wall, move_with_map, proximity_gain,
};
pub(crate) use models::{floor_map, sample_walkable};

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

/// The proximity-PF engine.
pub struct ProxPfEngine {
    cfg: ProxPfConfig,
    site: Arc<Site>,
    pdr: Pdr,
    front: BleFrontEnd,
    top_n: usize,
    rng: Pcg64,
    /// The particles: positions, accumulated likelihoods w, wall penalties.
    cloud: Cloud,
    motion: ProxMotion,
    weights: ProxWeights,
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
            cloud: models::new_cloud(cfg.n_particles),
            motion: ProxMotion::new(&cfg),
            weights: ProxWeights::new(&cfg),
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
    pub fn cloud(&self) -> &Cloud {
        &self.cloud
    }

    fn initialise(&mut self, floor: i32) {
        self.cloud.clear();
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
                Some(pos) => self.cloud.push(pos, self.cfg.initial_weight),
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
        if self.cloud.is_empty() {
            self.stats.no_fix += 1;
            return;
        }
        // Step 2: move
        for s in &steps {
            if s.yaw_rad.is_finite() && s.length_m.is_finite() {
                self.heading_rad = s.yaw_rad;
            }
        }
        let moves = ProxMoves { steps: &steps, map };
        self.motion
            .propagate(&mut self.cloud, &mut self.rng, &moves);
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
        let readings = ProxReadings { map, near: &near };
        self.weights.update(&mut self.cloud, &readings);
        self.evidence |= self.weights.saw_evidence();
        // Step 4: estimate
        let (positions, weights) = (self.cloud.positions(), self.cloud.weights());
        let total: f64 = weights.iter().sum();
        // dead: weights were positive (w(0) > 0 or a Near reading) and all fell to 0
        let had_weight = self.evidence || self.cfg.initial_weight > 0.0;
        if total == 0.0 && had_weight && self.cfg.restart_when_all_zero {
            // every likelihood is 0: no estimate now, start again from Step 1
            self.stats.no_fix += 1;
            self.initialise(floor);
            return;
        }
        let n = positions.len() as f64;
        let (mean, weights_used) = if !(self.informed || self.evidence) {
            (None, false)
        } else if total > 0.0 && total.is_finite() {
            let m = positions
                .iter()
                .zip(weights)
                .fold(Vec2::zeros(), |a, (p, w)| a + p * *w)
                / total;
            (Some(m), true)
        } else if self.informed {
            let m = positions.iter().fold(Vec2::zeros(), |a, p| a + p) / n;
            (Some(m), false)
        } else {
            (None, false)
        };
        match mean.filter(|m| m.x.is_finite() && m.y.is_finite()) {
            Some(m) => {
                let var = positions
                    .iter()
                    .zip(weights)
                    .map(|(p, w)| {
                        let w = if weights_used { w / total } else { 1.0 / n };
                        w * (p - m).norm_squared()
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
        self.cloud
            .resample_stratified_keeping_weights(&mut self.rng);
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
