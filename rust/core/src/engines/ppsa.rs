//! Engine `ppsa`: the RSSI/PDR probabilistic position selection algorithm
//! with NLOS identification (../shared/papers/ppsa-rssi-pdr-nlos.txt).
//!
//! One Fusion task per time slot (`ppsa.slot_s`, default 1 s):
//! - PDR over the slot: distance walked s = v dt, heading mean alpha and
//!   spread sigma_alpha of the steps' yaws (circular statistics).
//! - Measured RSSI per beacon: the mean of the slot's adverts (Sec. 2).
//! - Initial positioning (Sec. 2.1), when there is no previous position and
//!   no start was handed over: particles around the strongest beacon (no
//!   prediction exists yet, so every path counts as LOS), scored by eqs. 16-19.
//! - Normal positioning: predicted position X^ = X_{k-1} + s (cos a, sin a)
//!   (eq. 1 in the MCS, heading from +x); NLOS identification of every
//!   beacon at X^ ([`crate::ble::nlos`], eqs. 2-10); n random particles
//!   uniform in the disc of radius max(1.5 v dt, `min_radius_m`) around
//!   X_{k-1} (Sec. 3.1), those on a wall dropped; selection in the location
//!   ID (the room with the most LOS beacons, Sec. 3.3, [`select_in_area`])
//!   and in the ring of the best LOS beacon (eqs. 11-14); score res = P1 + P2 (eqs.
//!   15-22) with P1 = sum over LOS paths of A_j normpdf(RSSI_j, RSSI_ij,
//!   sigma_LOS), A_j ~ 1/|delta_j|, and P2 = normpdf(alpha_i, alpha,
//!   sigma_alpha) (only when the user walked); the best particle is the
//!   position (eq. 23).
//!
//! PPSA is a select-the-best sampler, not a recursive particle filter: the
//! candidates are drawn afresh each slot (no motion model propagates them,
//! no weights carry over, nothing is resampled), so it uses only the shared
//! draws ([`crate::fusion::random::in_disc`], the walkable sampling of
//! `prox-pf`), not the [`crate::fusion::Cloud`].

use std::collections::BTreeMap;
use std::sync::Arc;

use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use super::prox_pf::sample_walkable;
use crate::ble::nlos::{NlosIdentifier, PathCondition, normpdf};
use crate::ble::pathloss::{horizontal_m, range_m};
use crate::ble::{BleFrontEnd, FilteredBeacon};
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorEvent};
use crate::fusion::random::in_disc;
use crate::geometry::wrap_angle;
use crate::pdr::Pdr;
use crate::site::Site;
use crate::{Error, Result, Vec2};

/// Parameters of `ppsa` (`EngineConfig::ppsa`). The LOS/NLOS statistics
/// come from `ble.nlos`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PpsaConfig {
    /// Delta t, length of a time slot, seconds. Default 1 (paper Sec. 2).
    pub slot_s: f64,
    /// Random particles per slot. The paper does not give it; default 500.
    pub n_particles: usize,
    /// Radius factor of Sec. 3.1 (r = factor v dt). Default 1.5 (paper).
    pub radius_factor: f64,
    /// Smallest generation radius, metres (the paper's r is 0 when standing).
    /// Default 1.
    pub min_radius_m: f64,
    /// Radius of the initial-positioning cloud around the strongest beacon,
    /// metres. Default 6 (the paper's beacon spacing).
    pub init_radius_m: f64,
    /// k of eqs. 11-12 (ring = mu +/- k sigma_LOS). Default 3 (paper).
    pub ring_sigmas: f64,
    /// Floor of sigma_alpha, radians (one step has no spread). Default 0.2.
    pub min_heading_sigma_rad: f64,
    /// Floor of |delta_j| in the weights A_j = 1/|delta_j| (eq. 19), dB. Default 0.5.
    pub min_delta_db: f64,
    /// Evaluate P2 (eq. 21) with the angles in degrees. The paper adds a
    /// density over dBm (P1) to a density over angle (P2) without naming
    /// the angle's unit; in radians (sigma_alpha ~0.2) P2 peaks at ~2 while
    /// P1 stays below 0.21 (sigma_LOS 1.9 dB), so the PDR heading alone picks
    /// the particle and the RSSI hardly counts (docs/reproduction.md, PPSA).
    /// In degrees P2 is 57.3 times smaller. Default false (radians).
    pub heading_score_degrees: bool,
}

impl Default for PpsaConfig {
    fn default() -> Self {
        PpsaConfig {
            slot_s: 1.0,
            n_particles: 500,
            radius_factor: 1.5,
            min_radius_m: 1.0,
            init_radius_m: 6.0,
            ring_sigmas: 3.0,
            min_heading_sigma_rad: 0.2,
            min_delta_db: 0.5,
            heading_score_degrees: false,
        }
    }
}

impl PpsaConfig {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<()> {
        crate::bounds::check_range("ppsa.slot_s", self.slot_s, 0.01, 3600.0)?;
        for (f, v) in [
            ("slot_s", self.slot_s),
            ("radius_factor", self.radius_factor),
            ("min_radius_m", self.min_radius_m),
            ("init_radius_m", self.init_radius_m),
            ("ring_sigmas", self.ring_sigmas),
            ("min_heading_sigma_rad", self.min_heading_sigma_rad),
            ("min_delta_db", self.min_delta_db),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(
                    format!("ppsa.{f}"),
                    format!("must be finite and > 0, got {v}"),
                ));
            }
        }
        if self.n_particles == 0 || self.n_particles > 1_000_000 {
            return Err(Error::config("ppsa.n_particles", "must be in 1..=1000000"));
        }
        Ok(())
    }
}

/// The ring of eqs. 11-14 around beacon `b` whose slot-mean RSSI is `mu_dbm`:
/// horizontal radii (inner, outer), metres. RSSI_high = mu + k sigma gives
/// the inner radius, RSSI_low = mu - k sigma the outer one.
pub fn ring_radii(b: &FilteredBeacon, mu_dbm: f64, sigma_los_dbm: f64, k: f64) -> (f64, f64) {
    let d_in = b.model.distance(mu_dbm + k * sigma_los_dbm);
    let d_out = b.model.distance(mu_dbm - k * sigma_los_dbm);
    (horizontal_m(d_in, b.dz_m), horizontal_m(d_out, b.dz_m))
}

/// Whether `p` lies in the ring (inclusive).
pub fn in_ring(p: Vec2, centre: Vec2, radii: (f64, f64)) -> bool {
    let d = (p - centre).norm();
    d >= radii.0 && d <= radii.1
}

/// One beacon heard in the slot with its identification.
#[derive(Debug, Clone, Copy)]
struct Path {
    beacon: FilteredBeacon,
    /// Slot mean of the adverts, dBm.
    mean_dbm: f64,
    delta_db: f64,
    los: bool,
}

/// The PPSA engine.
pub struct PpsaEngine {
    cfg: PpsaConfig,
    site: Arc<Site>,
    pdr: Pdr,
    front: BleFrontEnd,
    nlos: NlosIdentifier,
    phone_height_m: f64,
    min_distance_m: f64,
    top_n: usize,
    rng: Pcg64,
    /// Slot sums of raw RSSI per registry index: (sum, count, last t).
    slot: BTreeMap<usize, (f64, u32, i64)>,
    last: Option<(Vec2, i32)>,
    init: Option<InitialPosition>,
    heading_rad: f64,
    period_ns: i64,
    pose: Option<Pose>,
    stats: EngineStats,
    /// Paths identified as NLOS / all paths identified (diagnostics).
    pub nlos_counts: (u64, u64),
}

impl PpsaEngine {
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        config.validate()?;
        let init = init.filter(|i| i.x_m.is_finite() && i.y_m.is_finite());
        Ok(PpsaEngine {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            front: BleFrontEnd::new(&config.ble, &site),
            nlos: NlosIdentifier::new(&config.ble.nlos, config.ble.min_distance_m),
            phone_height_m: config.ble.phone_height_m,
            min_distance_m: config.ble.min_distance_m,
            top_n: config.ble.gml.top_n,
            rng: Pcg64::seed_from_u64(config.seed),
            slot: BTreeMap::new(),
            last: None,
            heading_rad: init
                .and_then(|i| i.heading_rad)
                .filter(|h| h.is_finite())
                .unwrap_or(0.0),
            init,
            period_ns: ((config.ppsa.slot_s * 1e9).round() as i64).max(1),
            cfg: config.ppsa.clone(),
            site,
            pose: None,
            stats: EngineStats::default(),
            nlos_counts: (0, 0),
        })
    }

    /// The slot's beacons (slot means), strongest first, ties by index.
    fn slot_beacons(&self) -> Vec<FilteredBeacon> {
        let reg = self.front.registry();
        let mut out: Vec<FilteredBeacon> = self
            .slot
            .iter()
            .filter_map(|(&index, &(sum, n, last_t_ns))| {
                let b = reg.get(index)?;
                let mean = sum / f64::from(n.max(1));
                mean.is_finite().then_some(FilteredBeacon {
                    index,
                    floor: b.floor,
                    pos: b.pos,
                    dz_m: b.z_m - self.phone_height_m,
                    model: b.model,
                    rssi_dbm: mean,
                    var_dbm2: 0.0,
                    samples: n,
                    last_t_ns,
                })
            })
            .collect();
        out.sort_by(|a, b| {
            b.rssi_dbm
                .total_cmp(&a.rssi_dbm)
                .then(a.index.cmp(&b.index))
        });
        out
    }

    fn run_slot(&mut self, t_ns: i64) {
        let steps = self.pdr.take_steps();
        self.stats.steps += steps.len() as u64;
        let (mut dist, mut sx, mut sy) = (0.0, 0.0, 0.0);
        let mut yaws = Vec::new();
        for s in steps
            .iter()
            .filter(|s| s.length_m.is_finite() && s.yaw_rad.is_finite())
        {
            dist += s.length_m;
            sx += s.length_m * s.yaw_rad.cos();
            sy += s.length_m * s.yaw_rad.sin();
            yaws.push(s.yaw_rad);
        }
        let alpha = sy.atan2(sx);
        let sigma_alpha = circular_std(&yaws).max(self.cfg.min_heading_sigma_rad);
        let walked = dist > 0.0;
        if walked {
            self.heading_rad = alpha;
        }
        let all = self.slot_beacons();
        self.slot.clear();
        let floor = BleFrontEnd::likely_floor(&all, self.top_n);
        let beacons: Vec<FilteredBeacon> =
            all.into_iter().filter(|b| Some(b.floor) == floor).collect();

        // start: handed over, or initial positioning (Sec. 2.1)
        if self.last.is_none()
            && let Some(i) = self.init.take()
        {
            self.last = Some((Vec2::new(i.x_m, i.y_m), i.floor));
        }
        // a different floor: start again
        if let (Some((_, lf)), Some(f)) = (self.last, floor)
            && lf != f
        {
            self.last = None;
        }
        let Some((prev, prev_floor)) = self.last else {
            match self.initial_positioning(&beacons, floor) {
                Some((p, f)) => self.set_pose(t_ns, p, f),
                None => self.stats.no_fix += 1,
            }
            return;
        };

        // eq. 1: prediction by PDR (MCS: heading from +x)
        let step = if walked {
            Vec2::new(sx, sy)
        } else {
            Vec2::zeros()
        };
        let predicted = prev + step;
        let paths: Vec<Path> = beacons
            .iter()
            .filter_map(|b| {
                let v = self.nlos.identify(b, b.rssi_dbm, predicted)?;
                Some(Path {
                    beacon: *b,
                    mean_dbm: b.rssi_dbm,
                    delta_db: v.delta_db,
                    los: v.condition == PathCondition::Los,
                })
            })
            .collect();
        self.nlos_counts.0 += paths.iter().filter(|p| !p.los).count() as u64;
        self.nlos_counts.1 += paths.len() as u64;

        // Sec. 3.1: particles around the previous position
        let v = dist / self.cfg.slot_s;
        let radius = (self.cfg.radius_factor * v * self.cfg.slot_s).max(self.cfg.min_radius_m);
        let particles = self.generate(prev, radius, prev_floor);
        // Sec. 3.3 / Sec. 2: the location ID (positionID) is the area holding
        // the largest number of LOS beacons; particles outside it are dropped.
        let los_pos: Vec<Vec2> = paths
            .iter()
            .filter(|p| p.los)
            .map(|p| p.beacon.pos)
            .collect();
        let particles = select_in_area(
            &particles,
            super::prox_pf::floor_map(&self.site, prev_floor),
            &los_pos,
        );
        let best_los = paths
            .iter()
            .filter(|p| p.los)
            .min_by(|a, b| a.delta_db.abs().total_cmp(&b.delta_db.abs()));
        let selected = select_in_ring(
            &particles,
            best_los.map(|p| (p.beacon, p.mean_dbm)),
            self.nlos.config().sigma_los_dbm,
            self.cfg.ring_sigmas,
        );
        let heading = walked.then_some((prev, alpha, sigma_alpha));
        let best = self.best_particle(&selected, &paths, heading);
        let p = best.unwrap_or(predicted);
        if p.x.is_finite() && p.y.is_finite() {
            self.set_pose(t_ns, p, prev_floor);
        } else {
            self.stats.no_fix += 1;
        }
    }

    fn set_pose(&mut self, t_ns: i64, p: Vec2, floor: i32) {
        self.last = Some((p, floor));
        self.pose = Some(Pose {
            t_ns,
            x_m: p.x,
            y_m: p.y,
            floor,
            heading_rad: self.heading_rad,
            accuracy_m: self.nlos.config().sigma_los_dbm.max(1.0),
            floor_prob: 1.0,
            source: crate::engine::PoseSource::Fused,
        });
    }

    /// n particles uniform in the disc, on walkable points when the floor has a map.
    fn generate(&mut self, centre: Vec2, radius: f64, floor: i32) -> Vec<Vec2> {
        let site = Arc::clone(&self.site);
        let map = super::prox_pf::floor_map(&site, floor);
        let mut out = Vec::with_capacity(self.cfg.n_particles);
        for _ in 0..self.cfg.n_particles {
            let p = match map {
                Some(m) => sample_walkable(&mut self.rng, m, Some((centre, radius)), 1),
                None => Some(in_disc(&mut self.rng, centre, radius)),
            };
            out.extend(p);
        }
        out
    }

    fn initial_positioning(
        &mut self,
        beacons: &[FilteredBeacon],
        floor: Option<i32>,
    ) -> Option<(Vec2, i32)> {
        let floor = floor?;
        let strongest = beacons.first()?;
        let particles = self.generate(strongest.pos, self.cfg.init_radius_m, floor);
        let paths: Vec<Path> = beacons
            .iter()
            .map(|b| Path {
                beacon: *b,
                mean_dbm: b.rssi_dbm,
                delta_db: 1.0,
                los: true,
            })
            .collect();
        let selected = select_in_ring(
            &particles,
            Some((*strongest, strongest.rssi_dbm)),
            self.nlos.config().sigma_los_dbm,
            self.cfg.ring_sigmas,
        );
        self.best_particle(&selected, &paths, None)
            .map(|p| (p, floor))
    }

    /// Eqs. 15-23: the particle with the highest res = P1 + P2.
    fn best_particle(
        &self,
        particles: &[Vec2],
        paths: &[Path],
        heading: Option<(Vec2, f64, f64)>,
    ) -> Option<Vec2> {
        let sigma = self.nlos.config().sigma_los_dbm;
        let los: Vec<&Path> = paths.iter().filter(|p| p.los).collect();
        let inv: Vec<f64> = los
            .iter()
            .map(|p| 1.0 / p.delta_db.abs().max(self.cfg.min_delta_db))
            .collect();
        let inv_sum: f64 = inv.iter().sum();
        let mut best: Option<(f64, Vec2)> = None;
        for &x in particles {
            let mut p1 = 0.0;
            for (p, a) in los.iter().zip(&inv) {
                let d = range_m(x, p.beacon.pos, p.beacon.dz_m, self.min_distance_m);
                let expected = p.beacon.model.rssi_at(d, self.min_distance_m);
                p1 += a / inv_sum * normpdf(p.mean_dbm, expected, sigma);
            }
            let p2 = match heading {
                Some((prev, alpha, s_alpha)) if (x - prev).norm() > 1e-9 => {
                    let a_i = (x.y - prev.y).atan2(x.x - prev.x);
                    let unit = if self.cfg.heading_score_degrees {
                        180.0 / std::f64::consts::PI
                    } else {
                        1.0
                    };
                    normpdf(unit * wrap_angle(a_i - alpha), 0.0, unit * s_alpha)
                }
                _ => 0.0,
            };
            let res = p1 + p2;
            if res.is_finite() && best.is_none_or(|(r, _)| res > r) {
                best = Some((res, x));
            }
        }
        best.map(|(_, x)| x)
    }
}

/// Sec. 3.3 (location ID): the particles in the room (4-connected walkable
/// area of `map`, doors and walls bounding it) that holds the largest number
/// of the beacons in LOS (`los_beacons`; ties: the lower room id). The paper
/// says the target has "the same positionID with the largest number of
/// beacons in LOS" and that "according to the location ID, the particles
/// outside the area can be filtered out". Not in the paper (fallbacks): no
/// map, no LOS beacon in any room, or no particle in that room: every
/// particle stays.
pub fn select_in_area(
    particles: &[Vec2],
    map: Option<&crate::map::FloorMap>,
    los_beacons: &[Vec2],
) -> Vec<Vec2> {
    let Some(map) = map else {
        return particles.to_vec();
    };
    let mut counts: BTreeMap<crate::map::RoomId, usize> = BTreeMap::new();
    for &b in los_beacons {
        if let Some(r) = map.room_of(b) {
            *counts.entry(r).or_insert(0) += 1;
        }
    }
    let Some(room) = counts
        .iter()
        .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))
        .map(|(&r, _)| r)
    else {
        return particles.to_vec();
    };
    let inside: Vec<Vec2> = particles
        .iter()
        .copied()
        .filter(|&p| map.room_of(p) == Some(room))
        .collect();
    if inside.is_empty() {
        particles.to_vec()
    } else {
        inside
    }
}

/// Eqs. 11-14: the particles inside the ring of the best LOS beacon; all of
/// them when there is no such beacon or none falls in the ring.
fn select_in_ring(
    particles: &[Vec2],
    best: Option<(FilteredBeacon, f64)>,
    sigma_los: f64,
    k: f64,
) -> Vec<Vec2> {
    let Some((b, mu)) = best else {
        return particles.to_vec();
    };
    let radii = ring_radii(&b, mu, sigma_los, k);
    let inside: Vec<Vec2> = particles
        .iter()
        .copied()
        .filter(|&p| in_ring(p, b.pos, radii))
        .collect();
    if inside.is_empty() {
        particles.to_vec()
    } else {
        inside
    }
}

/// Circular standard deviation sqrt(-2 ln R) of angles, radians (0 for none).
pub fn circular_std(angles: &[f64]) -> f64 {
    if angles.is_empty() {
        return 0.0;
    }
    let n = angles.len() as f64;
    let (s, c) = angles
        .iter()
        .fold((0.0, 0.0), |(s, c), a| (s + a.sin(), c + a.cos()));
    let r = ((s / n).powi(2) + (c / n).powi(2)).sqrt().clamp(1e-12, 1.0);
    (-2.0 * r.ln()).max(0.0).sqrt()
}

impl Engine for PpsaEngine {
    fn name(&self) -> &'static str {
        "ppsa"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.pdr.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        if self.front.on_observation(obs)
            && let Some(i) = self.front.registry().lookup(&obs.beacon_id)
        {
            let e = self.slot.entry(i).or_insert((0.0, 0, obs.t_ns));
            e.0 += obs.rssi_dbm;
            e.1 += 1;
            e.2 = e.2.max(obs.t_ns);
        }
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        if task == Task::Fusion {
            self.run_slot(t_ns);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use crate::engine::replay::{ReplayOutput, replay};
    use crate::engines::build_engine;
    use crate::engines::prox_pf::testkit::*;
    use crate::events::LogEvent;

    fn beacon(x: f64, y: f64, dz: f64) -> FilteredBeacon {
        FilteredBeacon {
            index: 0,
            floor: 0,
            pos: Vec2::new(x, y),
            dz_m: dz,
            model: PathLoss {
                rssi_1m_dbm: -59.0,
                exponent: 2.0,
            },
            rssi_dbm: -79.0,
            var_dbm2: 1.0,
            samples: 3,
            last_t_ns: 0,
        }
    }

    #[test]
    fn ring_radii_follow_eqs_11_to_14() {
        let b = beacon(0.0, 0.0, 0.0);
        // mu = -79 dBm (10 m), sigma 1.9, k 3: RSSI_high -73.3, RSSI_low -84.7
        let (d_in, d_out) = ring_radii(&b, -79.0, 1.9, 3.0);
        assert!(
            (d_in - 10f64.powf((79.0 - 5.7 - 59.0) / 20.0)).abs() < 1e-9,
            "{d_in}"
        );
        assert!(
            (d_out - 10f64.powf((79.0 + 5.7 - 59.0) / 20.0)).abs() < 1e-9,
            "{d_out}"
        );
        assert!(d_in < 10.0 && d_out > 10.0);
        // a vertical offset shrinks the horizontal radii
        let (h_in, h_out) = ring_radii(&beacon(0.0, 0.0, 2.0), -79.0, 1.9, 3.0);
        assert!((h_in - (d_in * d_in - 4.0).sqrt()).abs() < 1e-9);
        assert!((h_out - (d_out * d_out - 4.0).sqrt()).abs() < 1e-9);
        // selection keeps exactly the particles in the ring
        let ps = [
            Vec2::new(3.0, 0.0),
            Vec2::new(0.0, 10.0),
            Vec2::new(-12.0, 0.0),
            Vec2::new(25.0, 0.0),
        ];
        let sel = select_in_ring(&ps, Some((b, -79.0)), 1.9, 3.0);
        assert_eq!(sel, vec![Vec2::new(0.0, 10.0), Vec2::new(-12.0, 0.0)]);
        assert!(in_ring(Vec2::new(d_in, 0.0), Vec2::zeros(), (d_in, d_out)));
        // nothing in the ring, or no LOS beacon: every particle stays
        assert_eq!(
            select_in_ring(&ps[..1], Some((b, -79.0)), 1.9, 3.0),
            ps[..1].to_vec()
        );
        assert_eq!(select_in_ring(&ps, None, 1.9, 3.0), ps.to_vec());
    }

    #[test]
    fn particles_outside_the_location_of_the_los_beacons_are_dropped() {
        // 20 x 40 m, a wall at x = 10 m: two rooms
        let map = walled_map();
        let left = [Vec2::new(3.0, 3.0), Vec2::new(6.0, 7.0)];
        let right = [Vec2::new(14.0, 5.0)];
        let ps = [
            Vec2::new(8.0, 5.0),
            Vec2::new(12.0, 5.0),
            Vec2::new(9.0, 2.0),
            Vec2::new(11.0, 8.0),
        ];
        // two LOS beacons on the left, one on the right: the left room
        let los: Vec<Vec2> = left.iter().chain(&right).copied().collect();
        assert_eq!(
            select_in_area(&ps, Some(&map), &los),
            vec![Vec2::new(8.0, 5.0), Vec2::new(9.0, 2.0)]
        );
        // no map, or no LOS beacon: all stay
        assert_eq!(select_in_area(&ps, None, &los), ps.to_vec());
        assert_eq!(select_in_area(&ps, Some(&map), &[]), ps.to_vec());
    }

    #[test]
    fn circular_std_of_headings() {
        assert_eq!(circular_std(&[]), 0.0);
        assert!(circular_std(&[1.0, 1.0, 1.0]) < 1e-5);
        // across the +-pi seam
        let s = circular_std(&[3.1, -3.1]);
        assert!(s < 0.1, "{s}");
        assert!(circular_std(&[0.0, std::f64::consts::FRAC_PI_2]) > 0.5);
    }

    fn run(events: Vec<LogEvent>, cfg: &EngineConfig) -> ReplayOutput {
        let mut e = build_engine("ppsa", site(), cfg, None).unwrap();
        replay(e.as_mut(), events)
    }

    fn mean_err(out: &ReplayOutput) -> f64 {
        let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
        assert!(errs.len() >= 15, "{} fixes", errs.len());
        errs.iter().sum::<f64>() / errs.len() as f64
    }

    #[test]
    fn tracks_a_walk_and_is_deterministic() {
        let cfg = EngineConfig::default();
        let out = run(walk_north(20, None), &cfg);
        let m = mean_err(&out);
        assert!(m < 1.5, "mean error {m}");
        assert!(
            out.track
                .iter()
                .all(|p| p.x_m.is_finite() && p.y_m.is_finite())
        );
        assert_eq!(run(walk_north(20, None), &cfg).track, out.track);
        let other = EngineConfig {
            seed: 99,
            ..EngineConfig::default()
        };
        assert_ne!(run(walk_north(20, None), &other).track, out.track);
    }

    #[test]
    fn identifies_injected_nlos_and_survives_it() {
        // every third beacon 12 dB weaker than the model (NLOS), the rest exact
        let f = |k: usize, t: f64| {
            let p = Vec2::new(7.0, 4.0 + STEP_HZ * STEP_M * t);
            let b = beacons()[k];
            let los = MODEL.rssi_at(range_m(p, b, 0.0, 0.5), 0.5);
            if k % 3 == 0 { los - 12.0 } else { los }
        };
        let cfg = EngineConfig {
            ppsa: PpsaConfig::default(),
            ..EngineConfig::default()
        };
        let mut e = PpsaEngine::new(site(), &cfg, None).unwrap();
        let out = replay(&mut e, walk_north(20, Some(&f)));
        let (nlos, all) = e.nlos_counts;
        // 4 of the 11 beacons are attenuated
        let frac = nlos as f64 / all as f64;
        assert!(
            (0.25..0.5).contains(&frac),
            "NLOS fraction {frac} ({nlos}/{all})"
        );
        let m = mean_err(&out);
        assert!(m < 2.5, "mean error with NLOS {m}");
    }

    #[test]
    fn bad_input_gives_no_fix_and_no_nan() {
        let cfg = EngineConfig::default();
        for r in [0.0, 5.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let f = move |_: usize, _: f64| r;
            let out = run(walk_north(5, Some(&f)), &cfg);
            assert!(out.track.is_empty(), "rssi {r}");
            assert!(
                out.stats.no_fix > 0 && out.stats.rejected_inputs > 0,
                "rssi {r}"
            );
        }
        let mut s = (*site()).clone();
        s.floors.clear();
        let mut e = build_engine("ppsa", Arc::new(s), &cfg, None).unwrap();
        let out = replay(e.as_mut(), walk_north(5, None));
        assert!(
            out.track
                .iter()
                .all(|p| p.x_m.is_finite() && p.y_m.is_finite())
        );
        let mut bad = EngineConfig::default();
        bad.ppsa.slot_s = f64::NAN;
        let err = build_engine("ppsa", site(), &bad, None)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("ppsa.slot_s"), "{err}");
    }
}

#[cfg(test)]
mod gml_switch_tests {
    use crate::ble::nlos::NlosGmlMode;
    use crate::engine::replay::replay;
    use crate::engines::prox_pf::testkit::*;
    use crate::engines::{EngineConfig, build_engine};

    #[test]
    fn gml_nlos_switch_changes_the_beacon_set() {
        let f = |k: usize, t: f64| {
            let p = crate::Vec2::new(7.0, 4.0 + STEP_HZ * STEP_M * t);
            let b = beacons()[k];
            let los = MODEL.rssi_at(crate::ble::pathloss::range_m(p, b, 0.0, 0.5), 0.5);
            if k % 3 == 0 { los - 12.0 } else { los }
        };
        let mut tracks = Vec::new();
        for mode in [NlosGmlMode::Off, NlosGmlMode::Drop, NlosGmlMode::Correct] {
            let mut cfg = EngineConfig::default();
            cfg.ble.nlos.gml_mode = mode;
            let mut e = build_engine("gml", site(), &cfg, None).unwrap();
            let out = replay(e.as_mut(), walk_north(20, Some(&f)));
            assert!(out.track.len() >= 15, "{mode:?}");
            assert!(
                out.track
                    .iter()
                    .all(|p| p.x_m.is_finite() && p.y_m.is_finite())
            );
            tracks.push(out.track);
        }
        assert_ne!(tracks[0], tracks[1]);
        assert_ne!(tracks[0], tracks[2]);
    }
}
