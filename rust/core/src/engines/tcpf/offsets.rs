//! The phone's RSSI offset: one for the cloud, or one per particle (drawn
//! at the start and on re-seeding, walked between radio updates,
//! summarised into the reported belief).

use super::TcpfEngine;
use super::start::Surface;
use crate::radio::likelihood::CloudLikelihood;
use crate::radio::offset::OffsetConfig;
use crate::radio::{Measurement, PhoneOffset};

/// The phone offset's belief and the time of its last random walk.
pub(super) struct OffsetState {
    /// The belief (with per-particle offsets: their summary).
    pub(super) phone: PhoneOffset,
    /// Last random walk of the per-particle offsets.
    last_walk_t_ns: Option<i64>,
}

impl OffsetState {
    /// The configured prior, never walked.
    pub(super) fn new(config: &OffsetConfig) -> Self {
        OffsetState {
            phone: PhoneOffset::new(config),
            last_walk_t_ns: None,
        }
    }
}

impl TcpfEngine {
    /// The prior of the offset profiled at a start or re-seeding: the
    /// current belief, or on a re-seeding under the configured prior
    /// (`reseed_under_prior`), that prior.
    pub(super) fn profile_prior(&self, reseed: bool) -> (f64, f64) {
        let oc = self.offset.phone.config();
        if reseed && self.reseed_under_prior() {
            (oc.prior_db, oc.prior_sd_db)
        } else {
            (self.offset.phone.mean_db(), self.offset.phone.sd_db())
        }
    }

    /// Whether a re-seeding profiles the offset under the configured
    /// prior: with one offset (not per particle) while its belief lies beyond
    /// `offset.reseed_prior_beyond_sd` prior sds from the prior's mean.
    fn reseed_under_prior(&self) -> bool {
        let oc = self.offset.phone.config();
        let k = oc.reseed_prior_beyond_sd;
        !self.per_particle_offset()
            && k > 0.0
            && (self.offset.phone.mean_db() - oc.prior_db).abs() > k * oc.prior_sd_db
    }

    /// Whether each particle carries its own offset: with the path-loss
    /// model (where position and offset trade off along every beacon's
    /// range, so they are resolved jointly), not with a radio map learned
    /// from a survey (one offset for the cloud; docs/lab "per-particle
    /// offsets" gives the figures of each choice).
    pub(super) fn per_particle_offset(&self) -> bool {
        self.offset.phone.config().enabled && !self.model.learned_per_floor()
    }

    /// Per-particle offsets: every particle's drawn from N(mean, (k sd)^2)
    /// of the current belief, k = `offset.particle_start_spread` (after an
    /// init at a point).
    pub(super) fn draw_offsets_from_belief(&mut self) {
        if !self.per_particle_offset() {
            return;
        }
        let (o, sd) = (self.offset.phone.mean_db(), self.offset.phone.sd_db());
        let sd = sd * self.offset.phone.config().particle_start_spread;
        let m = self.offset.phone.config().max_abs_db;
        let n = self.pf.particles().len();
        let v: Vec<f64> = (0..n)
            .map(|_| (o + sd * self.pf.draw_normal()).clamp(-m, m))
            .collect();
        self.pf.set_state(v);
    }

    /// Per-particle offsets of the particles the last cell draw placed:
    /// each from N(its cell's profiled offset, that offset's sd^2).
    pub(super) fn draw_offsets_from_cells(&mut self, s: &Surface) {
        if !self.per_particle_offset() {
            return;
        }
        let n = self.pf.particles().len();
        if self.pf.state().len() != n {
            let o = self.offset.phone.mean_db();
            self.pf.set_state(vec![o; n]);
        }
        let k = self.offset.phone.config().particle_start_spread;
        self.draw_offsets_of_cell_draws(|c| (s.cell_offset_db[c], k * s.cell_offset_sd_db[c]));
    }

    /// The offset of every particle the last cell draw placed, from
    /// N(mean, sd^2) = `of_cell(its cell)`, clamped to `max_abs_db`.
    pub(super) fn draw_offsets_of_cell_draws(&mut self, of_cell: impl Fn(usize) -> (f64, f64)) {
        let m = self.offset.phone.config().max_abs_db;
        let draws = self.pf.cell_draws().to_vec();
        for (i, c) in draws {
            let (mean, sd) = of_cell(c);
            let z = self.pf.draw_normal();
            self.pf.state_mut()[i] = (mean + sd * z).clamp(-m, m);
        }
    }

    /// One offset for the cloud after a re-seeding that placed `share` of
    /// the particles from `s` profiled under the prior
    /// (`offset.reseed_prior_beyond_sd`): the belief becomes the mixture
    /// of the old one (1 - share) and the surface's (share).
    pub(super) fn mix_offset_with_surface(&mut self, s: &Surface, share: f64) {
        if self.per_particle_offset() || !self.reseed_under_prior() {
            return;
        }
        let f = share.clamp(0.0, 1.0);
        let wsum: f64 = s.w.iter().sum();
        if f <= 0.0 || wsum <= 0.0 {
            return;
        }
        let var_s =
            s.w.iter()
                .zip(&s.cell_offset_sd_db)
                .zip(&s.cell_offset_db)
                .map(|((w, sd), o)| w * (sd * sd + (o - s.offset_db) * (o - s.offset_db)))
                .sum::<f64>()
                / wsum;
        let (m0, sd0) = (self.offset.phone.mean_db(), self.offset.phone.sd_db());
        let mean = (1.0 - f) * m0 + f * s.offset_db;
        let var = (1.0 - f) * sd0 * sd0 + f * var_s + f * (1.0 - f) * (m0 - s.offset_db).powi(2);
        self.offset.phone.set(mean, var.sqrt());
    }

    /// The weighted mean and sd of the particles' offsets into the
    /// reported belief.
    pub(super) fn summarise_offsets(&mut self) {
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
        self.offset.phone.set(mean, var.sqrt().max(0.05));
    }

    /// The random walk of every particle's offset over `dt_s`.
    pub(super) fn walk_offsets(&mut self, dt_s: f64) {
        let oc = self.offset.phone.config();
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

    /// With per-particle offsets (`per_particle`), the random walk of
    /// every particle's offset since the last radio update at `t_ns`.
    pub(super) fn walk_offsets_to(&mut self, t_ns: i64, per_particle: bool) {
        if per_particle {
            let dt_s = self
                .offset
                .last_walk_t_ns
                .map_or(0.0, |t0| (t_ns - t0).max(0) as f64 * 1e-9);
            self.walk_offsets(dt_s);
        }
        self.offset.last_walk_t_ns = Some(t_ns);
    }

    /// The phone offset after a radio update of `meas` whose per-particle
    /// expectations `cloud` holds: the particles' offsets summarised, or
    /// the one offset moved by the cloud's weighted residuals.
    pub(super) fn learn_offset(
        &mut self,
        t_ns: i64,
        meas: &[Measurement],
        cloud: &CloudLikelihood,
        per_particle: bool,
    ) {
        if per_particle {
            self.summarise_offsets();
        } else {
            // residuals of each transmitter averaged over the weighted
            // cloud (only the one offset for the whole cloud reads them)
            let residuals: Vec<(f64, f64, f64)> = at_weighted_cloud(meas, cloud, self.pf.weights())
                .map(|(rssi, mu, sd)| (rssi - mu, mu, sd))
                .collect();
            self.offset.phone.observe(t_ns, &residuals);
        }
    }
}

/// Each reading of `meas` with the model's mean and spread averaged over
/// the cloud with `weights` (dBm, dBm, dB; `cloud` holds the last
/// evaluation's per-particle values): readings of transmitters the model
/// does not know, or with no weight, are left out.
pub(super) fn at_weighted_cloud<'a>(
    meas: &'a [Measurement],
    cloud: &'a CloudLikelihood,
    weights: &'a [f64],
) -> impl Iterator<Item = (f64, f64, f64)> + 'a {
    meas.iter().enumerate().filter_map(move |(k, mm)| {
        let (mu, sd, wsum) = cloud.weighted_expected(k, weights)?;
        (wsum > 0.0).then(|| (mm.rssi_dbm, mu / wsum, sd / wsum))
    })
}
