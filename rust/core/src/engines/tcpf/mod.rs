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
//! - `Task::Radio` (every `tasks.radio_period_ms`): the readings of BLE beacons
//!   and WiFi access points since the last run become one measurement set.
//! - `Task::Fusion` (every `tasks.fusion_period_ms`): the PDR steps since the
//!   last run move the particles (each with its own heading offset and step
//!   scale); a move through a wall kills the particle (doors pass); the
//!   pending measurement set weighs them; the phone's RSSI offset is updated
//!   from the residuals ([`crate::radio::PhoneOffset`]; with per-particle
//!   offsets (without a radio map: with the path-loss model)
//!   each particle carries its own, drawn at the start
//!   and on re-seeding from the offset profiled at its cell); ESS resampling;
//!   augmented-MCL re-seeding from the likelihood surface when the cloud has
//!   lost the radio; the published point never jumps through a wall (it
//!   walks toward the cloud through the doors, [`crate::map::FloorMap::walk_toward`]).
//!
//! Start: with an [`InitialPosition`] the particles start there; otherwise
//! from the first measurement set, drawn over the walkable area of the most
//! likely floor in proportion to the likelihood with the phone offset
//! profiled per cell (a global start: the first pose comes with the first
//! radio update, with an accuracy radius as wide as the cloud); with
//! per-particle offsets each particle keeps its cell's offset, so a weak
//! phone near the beacons and a normal one far from them both stay in the
//! cloud until the walk tells them apart.
//!
//! Layout: this file holds the engine's state (grouped by concern), its
//! construction, the fusion task and the [`Engine`] impl; each concern
//! lives in its own module with the state it owns: `input` (readings into
//! the radio task's measurement set), `radio_update` (the radio weighing
//! and its buffers), `anchors` (reference-scan anchors), `recovery`
//! (re-seeding from the likelihood surface), `start` and `cells` (the
//! global start and its cells), `offsets` (the phone's RSSI offset),
//! `floor` (floor votes and changes), `motion` (steps, online step scale),
//! `magnetic` (the magnetic update), `survey_reach` (the distance to the
//! survey's walks), `survey_fit` (the survey's own misfit to the map
//! per place), `told_reach` (how far a told start's walker can be from
//! its dead-reckoned track), `particle_count` (resampling, the adaptive count),
//! `publish` (the published pose and its accuracy radius), `counts`
//! (diagnostics).

mod anchors;
mod cells;
pub mod config;
mod counts;
mod floor;
mod input;
pub mod integrity;
mod motion;
mod offsets;
mod particle_count;
mod publish;
mod radio_update;
mod recovery;
mod start;
mod survey_fit;
mod survey_reach;
mod told_reach;

use std::sync::Arc;

pub use config::{AnchorConfig, TcpfConfig};
pub use counts::TcpfCounts;
pub use integrity::{IntegrityConfig, RadioIntegrity};

use crate::Result;
use crate::Vec2;
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorData, SensorEvent, WifiScan};
use crate::floor::FloorTracker;
use crate::fusion::ParticleFilter;
use crate::pdr::Pdr;
use crate::radio::TxKind;
use crate::radio::model::PathLossParams;
use crate::radio::reference_scans::candidate_fix;
use crate::radio::{PathLossModel, RadioModel};
use crate::site::Site;

use anchors::AnchorState;
use cells::Cells;
use floor::FloorVotes;
use input::{RadioInput, RadioSet};
use offsets::OffsetState;
use publish::Publisher;
use radio_update::Scratch;
use recovery::RecoveryState;
use start::StartState;
use survey_fit::SurveyFit;
use survey_reach::SurveyReach;
use told_reach::ToldReach;

/// The tightly coupled radio-likelihood particle filter. Its state is
/// grouped by concern; each group lives in the module that works on it.
pub struct TcpfEngine {
    site: Arc<Site>,
    cfg: TcpfConfig,
    model: Arc<dyn RadioModel>,
    pdr: Pdr,
    pf: ParticleFilter,
    floors: FloorTracker,
    /// The floor the cloud is on.
    floor: i32,
    /// The radio readings since the last radio task, and the measurement
    /// set it made (`input.rs`).
    input: RadioInput,
    /// The reference-scan anchors (`anchors.rs`).
    anchors: AnchorState,
    /// The runs of floor votes (`floor.rs`).
    votes: FloorVotes,
    /// Start / re-seeding cells and the model's values over them (`cells.rs`).
    cells: Cells,
    /// What the global start waits for (`start.rs`).
    start: StartState,
    /// The phone's RSSI offset (`offsets.rs`).
    offset: OffsetState,
    /// The radio's trust from its pulls against the walk (`integrity`).
    integrity: RadioIntegrity,
    /// When the cloud has lost the radio (`recovery.rs`).
    recovery: RecoveryState,
    /// The published point and pose (`publish.rs`).
    publisher: Publisher,
    /// Reused buffers of the steps and the radio update (`radio_update.rs`).
    scratch: Scratch,
    /// The distance to the survey's walks, built at its first use (once
    /// per radio map, shared by its engines: `radio::derived`;
    /// `survey_reach.rs`).
    reach: Option<Arc<SurveyReach>>,
    /// The dead-reckoned told position and its reach (`told_reach.rs`).
    told_reach: ToldReach,
    /// The survey's own misfit per place, built at its first use (once
    /// per radio map, as `reach`; `survey_fit.rs`; `None` inside: the
    /// model has no reference scans).
    survey_fit: Option<Option<Arc<SurveyFit>>>,
    ble_period_ns: i64,
    fusion_period_ns: i64,
    stats: EngineStats,
    /// Diagnostics of the run.
    pub counts: TcpfCounts,
    /// The phone model's offsets (BLE, WiFi) the radio map knows, dB,
    /// subtracted from every reading (`EngineConfig::device`); `None`: 0.
    device_offsets_db: [Option<f64>; 2],
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
        let mut e = TcpfEngine {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            pf: ParticleFilter::new(&cfg.filter(), config.seed),
            floors: FloorTracker::new(&config.ekf.floor, &site.floor_heights(), start_floor),
            floor: start_floor,
            input: RadioInput::new(),
            anchors: AnchorState::default(),
            votes: FloorVotes::default(),
            cells: Cells::of_site(&site, cfg.cell_m),
            start: StartState::new(model.as_ref()),
            offset: OffsetState::new(&cfg.offset),
            integrity: RadioIntegrity::for_model(!model.learned_per_floor()),
            recovery: RecoveryState::of_site(&site),
            publisher: Publisher::default(),
            scratch: Scratch::default(),
            reach: None,
            told_reach: ToldReach::default(),
            survey_fit: None,
            ble_period_ns: i64::from(config.tasks.radio_period_ms) * 1_000_000,
            fusion_period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            stats: EngineStats::default(),
            counts: TcpfCounts::default(),
            // no map holds an empty name: "" (not known) finds nothing
            device_offsets_db: [TxKind::Ble, TxKind::Wifi]
                .map(|k| model.device_offset_db(&config.device, k)),
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

    /// The phone RSSI offset estimate and its sd, dB.
    pub fn rssi_offset_db(&self) -> (f64, f64) {
        (self.offset.phone.mean_db(), self.offset.phone.sd_db())
    }

    /// The radio's trust in [`IntegrityConfig::min_trust`, 1]: 1 unless
    /// `integrity` found the radio pulling the cloud beyond what the walk
    /// allows.
    pub fn radio_trust(&self) -> f64 {
        self.integrity.trust()
    }

    /// Particle positions and weights (plots, tests).
    pub fn particles(&self) -> (&[Vec2], &[f64]) {
        (self.pf.particles(), self.pf.weights())
    }

    /// The fusion task: the start, or the steps, the magnetic field and
    /// the pending radio set, then the published pose.
    fn fusion_task(&mut self, t_ns: i64) {
        let steps = self.pdr.take_steps();
        let pending = self.input.pending.take();
        if !self.pf.is_initialized() {
            self.stats.no_fix += 1;
            if let Some(RadioSet { meas, anchors }) = pending
                && meas.len() >= self.cfg.start_min_transmitters
            {
                // the strongest beacons' floor (BLE beacons are few per
                // floor and floors attenuate them), else the floor with
                // the most likelihood mass; the barometer gives floor
                // changes, not the floor itself, until the start anchors it
                let vote = self.radio_floor_vote(&meas);
                let by_anchors = candidate_fix(&anchors).map(|fix| fix.floor);
                let floor = if by_anchors.is_some() {
                    by_anchors
                } else if self.model.learned_per_floor() {
                    // a radio map's per-floor likelihood mass decides
                    None
                } else {
                    vote
                };
                let first = *self.start.first_radio_t_ns.get_or_insert(t_ns);
                let wait_ns = (self.cfg.start_wait_s * 1e9) as i64;
                if anchors.is_empty()
                    && self.cfg.anchors.k > 0
                    && self.model.reference_scans().is_some()
                    && t_ns - first < wait_ns
                {
                    // the survey's scans can place the start: wait a
                    // little for a window they recognise
                    return;
                }
                if by_anchors.is_none()
                    && vote.is_none()
                    && self.start.beacon_floors > 1
                    && t_ns - first < wait_ns
                {
                    // WiFi alone cannot tell the floors apart here (APs
                    // carry through floors): wait a little for a beacon
                    return;
                }
                if self.global_start(t_ns, &meas, &anchors, floor) {
                    self.publish(t_ns);
                }
            }
            return;
        }
        for s in &steps {
            if s.length_m.is_finite() && s.yaw_rad.is_finite() && s.length_m >= 0.0 {
                self.stats.steps += 1;
                self.step(s.length_m, s.yaw_rad);
            }
        }
        if let Some(RadioSet { meas, anchors }) = pending
            && !meas.is_empty()
        {
            self.publisher.last_radio_t_ns = Some(t_ns);
            self.radio_update(t_ns, &meas, &anchors);
        }
        self.publish(t_ns);
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
        self.pdr.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        self.hear_ble(obs);
    }

    fn on_wifi(&mut self, scan: &WifiScan) {
        self.hear_wifi(scan);
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
            Task::Radio => self.radio_task(t_ns),
            Task::Fusion => self.fusion_task(t_ns),
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        Some(match task {
            Task::Radio => self.ble_period_ns,
            Task::Fusion => self.fusion_period_ns,
        })
    }

    fn pose(&self) -> Option<Pose> {
        self.publisher.pose
    }

    fn diagnostics(&self) -> Vec<(&'static str, u64)> {
        self.counts.named().to_vec()
    }

    fn stats(&self) -> EngineStats {
        let mut s = self.stats.clone();
        s.rssi_offset_db = Some(self.offset.phone.mean_db());
        s.radio_trust = Some(self.integrity.trust());
        [s.device_ble_offset_db, s.device_wifi_offset_db] = self.device_offsets_db;
        s
    }
}

#[cfg(test)]
mod tests;
