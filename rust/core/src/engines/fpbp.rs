//! Engines `fpbp` (GML + PF + PPC, the paper's system) and `bp` (GML + PF,
//! no PPC: the paper's ablation).
//!
//! Two tasks, as in the paper's Runnables, each owning its state:
//! - [`BleSide`] (`Task::Radio`, every `tasks.radio_period_ms`): BLE front end +
//!   GML + mean filter, publishes x_B.
//! - [`FusionSide`] (`Task::Fusion`, every `tasks.fusion_period_ms`): PDR,
//!   particle filter and PPC; consumes the steps detected since its last run,
//!   reads the latest x_B, publishes the pose.
//!
//! They meet only through two small `Copy` values: x_B (BLE -> fusion) and
//! the published position (fusion -> BLE, the x^(k-1) GML restricts its
//! candidate grid with, eqs. 20-21). [`FpbpEngine`] holds both sides and hands
//! these values across; a JNI host may put each side behind its own lock.
//!
//! Start-up: with an [`InitialPosition`] the particles start there; otherwise
//! at the mean of the first `fusion.init_ble_fixes` BLE positions (Sec.
//! IV-C). Without a fresh x_B (BLE-poor floors, gaps) the filter keeps dead
//! reckoning: particles move, weights stay uniform, PPC keeps the track on
//! the map and decides doors by the incident angle alone.
//!
//! Files: this one holds the fusion task and the engine; `fpbp/ble_side.rs`
//! the BLE task; `fpbp/tests.rs` the tests.

use std::sync::Arc;

mod ble_side;
pub use ble_side::BleSide;

use crate::Vec2;
use crate::ble::task::BleFix;
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorEvent};
use crate::fusion::recovery::{LikelihoodMonitor, dominant_room};
use crate::fusion::{FusionConfig, ParticleFilter, PpcCase, ppc};
use crate::pdr::Pdr;
use crate::site::Site;
use crate::{Error, Result};

/// How often each PPC branch fired (diagnostics).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PpcCounts {
    pub free: u64,
    pub start_on_obstacle: u64,
    pub yaw_corrected: u64,
    pub blocked: u64,
    pub door_blocked_same_room: u64,
    pub door_passed: u64,
    pub door_snapped: u64,
    /// Particles moved off obstacles after eq. 44.
    pub particles_replaced: u64,
    /// Steps where the heaviest room took the track through a wall
    /// (`fusion.room_switch_mass`, PPC skipped).
    pub room_switched: u64,
    /// Particles re-seeded around x_B (`fusion.recovery_max_fraction`).
    pub particles_reseeded: u64,
}

/// The nearest walkable point to `p` on rings of 0.1 m spacing (32 bearings
/// each), up to `max_m`.
pub(crate) fn nearest_walkable(map: &crate::map::FloorMap, p: Vec2, max_m: f64) -> Option<Vec2> {
    let rings = (max_m / 0.1).ceil() as usize;
    (1..=rings).find_map(|k| {
        let r = k as f64 * 0.1;
        (0..32).find_map(|a| {
            let th = a as f64 * std::f64::consts::TAU / 32.0;
            let q = p + Vec2::new(r * th.cos(), r * th.sin());
            map.is_walkable(q).then_some(q)
        })
    })
}

/// The fusion task: PDR, particle filter and (for `fpbp`) PPC.
pub struct FusionSide {
    site: Arc<Site>,
    cfg: FusionConfig,
    use_ppc: bool,
    pdr: Pdr,
    pf: ParticleFilter,
    period_ns: i64,
    floor: i32,
    /// Collected x_B for the start-up mean, and the time of the last one used.
    init_fixes: Vec<Vec2>,
    last_fix_t_ns: Option<i64>,
    /// Consecutive fresh fixes on another floor (floor change after
    /// `init_ble_fixes` of them).
    other_floor: Option<(i32, Vec<Vec2>)>,
    /// Particle positions before the last move (particle wall check).
    before: Vec<Vec2>,
    /// Which particles' last move crossed a Wall (particle wall check).
    crossed: Vec<bool>,
    /// Consecutive fresh x_B far from the fused position (re-localisation).
    far_fixes: Vec<Vec2>,
    /// x^(k-1): the last output position.
    prev: Option<Vec2>,
    heading_rad: f64,
    pose: Option<Pose>,
    steps: u64,
    /// Augmented-MCL likelihood averages (recovery extension).
    monitor: LikelihoodMonitor,
    /// Time of the last x_B that weighted the particles.
    weighted_fix_t_ns: Option<i64>,
    /// Whether the current start is a caller's [`InitialPosition`] (exact:
    /// no spread, no re-localisation unless configured) rather than a mean
    /// of BLE fixes.
    given_start: bool,
    /// Running mean of the innovation |x_B - x^(k-1)| over fresh fixes, and
    /// the time of the last fix counted (innovation-driven noise).
    innovation_mean_m: Option<f64>,
    innovation_fix_t_ns: Option<i64>,
    /// Re-localisations so far.
    pub relocalized: u64,
    pub ppc_counts: PpcCounts,
}

impl FusionSide {
    /// A fusion task on `site`; `init` starts the particles at a known point.
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        use_ppc: bool,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        let mut side = FusionSide {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            pf: ParticleFilter::new(&config.fusion, config.seed),
            cfg: config.fusion.clone(),
            use_ppc,
            period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            floor: site.default_floor(),
            site,
            init_fixes: Vec::new(),
            last_fix_t_ns: None,
            other_floor: None,
            far_fixes: Vec::new(),
            before: Vec::new(),
            crossed: Vec::new(),
            prev: None,
            heading_rad: 0.0,
            pose: None,
            steps: 0,
            monitor: LikelihoodMonitor::default(),
            weighted_fix_t_ns: None,
            given_start: false,
            innovation_mean_m: None,
            innovation_fix_t_ns: None,
            relocalized: 0,
            ppc_counts: PpcCounts::default(),
        };
        if let Some(i) = init {
            if !(i.x_m.is_finite() && i.y_m.is_finite()) {
                return Err(Error::Input(format!(
                    "initial position ({}, {}) is not finite",
                    i.x_m, i.y_m
                )));
            }
            side.floor = i.floor;
            side.heading_rad = i.heading_rad.filter(|h| h.is_finite()).unwrap_or(0.0);
            side.start(Vec2::new(i.x_m, i.y_m), None, true);
        }
        Ok(side)
    }

    /// Hands one sensor sample to the PDR.
    pub fn on_sensor(&mut self, e: &SensorEvent) {
        self.pdr.on_sensor(e);
    }

    /// Moves the filter to a caller's position now (a tap, a QR code): the
    /// particles restart on the point as for a given start, the steps the PDR
    /// detected before it are dropped, and the pose is published at `t_ns`.
    /// The heading is kept when `at` has none.
    pub fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<()> {
        crate::engine::check_initial_position(&self.site, &at)?;
        drop(self.pdr.take_steps());
        self.floor = at.floor;
        if let Some(h) = at.heading_rad {
            self.heading_rad = h;
        }
        self.weighted_fix_t_ns = None;
        self.innovation_mean_m = None;
        self.innovation_fix_t_ns = None;
        self.start(Vec2::new(at.x_m, at.y_m), Some(t_ns), true);
        Ok(())
    }

    /// Starts the particles at `at`: on the point for a caller's start
    /// (`given`), spread over `init_spread_m` for a start from BLE fixes.
    fn start(&mut self, at: Vec2, t_ns: Option<i64>, given: bool) {
        let spread = if given { 0.0 } else { self.cfg.init_spread_m };
        self.given_start = given;
        let map = self.site.floor(self.floor);
        // A start on an obstacle (a mean of BLE fixes, a tap on a wall) moves
        // to the nearest walkable point found within 5 m.
        let at = match map {
            Some(m) if !m.is_walkable(at) => nearest_walkable(m, at, 5.0).unwrap_or(at),
            _ => at,
        };
        self.pf
            .init_at(at, spread, |p| map.is_none_or(|m| m.is_walkable(p)));
        self.prev = Some(at);
        self.init_fixes.clear();
        self.other_floor = None;
        self.far_fixes.clear();
        self.monitor.reset();
        if let Some(t) = t_ns {
            self.publish(t, at);
        }
    }

    fn publish(&mut self, t_ns: i64, pos: Vec2) {
        // Fused while an x_B weighted the particles within `ble_max_age_s`;
        // otherwise the pose rests on the start and the steps since.
        let max_age_ns = (self.cfg.ble_max_age_s * 1e9) as i64;
        let source = match self.weighted_fix_t_ns {
            Some(f) if t_ns.saturating_sub(f) <= max_age_ns => crate::engine::PoseSource::Fused,
            _ => crate::engine::PoseSource::DeadReckoning,
        };
        self.pose = Some(Pose {
            t_ns,
            x_m: pos.x,
            y_m: pos.y,
            floor: self.floor,
            heading_rad: self.heading_rad,
            accuracy_m: self.pf.spread_m().max(0.5),
            floor_prob: 1.0,
            source,
        });
    }

    /// Takes in a new x_B: start-up averaging and floor changes. Returns the
    /// fix when it may weight the particles.
    fn take_fix(&mut self, t_ns: i64, fix: Option<BleFix>) -> Option<BleFix> {
        let fix = fix?;
        let max_age_ns = (self.cfg.ble_max_age_s * 1e9) as i64;
        if t_ns.saturating_sub(fix.t_ns) > max_age_ns {
            return None;
        }
        let fresh = self.last_fix_t_ns != Some(fix.t_ns);
        self.last_fix_t_ns = Some(fix.t_ns);
        let need = self.cfg.init_ble_fixes as usize;
        if !self.pf.is_initialized() {
            if fresh {
                if self.init_fixes.is_empty() {
                    self.floor = fix.floor;
                }
                if fix.floor != self.floor {
                    self.init_fixes.clear();
                    self.floor = fix.floor;
                }
                self.init_fixes.push(fix.pos);
                if self.init_fixes.len() >= need {
                    let n = self.init_fixes.len() as f64;
                    let mean = self.init_fixes.iter().sum::<Vec2>() / n;
                    self.start(mean, Some(t_ns), false);
                }
            }
            return None;
        }
        if fix.floor != self.floor {
            if fresh {
                let entry = self.other_floor.get_or_insert((fix.floor, Vec::new()));
                if entry.0 != fix.floor {
                    *entry = (fix.floor, Vec::new());
                }
                entry.1.push(fix.pos);
                if entry.1.len() >= need {
                    let n = entry.1.len() as f64;
                    let mean = entry.1.iter().sum::<Vec2>() / n;
                    self.floor = fix.floor;
                    // Floors share the site's x, y frame: the walker changes
                    // floor where the track is (stairs, lift), not at x_B.
                    let at = match self.prev {
                        Some(p) if self.cfg.floor_change_keeps_position => p,
                        _ => mean,
                    };
                    self.start(at, Some(t_ns), false);
                }
            }
            return None;
        }
        if fresh {
            self.other_floor = None;
            let n = self.cfg.relocalize_after_fixes as usize;
            if n > 0
                && (!self.given_start || self.cfg.relocalize_after_given_start)
                && let Some(prev) = self.prev
            {
                if (fix.pos - prev).norm() > self.cfg.relocalize_distance_m {
                    self.far_fixes.push(fix.pos);
                    if self.far_fixes.len() >= n {
                        let mean = self.far_fixes.iter().sum::<Vec2>() / n as f64;
                        self.relocalized += 1;
                        self.start(mean, Some(t_ns), false);
                        return None;
                    }
                } else {
                    self.far_fixes.clear();
                }
            }
        }
        Some(fix)
    }

    /// One fusion run at `t_ns` with the latest x_B: every step the PDR
    /// detected since the last run moves, weights and resamples the
    /// particles, then PPC corrects the estimate.
    pub fn run(&mut self, t_ns: i64, x_b: Option<BleFix>) {
        let steps: Vec<(f64, f64)> = self
            .pdr
            .take_steps()
            .into_iter()
            .map(|s| (s.length_m, s.yaw_rad))
            .collect();
        self.run_steps(t_ns, x_b, &steps);
    }

    /// [`FusionSide::run`] with explicit steps (length_m, yaw_rad) instead of
    /// the PDR's pending ones (tests, other front ends).
    pub fn run_steps(&mut self, t_ns: i64, x_b: Option<BleFix>, steps: &[(f64, f64)]) {
        let fix = self.take_fix(t_ns, x_b);
        if !self.pf.is_initialized() {
            return;
        }
        if self.pose.is_none()
            && let Some(p) = self.prev
        {
            // Started from an InitialPosition: publish it at the first run.
            self.publish(t_ns, p);
        }
        let site = Arc::clone(&self.site);
        let map = site.floor(self.floor);
        let mut last = None;
        for &(length_m, yaw_rad) in steps {
            if !(length_m.is_finite() && yaw_rad.is_finite() && length_m >= 0.0) {
                continue;
            }
            self.steps += 1;
            let check = self.use_ppc && self.cfg.particle_wall_check && map.is_some();
            if check {
                self.before.clear();
                self.before.extend_from_slice(self.pf.particles());
            }
            if self.cfg.innovation_noise_gain > 0.0 {
                let sd = self.innovation_noise_m(fix);
                self.pf.set_extra_noise(sd);
            }
            self.pf.predict(length_m, yaw_rad);
            let mut reseed = 0.0;
            let weigh = fix.filter(|f| {
                !self.cfg.weight_each_fix_once || self.weighted_fix_t_ns != Some(f.t_ns)
            });
            if let Some(f) = weigh {
                self.weighted_fix_t_ns = Some(f.t_ns);
                if self.use_ppc && map.is_some() && self.cfg.recovery_max_fraction > 0.0 {
                    let l = self.pf.mean_likelihood(f.pos, self.cfg.sigma_x_m);
                    reseed = self.monitor.update(
                        l,
                        self.cfg.recovery_alpha_slow,
                        self.cfg.recovery_alpha_fast,
                        self.cfg.recovery_max_fraction,
                    );
                }
                self.pf.weight(f.pos);
            }
            if check && let Some(m) = map {
                let step_m = self.cfg.ppc.raycast_step_m;
                if self.cfg.particles_pass_doors {
                    // ppc::crosses_wall of every move, in one call
                    ppc::crosses_wall_each(
                        m,
                        &self.before,
                        self.pf.particles(),
                        step_m,
                        &mut self.crossed,
                    );
                    self.pf
                        .penalize_flagged(&self.crossed, self.cfg.wall_crossing_weight);
                } else {
                    self.pf
                        .penalize_moves(&self.before, self.cfg.wall_crossing_weight, |a, b| {
                            m.raycast(a, b, step_m).is_some()
                        });
                }
            }
            // Room-level hypothesis: the heaviest room's mean is the estimate.
            let mode = match map {
                Some(m) if self.use_ppc && self.cfg.room_estimate => {
                    dominant_room(self.pf.particles(), self.pf.weights(), |p| m.room_of(p))
                }
                _ => None,
            };
            let Some(x_hat) = mode.map(|r| r.mean).or_else(|| self.pf.mean()) else {
                return;
            };
            self.pf.resample_if_degenerate();
            let prev = self.prev.unwrap_or(x_hat);
            // The heaviest room is not the previous one and holds enough of
            // the weight: the cloud has moved, follow it even through a wall.
            let switch = match (map, mode) {
                (Some(m), Some(r))
                    if self.cfg.room_switch_mass > 0.0
                        && r.mass >= self.cfg.room_switch_mass
                        && m.room_of(prev).is_some_and(|p| p != r.room) =>
                {
                    m.nearest_walkable_in_room(r.room, r.mean)
                }
                _ => None,
            };
            let pos = match (self.use_ppc, map, switch) {
                (true, Some(m), Some(to)) => {
                    self.ppc_counts.room_switched += 1;
                    let doors_ok = self.cfg.particles_pass_doors;
                    let n = self
                        .pf
                        .replace_invalid(|p| ppc::blocks_particle(m.feature(p), doors_ok), to);
                    self.ppc_counts.particles_replaced += n as u64;
                    to
                }
                (true, Some(m), None) if self.cfg.ppc.enabled => {
                    let o = ppc::correct(m, prev, x_hat, fix.map(|f| f.pos), &self.cfg.ppc);
                    self.count(o.case);
                    let n = ppc::apply_to_particles_with_doors(
                        m,
                        &mut self.pf,
                        x_hat,
                        &o,
                        self.cfg.ppc.shift_particles,
                        self.cfg.particles_pass_doors,
                    );
                    self.ppc_counts.particles_replaced += n as u64;
                    o.position
                }
                _ => x_hat,
            };
            if reseed > 0.0
                && let (Some(m), Some(f)) = (map, fix)
            {
                let n = self
                    .pf
                    .inject(reseed, f.pos, self.cfg.recovery_sigma_m, |p| {
                        m.is_walkable(p)
                    });
                self.ppc_counts.particles_reseeded += n as u64;
            }
            let d = pos - prev;
            self.heading_rad = if d.norm() > 1e-6 {
                d.y.atan2(d.x)
            } else {
                yaw_rad
            };
            self.prev = Some(pos);
            last = Some(pos);
        }
        if let Some(p) = last {
            self.publish(t_ns, p);
        }
    }

    /// Innovation-driven process noise (`fusion.innovation_noise_gain`):
    /// the innovation d = |x_B - x^(k-1)| of the latest fix updates its
    /// running mean once per fix; the noise is gain (d - free), free =
    /// max(`innovation_free_m`, `innovation_typical_ratio` x mean), clamped
    /// to [0, `innovation_noise_max_m`]. Without a fix, 0.
    fn innovation_noise_m(&mut self, fix: Option<BleFix>) -> f64 {
        let (Some(f), Some(prev)) = (fix, self.prev) else {
            return 0.0;
        };
        let d = (f.pos - prev).norm();
        if self.innovation_fix_t_ns != Some(f.t_ns) {
            self.innovation_fix_t_ns = Some(f.t_ns);
            let b = self.cfg.innovation_average_rate;
            self.innovation_mean_m = Some(match self.innovation_mean_m {
                Some(m) => (1.0 - b) * m + b * d,
                None => d,
            });
        }
        let typical = self.cfg.innovation_typical_ratio * self.innovation_mean_m.unwrap_or(0.0);
        let free = self.cfg.innovation_free_m.max(typical);
        (self.cfg.innovation_noise_gain * (d - free)).clamp(0.0, self.cfg.innovation_noise_max_m)
    }

    fn count(&mut self, case: PpcCase) {
        let c = &mut self.ppc_counts;
        match case {
            PpcCase::Free => c.free += 1,
            PpcCase::StartOnObstacle => c.start_on_obstacle += 1,
            PpcCase::YawCorrected { .. } => c.yaw_corrected += 1,
            PpcCase::Blocked { .. } => c.blocked += 1,
            PpcCase::DoorBlockedSameRoom => c.door_blocked_same_room += 1,
            PpcCase::DoorPassed => c.door_passed += 1,
            PpcCase::DoorSnapped => c.door_snapped += 1,
        }
    }

    /// The latest published pose.
    pub fn pose(&self) -> Option<Pose> {
        self.pose
    }

    /// The particles (for plots and tests).
    pub fn particles(&self) -> &[Vec2] {
        self.pf.particles()
    }

    /// Steps fused so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }
}

/// `fpbp` / `bp`: a [`BleSide`] and a [`FusionSide`] meeting through x_B.
pub struct FpbpEngine {
    name: &'static str,
    ble: BleSide,
    fusion: FusionSide,
    /// The latest x_B published by the BLE side.
    x_b: Option<BleFix>,
    stats: EngineStats,
}

impl FpbpEngine {
    /// `use_ppc`: true for `fpbp`, false for `bp`.
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        use_ppc: bool,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        config.validate()?;
        Ok(FpbpEngine {
            name: if use_ppc { "fpbp" } else { "bp" },
            ble: BleSide::new(&site, config),
            fusion: FusionSide::new(site, config, use_ppc, init)?,
            x_b: None,
            stats: EngineStats::default(),
        })
    }

    /// The fusion side (particles, PPC counters).
    pub fn fusion(&self) -> &FusionSide {
        &self.fusion
    }
}

impl Engine for FpbpEngine {
    fn name(&self) -> &'static str {
        self.name
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.fusion.on_sensor(event);
        self.ble.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        if !self.ble.on_ble(obs) {
            self.stats.unknown_beacons += 1;
        }
    }

    /// The particles restart at `at`; the BLE side forgets its mean filter
    /// and the x_B from before, so the next fix is computed around `at`.
    fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<()> {
        self.fusion.set_position(t_ns, at)?;
        self.ble.reset_position();
        self.x_b = None;
        Ok(())
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        match task {
            Task::Radio => {
                let prev = self.fusion.pose().map(|p| Vec2::new(p.x_m, p.y_m));
                match self.ble.run(t_ns, prev) {
                    Some(fix) => self.x_b = Some(fix),
                    None => self.stats.no_fix += 1,
                }
            }
            Task::Fusion => self.fusion.run(t_ns, self.x_b),
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        Some(match task {
            Task::Radio => self.ble.period_ns,
            Task::Fusion => self.fusion.period_ns,
        })
    }

    fn pose(&self) -> Option<Pose> {
        self.fusion.pose()
    }

    fn ble_position(&self) -> Option<Pose> {
        self.x_b.map(|f| Pose {
            t_ns: f.t_ns,
            x_m: f.pos.x,
            y_m: f.pos.y,
            floor: f.floor,
            heading_rad: 0.0,
            accuracy_m: 0.0,
            floor_prob: 1.0,
            source: crate::engine::PoseSource::Radio,
        })
    }

    fn stats(&self) -> EngineStats {
        EngineStats {
            steps: self.fusion.steps(),
            ..self.stats.clone()
        }
    }
}

#[cfg(test)]
mod tests;
