//! `tcpf` section of the engine config (docs/parameters.md "tcpf" gives
//! every default's source).

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::fusion::FusionConfig;
use crate::fusion::kld::KldConfig;
use crate::radio::LikelihoodConfig;
use crate::radio::offset::OffsetConfig;
use crate::radio::reference_scans::ScanMetric;

use super::integrity::IntegrityConfig;

/// Settings of engine `tcpf`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TcpfConfig {
    /// Particles.
    pub particle_count: usize,
    /// Uniform step-length and heading noise of a move (half-widths).
    pub step_noise_m: f64,
    pub heading_noise_rad: f64,
    /// Per-particle persistent heading offset (sd at the start, rad) and
    /// its random walk per step.
    pub heading_offset_sd_rad: f64,
    pub heading_offset_walk_rad: f64,
    /// Gaussian position noise added to every move (roughening), metres.
    pub position_noise_m: f64,
    /// Resample when the effective sample size falls below this fraction.
    pub resample_ess_fraction: f64,
    /// Spacing of the start / re-seeding cells over the walkable area, m.
    pub cell_m: f64,
    /// The global start needs this many transmitters in one update.
    pub start_min_transmitters: usize,
    /// The global start waits up to this long (after the first radio
    /// update) for what can place it: with reference scans, a window they
    /// recognise (anchors); on a site with beacons on several floors, a
    /// beacon to pick the floor. s.
    pub start_wait_s: f64,
    /// Augmented MCL: slow and fast averages of the per-transmitter
    /// likelihood, and the largest fraction re-seeded per update.
    pub recovery_alpha_slow: f64,
    pub recovery_alpha_fast: f64,
    pub recovery_max_fraction: f64,
    /// ... and only while the moving share of particles killed by walls
    /// per step is at least this (the map says the cloud is lost; the
    /// radio alone is too biased on real sites to say so).
    pub recovery_min_wall_kill: f64,
    /// ... or, whatever the walls say, when the surface beats the cloud
    /// by more than this (a kidnapped walker whose steps fit the map where
    /// the cloud is).
    pub recovery_radio_alone_margin: f64,
    /// `recovery_radio_alone_margin` for a cloud the radio placed (a
    /// global start, not a told position): what the radio placed, the
    /// radio may move with less evidence.
    pub recovery_global_radio_alone_margin: f64,
    /// After a told start (`InitialPosition`, `set_position`): the told
    /// position moved by every step since (no walls, no radio) and a reach
    /// around it of `told_reach_m` + `told_reach_per_walked` x the distance
    /// the steps walked since (`told_reach.rs`). A walker told where it
    /// stood is within the steps' drift of that point, whatever a radio
    /// biased off the survey's routes says: re-seeding draws only from
    /// the surface's cells within the reach, and each radio update takes
    /// `told_reach_weight` x ((d - reach) / reach)^2 / 2 off the
    /// log-likelihood of a particle d m from the point beyond it. m; 0 =
    /// off (as after a global start, which has no reach; nor has a floor
    /// other than the told one).
    pub told_reach_m: f64,
    /// See `told_reach_m`, m per m walked.
    pub told_reach_per_walked: f64,
    /// See `told_reach_m` (0 = only the re-seeding is bounded).
    pub told_reach_weight: f64,
    /// The told reach around the wedge of the steps' displacement since
    /// the told position, scaled by `told_reach_scale_lo`..`_hi` and turned
    /// by at most `told_reach_turn_rad`, instead of around the
    /// dead-reckoned point (a step length or a heading biased alike over
    /// the walk moves the walker along or across the displacement).
    pub told_reach_wedge: bool,
    /// See `told_reach_wedge`.
    pub told_reach_scale_lo: f64,
    /// See `told_reach_wedge`.
    pub told_reach_scale_hi: f64,
    /// See `told_reach_wedge`, rad.
    pub told_reach_turn_rad: f64,
    /// Without a barometer, a floor change needs this many consecutive
    /// radio updates voting for the other floor.
    pub floor_switch_votes: u32,
    /// A floor change puts the cloud at the track's point on the new
    /// floor, or at the nearest walkable point within this many metres.
    pub floor_snap_m: f64,
    /// The published point is held (not moved through a wall) for at most
    /// this many fusion runs before it follows the cloud anyway.
    pub max_hold_runs: u32,
    /// The hold applies only when the last published pose claimed at most
    /// this accuracy radius (m): a pose of a cloud spread over the floor
    /// (the global start before the radio places it) says nowhere in
    /// particular, so the point walks toward the first sharp estimate
    /// (through the doors) at once instead of waiting `max_hold_runs`.
    /// 0 = always hold.
    pub hold_max_accuracy_m: f64,
    /// Accuracy radius: this quantile of the weighted particle distances
    /// from the published point, times `accuracy_scale`, at least
    /// `accuracy_min_m`.
    pub accuracy_quantile: f64,
    pub accuracy_scale: f64,
    pub accuracy_min_m: f64,
    /// After a global start the radius keeps a memory of how wide the
    /// start was: it is widened (in quadrature) by
    /// `start_accuracy_share` x the start cloud's RMS spread x
    /// exp(-t / `start_accuracy_decay_s`), t the time since the start.
    /// The cloud narrows within seconds of radio updates whose errors are
    /// correlated, faster than the evidence warrants; 0 = off.
    pub start_accuracy_share: f64,
    /// See `start_accuracy_share`, s.
    pub start_accuracy_decay_s: f64,
    /// Only WiFi results at most this old (vs their scan) are used, s; an
    /// AP not heard for this long while WiFi scans counts as missed.
    pub wifi_max_age_s: f64,
    /// Readings weaker than this are not used, dBm.
    pub min_rssi_dbm: f64,
    pub likelihood: LikelihoodConfig,
    pub offset: OffsetConfig,
    pub anchors: AnchorConfig,
    /// The radio checked against the walk (module `integrity`).
    pub integrity: IntegrityConfig,
    /// The particle count adapted to the cloud's extent (KLD-sampling,
    /// module `particle_count`): many while the cloud is wide (a global
    /// start), few once it has converged; `max_particles` 0 keeps
    /// `particle_count` throughout.
    pub adaptive_count: KldConfig,
}

/// Anchors: the k reference scans of the radio map closest to the phone's
/// trailing scan window ([`crate::radio::reference_scans`]) as a mixture
/// of Gaussians over the floor: it shapes the global start, weighs the
/// particles weakly, and re-seeds a cloud that has lost it. Used only with
/// a radio map that carries reference scans.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnchorConfig {
    /// Candidates per query (0 = anchors off).
    pub k: usize,
    /// A query needs this many transmitters in its window.
    pub min_transmitters: usize,
    /// Candidate weight exp(-(d - d_best) / tau_db) of its RSSI distance d.
    pub tau_db: f64,
    /// Spread of each candidate's Gaussian, metres.
    pub sigma_m: f64,
    /// Mixture floor relative to a lone candidate's peak: a particle far
    /// from every candidate keeps this much likelihood (heavy tail).
    pub floor: f64,
    /// Exponent of the mixture in each radio update (0 = start and
    /// re-seeding only).
    pub weight: f64,
    /// Floor votes after the start come from the anchors (their heaviest
    /// floor when it holds at least this share of their weight; 0 = the
    /// strongest beacons vote, as without anchors).
    pub floor_vote_share: f64,
    /// With a barometer, this many consecutive anchor votes for another
    /// floor move the track there even when the barometer saw no change
    /// (a wrong start floor is otherwise kept for good; 0 = never).
    pub floor_force_votes: u32,
    /// Far from the survey: when the closest reference scan is more than
    /// this (RMS dB) from the phone's window, or none shares a heard
    /// transmitter, the cloud is not re-seeded from the likelihood surface
    /// (there the radio map is its own extrapolation). 0 = off.
    pub far_db: f64,
    /// Far from the survey (`far_db`), the survey's own walked lines are
    /// where the phone is least likely: had it been there, its window
    /// would resemble their scans. Each radio update then takes
    /// `far_survey_penalty` x exp(-d^2 / (2 `far_survey_sigma_m`^2)) off
    /// the log-likelihood of a particle `d` m from the nearest reference
    /// scan (tempered by the radio's trust), so the cloud is not drawn onto
    /// the nearest surveyed corridor by the map's extrapolation. 0 = off.
    pub far_survey_penalty: f64,
    /// See `far_survey_penalty`, m.
    pub far_survey_sigma_m: f64,
    /// Accuracy radius: the cloud's radius and this share of the distance
    /// from the published point to the anchors' mean, added in
    /// quadrature (a track the fingerprints disagree with is less sure
    /// than its cloud says; 0 = the cloud alone).
    pub accuracy_share: f64,
    /// How the query ranks and weighs the reference scans
    /// (`rms_db` or `bray_curtis_powed`).
    pub metric: ScanMetric,
    /// Candidate weight exp(-(s - s_best) / tau_powed) of its Bray-Curtis
    /// score s (in [0, 1]) under `bray_curtis_powed`.
    pub tau_powed: f64,
}

impl Default for AnchorConfig {
    fn default() -> Self {
        AnchorConfig {
            k: 8,
            min_transmitters: 3,
            tau_db: 2.0,
            sigma_m: 8.0,
            floor: 0.05,
            weight: 3.0,
            floor_vote_share: 0.5,
            floor_force_votes: 5,
            far_db: 12.0,
            far_survey_penalty: 3.0,
            far_survey_sigma_m: 4.0,
            accuracy_share: 0.4,
            metric: ScanMetric::BrayCurtisPowed,
            tau_powed: 0.2,
        }
    }
}

impl AnchorConfig {
    /// The candidate weights' temperature of `metric`.
    pub fn tau(&self) -> f64 {
        match self.metric {
            ScanMetric::RmsDb => self.tau_db,
            ScanMetric::BrayCurtisPowed => self.tau_powed,
        }
    }

    /// Checks every field; errors name `tcpf.anchors.<field>`.
    pub fn validate(&self) -> Result<()> {
        for (f, v, lo, hi) in [
            ("tau_db", self.tau_db, 0.01, 100.0),
            ("sigma_m", self.sigma_m, 0.1, 100.0),
            ("floor", self.floor, 1e-9, 10.0),
            ("weight", self.weight, 0.0, 100.0),
            ("far_db", self.far_db, 0.0, 1000.0),
            ("far_survey_penalty", self.far_survey_penalty, 0.0, 100.0),
            ("far_survey_sigma_m", self.far_survey_sigma_m, 0.5, 50.0),
            ("floor_vote_share", self.floor_vote_share, 0.0, 1.0),
            ("accuracy_share", self.accuracy_share, 0.0, 10.0),
            ("tau_powed", self.tau_powed, 1e-4, 10.0),
        ] {
            crate::bounds::check_range(&format!("tcpf.anchors.{f}"), v, lo, hi)?;
        }
        if self.k > 256
            || !(1..=1024).contains(&self.min_transmitters)
            || self.floor_force_votes > 1000
        {
            return Err(crate::Error::config(
                "tcpf.anchors.k",
                "k must be <= 256, min_transmitters in 1..=1024, floor_force_votes <= 1000",
            ));
        }
        Ok(())
    }
}

impl Default for TcpfConfig {
    fn default() -> Self {
        TcpfConfig {
            particle_count: 1000,
            step_noise_m: 0.15,
            heading_noise_rad: 0.15,
            heading_offset_sd_rad: 0.15,
            heading_offset_walk_rad: 0.01,
            position_noise_m: 0.2,
            resample_ess_fraction: 0.5,
            cell_m: 2.0,
            start_min_transmitters: 1,
            start_wait_s: 5.0,
            recovery_alpha_slow: 0.05,
            recovery_alpha_fast: 0.5,
            recovery_max_fraction: 0.1,
            recovery_min_wall_kill: 0.3,
            recovery_radio_alone_margin: 20.0,
            recovery_global_radio_alone_margin: 8.0,
            told_reach_m: 3.0,
            told_reach_per_walked: 0.1,
            told_reach_weight: 10.0,
            told_reach_wedge: true,
            told_reach_scale_lo: 0.8,
            told_reach_scale_hi: 1.4,
            told_reach_turn_rad: 0.2,
            floor_switch_votes: 3,
            floor_snap_m: 5.0,
            max_hold_runs: 5,
            hold_max_accuracy_m: 24.0,
            accuracy_quantile: 0.68,
            accuracy_scale: 1.6,
            accuracy_min_m: 1.6,
            start_accuracy_share: 0.25,
            start_accuracy_decay_s: 30.0,
            wifi_max_age_s: 4.0,
            min_rssi_dbm: -100.0,
            likelihood: LikelihoodConfig::default(),
            offset: OffsetConfig::default(),
            anchors: AnchorConfig::default(),
            integrity: IntegrityConfig::default(),
            adaptive_count: KldConfig::default(),
        }
    }
}

impl TcpfConfig {
    /// Checks every field's range; errors name `tcpf.<field>`.
    pub fn validate(&self) -> Result<()> {
        if !(1..=100_000).contains(&self.particle_count) {
            return Err(crate::Error::config(
                "tcpf.particle_count",
                format!("must be in 1..=100000, got {}", self.particle_count),
            ));
        }
        self.check_ranges()?;
        if self.recovery_alpha_slow > self.recovery_alpha_fast {
            return Err(crate::Error::config(
                "tcpf.recovery_alpha_slow",
                "must not exceed recovery_alpha_fast",
            ));
        }
        if !(1..=64).contains(&self.start_min_transmitters) {
            return Err(crate::Error::config(
                "tcpf.start_min_transmitters",
                "must be in 1..=64",
            ));
        }
        if self.floor_switch_votes > 1000 || self.max_hold_runs > 1000 {
            return Err(crate::Error::config(
                "tcpf.floor_switch_votes",
                "floor_switch_votes and max_hold_runs must be <= 1000",
            ));
        }
        self.likelihood.validate()?;
        self.anchors.validate()?;
        self.integrity.validate()?;
        self.adaptive_count.validate("tcpf.adaptive_count")?;
        self.offset.validate()
    }

    /// Checks the real-valued fields' ranges; errors name `tcpf.<field>`.
    fn check_ranges(&self) -> Result<()> {
        // field lo hi: each must be finite and in [lo, hi]
        macro_rules! ranges {
            ($($f:ident $lo:literal $hi:literal,)*) => { $(
                let v = self.$f;
                if !(v.is_finite() && ($lo..=$hi).contains(&v)) {
                    return Err(crate::Error::config(
                        concat!("tcpf.", stringify!($f)),
                        format!("must be in [{}, {}], got {v}", $lo, $hi),
                    ));
                }
            )* };
        }
        ranges! {
            step_noise_m 0.0 5.0,
            heading_noise_rad 0.0 3.2,
            heading_offset_sd_rad 0.0 1.0,
            heading_offset_walk_rad 0.0 1.0,
            position_noise_m 0.0 10.0,
            resample_ess_fraction 0.0 1.0,
            recovery_min_wall_kill 0.0 1.0,
            recovery_radio_alone_margin 0.0 1e6,
            recovery_global_radio_alone_margin 0.0 1e6,
            told_reach_m 0.0 1e4,
            told_reach_per_walked 0.0 10.0,
            told_reach_weight 0.0 1e6,
            told_reach_scale_lo 0.0 10.0,
            told_reach_scale_hi 0.0 10.0,
            told_reach_turn_rad 0.0 3.2,
            cell_m 0.25 50.0,
            start_wait_s 0.0 600.0,
            recovery_alpha_slow 0.0 1.0,
            recovery_alpha_fast 0.0 1.0,
            recovery_max_fraction 0.0 1.0,
            accuracy_quantile 0.01 0.999,
            floor_snap_m 0.0 50.0,
            hold_max_accuracy_m 0.0 1e6,
            accuracy_scale 0.01 100.0,
            accuracy_min_m 0.0 1000.0,
            start_accuracy_share 0.0 10.0,
            start_accuracy_decay_s 0.1 3600.0,
            wifi_max_age_s 0.0 600.0,
            min_rssi_dbm -200.0 0.0,
        }
        Ok(())
    }

    /// The particle filter's settings (the shared [`crate::fusion::ParticleFilter`]).
    pub fn filter(&self) -> FusionConfig {
        FusionConfig {
            particle_count: self.particle_count,
            step_noise_m: self.step_noise_m,
            heading_noise_rad: self.heading_noise_rad,
            heading_offset_sd_rad: self.heading_offset_sd_rad,
            heading_offset_walk_rad: self.heading_offset_walk_rad,
            heading_offset_corr_steps: 0.0,
            step_scale_sd: 0.0,
            step_scale_walk: 0.0,
            resample_ess_fraction: self.resample_ess_fraction,
            ..FusionConfig::default()
        }
    }
}
