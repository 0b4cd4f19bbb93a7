//! Engine `tcpf`: a tightly coupled radio-likelihood particle filter (not
//! one of the papers; the default engine of the SDK and `fpbp demo`).
//!
//! Where `fpbp` weighs its particles by their distance to one BLE position
//! x_B, `tcpf` weighs each particle by the likelihood of every heard RSSI at
//! the particle's own position ([`crate::radio`]: path-loss model per
//! transmitter, Student-t residuals, tempered by the number heard), so few
//! or weak transmitters give a broad likelihood and PDR and the map carry
//! the track. Two tasks, as in every engine here:
//!
//! - `Task::Ble` (every `tasks.gml_period_ms`): the readings of BLE beacons
//!   and WiFi access points since the last run become one measurement set.
//! - `Task::Fusion` (every `tasks.fusion_period_ms`): the PDR steps since the
//!   last run move the particles (each with its own heading offset and step
//!   scale); a move through a wall kills the particle (doors pass); the
//!   pending measurement set weighs them; the phone's RSSI offset is updated
//!   from the residuals ([`crate::radio::PhoneOffset`]; with per-particle
//!   offsets (the default without a radio map, `offset.per_particle` /
//!   `per_particle_without_map`) each particle carries its own, drawn at the start
//!   and on re-seeding from the offset profiled at its cell); ESS resampling;
//!   augmented-MCL re-seeding from the likelihood surface when the cloud has
//!   lost the radio; the published point never jumps through a wall (it
//!   walks toward the cloud through the doors, [`FloorMap::walk_toward`]).
//!
//! Start: with an [`InitialPosition`] the particles start there; otherwise
//! from the first measurement set, drawn over the walkable area of the most
//! likely floor in proportion to the likelihood with the phone offset
//! profiled per cell (a global start: the first pose comes with the first
//! radio update, with an accuracy radius as wide as the cloud); with
//! per-particle offsets each particle keeps its cell's offset, so a weak
//! phone near the beacons and a normal one far from them both stay in the
//! cloud until the walk tells them apart.

pub mod config;
pub mod integrity;
pub mod step_scale;

use std::collections::BTreeMap;
use std::sync::Arc;

pub use config::{AnchorConfig, TcpfConfig};
pub use integrity::{IntegrityConfig, RadioIntegrity};
pub use step_scale::{OnlineStep, OnlineStepConfig};

use crate::Result;
use crate::Vec2;
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, PoseSource, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorData, SensorEvent, WifiScan};
use crate::fast_math::{exp_many, fast_exp, max_many};
use crate::floor::FloorTracker;
use crate::fusion::ParticleFilter;
use crate::fusion::recovery::{LikelihoodMonitor, dominant_room};
use crate::fusion::weighted_quantile::weighted_quantile;
use crate::map::FloorMap;
use crate::pdr::Pdr;
use crate::radio::fast_ln::fast_ln;
use crate::radio::likelihood::{CloudLikelihood, missing_log_likelihood, profiled_many};
use crate::radio::model::PathLossParams;
use crate::radio::reference_scans::{ScanTrail, WeightedCandidate, candidate_fix};
use crate::radio::{Measurement, PathLossModel, PhoneOffset, RadioModel, ScanWindow, TxKind};
use crate::site::Site;
use crate::wifi::FreshResults;

/// Sampling step of the particles' wall checks, metres (the published
/// point is checked as `fpbp eval` checks it: [`FloorMap::track_crosses_wall`]).
const WALL_STEP_M: f64 = 0.1;

/// Lattice spacing and search margin of the published point's walk
/// through the doors ([`FloorMap::walk_toward`]), metres: a door is at
/// least ~0.8 m wide, so several lattice columns pass it.
const WALK_SPACING_M: f64 = 0.25;
const WALK_MARGIN_M: f64 = 15.0;

/// Diagnostics of a `tcpf` run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TcpfCounts {
    /// Global starts (from a measurement set, including floor changes
    /// onto a floor where the track's point is not walkable).
    pub global_starts: u64,
    /// Radio updates that weighed the particles.
    pub radio_updates: u64,
    /// Particles killed by a move through a wall.
    pub wall_killed: u64,
    /// Steps every particle tried to make through a wall (undone).
    pub steps_blocked: u64,
    /// Particles re-seeded from the likelihood surface.
    pub reseeded: u64,
    /// Fusion runs that held the published point instead of jumping
    /// through a wall; moves of it along a walk through the doors toward
    /// the cloud after the hold ran out; jumps where the map had no way
    /// (not eval's `jumps`, which counts every jump of the published track).
    pub held: u64,
    pub walked: u64,
    pub jumps_no_way: u64,
    pub floor_changes: u64,
    /// Barometer floor changes not made: the new floor's plan has no
    /// walkable point within `floor_snap_m` of the track (a stairwell the
    /// plan lacks, passed through; `floor_keep_off_map`).
    pub floor_changes_off_map: u64,
    /// Anchor queries that gave candidates, and particles re-seeded
    /// around them.
    pub anchor_queries: u64,
    pub anchor_reseeded: u64,
    /// Re-seedings not done: the phone far from the survey
    /// (`anchors.far_db`).
    pub reseed_far: u64,
    /// Anchor queries whose candidates were dropped as too far from the
    /// phone's window (`anchors.drop_far_db`).
    pub anchors_dropped_far: u64,
    /// Fusion runs that weighed the particles by the magnetic map.
    pub magnetic_updates: u64,
    /// Windows that fed the online step-length scale (`online_step`).
    pub step_windows: u64,
    /// Radio updates made with the radio's trust below 1 and below 0.5
    /// (`integrity`).
    pub trust_reduced: u64,
    pub trust_low: u64,
    /// Re-seedings refused: the surface lay farther from the cloud than
    /// the walk allows (`integrity`).
    pub reseed_untrusted: u64,
}

impl TcpfCounts {
    /// Every count with its field's name (the destructuring lists every
    /// field, so a new count does not compile until it is named here).
    pub fn named(&self) -> [(&'static str, u64); 19] {
        let TcpfCounts {
            global_starts,
            radio_updates,
            wall_killed,
            steps_blocked,
            reseeded,
            held,
            walked,
            jumps_no_way,
            floor_changes,
            floor_changes_off_map,
            anchor_queries,
            anchor_reseeded,
            reseed_far,
            anchors_dropped_far,
            magnetic_updates,
            step_windows,
            trust_reduced,
            trust_low,
            reseed_untrusted,
        } = *self;
        [
            ("global_starts", global_starts),
            ("radio_updates", radio_updates),
            ("wall_killed", wall_killed),
            ("steps_blocked", steps_blocked),
            ("reseeded", reseeded),
            ("held", held),
            ("walked", walked),
            ("jumps_no_way", jumps_no_way),
            ("floor_changes", floor_changes),
            ("floor_changes_off_map", floor_changes_off_map),
            ("anchor_queries", anchor_queries),
            ("anchor_reseeded", anchor_reseeded),
            ("reseed_far", reseed_far),
            ("anchors_dropped_far", anchors_dropped_far),
            ("magnetic_updates", magnetic_updates),
            ("step_windows", step_windows),
            ("trust_reduced", trust_reduced),
            ("trust_low", trust_low),
            ("reseed_untrusted", reseed_untrusted),
        ]
    }
}

/// One candidate place of the reference-scan query, with its weight
/// (the weights of one query sum to 1).
type Anchor = WeightedCandidate;

/// One radio task's output: time, heard transmitters, missed ones with
/// their radio's sensitivity (dBm), and the anchors of the scan window.
struct RadioSet {
    meas: Vec<Measurement>,
    missing: Vec<(usize, f64)>,
    anchors: Vec<Anchor>,
}

/// A likelihood surface over the cells of a floor (tempered): cell
/// weights exp(alpha l - max), their log-sum-exp, the weighted mean of the
/// offsets profiled per cell, and per cell that offset and its sd (dB).
struct Surface {
    cells: Vec<Vec2>,
    w: Vec<f64>,
    lse: f64,
    offset_db: f64,
    cell_offset_db: Vec<f64>,
    cell_offset_sd_db: Vec<f64>,
}

/// The cloud's weighted mean of the anchors' mixture (`mix`, one value
/// per particle) over the mixture's highest value at a candidate of
/// `floor` (1: the cloud sits on the best candidates; 0: far from all).
/// `None` without anchors there.
fn anchor_support(
    anchors: &[Anchor],
    floor: i32,
    sigma_m: f64,
    mix: &[f64],
    weights: &[f64],
) -> Option<f64> {
    let peak = anchors
        .iter()
        .filter(|a| a.floor == floor)
        .map(|a| anchor_mix(anchors, floor, a.pos, sigma_m))
        .fold(0.0, f64::max);
    let wsum: f64 = weights.iter().sum();
    if peak <= 0.0 || wsum <= 0.0 {
        return None;
    }
    let s: f64 = mix.iter().zip(weights).map(|(a, w)| a * w).sum();
    Some(s / wsum / peak)
}

/// The anchors' mixture at `p` on `floor`: sum of w exp(-d^2 / 2 sigma^2)
/// ([`fast_exp`]).
fn anchor_mix(anchors: &[Anchor], floor: i32, p: Vec2, sigma_m: f64) -> f64 {
    let k = -0.5 / (sigma_m * sigma_m);
    anchors
        .iter()
        .filter(|a| a.floor == floor)
        .map(|a| a.w * fast_exp((p - a.pos).norm_squared() * k))
        .sum()
}

/// [`anchor_mix`] at every point of `ps`, appended to `out`: anchor by
/// anchor over the cloud, the exponentials by [`exp_many`] (vectorises;
/// [`fast_exp`]'s values, added per point in the same order, so the same
/// sums).
fn anchor_mix_many(anchors: &[Anchor], floor: i32, ps: &[Vec2], sigma_m: f64, out: &mut Vec<f64>) {
    let k = -0.5 / (sigma_m * sigma_m);
    let start = out.len();
    // -0.0: where `Iterator::sum` of f64 starts (no anchor: the same -0.0)
    out.resize(start + ps.len(), -0.0);
    let (mut xs, mut e) = (Vec::with_capacity(ps.len()), vec![0.0; ps.len()]);
    for a in anchors.iter().filter(|a| a.floor == floor) {
        xs.clear();
        xs.extend(ps.iter().map(|p| (p - a.pos).norm_squared() * k));
        exp_many(&xs, &mut e);
        for (o, e) in out[start..].iter_mut().zip(&e) {
            *o += a.w * e;
        }
    }
}

/// At most this many (mean, sd) pairs in [`CellExpected`] (16 MB); past
/// it the surface samples the model as before.
const CELL_EXPECTED_MAX: usize = 1 << 20;

/// The model's expected RSSI (mean, sd) of transmitters over a floor's
/// start / re-seeding cells, computed once per (floor, transmitter): the
/// cells and the model never change, so the likelihood surface of every
/// recovery check reads the same values instead of sampling the model
/// again (two thirds of a surface's work with a radio map).
#[derive(Debug, Default)]
struct CellExpected {
    by: BTreeMap<(i32, usize), CellValues>,
    pairs: usize,
}

/// One transmitter's expected RSSI over a floor's cells.
#[derive(Debug)]
struct CellValues {
    mean: Vec<f64>,
    sd: Vec<f64>,
    /// The smallest of `sd` ([`TcpfEngine::surface_gap_bound`]).
    min_sd: f64,
}

impl CellExpected {
    /// Computes the transmitters of `meas` not yet held for `floor` over
    /// `cells` (those the model knows, while under [`CELL_EXPECTED_MAX`]).
    fn fill(&mut self, model: &dyn RadioModel, floor: i32, cells: &[Vec2], meas: &[Measurement]) {
        for m in meas {
            if self.by.contains_key(&(floor, m.tx)) || self.pairs + cells.len() > CELL_EXPECTED_MAX
            {
                continue;
            }
            let (mut mean, mut sd) = (vec![0.0; cells.len()], vec![0.0; cells.len()]);
            if model.expected_many(m.tx, floor, cells, &mut mean, &mut sd) {
                let min_sd = sd.iter().copied().fold(f64::INFINITY, f64::min);
                self.by
                    .insert((floor, m.tx), CellValues { mean, sd, min_sd });
                self.pairs += cells.len();
            }
        }
    }
}

/// `model` with the expected RSSI over `cells` of `floor` read from
/// `cache` where it holds them (the same values; anything else asks
/// `model`). Forwards the trait by hand: [`profiled_many`] takes a
/// `&dyn RadioModel`, and the defaulted methods must reach `model` too
/// (`learned_per_floor`, `reference_scans`), not fall back to the defaults.
struct WithCells<'a> {
    model: &'a dyn RadioModel,
    floor: i32,
    cells: &'a [Vec2],
    cache: &'a CellExpected,
}

impl RadioModel for WithCells<'_> {
    fn transmitters(&self) -> &[crate::radio::Transmitter] {
        self.model.transmitters()
    }

    fn lookup(&self, kind: TxKind, id: &str) -> Option<usize> {
        self.model.lookup(kind, id)
    }

    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        self.model.expected(tx, floor, p)
    }

    fn expected_many(
        &self,
        tx: usize,
        floor: i32,
        ps: &[Vec2],
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> bool {
        // the very cell list (not merely as many points)
        let cells = floor == self.floor && std::ptr::eq(ps, self.cells);
        if let (true, Some(v)) = (cells, self.cache.by.get(&(floor, tx))) {
            let n = ps.len();
            mean[..n].copy_from_slice(&v.mean);
            sd[..n].copy_from_slice(&v.sd);
            return true;
        }
        self.model.expected_many(tx, floor, ps, mean, sd)
    }

    fn learned_per_floor(&self) -> bool {
        self.model.learned_per_floor()
    }

    fn reference_scans(&self) -> Option<&crate::radio::reference_scans::ReferenceScans> {
        self.model.reference_scans()
    }

    fn magnetic(&self) -> Option<&crate::radio::magnetic_map::MagneticMap> {
        self.model.magnetic()
    }
}

/// The tightly coupled radio-likelihood particle filter.
pub struct TcpfEngine {
    site: Arc<Site>,
    cfg: TcpfConfig,
    model: Arc<dyn RadioModel>,
    pdr: Pdr,
    pf: ParticleFilter,
    floors: FloorTracker,
    window: ScanWindow,
    fresh_wifi: FreshResults,
    /// Measurement set of the last radio task (heard, and missed with
    /// their radio's sensitivity), not yet used by fusion.
    pending: Option<RadioSet>,
    /// The phone's trailing window for the reference-scan query.
    trail: ScanTrail,
    /// Consecutive radio updates with the cloud away from the anchors.
    low_support: u32,
    /// The weighted mean of the last anchors on their heaviest floor.
    anchor_mean: Option<(i32, Vec2)>,
    /// The anchors' mixture per particle (reused buffer).
    anchor_buf: Vec<f64>,
    /// RSSI distance of the closest reference scan at the last anchor
    /// query (`None`: no scan shares a heard transmitter, or no query).
    survey_dist_db: Option<f64>,
    /// The last query's candidates were dropped as too far from the
    /// phone's window (`anchors.drop_far_db`).
    anchors_dropped_far: bool,
    /// Consecutive anchor floor votes for another floor.
    anchor_floor_run: Option<(i32, u32)>,
    /// The last query that gave candidates: its time and candidates
    /// (reused until `anchors.query_period_s` has passed).
    last_query: Option<(i64, Vec2, Vec<Anchor>)>,
    /// The steps' summed displacement (length along the step's yaw, MCS
    /// m): reused anchors move by what was walked since their query.
    walked: Vec2,
    /// Last time each model transmitter was heard (cached WiFi results
    /// included), ns; i64::MIN never.
    last_heard: Vec<i64>,
    /// Whether BLE readings / a WiFi scan arrived since the last radio task.
    ble_active: bool,
    wifi_active: bool,
    offset: PhoneOffset,
    /// The user's step length learned online (`online_step`).
    online_step: OnlineStep,
    /// The radio's trust from its pulls against the walk (`integrity`).
    integrity: RadioIntegrity,
    /// The counters that say the cloud moved other than by its steps and
    /// the radio, at the last fusion run (the online step scale skips
    /// stretches across such a move).
    jump_key: u64,
    monitor: LikelihoodMonitor,
    floor: i32,
    /// Consecutive radio votes for another floor (no barometer).
    other_floor: Option<(i32, u32)>,
    /// Floors whose map has more than one room: there the walls can say a
    /// cloud is lost (the re-seeding gate); on a floor that is one open
    /// area the radio alone decides.
    walled: BTreeMap<i32, bool>,
    /// Start / re-seeding cells per floor (walkable, `cell_m` apart).
    cells: BTreeMap<i32, Vec<Vec2>>,
    /// The model's expected RSSI over those cells, per heard transmitter.
    cell_expected: CellExpected,
    before: Vec<Vec2>,
    crossed: Vec<bool>,
    log_l: Vec<f64>,
    /// The cloud's likelihood of the last radio update (reused buffers).
    cloud: CloudLikelihood,
    /// Exponents and their exp of one radio update (reused).
    exp_in: Vec<f64>,
    exp_out: Vec<f64>,
    published: Option<Vec2>,
    hold_runs: u32,
    /// Radio updates since the last radio-alone recovery check.
    radio_updates_since_check: u32,
    /// The cloud was last placed at a told position (`InitialPosition`,
    /// `set_position`), not by the radio (`recovery_told_open_floor`).
    told_start: bool,
    /// Moving average (rate 0.1 per step) of the share of particles a step
    /// kills at walls: a cloud whose steps keep hitting walls is lost.
    kill_ema: f64,
    heading_rad: f64,
    pose: Option<Pose>,
    /// The last pose's accuracy radius from the cloud and the anchors
    /// alone (without the survey-distance term): what `hold_max_accuracy_m`
    /// compares.
    cloud_accuracy_m: Option<f64>,
    last_radio_t_ns: Option<i64>,
    /// Last random walk of the per-particle offsets.
    last_offset_walk_t_ns: Option<i64>,
    /// First radio update before the start, and how many floors have beacons.
    first_radio_t_ns: Option<i64>,
    beacon_floors: usize,
    ble_period_ns: i64,
    fusion_period_ns: i64,
    /// Sum and count of the magnetometer's |B| since the last fusion task.
    mag_sum_ut: f64,
    mag_n: u32,
    /// The phone's |B| offset against the magnetic map, uT.
    mag_offset_ut: f64,
    stats: EngineStats,
    pub counts: TcpfCounts,
}

/// The walkable cells of `map`, one per `cell_m` square that holds a grid
/// point (the first grid point in it).
fn cells_of(map: &FloorMap, cell_m: f64) -> Vec<Vec2> {
    let mut seen = std::collections::BTreeSet::new();
    let mut out = Vec::new();
    for p in map.grid() {
        let key = ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64);
        if seen.insert(key) {
            out.push(*p);
        }
    }
    out
}

impl TcpfEngine {
    /// The engine on `site` with the path-loss model of its beacons and
    /// access points; `init` starts it at a known point.
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        let model = PathLossModel::for_site(&site, Self::path_loss_params(config));
        Self::with_model(site, config, init, Arc::new(model))
    }

    /// The path-loss model's parameters of [`TcpfEngine::new`]: the
    /// likelihood's spreads and ranges, the phone's height.
    pub fn path_loss_params(config: &EngineConfig) -> PathLossParams {
        let l = &config.tcpf.likelihood;
        PathLossParams {
            ble_sd_db: l.ble_sd_db,
            wifi_sd_db: l.wifi_sd_db,
            floor_loss_db: l.floor_loss_db,
            other_floor_sd_db: l.other_floor_sd_db,
            min_range_m: l.min_range_m,
            phone_height_m: config.ble.phone_height_m,
        }
    }

    /// The engine with any [`RadioModel`].
    pub fn with_model(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
        model: Arc<dyn RadioModel>,
    ) -> Result<Self> {
        config.validate()?;
        let cfg = config.tcpf.clone();
        let start_floor = init.map_or(site.default_floor(), |i| i.floor);
        let cells = site
            .spec
            .floors
            .iter()
            .zip(&site.floors)
            .map(|(f, m)| (f.id, cells_of(m, cfg.cell_m)))
            .collect();
        let walled = site
            .spec
            .floors
            .iter()
            .zip(&site.floors)
            .map(|(f, m)| (f.id, m.rooms().len() > 1))
            .collect();
        let mut e = TcpfEngine {
            walled,
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            pf: ParticleFilter::new(&cfg.filter(), config.seed),
            floors: FloorTracker::for_site(&config.ekf.floor, &site, start_floor),
            window: ScanWindow::default(),
            fresh_wifi: FreshResults::default(),
            pending: None,
            trail: ScanTrail::default(),
            low_support: 0,
            anchor_floor_run: None,
            anchor_mean: None,
            anchor_buf: Vec::new(),
            survey_dist_db: None,
            anchors_dropped_far: false,
            last_query: None,
            walked: Vec2::zeros(),
            last_heard: vec![i64::MIN; model.transmitters().len()],
            ble_active: false,
            wifi_active: false,
            offset: PhoneOffset::new(&cfg.offset),
            online_step: OnlineStep::new(&cfg.online_step),
            integrity: RadioIntegrity::default(),
            jump_key: 0,
            monitor: LikelihoodMonitor::default(),
            floor: start_floor,
            other_floor: None,
            cells,
            cell_expected: CellExpected::default(),
            before: Vec::new(),
            crossed: Vec::new(),
            log_l: Vec::new(),
            cloud: CloudLikelihood::default(),
            exp_in: Vec::new(),
            exp_out: Vec::new(),
            published: None,
            hold_runs: 0,
            radio_updates_since_check: 0,
            told_start: false,
            kill_ema: 0.0,
            heading_rad: 0.0,
            pose: None,
            cloud_accuracy_m: None,
            last_radio_t_ns: None,
            last_offset_walk_t_ns: None,
            first_radio_t_ns: None,
            beacon_floors: model
                .transmitters()
                .iter()
                .filter(|t| t.kind == TxKind::Ble)
                .map(|t| t.floor)
                .collect::<std::collections::BTreeSet<_>>()
                .len(),
            ble_period_ns: i64::from(config.tasks.gml_period_ms) * 1_000_000,
            fusion_period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            mag_sum_ut: 0.0,
            mag_n: 0,
            mag_offset_ut: 0.0,
            stats: EngineStats::default(),
            counts: TcpfCounts::default(),
            model,
            cfg,
            site,
        };
        if let Some(at) = init {
            e.start_at(at);
        }
        Ok(e)
    }

    /// The radio model the engine weighs with.
    pub fn model(&self) -> &dyn RadioModel {
        self.model.as_ref()
    }

    /// The phone's |B| offset against the magnetic map, uT.
    pub fn magnetic_offset_ut(&self) -> f64 {
        self.mag_offset_ut
    }

    /// The phone RSSI offset estimate and its sd, dB.
    pub fn rssi_offset_db(&self) -> (f64, f64) {
        (self.offset.mean_db(), self.offset.sd_db())
    }

    /// The radio's trust in [`IntegrityConfig::min_trust`, 1]: 1 unless
    /// `integrity` found the radio pulling the cloud beyond what the walk
    /// allows.
    pub fn radio_trust(&self) -> f64 {
        self.integrity.trust()
    }

    /// The online step-length scale every PDR step is multiplied by
    /// (1 with `online_step` off).
    pub fn step_scale(&self) -> f64 {
        self.online_step.scale()
    }

    /// Particle positions and weights (plots, tests).
    pub fn particles(&self) -> (&[Vec2], &[f64]) {
        (self.pf.particles(), self.pf.weights())
    }

    fn start_at(&mut self, at: InitialPosition) {
        self.floor = at.floor;
        self.floors.reset_to_floor(at.floor);
        if let Some(h) = at.heading_rad {
            self.heading_rad = h;
        }
        let site = Arc::clone(&self.site);
        let map = site.floor(at.floor);
        // a tap on a wall line starts at the nearest walkable point (5 m)
        let p = Vec2::new(at.x_m, at.y_m);
        let p = match map {
            Some(m) if !m.is_walkable(p) => {
                crate::engines::fpbp::nearest_walkable(m, p, 5.0).unwrap_or(p)
            }
            _ => p,
        };
        self.pf
            .init_at(p, 0.5, |q| map.is_none_or(|m| m.is_walkable(q)));
        self.told_start = true;
        self.integrity.restart(&self.cfg.integrity, true);
        self.online_step.drop_window();
        self.draw_offsets_from_belief();
        self.monitor.reset();
        self.published = Some(p);
        self.hold_runs = 0;
    }

    /// Likelihood surface of `meas` over the cells of `floor`, tempered,
    /// with the offset profiled per cell under N(`prior.0`, `prior.1`^2)
    /// (dB).
    fn surface(
        &mut self,
        floor: i32,
        meas: &[Measurement],
        missing: &[(usize, f64)],
        anchors: &[Anchor],
        prior: (f64, f64),
    ) -> Option<Surface> {
        let cells = self.cells.get(&floor)?;
        if cells.is_empty() || meas.is_empty() {
            return None;
        }
        let model = self.model.as_ref();
        self.cell_expected.fill(model, floor, cells, meas);
        let lc = &self.cfg.likelihood;
        let alpha = lc.alpha(meas.len());
        let (o0, sd0) = prior;
        let (mut offs, mut sds, mut ll) = (Vec::new(), Vec::new(), Vec::new());
        let cached = WithCells {
            model,
            floor,
            cells,
            cache: &self.cell_expected,
        };
        profiled_many(
            &cached, lc, meas, floor, cells, o0, sd0, &mut offs, &mut sds, &mut ll,
        );
        for ((l, c), o) in ll.iter_mut().zip(cells).zip(&offs) {
            let miss = missing_log_likelihood(model, lc, missing, floor, *c, *o);
            *l = alpha * (*l + miss);
        }
        let ac = &self.cfg.anchors;
        if !anchors.is_empty() && ac.start_weight > 0.0 {
            for (l, c) in ll.iter_mut().zip(cells) {
                let a = anchor_mix(anchors, floor, *c, ac.sigma_m);
                *l += ac.start_weight * ((ac.floor + a) / (ac.floor + 1.0)).ln();
            }
        }
        let max = ll.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !max.is_finite() {
            return None;
        }
        let w: Vec<f64> = ll.iter().map(|l| (l - max).exp()).collect();
        let sum: f64 = w.iter().sum();
        let offset_db = w.iter().zip(&offs).map(|(w, o)| w * o).sum::<f64>() / sum;
        Some(Surface {
            cells: cells.clone(),
            w,
            lse: max + sum.ln(),
            offset_db,
            cell_offset_db: offs,
            cell_offset_sd_db: sds,
        })
    }

    /// An upper bound on the recovery check's gap (the surface's
    /// log-sum-exp over its cells' weights, less the cloud's tempered log
    /// mean likelihood `cloud_ll`) for `meas` on `floor`, without the
    /// surface: every factor 1 + z^2/nu is at least 1, the offset's prior
    /// term and the misses' at most 0, so a cell's tempered log-likelihood
    /// is at most alpha times -`sd_norm_weight` times the sum of ln sd, and
    /// sd at least the smallest over the floor's cells ([`CellExpected`]).
    /// With a small slack for the rounding of [`fast_ln`] and the products.
    /// `None` when a heard transmitter's cells are not held (cache full, or
    /// unknown to the model there): the surface must be computed.
    fn surface_gap_bound(
        &mut self,
        floor: i32,
        meas: &[Measurement],
        cloud_ll: f64,
    ) -> Option<f64> {
        let cells = self.cells.get(&floor)?;
        self.cell_expected
            .fill(self.model.as_ref(), floor, cells, meas);
        let mut ln_sd = 0.0;
        for m in meas {
            ln_sd += self.cell_expected.by.get(&(floor, m.tx))?.min_sd.ln();
        }
        let lc = &self.cfg.likelihood;
        let best = lc.alpha(meas.len()) * -(lc.sd_norm_weight * ln_sd);
        Some(best - cloud_ll + 1e-6 * (1.0 + best.abs() + cloud_ll.abs()))
    }

    /// The prior of the offset profiled at a start or re-seeding: the
    /// current belief, or with per-particle offsets and
    /// `offset.reseed_from_prior` on a re-seeding, the configured prior.
    fn profile_prior(&self, reseed: bool) -> (f64, f64) {
        let oc = self.offset.config();
        if reseed && self.per_particle_offset() && oc.reseed_from_prior {
            (oc.prior_db, oc.prior_sd_db)
        } else {
            (self.offset.mean_db(), self.offset.sd_db())
        }
    }

    /// Whether each particle carries its own offset: when asked for, or
    /// (`per_particle_without_map`) when the model is the path-loss model
    /// rather than a radio map learned from a survey.
    fn per_particle_offset(&self) -> bool {
        let oc = self.offset.config();
        let path_loss = !self.model.learned_per_floor();
        oc.enabled && (oc.per_particle || (oc.per_particle_without_map && path_loss))
    }

    /// Per-particle offsets: every particle's drawn from N(mean, (k sd)^2)
    /// of the current belief, k = `offset.particle_start_spread` (after an
    /// init at a point).
    fn draw_offsets_from_belief(&mut self) {
        if !self.per_particle_offset() {
            return;
        }
        let (o, sd) = (self.offset.mean_db(), self.offset.sd_db());
        let sd = sd * self.offset.config().particle_start_spread;
        let m = self.offset.config().max_abs_db;
        let n = self.pf.particles().len();
        let v: Vec<f64> = (0..n)
            .map(|_| (o + sd * self.pf.draw_normal()).clamp(-m, m))
            .collect();
        self.pf.set_state(v);
    }

    /// Per-particle offsets of the particles the last cell draw placed:
    /// each from N(its cell's profiled offset, that offset's sd^2).
    fn draw_offsets_from_cells(&mut self, s: &Surface) {
        if !self.per_particle_offset() {
            return;
        }
        let n = self.pf.particles().len();
        if self.pf.state().len() != n {
            let o = self.offset.mean_db();
            self.pf.set_state(vec![o; n]);
        }
        let k = self.offset.config().particle_start_spread;
        self.draw_offsets_of_cell_draws(|c| (s.cell_offset_db[c], k * s.cell_offset_sd_db[c]));
    }

    /// The offset of every particle the last cell draw placed, from
    /// N(mean, sd^2) = `of_cell(its cell)`, clamped to `max_abs_db`.
    fn draw_offsets_of_cell_draws(&mut self, of_cell: impl Fn(usize) -> (f64, f64)) {
        let m = self.offset.config().max_abs_db;
        let draws = self.pf.cell_draws().to_vec();
        for (i, c) in draws {
            let (mean, sd) = of_cell(c);
            let z = self.pf.draw_normal();
            self.pf.state_mut()[i] = (mean + sd * z).clamp(-m, m);
        }
    }

    /// The weighted mean and sd of the particles' offsets into the
    /// reported belief.
    fn summarise_offsets(&mut self) {
        let (os, ws) = (self.pf.state(), self.pf.weights());
        if os.len() != ws.len() || os.is_empty() {
            return;
        }
        // both sums in one pass, each in its order (the two chains of
        // dependent adds overlap)
        let (mut wsum, mut owsum) = (-0.0, -0.0);
        for (o, w) in os.iter().zip(ws) {
            wsum += w;
            owsum += o * w;
        }
        if wsum <= 0.0 {
            return;
        }
        let mean = owsum / wsum;
        let var = os
            .iter()
            .zip(ws)
            .map(|(o, w)| w * (o - mean) * (o - mean))
            .sum::<f64>()
            / wsum;
        self.offset.set(mean, var.sqrt().max(0.05));
    }

    /// The random walk of every particle's offset over `dt_s`.
    fn walk_offsets(&mut self, dt_s: f64) {
        let oc = self.offset.config();
        let sd = oc.particle_walk_db_per_sqrt_s * dt_s.max(0.0).sqrt();
        let m = oc.max_abs_db;
        if sd <= 0.0 || self.pf.state().is_empty() {
            return;
        }
        // the same draws as one draw_normal per particle in turn, batched
        let mut z = vec![0.0; self.pf.state().len()];
        self.pf.draw_normals(&mut z);
        for (o, z) in self.pf.state_mut().iter_mut().zip(&z) {
            *o = (*o + sd * z).clamp(-m, m);
        }
    }

    /// The floor of the strongest beacons heard: the floor most of the
    /// three strongest BLE beacons stand on (ties: the strongest's). WiFi
    /// APs do not vote: their calibrated floors are the survey's floor,
    /// and they carry through floors.
    fn radio_floor_vote(&self, meas: &[Measurement]) -> Option<i32> {
        let tx = self.model.transmitters();
        let top: Vec<i32> = meas
            .iter()
            .filter_map(|m| tx.get(m.tx))
            .filter(|t| t.kind == TxKind::Ble)
            .take(3)
            .map(|t| t.floor)
            .collect();
        let mut best: Option<(usize, i32)> = None;
        for f in &top {
            let n = top.iter().filter(|g| *g == f).count();
            if best.is_none_or(|(c, _)| n > c) {
                best = Some((n, *f));
            }
        }
        best.map(|(_, f)| f)
    }

    /// Global start from `meas` on `floor` (or the most likely floor).
    fn global_start(
        &mut self,
        t_ns: i64,
        meas: &[Measurement],
        missing: &[(usize, f64)],
        anchors: &[Anchor],
        floor: Option<i32>,
    ) -> bool {
        let floors: Vec<i32> = match floor {
            Some(f) => vec![f],
            None => self.site.spec.floors.iter().map(|f| f.id).collect(),
        };
        let prior = self.profile_prior(false);
        let best = floors
            .into_iter()
            .filter_map(|f| {
                self.surface(f, meas, missing, anchors, prior)
                    .map(|s| (f, s))
            })
            .max_by(|a, b| a.1.lse.total_cmp(&b.1.lse).then(b.0.cmp(&a.0)));
        let Some((f, surf)) = best else {
            return false;
        };
        self.floor = f;
        self.floors.reset_to_floor(f);
        self.other_floor = None;
        let site = Arc::clone(&self.site);
        let map = site.floor(f);
        self.pf
            .init_from_cells(&surf.cells, &surf.w, self.cfg.cell_m, |q| {
                map.is_none_or(|m| m.is_walkable(q))
            });
        self.offset.set(surf.offset_db, self.offset.sd_db());
        self.draw_offsets_from_cells(&surf);
        self.summarise_offsets();
        self.monitor.reset();
        self.low_support = 0;
        self.published = None;
        self.hold_runs = 0;
        self.counts.global_starts += 1;
        self.told_start = false;
        self.integrity.restart(&self.cfg.integrity, false);
        self.last_radio_t_ns = Some(t_ns);
        true
    }

    /// One step of every particle, with the wall check; the share of the
    /// particles the walls stopped.
    fn step(&mut self, length_m: f64, yaw_rad: f64) -> f64 {
        let site = Arc::clone(&self.site);
        let map = site.floor(self.floor);
        if map.is_some() {
            self.before.clear();
            self.before.extend_from_slice(self.pf.particles());
        }
        self.pf.set_extra_noise(self.cfg.position_noise_m);
        self.pf.predict(length_m, yaw_rad);
        self.integrity.on_step(length_m);
        if self.cfg.anchors.query_period_s > 0.0 {
            // only reused anchors move by it
            self.walked += Vec2::new(yaw_rad.cos(), yaw_rad.sin()) * length_m;
        }
        let mut frac = 0.0;
        if let Some(m) = map {
            m.crosses_wall_each(
                &self.before,
                self.pf.particles(),
                WALL_STEP_M,
                &mut self.crossed,
            );
            let n = self.crossed.iter().filter(|c| **c).count();
            frac = n as f64 / self.crossed.len().max(1) as f64;
            self.kill_ema += 0.1 * (frac - self.kill_ema);
            if n == self.crossed.len() {
                // every hypothesis hit a wall (an unmapped door, a bad
                // heading): the step is undone rather than the cloud lost
                self.pf.restore_positions(&self.before);
                self.counts.steps_blocked += 1;
            } else if n > 0 {
                self.pf.penalize_flagged(&self.crossed, 0.0);
                self.counts.wall_killed += n as u64;
            }
        }
        self.pf.resample_if_degenerate();
        frac
    }

    /// Weighs the particles with one measurement set, updates the phone
    /// offset, the floor and, when the cloud has lost the radio, re-seeds.
    fn radio_update(
        &mut self,
        t_ns: i64,
        meas: &[Measurement],
        missing: &[(usize, f64)],
        anchors: &[Anchor],
    ) {
        let lc = self.cfg.likelihood.clone();
        let model = Arc::clone(&self.model);
        let floor = self.floor;
        let o = self.offset.mean_db();
        let c = self.cfg.converged_radio_scale;
        let (lo, hi) = (
            self.cfg.converged_spread_lo_m,
            self.cfg.converged_spread_hi_m,
        );
        let spread_before = self.pf.spread_m();
        // the cloud's mean before the update: only the integrity check reads it
        let mean_before = self.integrity.is_active().then(|| self.pf.mean()).flatten();
        let g = ((spread_before - lo) / (hi - lo)).clamp(0.0, 1.0);
        // the radio's trust tempers its weights (1 unless `integrity`)
        let trust = self.integrity.trust();
        let alpha = lc.alpha(meas.len()) * (c + (1.0 - c) * g) * trust;
        let m = meas.len().max(1) as f64;
        let missed = self.near_missing(missing, o);
        let alpha0 = lc.alpha(meas.len());
        self.log_l.clear();
        let mut mean_l = 0.0;
        // untempered log-likelihood per particle first; each transmitter's
        // expected RSSI per particle is kept for the residuals below
        let mut cloud = std::mem::take(&mut self.cloud);
        let per_particle = self.per_particle_offset() && !self.pf.state().is_empty();
        if per_particle {
            let dt_s = self
                .last_offset_walk_t_ns
                .map_or(0.0, |t0| (t_ns - t0).max(0) as f64 * 1e-9);
            self.walk_offsets(dt_s);
        }
        self.last_offset_walk_t_ns = Some(t_ns);
        let ps = self.pf.particles();
        if per_particle {
            let os = self.pf.state();
            cloud.evaluate_each(model.as_ref(), &lc, meas, floor, ps, os, &mut self.log_l);
        } else {
            cloud.evaluate(model.as_ref(), &lc, meas, floor, ps, o, &mut self.log_l);
        }
        // exp of the per-transmitter mean log-likelihoods in one pass
        let (xs, ex) = (&mut self.exp_in, &mut self.exp_out);
        xs.clear();
        xs.extend(self.log_l.iter().map(|u| *u / m));
        ex.resize(xs.len(), 0.0);
        exp_many(xs, ex);
        for e in ex.iter() {
            mean_l += e;
        }
        if !missed.is_empty() {
            for (u, p) in self.log_l.iter_mut().zip(ps) {
                *u += missing_log_likelihood(model.as_ref(), &lc, &missed, floor, *p, o);
            }
        }
        // log of the cloud's mean likelihood tempered by alpha0 (comparable
        // with the surface), by log-sum-exp
        let lmax = max_many(&self.log_l, |u| alpha0 * u);
        let n = self.log_l.len().max(1) as f64;
        xs.clear();
        xs.extend(self.log_l.iter().map(|u| alpha0 * u - lmax));
        exp_many(xs, ex);
        let cloud_ll = lmax + (ex.iter().sum::<f64>() / n).ln();
        mean_l /= self.pf.particles().len().max(1) as f64;
        let mut log_l = std::mem::take(&mut self.log_l);
        log_l.iter_mut().for_each(|u| *u *= alpha);
        if let Some(fix) = candidate_fix(anchors) {
            self.anchor_mean = Some((fix.floor, fix.mean));
        }
        // the anchors' mixture at each particle, once: the cloud's support
        // (before this update's weights) and the weak extra likelihood
        let ac = &self.cfg.anchors;
        let on_floor = anchors.iter().any(|a| a.floor == floor);
        let mut support = None;
        if on_floor {
            let mix = &mut self.anchor_buf;
            mix.clear();
            anchor_mix_many(anchors, floor, self.pf.particles(), ac.sigma_m, mix);
            support = anchor_support(anchors, floor, ac.sigma_m, mix, self.pf.weights());
            if ac.weight > 0.0 {
                let norm = (ac.floor + 1.0).ln();
                let weight = ac.weight * trust;
                for (u, a) in log_l.iter_mut().zip(mix.iter()) {
                    *u += weight * (fast_ln(ac.floor + a) - norm);
                }
            }
        }
        self.pf.weight_log(&log_l);
        self.log_l = log_l;
        self.counts.radio_updates += 1;
        if per_particle {
            self.summarise_offsets();
        } else {
            // residuals of each transmitter averaged over the weighted
            // cloud (only the one offset for the whole cloud reads them)
            let ws = self.pf.weights();
            let residuals: Vec<(f64, f64, f64)> = meas
                .iter()
                .enumerate()
                .filter_map(|(k, mm)| {
                    let (mu, sd, wsum) = cloud.weighted_expected(k, ws)?;
                    (wsum > 0.0).then(|| (mm.rssi_dbm - mu / wsum, mu / wsum, sd / wsum))
                })
                .collect();
            self.offset.observe(t_ns, &residuals);
        }
        self.cloud = cloud;
        self.pf.resample_if_degenerate();
        let reseed = self.monitor.update(
            mean_l,
            self.cfg.recovery_alpha_slow,
            self.cfg.recovery_alpha_fast,
            self.cfg.recovery_max_fraction,
        );
        // re-seed only when the surface's best cell beats the cloud by
        // `recovery_margin` (tempered log-likelihood) and the walls say the
        // cloud is lost (a biased radio model has better-fitting spots away
        // from the walker: re-seeding there on every dip of the likelihood
        // loses a good track), or when the surface beats the cloud by far
        // (checked every `recovery_check_every` updates even without a dip:
        // a kidnapped cloud's likelihood is low from the start, not falling)
        self.radio_updates_since_check += 1;
        let every = self.cfg.recovery_check_every;
        let check = every > 0 && self.radio_updates_since_check >= every;
        if check {
            self.radio_updates_since_check = 0;
        }
        // far from every survey walk (with reference scans to tell) the
        // surface is the radio map's extrapolation: no re-seeding from it
        let far = self.far_from_survey();
        if far && (reseed > 0.0 || check) {
            self.counts.reseed_far += 1;
        }
        // on a floor without inner walls nothing but the radio can say the
        // cloud is lost, unless the cloud came from a told position
        // (`recovery_told_open_floor`)
        let open = !self.walled.get(&floor).copied().unwrap_or(false);
        let radio_decides = open && !(self.told_start && self.cfg.recovery_told_open_floor);
        let walls_agree = self.kill_ema >= self.cfg.recovery_min_wall_kill || radio_decides;
        // the gap that re-seeds: past `recovery_radio_alone_margin`, or
        // with a dip and the walls' consent past `recovery_margin`; when
        // the bound says the gap cannot pass it, the surface (the largest
        // share of an update that computes it) would change nothing
        let needed = if reseed > 0.0 && walls_agree {
            self.cfg
                .recovery_radio_alone_margin
                .min(self.cfg.recovery_margin)
        } else {
            self.cfg.recovery_radio_alone_margin
        };
        // a radio the walk disagrees with re-seeds nothing (`integrity`)
        let trusted = trust >= self.cfg.integrity.reseed_min_trust;
        if (reseed > 0.0 || check)
            && !far
            && trusted
            && self
                .surface_gap_bound(floor, meas, cloud_ll)
                .is_none_or(|b| b > needed)
            && let Some(surf) = self.surface(floor, meas, missing, &[], self.profile_prior(true))
            && let gap = surf.lse - surf.w.iter().sum::<f64>().ln() - cloud_ll
            && let Some(fraction) = if gap > self.cfg.recovery_radio_alone_margin {
                Some(self.cfg.recovery_max_fraction)
            } else {
                (reseed > 0.0 && gap > self.cfg.recovery_margin && walls_agree).then_some(reseed)
            }
        {
            let reseed = fraction;
            // the re-seeding would move the cloud toward the surface's
            // mean: beyond what the walk allows, the radio is not
            // followed there (`integrity`), and the refused pull counts
            let refused = self.integrity.is_active().then(|| {
                let wsum: f64 = surf.w.iter().sum();
                let toward = surf
                    .cells
                    .iter()
                    .zip(&surf.w)
                    .fold(Vec2::zeros(), |s, (c, w)| {
                        s + c * (*w / wsum.max(f64::MIN_POSITIVE))
                    });
                toward - self.pf.mean().unwrap_or(toward)
            });
            if let Some(pull) = refused.filter(|pull| {
                pull.norm() > self.integrity.allowed_m(&self.cfg.integrity, spread_before)
            }) {
                self.integrity.refuse(pull * reseed);
                self.counts.reseed_untrusted += 1;
            } else {
                self.pf.resample();
                let site = Arc::clone(&self.site);
                let map = site.floor(floor);
                let n =
                    self.pf
                        .inject_from_cells(reseed, &surf.cells, &surf.w, self.cfg.cell_m, |q| {
                            map.is_none_or(|m| m.is_walkable(q))
                        });
                self.draw_offsets_from_cells(&surf);
                self.counts.reseeded += n as u64;
            }
        }
        if trusted {
            self.anchor_reseed(anchors, floor, support);
        }
        if let (Some(a), Some(b)) = (mean_before, self.pf.mean()) {
            self.integrity
                .on_radio(&self.cfg.integrity, t_ns, b - a, spread_before);
        }
        if trust < 1.0 {
            self.counts.trust_reduced += 1;
        }
        if trust < 0.5 {
            self.counts.trust_low += 1;
        }
        self.update_floor(t_ns, meas, anchors);
        if self.floor != floor {
            // pulls on another floor's cloud do not add up with these
            self.integrity.restart(&self.cfg.integrity, self.told_start);
        }
    }

    /// Weighs the particles by the magnetic map at each against the
    /// task's mean |B| `b_ut` less the phone offset (`tcpf.magnetic`); a
    /// particle where the map has no value gets the valued ones' weighted
    /// mean (no evidence either way). Then moves the offset toward the
    /// cloud's mean residual.
    fn magnetic_update(&mut self, b_ut: f64) {
        let model = Arc::clone(&self.model);
        let Some(grid) = model.magnetic().and_then(|m| m.grid(self.floor)) else {
            return;
        };
        let mc = &self.cfg.magnetic;
        let (nu, extra2) = (mc.nu, mc.extra_sd_ut * mc.extra_sd_ut);
        let mut log_l = std::mem::take(&mut self.log_l);
        log_l.clear();
        let (mut wsum, mut lsum, mut rsum) = (0.0, 0.0, 0.0);
        for (p, w) in self.pf.particles().iter().zip(self.pf.weights()) {
            match grid.sample(*p) {
                Some((mu, sd)) => {
                    let s2 = sd * sd + extra2;
                    let r = b_ut - self.mag_offset_ut - mu;
                    let l = -0.5 * (nu + 1.0) * (r * r / (nu * s2)).ln_1p() - 0.5 * s2.ln();
                    log_l.push(l);
                    wsum += w;
                    lsum += w * l;
                    rsum += w * (b_ut - mu);
                }
                None => log_l.push(f64::NAN),
            }
        }
        if wsum > 0.0 {
            let fill = lsum / wsum;
            let weight = mc.weight;
            for l in log_l.iter_mut() {
                *l = weight * if l.is_nan() { fill } else { *l };
            }
            self.pf.weight_log(&log_l);
            self.pf.resample_if_degenerate();
            self.counts.magnetic_updates += 1;
            let innovation = (rsum / wsum - self.mag_offset_ut).clamp(-10.0, 10.0);
            self.mag_offset_ut = (self.mag_offset_ut + mc.offset_gain * innovation)
                .clamp(-mc.max_offset_ut, mc.max_offset_ut);
        }
        self.log_l = log_l;
    }

    /// Whether the phone is far from the survey: the model has reference
    /// scans, `anchors.far_db` is set, and the last query's closest scan
    /// was farther than that (or shared no transmitter).
    fn far_from_survey(&self) -> bool {
        let ac = &self.cfg.anchors;
        ac.k > 0
            && ac.far_db > 0.0
            && self.model.reference_scans().is_some()
            && self.survey_dist_db.is_none_or(|d| d > ac.far_db)
    }

    /// Re-seeds part of the cloud around the anchors of `floor` when its
    /// support has stayed low for `reseed_after` updates.
    fn anchor_reseed(&mut self, anchors: &[Anchor], floor: i32, support: Option<f64>) {
        let ac = self.cfg.anchors.clone();
        let Some(s) = support else { return };
        if ac.reseed_fraction <= 0.0 || ac.reseed_after == 0 {
            return;
        }
        if s >= ac.reseed_support {
            self.low_support = 0;
            return;
        }
        self.low_support += 1;
        if self.low_support < ac.reseed_after {
            return;
        }
        self.low_support = 0;
        let (cells, w): (Vec<Vec2>, Vec<f64>) = anchors
            .iter()
            .filter(|a| a.floor == floor)
            .map(|a| (a.pos, a.w))
            .unzip();
        let site = Arc::clone(&self.site);
        let map = site.floor(floor);
        self.pf.resample();
        let n = self
            .pf
            .inject_from_cells(ac.reseed_fraction, &cells, &w, 2.0 * ac.sigma_m, |q| {
                map.is_none_or(|m| m.is_walkable(q))
            });
        if self.per_particle_offset() && !self.pf.state().is_empty() {
            let belief = (self.offset.mean_db(), self.offset.sd_db());
            self.draw_offsets_of_cell_draws(|_| belief);
        }
        self.counts.anchor_reseeded += n as u64;
    }

    /// The anchors of the trailing scan window: the `k` closest reference
    /// scans of the model, weighted by their RSSI distance.
    fn query_anchors(&mut self, t_ns: i64) -> Vec<Anchor> {
        let model = Arc::clone(&self.model);
        let ac = &self.cfg.anchors;
        let Some(scans) = model.reference_scans() else {
            return Vec::new();
        };
        if ac.k == 0 {
            return Vec::new();
        }
        // the queries of the first full window are all fresh: the start
        // waits for anchors, and those of its short windows are poor
        let window_ns = (scans.config().window_s * 1e9) as i64;
        if let Some((t0, w0, last)) = &self.last_query
            && self.pf.is_initialized()
            && self.first_radio_t_ns.is_some_and(|t| t0 - t >= window_ns)
            && ((t_ns - t0) as f64) < ac.query_period_s * 1e9
        {
            let shift = self.walked - w0;
            let mut out = last.clone();
            out.iter_mut().for_each(|a| a.pos += shift);
            return out;
        }
        self.last_query = None;
        let off = if ac.use_offset {
            self.offset.mean_db()
        } else {
            0.0
        };
        let q = self.trail.vector(t_ns, scans.config().window_s, off);
        if q.len() < ac.min_transmitters {
            return Vec::new();
        }
        let out = scans.weighted_query(&q, ac.k, ac.tau(), ac.metric);
        self.survey_dist_db = out.first().map(|a| a.dist_db);
        self.anchors_dropped_far =
            ac.drop_far_db > 0.0 && self.survey_dist_db.is_some_and(|d| d > ac.drop_far_db);
        if self.anchors_dropped_far {
            self.counts.anchors_dropped_far += 1;
            self.anchor_mean = None;
            return Vec::new();
        }
        if out.is_empty() {
            return out;
        }
        self.counts.anchor_queries += 1;
        if ac.query_period_s > 0.0 {
            self.last_query = Some((t_ns, self.walked, out.clone()));
        }
        out
    }

    fn update_floor(&mut self, t_ns: i64, meas: &[Measurement], anchors: &[Anchor]) {
        if self.site.spec.floors.len() < 2 {
            return;
        }
        let share = self.cfg.anchors.floor_vote_share;
        let vote = if share > 0.0 && !anchors.is_empty() {
            candidate_fix(anchors)
                .filter(|fix| fix.share >= share)
                .map(|fix| fix.floor)
        } else {
            self.radio_floor_vote(meas)
        };
        if let Some(v) = vote {
            self.floors.on_ble_floor(t_ns, v);
        }
        let force = self.cfg.anchors.floor_force_votes;
        let anchor_vote = vote.filter(|_| !anchors.is_empty());
        self.anchor_floor_run = match (anchor_vote, self.anchor_floor_run) {
            (Some(v), _) if v == self.floor => None,
            (Some(v), Some((f, n))) if f == v => Some((v, n + 1)),
            (Some(v), _) => Some((v, 1)),
            (None, run) => run,
        };
        let mut from_barometer = false;
        let target = if self.floors.has_pressure() {
            match self.anchor_floor_run {
                Some((v, n)) if force > 0 && n >= force => {
                    // the anchors have said another floor for long: the
                    // barometer only gives changes, its start was wrong
                    self.floors.reset_to_floor(v);
                    Some(v)
                }
                _ => {
                    from_barometer = true;
                    self.floors.floor()
                }
            }
        } else {
            match (vote, self.other_floor) {
                (Some(v), _) if v == self.floor => {
                    self.other_floor = None;
                    None
                }
                (Some(v), Some((f, n))) if f == v => {
                    self.other_floor = Some((v, n + 1));
                    (n + 1 >= self.cfg.floor_switch_votes).then_some(v)
                }
                (Some(v), _) => {
                    self.other_floor = Some((v, 1));
                    (1 >= self.cfg.floor_switch_votes).then_some(v)
                }
                (None, _) => None,
            }
        };
        let Some(f) = target.filter(|f| *f != self.floor && self.site.floor(*f).is_some()) else {
            return;
        };
        // floors share the x, y frame: the walker changes floor where the
        // track is (stairs, lift), or at the nearest walkable point within
        // `floor_snap_m` (a stairwell drawn as a wall); with none there, a
        // change the barometer alone asks for is not made when
        // `floor_keep_off_map` (the plan lacks the place the walker passes
        // through: a global start on that floor would put the track
        // wherever its plan has room), otherwise a global start there
        let at = self.published.or_else(|| self.pf.mean());
        let site = Arc::clone(&self.site);
        let Some(m) = site.floor(f) else { return };
        let snapped = at.and_then(|p| m.nearest_walkable_within(p, self.cfg.floor_snap_m));
        if snapped.is_none() && at.is_some() && from_barometer && self.cfg.floor_keep_off_map {
            self.counts.floor_changes_off_map += 1;
            return;
        }
        self.counts.floor_changes += 1;
        self.other_floor = None;
        self.anchor_floor_run = None;
        match snapped {
            Some(p) => {
                self.floor = f;
                self.pf.init_at(p, 3.0, |q| m.is_walkable(q));
                self.draw_offsets_from_belief();
                self.monitor.reset();
                self.published = Some(p);
            }
            None => {
                self.global_start(t_ns, meas, &[], &[], Some(f));
            }
        }
    }

    /// The missed transmitters that could matter for the cloud: those
    /// whose expected RSSI at the nearest point of the cloud's bounding box
    /// reaches within 6 sensitivity scales of their radio's sensitivity.
    fn near_missing(&self, missing: &[(usize, f64)], offset_db: f64) -> Vec<(usize, f64)> {
        let ps = self.pf.particles();
        if ps.is_empty() || missing.is_empty() {
            return Vec::new();
        }
        let (mut lo, mut hi) = (ps[0], ps[0]);
        for p in ps {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let tx = self.model.transmitters();
        let scale = self.cfg.likelihood.sensitivity_scale_db;
        missing
            .iter()
            .copied()
            .filter(|&(i, sens)| {
                let Some(t) = tx.get(i) else { return false };
                let q = Vec2::new(t.pos.x.clamp(lo.x, hi.x), t.pos.y.clamp(lo.y, hi.y));
                self.model
                    .expected(i, self.floor, q)
                    .is_some_and(|(mu, _)| mu + offset_db - sens > -6.0 * scale)
            })
            .collect()
    }

    /// The point to publish: the weighted mean, or the heaviest room's
    /// mean, or the heaviest particles, whichever the last published point
    /// reaches without crossing a wall; held up to `max_hold_runs`.
    fn estimate(&mut self) -> Option<Vec2> {
        let mean = if self.cfg.mode_bin_m > 0.0 {
            self.mode_mean(self.cfg.mode_bin_m)?
        } else if self.cfg.median_iters > 0 {
            self.pf.geometric_median(self.cfg.median_iters)?
        } else {
            self.pf.mean()?
        };
        let site = Arc::clone(&self.site);
        let Some(map) = site.floor(self.floor) else {
            return Some(mean);
        };
        let (ps, ws) = (self.pf.particles(), self.pf.weights());
        let Some(prev) = self.published else {
            // the first point: the mean of a cloud spread over two wings
            // can lie in the void between them
            if map.is_walkable(mean) {
                return Some(mean);
            }
            let room = dominant_room(ps, ws, |p| map.room_of(p)).map(|r| r.mean);
            if let Some(r) = room.filter(|r| map.is_walkable(*r)) {
                return Some(r);
            }
            let best = (0..ps.len()).max_by(|a, b| ws[*a].total_cmp(&ws[*b]).then(b.cmp(a)));
            return best.map(|i| ps[i]).or(Some(mean));
        };
        let broad = self.cfg.hold_max_accuracy_m > 0.0
            && self
                .cloud_accuracy_m
                .is_some_and(|a| a > self.cfg.hold_max_accuracy_m);
        let ok = |q: Vec2| map.is_walkable(q) && !map.track_crosses_wall(prev, q);
        if ok(mean) {
            self.hold_runs = 0;
            return Some(mean);
        }
        if let Some(r) = dominant_room(ps, ws, |p| map.room_of(p))
            && ok(r.mean)
        {
            self.hold_runs = 0;
            return Some(r.mean);
        }
        let mut idx: Vec<usize> = (0..ps.len()).collect();
        idx.sort_by(|a, b| ws[*b].total_cmp(&ws[*a]).then(a.cmp(b)));
        if let Some(i) = idx.iter().take(32).find(|i| ok(ps[**i])) {
            self.hold_runs = 0;
            return Some(ps[*i]);
        }
        if self.hold_runs < self.cfg.max_hold_runs && !broad {
            self.hold_runs += 1;
            self.counts.held += 1;
            return Some(prev);
        }
        // the hold ran out: walk toward the cloud through the doors (the
        // hold is not reset, so the walk goes on run after run until the
        // cloud is in reach); where the map has no way there (a door it
        // lacks: the cloud got there through a wall the walker did not
        // cross), jump as before
        let r = dominant_room(ps, ws, |p| map.room_of(p)).map(|r| r.mean);
        let target = r.filter(|q| map.is_walkable(*q)).unwrap_or(mean);
        match map.walk_toward(prev, target, WALK_SPACING_M, WALK_MARGIN_M) {
            Some(w) if w.reaches => {
                self.counts.walked += 1;
                Some(w.next)
            }
            _ => {
                self.hold_runs = 0;
                self.counts.jumps_no_way += 1;
                Some(target)
            }
        }
    }

    /// The weighted mean of the particles within one bin of the heaviest
    /// `bin_m` square: the cloud's main mode (the mean of a cloud split
    /// over two places lies between them).
    fn mode_mean(&self, bin_m: f64) -> Option<Vec2> {
        let (ps, ws) = (self.pf.particles(), self.pf.weights());
        if ps.is_empty() {
            return None;
        }
        let key = |p: &Vec2| ((p.x / bin_m).floor() as i64, (p.y / bin_m).floor() as i64);
        let mut bins: BTreeMap<(i64, i64), f64> = BTreeMap::new();
        for (p, w) in ps.iter().zip(ws) {
            *bins.entry(key(p)).or_insert(0.0) += w;
        }
        // mass of each bin with its 8 neighbours
        let best = bins
            .keys()
            .map(|&(i, j)| {
                let m: f64 = (-1..=1)
                    .flat_map(|di| (-1..=1).map(move |dj| (i + di, j + dj)))
                    .filter_map(|k| bins.get(&k))
                    .sum();
                (m, (i, j))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)))?
            .1;
        let (mut s, mut wsum) = (Vec2::zeros(), 0.0);
        for (p, w) in ps.iter().zip(ws) {
            let (i, j) = key(p);
            if (i - best.0).abs() <= 1 && (j - best.1).abs() <= 1 {
                s += p * *w;
                wsum += w;
            }
        }
        (wsum > 0.0).then(|| s / wsum)
    }

    /// The `accuracy_quantile` of the weighted distances from `at`
    /// ([`weighted_quantile`]: the sorted cloud's value without sorting it).
    fn accuracy_m(&self, at: Vec2) -> f64 {
        let (ps, ws) = (self.pf.particles(), self.pf.weights());
        let mut d: Vec<(f64, f64)> = ps
            .iter()
            .zip(ws)
            .map(|(p, w)| ((p - at).norm(), *w))
            .collect();
        let r = weighted_quantile(&mut d, self.cfg.accuracy_quantile).unwrap_or(0.0);
        (r * self.cfg.accuracy_scale).max(self.cfg.accuracy_min_m)
    }

    /// [`Self::accuracy_m`] widened by the distance to the last anchors'
    /// mean on the track's floor (`anchors.accuracy_share`).
    fn accuracy_with_anchors(&self, at: Vec2) -> f64 {
        let r = self.accuracy_m(at);
        let share = self.cfg.anchors.accuracy_share;
        match self.anchor_mean {
            Some((f, m)) if share > 0.0 && f == self.floor => r.hypot(share * (m - at).norm()),
            _ => r,
        }
    }

    /// The published radius: `cloud_m` widened by `anchors.accuracy_per_db_m`
    /// per dB of RSSI distance from the closest reference scan beyond
    /// `anchors.accuracy_free_db` (in quadrature): a window far, in RSSI,
    /// from every survey scan was heard where the survey never went, and
    /// the radio there is extrapolated.
    fn accuracy_with_survey(&self, cloud_m: f64) -> f64 {
        let ac = &self.cfg.anchors;
        match self.survey_dist_db {
            Some(d) if ac.accuracy_per_db_m > 0.0 && d > ac.accuracy_free_db => {
                cloud_m.hypot(ac.accuracy_per_db_m * (d - ac.accuracy_free_db))
            }
            _ => cloud_m,
        }
    }

    /// The published radius `r` widened, in quadrature, by
    /// `integrity.accuracy_share` of the pull the engine did not follow
    /// (the radio and the walk disagree: either may be wrong).
    fn accuracy_with_integrity(&self, r: f64) -> f64 {
        let share = self.cfg.integrity.accuracy_share;
        let u = self.integrity.unfollowed_m();
        if share > 0.0 && u > 0.0 {
            r.hypot(share * u)
        } else {
            r
        }
    }

    fn publish(&mut self, t_ns: i64) {
        let Some(pos) = self.estimate() else { return };
        if let Some(prev) = self.published {
            let d = pos - prev;
            if d.norm() > 0.2 {
                self.heading_rad = d.y.atan2(d.x);
            }
        }
        self.published = Some(pos);
        let max_age = 3 * self.ble_period_ns.max(1);
        let source = match self.last_radio_t_ns {
            Some(t) if t_ns - t <= max_age => PoseSource::Fused,
            _ => PoseSource::DeadReckoning,
        };
        let floor_prob = if self.site.spec.floors.len() < 2 {
            1.0
        } else if self.other_floor.is_some() {
            0.6
        } else {
            0.9
        };
        let cloud_m = self.accuracy_with_anchors(pos);
        self.cloud_accuracy_m = Some(cloud_m);
        self.pose = Some(Pose {
            t_ns,
            x_m: pos.x,
            y_m: pos.y,
            floor: self.floor,
            heading_rad: self.heading_rad,
            accuracy_m: self.accuracy_with_integrity(self.accuracy_with_survey(cloud_m)),
            floor_prob,
            source,
        });
    }

    fn radio_task(&mut self, t_ns: i64) {
        let (ble, wifi) = (self.ble_active, self.wifi_active);
        self.ble_active = false;
        self.wifi_active = false;
        if self.window.is_empty() {
            return;
        }
        let meas = self.window.take(self.cfg.likelihood.max_transmitters);
        let lc = &self.cfg.likelihood;
        let ble_quiet = (self.cfg.ble_miss_after_s * 1e9) as i64;
        let wifi_quiet = (self.cfg.wifi_max_age_s * 1e9) as i64;
        let missing = if lc.miss_weight > 0.0 {
            self.model
                .transmitters()
                .iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    let (active, quiet, sens) = match t.kind {
                        TxKind::Ble => (ble, ble_quiet, lc.ble_sensitivity_dbm),
                        TxKind::Wifi => (wifi, wifi_quiet, lc.wifi_sensitivity_dbm),
                    };
                    let last = self.last_heard.get(i).copied().unwrap_or(i64::MIN);
                    (active && t_ns.saturating_sub(last) > quiet).then_some((i, sens))
                })
                .collect()
        } else {
            Vec::new()
        };
        let anchors = self.query_anchors(t_ns);
        self.pending = Some(RadioSet {
            meas,
            missing,
            anchors,
        });
    }

    fn fusion_task(&mut self, t_ns: i64) {
        let steps = self.pdr.take_steps();
        let pending = self.pending.take();
        if !self.pf.is_initialized() {
            self.stats.no_fix += 1;
            if let Some(RadioSet {
                meas,
                missing,
                anchors,
            }) = pending
                && meas.len() >= self.cfg.start_min_transmitters
            {
                // the strongest beacons' floor (BLE beacons are few per
                // floor and floors attenuate them), else the floor with
                // the most likelihood mass; the barometer gives floor
                // changes, not the floor itself, until the start anchors it
                let vote = self.radio_floor_vote(&meas);
                let by_anchors = if self.cfg.anchors.start_floor {
                    candidate_fix(&anchors).map(|fix| fix.floor)
                } else {
                    None
                };
                let floor = if by_anchors.is_some() {
                    by_anchors
                } else if self.cfg.start_floor_from_map && self.model.learned_per_floor() {
                    // a radio map's per-floor likelihood mass decides
                    None
                } else {
                    vote
                };
                let first = *self.first_radio_t_ns.get_or_insert(t_ns);
                let anchor_wait_ns = (self.cfg.anchors.start_wait_s * 1e9) as i64;
                if anchors.is_empty()
                    && !self.anchors_dropped_far
                    && self.cfg.anchors.k > 0
                    && self.model.reference_scans().is_some()
                    && t_ns - first < anchor_wait_ns
                {
                    // the survey's scans can place the start: wait a
                    // little for a window they recognise
                    return;
                }
                let wait_ns = (self.cfg.start_wait_ble_s * 1e9) as i64;
                if by_anchors.is_none()
                    && vote.is_none()
                    && self.beacon_floors > 1
                    && t_ns - first < wait_ns
                {
                    // WiFi alone cannot tell the floors apart here (APs
                    // carry through floors): wait a little for a beacon
                    return;
                }
                if self.global_start(t_ns, &meas, &missing, &anchors, floor) {
                    self.publish(t_ns);
                }
            }
            return;
        }
        let mut stepped = false;
        let scale = self.online_step.scale();
        for s in &steps {
            if s.length_m.is_finite() && s.yaw_rad.is_finite() && s.length_m >= 0.0 {
                self.stats.steps += 1;
                let kill = self.step(s.length_m * scale, s.yaw_rad);
                self.online_step.on_step(s.length_m, s.yaw_rad, kill);
                stepped = true;
            }
        }
        let (mag_sum, mag_n) = (self.mag_sum_ut, self.mag_n);
        (self.mag_sum_ut, self.mag_n) = (0.0, 0);
        // a walker standing still reads the same place again and again:
        // the field weighs only after steps (samples are summed only with
        // `magnetic.weight` > 0)
        if stepped && mag_n > 0 {
            self.magnetic_update(mag_sum / f64::from(mag_n));
        }
        if let Some(RadioSet {
            meas,
            missing,
            anchors,
        }) = pending
            && !meas.is_empty()
        {
            self.last_radio_t_ns = Some(t_ns);
            self.radio_update(t_ns, &meas, &missing, &anchors);
        }
        self.learn_step_scale();
        self.publish(t_ns);
    }

    /// Feeds the online step scale the cloud after this fusion run: its
    /// mean and spread, and whether it was moved other than by the steps
    /// and the radio (started, re-seeded, changed floor, a step undone).
    fn learn_step_scale(&mut self) {
        if !self.cfg.online_step.enabled {
            return;
        }
        let c = &self.counts;
        let key =
            c.global_starts + c.reseeded + c.anchor_reseeded + c.floor_changes + c.steps_blocked;
        let jumped = key != self.jump_key;
        self.jump_key = key;
        let before = self.online_step.windows;
        self.online_step
            .on_fusion(self.pf.mean(), self.pf.spread_m(), jumped);
        self.counts.step_windows += self.online_step.windows - before;
    }
}

impl Engine for TcpfEngine {
    fn name(&self) -> &'static str {
        "tcpf"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        if let SensorData::Pressure(p) = event.data
            && p.is_finite()
        {
            self.floors.on_pressure(event.t_ns, p);
        }
        if self.cfg.magnetic.weight > 0.0
            && let SensorData::Magnetometer(b) = event.data
        {
            let ut = crate::radio::magnetic_map::magnitude_ut(b);
            if ut.is_finite() && ut < 1000.0 {
                self.mag_sum_ut += ut;
                self.mag_n += 1;
            }
        }
        self.pdr.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        if !(obs.rssi_dbm.is_finite() && obs.rssi_dbm < 0.0) {
            self.stats.rejected_inputs += 1;
            return;
        }
        if let Some(scans) = self.model.reference_scans()
            && obs.rssi_dbm >= self.cfg.min_rssi_dbm
        {
            self.trail
                .push_ble(scans, &obs.beacon_id, obs.t_ns, obs.rssi_dbm);
        }
        match self.model.lookup(TxKind::Ble, &obs.beacon_id) {
            Some(tx) => {
                self.ble_active = true;
                if let Some(l) = self.last_heard.get_mut(tx) {
                    *l = (*l).max(obs.t_ns);
                }
                if obs.rssi_dbm >= self.cfg.min_rssi_dbm {
                    self.window.push(tx, obs.rssi_dbm);
                }
            }
            None => self.stats.unknown_beacons += 1,
        }
    }

    fn on_wifi(&mut self, scan: &WifiScan) {
        let max_age = (self.cfg.wifi_max_age_s * 1e9) as i64;
        self.wifi_active = true;
        for r in &scan.results {
            if let Some(tx) = self.model.lookup(TxKind::Wifi, &r.bssid)
                && let Some(l) = self.last_heard.get_mut(tx)
            {
                *l = (*l).max(r.seen_t_ns.min(scan.t_ns));
            }
        }
        for r in self.fresh_wifi.of(scan, max_age) {
            if !(r.rssi_dbm.is_finite() && r.rssi_dbm < 0.0) {
                self.stats.rejected_inputs += 1;
                continue;
            }
            if r.rssi_dbm < self.cfg.min_rssi_dbm {
                continue;
            }
            if let Some(scans) = self.model.reference_scans() {
                self.trail
                    .push_wifi(scans, &r.bssid, r.seen_t_ns.min(scan.t_ns), r.rssi_dbm);
            }
            if let Some(tx) = self.model.lookup(TxKind::Wifi, &r.bssid) {
                self.window.push(tx, r.rssi_dbm);
            }
        }
    }

    fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<()> {
        crate::engine::check_initial_position(&self.site, &at)?;
        drop(self.pdr.take_steps());
        self.start_at(at);
        self.publish(t_ns);
        Ok(())
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        match task {
            Task::Ble => self.radio_task(t_ns),
            Task::Fusion => self.fusion_task(t_ns),
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        Some(match task {
            Task::Ble => self.ble_period_ns,
            Task::Fusion => self.fusion_period_ns,
        })
    }

    fn pose(&self) -> Option<Pose> {
        self.pose
    }

    fn diagnostics(&self) -> Vec<(&'static str, u64)> {
        self.counts.named().to_vec()
    }

    fn stats(&self) -> EngineStats {
        let mut s = self.stats.clone();
        s.rssi_offset_db = Some(self.offset.mean_db());
        s.step_scale = Some(self.online_step.scale());
        s.radio_trust = Some(self.integrity.trust());
        s
    }
}

#[cfg(test)]
mod tests;
