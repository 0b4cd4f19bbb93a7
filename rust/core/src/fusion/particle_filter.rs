//! The particle filter of FP-BP Sec. IV-C, as FP-BP and tcpf use it.
//!
//! State: a [`Cloud`] of particle positions x_i in the MCS with weights
//! w_i. One PDR step moves every particle by eq. 34 ([`Eq34Motion`]),
//! weights come from the BLE position x_B by eq. 36 ([`Eq36Weights`]) and
//! are normalised, the estimate is the weighted particle mean (eq. 35b),
//! then the particles are resampled (systematic or stratified). The filter
//! owns its seeded RNG; every draw comes from it in a fixed order.
//!
//! Besides: the per-particle heading offsets and step scales of the
//! motion model's extension, one scalar per particle for the filter's
//! owner (tcpf: the phone's RSSI offset), wall penalties, log-likelihood
//! weights, recovery injections and draws from a likelihood surface over
//! cells (tcpf's global start and re-seeding).

use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::cells::{cumulative, draw_cell};
use super::cloud::{Cloud, scale_flagged};
use super::config::{FusionConfig, Resampling};
use super::fpbp_models::{
    Eq34Motion, Eq36Weights, HEADING_OFFSET, PdrStep, STEP_SCALE, mean_likelihood,
};
use super::model::{MeasurementModel, MotionModel};
use super::random::{Normals, std_normal, uniform_index};
use crate::Vec2;

/// Cloud column of the owner's scalar per particle.
const STATE: usize = 2;

/// Particles, weights, FP-BP's models and the RNG that moves and resamples them.
#[derive(Debug, Clone)]
pub struct ParticleFilter {
    cloud: Cloud,
    rng: Pcg64,
    count: usize,
    motion: Eq34Motion,
    measurement: Eq36Weights,
    resampling: Resampling,
    /// Resample only when the effective sample size falls below this
    /// fraction of m; >= 1 resamples at every step (the paper) and weights
    /// are set, not multiplied, by each fix.
    resample_ess_fraction: f64,
    /// (particle, cell) of every draw of the last
    /// [`ParticleFilter::init_from_cells`] / [`ParticleFilter::inject_from_cells`].
    cell_draws: Vec<(usize, usize)>,
    /// Buffers of [`ParticleFilter::draw_normals`].
    normals: Normals,
}

impl ParticleFilter {
    /// An empty filter (no particles until [`ParticleFilter::init_at`]).
    /// `config` must have been validated.
    pub fn new(config: &FusionConfig, seed: u64) -> Self {
        let count = config.particle_count.max(1);
        let motion = Eq34Motion::new(config, count);
        let mut cloud = Cloud::new(count, 3);
        // Without per-particle biases every offset is 0 and every scale 1
        // (nothing writes them but copies): copying them along would
        // change nothing.
        let biases = motion.has_particle_biases();
        cloud.set_carried(HEADING_OFFSET, biases);
        cloud.set_carried(STEP_SCALE, biases);
        let carry = config.resample_ess_fraction < 1.0;
        ParticleFilter {
            cloud,
            rng: Pcg64::seed_from_u64(seed),
            count,
            motion,
            measurement: Eq36Weights::new(config.sigma_x_m, carry),
            resampling: config.resampling,
            resample_ess_fraction: config.resample_ess_fraction,
            cell_draws: Vec::new(),
            normals: Normals::default(),
        }
    }

    /// Whether the filter has particles.
    pub fn is_initialized(&self) -> bool {
        !self.cloud.is_empty()
    }

    /// The particle set.
    pub fn cloud(&self) -> &Cloud {
        &self.cloud
    }

    /// Places the m particles at `start` (x_i^(0) = x̄_B^(0), w_i = 1/m), or
    /// uniformly in a disc of radius `spread_m` around it when `spread_m > 0`.
    /// `accept` may reject a drawn point (e.g. one inside a wall); a rejected
    /// draw falls back to `start` after a few tries. Each particle's heading
    /// offset ~ N(0, `heading_offset_sd_rad`) and step scale ~ 1 +
    /// N(0, `step_scale_sd`) are drawn after the positions (none when the sd is 0).
    pub fn init_at(&mut self, start: Vec2, spread_m: f64, accept: impl Fn(Vec2) -> bool) {
        self.cell_draws.clear();
        self.cloud
            .fill_disc(&mut self.rng, self.count, start, spread_m, accept);
        self.motion.draw_biases(&mut self.cloud, &mut self.rng);
    }

    /// State transition, eq. 34 ([`Eq34Motion`]), then the extra noise
    /// set by [`ParticleFilter::set_extra_noise`].
    pub fn predict(&mut self, step_length_m: f64, yaw_rad: f64) {
        let step = PdrStep {
            length_m: step_length_m,
            yaw_rad,
        };
        self.motion.propagate(&mut self.cloud, &mut self.rng, &step);
    }

    /// Sets the extra position noise (standard deviation per axis, metres)
    /// that every following [`ParticleFilter::predict`] adds after eq. 34;
    /// 0 (the default) adds none. Not finite or negative counts as 0.
    pub fn set_extra_noise(&mut self, sd_m: f64) {
        self.motion.set_extra_noise(sd_m);
    }

    /// Extension (not in the paper): multiplies by `factor` (0 = zeroes)
    /// the weight of every particle whose last move (from `before[i]` to its
    /// position) `crossed` an obstacle, then renormalises (uniform when every
    /// weight is 0). Returns how many were penalised.
    pub fn penalize_moves(
        &mut self,
        before: &[Vec2],
        factor: f64,
        crossed: impl Fn(Vec2, Vec2) -> bool,
    ) -> usize {
        let (particles, weights) = self.cloud.positions_and_weights_mut();
        let flags = particles.iter().zip(before).map(|(p, b)| crossed(*b, *p));
        scale_flagged(weights, flags, factor)
    }

    /// [`ParticleFilter::penalize_moves`] with the crossings already known:
    /// multiplies by `factor` the weight of every particle i with
    /// `crossed[i]`, then renormalises; same arithmetic. Returns how many
    /// were penalised.
    pub fn penalize_flagged(&mut self, crossed: &[bool], factor: f64) -> usize {
        self.cloud.scale_flagged(crossed.iter().copied(), factor)
    }

    /// Weights of eq. 36 against the BLE position `x_b` ([`Eq36Weights`]),
    /// normalised to sum 1.
    pub fn weight(&mut self, x_b: Vec2) {
        self.measurement.update(&mut self.cloud, &x_b);
    }

    /// Whether weights carry over between steps (ESS-triggered resampling,
    /// `resample_ess_fraction` < 1).
    fn accumulates_weights(&self) -> bool {
        self.resample_ess_fraction < 1.0
    }

    /// Effective sample size 1 / sum w_i^2 of the normalised weights.
    pub fn effective_sample_size(&self) -> f64 {
        self.cloud.effective_sample_size()
    }

    /// The engine's resampling step: [`ParticleFilter::resample`] at every
    /// call (the paper), or, with `resample_ess_fraction` < 1, only when the
    /// effective sample size has fallen below that fraction of m. Returns
    /// whether it resampled.
    pub fn resample_if_degenerate(&mut self) -> bool {
        if !self.is_degenerate() {
            return false;
        }
        self.resample();
        true
    }

    /// Whether [`ParticleFilter::resample_if_degenerate`] would resample.
    pub fn is_degenerate(&self) -> bool {
        !(self.accumulates_weights()
            && self.effective_sample_size() >= self.resample_ess_fraction * self.cloud.len() as f64)
    }

    /// Normalises the weights to sum 1 (uniform when they are all zero or not finite).
    pub fn normalize(&mut self) {
        self.cloud.normalize();
    }

    /// Resamples m particles by the configured scheme ([`Cloud::resample`]);
    /// weights become 1/m.
    pub fn resample(&mut self) {
        self.cloud.resample(&mut self.rng, self.resampling);
    }

    /// Resamples to `n` particles ([`Cloud::resample_to`]): the cloud
    /// grows or shrinks (an adaptive count, [`super::kld`]); weights 1/n.
    /// The count of later initialisations is unchanged.
    pub fn resample_to(&mut self, n: usize) {
        self.cloud.resample_to(&mut self.rng, self.resampling, n);
    }

    /// The number of particles the next [`ParticleFilter::init_at`] or
    /// [`ParticleFilter::init_from_cells`] places (at least 1).
    pub fn set_count(&mut self, n: usize) {
        self.count = n.max(1);
    }

    /// The weighted mean of the particles, eq. 35b (`None` without particles).
    pub fn mean(&self) -> Option<Vec2> {
        self.cloud.mean()
    }

    /// Root-mean-square distance of the particles from their weighted mean, metres.
    pub fn spread_m(&self) -> f64 {
        self.cloud.spread_m()
    }

    /// Eq. 44: shifts every particle by `delta` (= x^(k) - x̂).
    pub fn shift(&mut self, delta: Vec2) {
        self.cloud.shift(delta);
    }

    /// Replaces every particle for which `bad` holds by a copy of a random
    /// particle for which it does not (drawn with the filter's RNG), or by
    /// `fallback` when every particle is bad. Returns how many were replaced.
    pub fn replace_invalid(&mut self, bad: impl Fn(Vec2) -> bool, fallback: Vec2) -> usize {
        let keep = self.accumulates_weights();
        self.cloud
            .replace_invalid(&mut self.rng, bad, fallback, keep)
    }

    /// Mean over the particles of the unnormalised eq. 36 likelihood with
    /// standard deviation `sigma_m` ([`mean_likelihood`]).
    pub fn mean_likelihood(&self, x_b: Vec2, sigma_m: f64) -> f64 {
        mean_likelihood(&self.cloud, x_b, sigma_m)
    }

    /// Sets sigma_x of eq. 36 for the following [`ParticleFilter::weight`]
    /// calls, metres (ignored unless finite and > 0).
    pub fn set_sigma_x(&mut self, sigma_m: f64) {
        self.measurement.set_sigma_x(sigma_m);
    }

    /// Recovery extension (sensor-resetting / augmented MCL): replaces
    /// `round(fraction * m)` particles, chosen at random, by draws from an
    /// isotropic Gaussian around `center` with standard deviation `sigma_m`
    /// that `accept` takes ([`Cloud::inject`]). Weights are left as they
    /// are (call after resampling, when they are equal). Returns how many
    /// were replaced.
    pub fn inject(
        &mut self,
        fraction: f64,
        center: Vec2,
        sigma_m: f64,
        accept: impl Fn(Vec2) -> bool,
    ) -> usize {
        self.cloud
            .inject(&mut self.rng, fraction, center, sigma_m, accept)
    }

    /// Cumulative distribution of `weights` (non-negative; uniform when
    /// they sum to 0 or are not finite).
    pub fn cumulative(weights: &[f64]) -> Vec<f64> {
        cumulative(weights)
    }

    /// Global start: the m particles drawn from `cells` with probability
    /// proportional to `weights` (a likelihood surface over the walkable
    /// area), jittered within the cell (`jitter_m`) on ground `accept`
    /// takes; weights 1/m; heading offsets and step scales drawn as in
    /// [`ParticleFilter::init_at`]. Nothing happens without cells.
    pub fn init_from_cells(
        &mut self,
        cells: &[Vec2],
        weights: &[f64],
        jitter_m: f64,
        accept: impl Fn(Vec2) -> bool,
    ) {
        if cells.is_empty() || cells.len() != weights.len() {
            return;
        }
        let cdf = cumulative(weights);
        let first = cells[0];
        self.init_at(first, 0.0, |_| true);
        for i in 0..self.cloud.len() {
            let (q, k) = draw_cell(&mut self.rng, cells, &cdf, jitter_m, &accept);
            self.cloud.positions_mut()[i] = q;
            self.cell_draws.push((i, k));
        }
    }

    /// Re-seeding from a likelihood surface (augmented MCL): replaces
    /// `round(fraction * m)` particles chosen at random by draws as in
    /// [`ParticleFilter::init_from_cells`]; each keeps its heading offset
    /// and step scale. Weights are set uniform. Returns how many.
    pub fn inject_from_cells(
        &mut self,
        fraction: f64,
        cells: &[Vec2],
        weights: &[f64],
        jitter_m: f64,
        accept: impl Fn(Vec2) -> bool,
    ) -> usize {
        let m = self.cloud.len();
        if m == 0
            || cells.is_empty()
            || cells.len() != weights.len()
            || fraction.is_nan()
            || fraction <= 0.0
        {
            return 0;
        }
        let cdf = cumulative(weights);
        let k = ((fraction.min(1.0) * m as f64).round() as usize).min(m);
        self.cell_draws.clear();
        for _ in 0..k {
            let i = uniform_index(&mut self.rng, m);
            let (q, c) = draw_cell(&mut self.rng, cells, &cdf, jitter_m, &accept);
            self.cloud.positions_mut()[i] = q;
            self.cell_draws.push((i, c));
        }
        let u = 1.0 / m as f64;
        self.cloud.weights_mut().iter_mut().for_each(|w| *w = u);
        k
    }

    /// Multiplies every weight by exp(`log_l[i]` - max) and renormalises
    /// (a measurement update given as log-likelihoods; non-finite entries
    /// count as -inf). Uniform when every particle gets 0.
    pub fn weight_log(&mut self, log_l: &[f64]) {
        self.cloud.weight_log(log_l);
    }

    /// Puts every particle back at `positions` (same length; a move every
    /// particle made through a wall is undone). Weights are kept.
    pub fn restore_positions(&mut self, positions: &[Vec2]) {
        self.cloud.restore_positions(positions);
    }

    /// Particle positions.
    pub fn particles(&self) -> &[Vec2] {
        self.cloud.positions()
    }

    /// Normalised weights (same order as [`ParticleFilter::particles`]).
    pub fn weights(&self) -> &[f64] {
        self.cloud.weights()
    }

    /// Per-particle heading offsets, rad (same order as the particles).
    pub fn heading_offsets(&self) -> &[f64] {
        self.cloud.column(HEADING_OFFSET)
    }

    /// Per-particle step-length scales (same order as the particles).
    pub fn step_scales(&self) -> &[f64] {
        self.cloud.column(STEP_SCALE)
    }

    /// The owner's scalar per particle (same order as the particles;
    /// empty until [`ParticleFilter::set_state`], and after every
    /// (re)initialisation).
    pub fn state(&self) -> &[f64] {
        self.cloud.column(STATE)
    }

    /// Mutable access to the owner's scalars.
    pub fn state_mut(&mut self) -> &mut [f64] {
        self.cloud.column_mut(STATE)
    }

    /// Sets the owner's scalar of every particle (`values` as long as the
    /// particles; otherwise the state is emptied).
    pub fn set_state(&mut self, values: Vec<f64>) {
        self.cloud.set_column(STATE, values);
    }

    /// (particle, cell index) of every draw of the last
    /// [`ParticleFilter::init_from_cells`] or
    /// [`ParticleFilter::inject_from_cells`], in draw order (a particle
    /// drawn twice appears twice; the later draw holds).
    pub fn cell_draws(&self) -> &[(usize, usize)] {
        &self.cell_draws
    }

    /// One N(0, 1) draw from the filter's seeded RNG (for the owner's
    /// per-particle state).
    pub fn draw_normal(&mut self) -> f64 {
        std_normal(&mut self.rng)
    }

    /// `out.len()` N(0, 1) draws from the filter's seeded RNG, the same
    /// values as that many calls of [`ParticleFilter::draw_normal`].
    pub fn draw_normals(&mut self, out: &mut [f64]) {
        self.normals.fill(&mut self.rng, out);
    }
}

#[cfg(test)]
pub(crate) mod tests;
