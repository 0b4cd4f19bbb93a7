//! The radio measurement update: the cloud weighed by the likelihood of
//! every heard RSSI at each particle, and its reused buffers.

use super::TcpfEngine;
use super::anchors::Anchor;
use super::offsets::at_weighted_cloud;
use super::recovery::RadioFit;
use crate::Vec2;
use crate::fast_math::{exp_many, max_many};
use crate::radio::Measurement;
use crate::radio::likelihood::CloudLikelihood;

/// Reused buffers of the steps' wall checks and the radio update.
#[derive(Default)]
pub(super) struct Scratch {
    /// The particles before a step, and which of them crossed a wall.
    pub(super) before: Vec<Vec2>,
    pub(super) crossed: Vec<bool>,
    /// Log-likelihood per particle (the radio and the magnetic update).
    pub(super) log_l: Vec<f64>,
    /// The cloud's likelihood of the last radio update.
    cloud: CloudLikelihood,
    /// Exponents and their exp of one radio update.
    exp_in: Vec<f64>,
    exp_out: Vec<f64>,
}

impl TcpfEngine {
    /// Weighs the particles with one measurement set, updates the phone
    /// offset, the floor and, when the cloud has lost the radio, re-seeds.
    pub(super) fn radio_update(&mut self, t_ns: i64, meas: &[Measurement], anchors: &[Anchor]) {
        let floor = self.floor;
        let o = self.offset.phone.mean_db();
        // the radio's trust tempers its weights (1 unless `integrity`)
        let trust = self.integrity.trust();
        let alpha = self.cfg.likelihood.alpha(meas.len()) * trust;
        // untempered log-likelihood per particle first; each transmitter's
        // expected RSSI per particle is kept for the residuals below
        let mut cloud = std::mem::take(&mut self.scratch.cloud);
        let per_particle = self.per_particle_offset() && !self.pf.state().is_empty();
        self.walk_offsets_to(t_ns, per_particle);
        self.evaluate_cloud(&mut cloud, meas, floor, o, per_particle);
        let fit = self.cloud_fit(meas.len());
        self.read_fit(meas, &cloud, o, floor);
        let mut log_l = std::mem::take(&mut self.scratch.log_l);
        log_l.iter_mut().for_each(|u| *u *= alpha);
        self.weigh_by_anchors(anchors, floor, trust, &mut log_l);
        self.weigh_by_survey_reach(floor, trust, &mut log_l);
        self.weigh_by_told_reach(floor, &mut log_l);
        self.pf.weight_log(&log_l);
        self.scratch.log_l = log_l;
        self.counts.radio_updates += 1;
        if self.far_from_survey() {
            self.counts.far_updates += 1;
        }
        self.learn_offset(t_ns, meas, &cloud, per_particle);
        self.scratch.cloud = cloud;
        self.resample_if_degenerate();
        // a radio the walk disagrees with re-seeds nothing (`integrity`),
        // nor one that misfits its model, unless the walls say clearly
        // that the cloud is lost: then the misfit is the cloud's, not the
        // model's (a wrong told start)
        let ic = &self.cfg.integrity;
        let lost = self.recovery.kill_ema >= ic.fit_lost_wall_kill;
        let trusted = lost || !self.integrity.fit_holds_reseed(ic);
        self.recover(floor, meas, fit, trusted);
        if trust < 1.0 {
            self.counts.trust_reduced += 1;
        }
        if trust < 0.5 {
            self.counts.trust_low += 1;
        }
        self.update_floor(t_ns, meas, anchors);
        if self.floor != floor {
            // pulls on another floor's cloud do not add up with these
            self.integrity
                .restart(&self.cfg.integrity, self.recovery.told_start);
        }
    }

    /// The untempered log-likelihood of `meas` at every particle into
    /// `scratch.log_l` (with each particle's own offset, or `offset_db`).
    fn evaluate_cloud(
        &mut self,
        cloud: &mut CloudLikelihood,
        meas: &[Measurement],
        floor: i32,
        offset_db: f64,
        per_particle: bool,
    ) {
        let lc = &self.cfg.likelihood;
        let model = self.model.as_ref();
        let ps = self.pf.particles();
        let out = &mut self.scratch.log_l;
        out.clear();
        if per_particle {
            cloud.evaluate_each(model, lc, meas, floor, ps, self.pf.state(), out);
        } else {
            cloud.evaluate(model, lc, meas, floor, ps, offset_db, out);
        }
    }

    /// How well the cloud fits the update before it weighs, from the
    /// untempered `scratch.log_l` of `heard` transmitters: the mean over
    /// the particles of the per-transmitter mean likelihood (the recovery
    /// monitor's input), and the log of the cloud's mean likelihood
    /// tempered as the surface is (comparable with it), by log-sum-exp.
    fn cloud_fit(&mut self, heard: usize) -> RadioFit {
        let alpha0 = self.cfg.likelihood.alpha(heard);
        let m = heard.max(1) as f64;
        let (xs, ex) = (&mut self.scratch.exp_in, &mut self.scratch.exp_out);
        let log_l = &self.scratch.log_l;
        // exp of the per-transmitter mean log-likelihoods in one pass
        xs.clear();
        xs.extend(log_l.iter().map(|u| *u / m));
        ex.resize(xs.len(), 0.0);
        exp_many(xs, ex);
        let mut mean_l = 0.0;
        for e in ex.iter() {
            mean_l += e;
        }
        let lmax = max_many(log_l, |u| alpha0 * u);
        let n = log_l.len().max(1) as f64;
        xs.clear();
        xs.extend(log_l.iter().map(|u| alpha0 * u - lmax));
        exp_many(xs, ex);
        let cloud_ll = lmax + (ex.iter().sum::<f64>() / n).ln();
        mean_l /= self.pf.particles().len().max(1) as f64;
        RadioFit { mean_l, cloud_ll }
    }

    /// The fit check's reading of this update: the readings against the
    /// model at the cloud before it weighs (`integrity.fit_free_z2`).
    fn read_fit(
        &mut self,
        meas: &[Measurement],
        cloud: &CloudLikelihood,
        offset_db: f64,
        floor: i32,
    ) {
        if !self.integrity.fit_is_watched(&self.cfg.integrity) {
            return;
        }
        let cap = self.cfg.integrity.fit_z2_cap;
        let (mut sum, mut n) = (0.0, 0usize);
        for (rssi, mu, sd) in at_weighted_cloud(meas, cloud, self.pf.weights()) {
            if sd > 0.0 {
                let z = (rssi - offset_db - mu) / sd;
                sum += (z * z).min(cap);
                n += 1;
            }
        }
        if n > 0 {
            let local = self.survey_fit_level(floor);
            self.integrity
                .on_fit(&self.cfg.integrity, sum / n as f64, local);
        }
    }
}
