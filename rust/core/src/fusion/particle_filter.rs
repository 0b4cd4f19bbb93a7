//! The particle filter of FP-BP Sec. IV-C.
//!
//! State: particle positions x_i in the MCS with weights w_i. One PDR step
//! moves every particle by eq. 34 (uniform step-length and heading noise),
//! weights come from the BLE position x_B by eq. 36 and are normalised, the
//! estimate is the weighted particle mean (eq. 35b), then the particles are
//! resampled (systematic or stratified). The filter owns its seeded RNG.
//!
//! Extension (not in the paper, off in [`FusionConfig::paper`]): every
//! particle may also carry its own heading offset and step-length scale,
//! drawn at the start and random-walking a little per step, so that the
//! cloud holds hypotheses about the phone's persistent heading and
//! step-length errors and BLE and walls select the right ones (eq. 34 draws
//! fresh noise every step and cannot learn a constant 10 deg offset).

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::config::{FusionConfig, Resampling};
use super::uniforms::fill_interleaved;
use crate::Vec2;
use crate::radio::fast_ln::ln_normal;

/// Largest heading-noise half-width for which [`ParticleFilter::predict`]
/// uses [`small_sin_cos`], rad.
const SMALL_ANGLE_MAX_RAD: f64 = 0.5;

/// (sin x, cos x) for |x| <= 0.5 by their Taylor series to x^13 / x^14
/// (truncation error < 1e-16 there); Horner in x^2.
fn small_sin_cos(x: f64) -> (f64, f64) {
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0
                    + x2 * (-1.0 / 5040.0
                        + x2 * (1.0 / 362_880.0
                            + x2 * (-1.0 / 39_916_800.0 + x2 * (1.0 / 6_227_020_800.0)))))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0
                    + x2 * (1.0 / 40_320.0
                        + x2 * (-1.0 / 3_628_800.0
                            + x2 * (1.0 / 479_001_600.0 + x2 * (-1.0 / 87_178_291_200.0)))))));
    (s, c)
}

/// A step of `len` metres along the yaw whose sine and cosine are `sy`,
/// `cy`, turned by `d` radians (the particle's heading offset and draw).
#[inline]
fn step_vector(len: f64, d: f64, sy: f64, cy: f64) -> Vec2 {
    let (sn, cn) = if d.abs() <= SMALL_ANGLE_MAX_RAD {
        small_sin_cos(d)
    } else {
        d.sin_cos()
    };
    let (s, c) = (sy * cn + cy * sn, cy * cn - sy * sn);
    Vec2::new(len * c, len * s)
}

/// One standard normal draw (Box-Muller, one of the pair): the logarithm
/// by [`ln_normal`] (relative 1e-10, u1 is a normal number), the cosine
/// by [`crate::fast_math::cos_turns`] (within 1e-15 of `f64::cos`).
fn std_normal(rng: &mut Pcg64) -> f64 {
    let u1: f64 = rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    box_muller(u1, u2)
}

/// [`std_normal`] of the two uniforms `u1`, `u2` (drawn in that order):
/// no branch, so that loops over it vectorise.
#[inline]
fn box_muller(u1: f64, u2: f64) -> f64 {
    (-2.0 * ln_normal(u1.max(f64::MIN_POSITIVE))).sqrt() * crate::fast_math::cos_turns(u2)
}

/// `n` standard normal draws into `out`, the same values in the same
/// order as `n` calls of [`std_normal`]: the uniforms first (the serial
/// chain through the RNG state, into `out` and `u2`), then Box-Muller
/// over the arrays (independent per draw: it vectorises).
fn std_normals(rng: &mut Pcg64, out: &mut [f64], u2: &mut Vec<f64>, raw: &mut Vec<f64>) {
    let n = out.len();
    u2.resize(n, 0.0);
    fill_interleaved(rng, raw, n, &mut [&mut *out, &mut u2[..]]);
    box_muller_in_place(out, u2);
}

crate::simd::avx2_dispatch! {
    /// `u1[i]` := [`box_muller`]`(u1[i], u2[i])` for every i.
    fn box_muller_in_place(u1: &mut [f64], u2: &[f64]) {
        for (a, b) in u1.iter_mut().zip(u2) {
            *a = box_muller(*a, *b);
        }
    }
}

/// `buf` resized to `K` * `m` and cut into `K` consecutive rows of `m`
/// (the draw arrays of one batched predict).
fn rows<const K: usize>(buf: &mut Vec<f64>, m: usize) -> [&mut [f64]; K] {
    buf.resize(K * m, 0.0);
    let mut rest = &mut buf[..];
    std::array::from_fn(|_| {
        let (row, tail) = std::mem::take(&mut rest).split_at_mut(m);
        rest = tail;
        row
    })
}

/// Normalises `weights` to sum 1 (uniform when they are all zero or not finite).
fn normalize_weights(weights: &mut [f64]) {
    let sum: f64 = weights.iter().sum();
    if sum.is_finite() && sum > 0.0 {
        for w in weights.iter_mut() {
            *w /= sum;
        }
    } else {
        let u = 1.0 / weights.len().max(1) as f64;
        weights.iter_mut().for_each(|w| *w = u);
    }
}

/// Multiplies by `factor` every weight whose flag is set, then renormalises
/// when any was; returns how many were.
fn scale_flagged(weights: &mut [f64], flags: impl Iterator<Item = bool>, factor: f64) -> usize {
    let mut n = 0;
    for (w, flag) in weights.iter_mut().zip(flags) {
        if flag {
            *w *= factor;
            n += 1;
        }
    }
    if n > 0 {
        normalize_weights(weights);
    }
    n
}

/// Largest per-particle heading offset, rad (draws are clamped to it).
const MAX_HEADING_OFFSET_RAD: f64 = 0.6;
/// Per-particle step-length scales are clamped to [1 - this, 1 + this].
const MAX_SCALE_DEVIATION: f64 = 0.4;

/// Particles, weights and the RNG that moves and resamples them.
#[derive(Debug, Clone)]
pub struct ParticleFilter {
    particles: Vec<Vec2>,
    weights: Vec<f64>,
    /// Per-particle heading offset, rad (all 0 unless `heading_offset_sd_rad` > 0).
    heading_offset: Vec<f64>,
    /// Per-particle step-length scale (all 1 unless `step_scale_sd` > 0).
    step_scale: Vec<f64>,
    /// One more scalar per particle that the owner of the filter keeps
    /// (tcpf: the phone's RSSI offset, dB), carried along by resampling;
    /// empty = none. Emptied by every (re)initialisation.
    state: Vec<f64>,
    scratch_state: Vec<f64>,
    /// (particle, cell) of every draw of the last
    /// [`ParticleFilter::init_from_cells`] / [`ParticleFilter::inject_from_cells`].
    cell_draws: Vec<(usize, usize)>,
    scratch: Vec<Vec2>,
    scratch_offset: Vec<f64>,
    scratch_scale: Vec<f64>,
    index_scratch: Vec<usize>,
    /// Uniform draws of one predict (step length, heading), reused.
    draw_s: Vec<f64>,
    /// Exponents and their exp in [`ParticleFilter::weight_log`], reused.
    exp_in: Vec<f64>,
    exp_out: Vec<f64>,
    draw_th: Vec<f64>,
    /// Uniform draws of one predict with particle biases or extra noise
    /// (then their normals), reused.
    draw_buf: Vec<f64>,
    /// The same draws as they come from the RNG, particle by particle
    /// ([`fill_interleaved`]), reused.
    uniform_buf: Vec<f64>,
    rng: Pcg64,
    count: usize,
    step_noise_m: f64,
    heading_noise_rad: f64,
    sigma_x_m: f64,
    resampling: Resampling,
    heading_offset_sd_rad: f64,
    heading_offset_walk_rad: f64,
    /// Gauss-Markov factor a = exp(-1 / heading_offset_corr_steps) of the
    /// heading offsets (0 = the random walk `heading_offset_walk_rad`).
    heading_offset_decay: f64,
    /// Resample only when the effective sample size falls below this
    /// fraction of m; >= 1 resamples at every step (the paper) and weights
    /// are set, not multiplied, by each fix.
    resample_ess_fraction: f64,
    /// Extra isotropic Gaussian position noise of the next moves, metres
    /// (innovation-driven process noise; 0 = eq. 34 alone).
    extra_noise_m: f64,
    step_scale_sd: f64,
    step_scale_walk: f64,
}

impl ParticleFilter {
    /// An empty filter (no particles until [`ParticleFilter::init_at`]).
    /// `config` must have been validated.
    pub fn new(config: &FusionConfig, seed: u64) -> Self {
        let count = config.particle_count.max(1);
        ParticleFilter {
            particles: Vec::with_capacity(count),
            weights: Vec::with_capacity(count),
            heading_offset: Vec::with_capacity(count),
            step_scale: Vec::with_capacity(count),
            state: Vec::new(),
            scratch_state: Vec::new(),
            cell_draws: Vec::new(),
            scratch: Vec::with_capacity(count),
            scratch_offset: Vec::with_capacity(count),
            scratch_scale: Vec::with_capacity(count),
            index_scratch: Vec::with_capacity(count),
            draw_s: Vec::with_capacity(count),
            exp_in: Vec::new(),
            exp_out: Vec::new(),
            draw_th: Vec::with_capacity(count),
            draw_buf: Vec::new(),
            uniform_buf: Vec::new(),
            rng: Pcg64::seed_from_u64(seed),
            count,
            step_noise_m: config.step_noise_m,
            heading_noise_rad: config.heading_noise_rad,
            sigma_x_m: config.sigma_x_m,
            resampling: config.resampling,
            heading_offset_sd_rad: config.heading_offset_sd_rad,
            heading_offset_walk_rad: config.heading_offset_walk_rad,
            heading_offset_decay: if config.heading_offset_corr_steps > 0.0 {
                (-1.0 / config.heading_offset_corr_steps).exp()
            } else {
                0.0
            },
            resample_ess_fraction: config.resample_ess_fraction,
            extra_noise_m: 0.0,
            step_scale_sd: config.step_scale_sd,
            step_scale_walk: config.step_scale_walk,
        }
    }

    /// Whether the filter has particles.
    pub fn is_initialized(&self) -> bool {
        !self.particles.is_empty()
    }

    /// Places the m particles at `start` (x_i^(0) = x̄_B^(0), w_i = 1/m), or
    /// uniformly in a disc of radius `spread_m` around it when `spread_m > 0`.
    /// `accept` may reject a drawn point (e.g. one inside a wall); a rejected
    /// draw falls back to `start` after a few tries. Each particle's heading
    /// offset ~ N(0, `heading_offset_sd_rad`) and step scale ~ 1 +
    /// N(0, `step_scale_sd`) are drawn after the positions (none when the sd is 0).
    pub fn init_at(&mut self, start: Vec2, spread_m: f64, accept: impl Fn(Vec2) -> bool) {
        self.particles.clear();
        self.weights.clear();
        self.heading_offset.clear();
        self.step_scale.clear();
        self.state.clear();
        self.cell_draws.clear();
        let w = 1.0 / self.count as f64;
        for _ in 0..self.count {
            let mut p = start;
            if spread_m > 0.0 {
                for _ in 0..8 {
                    let r = spread_m * self.rng.random::<f64>().sqrt();
                    let a = std::f64::consts::TAU * self.rng.random::<f64>();
                    let q = start + Vec2::new(r * a.cos(), r * a.sin());
                    if accept(q) {
                        p = q;
                        break;
                    }
                }
            }
            self.particles.push(p);
            self.weights.push(w);
        }
        for _ in 0..self.count {
            let off = if self.heading_offset_sd_rad > 0.0 {
                (self.heading_offset_sd_rad * std_normal(&mut self.rng))
                    .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD)
            } else {
                0.0
            };
            let scale = if self.step_scale_sd > 0.0 {
                (1.0 + self.step_scale_sd * std_normal(&mut self.rng))
                    .clamp(1.0 - MAX_SCALE_DEVIATION, 1.0 + MAX_SCALE_DEVIATION)
            } else {
                1.0
            };
            self.heading_offset.push(off);
            self.step_scale.push(scale);
        }
    }

    /// Whether the particles carry their own heading offsets or step scales.
    fn has_particle_biases(&self) -> bool {
        self.heading_offset_sd_rad > 0.0
            || self.heading_offset_walk_rad > 0.0
            || self.step_scale_sd > 0.0
            || self.step_scale_walk > 0.0
    }

    /// State transition, eq. 34: every particle moves by
    /// (s + nu_s) [cos(theta + nu_theta), sin(theta + nu_theta)] with nu_s,
    /// nu_theta uniform in ±step_noise_m, ±heading_noise_rad. With
    /// per-particle biases: (s * scale_i + nu_s) along theta + offset_i +
    /// nu_theta, after offset_i and scale_i took their random-walk step.
    pub fn predict(&mut self, step_length_m: f64, yaw_rad: f64) {
        self.predict_eq34(step_length_m, yaw_rad);
        let sd = self.extra_noise_m;
        if sd > 0.0 {
            // per particle the draws of a then b (two uniforms each), as
            // two calls of std_normal would take them; Box-Muller batched
            let m = self.particles.len();
            let [a1, a2, b1, b2] = rows(&mut self.draw_buf, m);
            let outs = &mut [&mut *a1, &mut *a2, &mut *b1, &mut *b2];
            fill_interleaved(&mut self.rng, &mut self.uniform_buf, m, outs);
            box_muller_in_place(a1, a2);
            box_muller_in_place(b1, b2);
            for ((p, a), b) in self.particles.iter_mut().zip(&*a1).zip(&*b1) {
                *p += Vec2::new(sd * a, sd * b);
            }
        }
    }

    /// Sets the extra position noise (standard deviation per axis, metres)
    /// that every following [`ParticleFilter::predict`] adds after eq. 34;
    /// 0 (the default) adds none. Not finite or negative counts as 0.
    pub fn set_extra_noise(&mut self, sd_m: f64) {
        self.extra_noise_m = if sd_m.is_finite() { sd_m.max(0.0) } else { 0.0 };
    }

    fn predict_eq34(&mut self, step_length_m: f64, yaw_rad: f64) {
        let (ds, dth) = (self.step_noise_m, self.heading_noise_rad);
        if self.has_particle_biases() {
            self.predict_biased(step_length_m, yaw_rad);
            return;
        }
        if dth <= SMALL_ANGLE_MAX_RAD {
            // cos/sin of yaw + nu by the angle-sum rule, with nu's from
            // series accurate to ~1e-16 on |nu| <= 0.5 (no libm call per
            // particle); same draws in the same order as the general branch
            let (sy, cy) = yaw_rad.sin_cos();
            // The draws first (one serial chain through the RNG state), then
            // the arithmetic, which has no dependence between particles and
            // vectorises: the same operations on the same values.
            let m = self.particles.len();
            self.draw_s.resize(m, 0.0);
            self.draw_th.resize(m, 0.0);
            let outs = &mut [&mut self.draw_s[..], &mut self.draw_th[..]];
            fill_interleaved(&mut self.rng, &mut self.uniform_buf, m, outs);
            for ((p, &u_s), &u_th) in self
                .particles
                .iter_mut()
                .zip(&self.draw_s)
                .zip(&self.draw_th)
            {
                let nu_s = ds * (2.0 * u_s - 1.0);
                let nu_th = dth * (2.0 * u_th - 1.0);
                let len = (step_length_m + nu_s).max(0.0);
                let (sn, cn) = small_sin_cos(nu_th);
                let (s, c) = (sy * cn + cy * sn, cy * cn - sy * sn);
                *p += Vec2::new(len * c, len * s);
            }
            return;
        }
        for p in &mut self.particles {
            let nu_s = ds * (2.0 * self.rng.random::<f64>() - 1.0);
            let nu_th = dth * (2.0 * self.rng.random::<f64>() - 1.0);
            let len = (step_length_m + nu_s).max(0.0);
            let (s, c) = (yaw_rad + nu_th).sin_cos();
            *p += Vec2::new(len * c, len * s);
        }
    }

    fn predict_biased(&mut self, step_length_m: f64, yaw_rad: f64) {
        let (ds, dth) = (self.step_noise_m, self.heading_noise_rad);
        let (walk_off, walk_scale) = (self.heading_offset_walk_rad, self.step_scale_walk);
        // first-order Gauss-Markov offsets keep N(0, sd^2) as their
        // stationary law: off <- a off + sd sqrt(1 - a^2) n
        let a = self.heading_offset_decay;
        let gm_sd = self.heading_offset_sd_rad * (1.0 - a * a).sqrt();
        let (sy, cy) = yaw_rad.sin_cos();
        // The draws first, in the order of the per-particle loop (offset's
        // normal, scale's normal, each two uniforms when on; then step and
        // heading noise): one serial chain through the RNG state. Then
        // Box-Muller over the arrays (vectorises), then the moves: the
        // same operations on the same values as drawing inside the loop.
        let (off_on, scale_on) = (a > 0.0 || walk_off > 0.0, walk_scale > 0.0);
        let m = self.particles.len();
        let [o1, o2, s1, s2, us, uth] = rows(&mut self.draw_buf, m);
        let (rng, buf) = (&mut self.rng, &mut self.uniform_buf);
        match (off_on, scale_on) {
            (true, true) => fill_interleaved(rng, buf, m, &mut [o1, o2, s1, s2, us, uth]),
            (true, false) => fill_interleaved(rng, buf, m, &mut [o1, o2, us, uth]),
            (false, true) => fill_interleaved(rng, buf, m, &mut [s1, s2, us, uth]),
            (false, false) => fill_interleaved(rng, buf, m, &mut [us, uth]),
        }
        if off_on {
            box_muller_in_place(o1, o2);
        }
        if scale_on {
            box_muller_in_place(s1, s2);
        }
        for (((((p, off), scale), &z_off), &z_scale), (&u_s, &u_th)) in self
            .particles
            .iter_mut()
            .zip(&mut self.heading_offset)
            .zip(&mut self.step_scale)
            .zip(&*o1)
            .zip(&*s1)
            .zip(us.iter().zip(&*uth))
        {
            if a > 0.0 {
                *off = (a * *off + gm_sd * z_off)
                    .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD);
            } else if walk_off > 0.0 {
                *off = (*off + walk_off * z_off)
                    .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD);
            }
            if scale_on {
                *scale = (*scale + walk_scale * z_scale)
                    .clamp(1.0 - MAX_SCALE_DEVIATION, 1.0 + MAX_SCALE_DEVIATION);
            }
            let nu_s = ds * (2.0 * u_s - 1.0);
            let nu_th = dth * (2.0 * u_th - 1.0);
            let len = (step_length_m * *scale + nu_s).max(0.0);
            *p += step_vector(len, *off + nu_th, sy, cy);
        }
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
        let flags = self
            .particles
            .iter()
            .zip(before)
            .map(|(p, b)| crossed(*b, *p));
        scale_flagged(&mut self.weights, flags, factor)
    }

    /// [`ParticleFilter::penalize_moves`] with the crossings already known:
    /// multiplies by `factor` the weight of every particle i with
    /// `crossed[i]`, then renormalises; same arithmetic. Returns how many
    /// were penalised.
    pub fn penalize_flagged(&mut self, crossed: &[bool], factor: f64) -> usize {
        scale_flagged(&mut self.weights, crossed.iter().copied(), factor)
    }

    /// Weights of eq. 36 against the BLE position `x_b`, normalised to sum 1.
    /// The constant 1/sqrt(2 pi sigma^2) cancels in the normalisation; the
    /// exponent is shifted by its maximum so far-away fixes do not underflow.
    pub fn weight(&mut self, x_b: Vec2) {
        if self.particles.is_empty() {
            return;
        }
        let inv = 1.0 / (2.0 * self.sigma_x_m * self.sigma_x_m);
        let d2min = self
            .particles
            .iter()
            .map(|p| (p - x_b).norm_squared())
            .fold(f64::INFINITY, f64::min);
        // with ESS resampling (sequential importance sampling) the fix
        // multiplies the weights the cloud carries since its last resampling
        let carry = self.accumulates_weights();
        for (w, p) in self.weights.iter_mut().zip(&self.particles) {
            let l = (-((p - x_b).norm_squared() - d2min) * inv).exp();
            *w = if carry { *w * l } else { l };
        }
        self.normalize();
    }

    /// Whether weights carry over between steps (ESS-triggered resampling,
    /// `resample_ess_fraction` < 1).
    fn accumulates_weights(&self) -> bool {
        self.resample_ess_fraction < 1.0
    }

    /// Effective sample size 1 / sum w_i^2 of the normalised weights.
    pub fn effective_sample_size(&self) -> f64 {
        let s: f64 = self.weights.iter().map(|w| w * w).sum();
        if s > 0.0 { 1.0 / s } else { 0.0 }
    }

    /// The engine's resampling step: [`ParticleFilter::resample`] at every
    /// call (the paper), or, with `resample_ess_fraction` < 1, only when the
    /// effective sample size has fallen below that fraction of m. Returns
    /// whether it resampled.
    pub fn resample_if_degenerate(&mut self) -> bool {
        if self.accumulates_weights()
            && self.effective_sample_size()
                >= self.resample_ess_fraction * self.particles.len() as f64
        {
            return false;
        }
        self.resample();
        true
    }

    /// Normalises the weights to sum 1 (uniform when they are all zero or not finite).
    pub fn normalize(&mut self) {
        normalize_weights(&mut self.weights);
    }

    /// Resamples m particles by the configured scheme; weights become 1/m.
    pub fn resample(&mut self) {
        let m = self.particles.len();
        if m == 0 {
            return;
        }
        let inv_m = 1.0 / m as f64;
        // Without per-particle biases every offset is 0 and every scale 1
        // (init_at, and nothing else writes them but copies): copying them
        // along would change nothing.
        let biases = self.has_particle_biases();
        // the source index of every new particle first (disjoint borrows:
        // the loop state stays in registers), then the copies
        let weights = &self.weights;
        let rng = &mut self.rng;
        let resampling = self.resampling;
        self.index_scratch.resize(m, 0);
        let mut cum = weights[0];
        let mut j = 0usize;
        let u0: f64 = rng.random::<f64>();
        // i as f64, counted in f64 (exact below 2^53; the usize conversion
        // is several instructions on x86-64)
        let mut fi = 0.0f64;
        for slot in &mut self.index_scratch {
            let u = match resampling {
                Resampling::Systematic => (fi + u0) * inv_m,
                Resampling::Stratified => (fi + rng.random::<f64>()) * inv_m,
            };
            fi += 1.0;
            while u > cum && j + 1 < m {
                j += 1;
                cum += weights[j];
            }
            *slot = j;
        }
        let src = &self.index_scratch;
        self.scratch.clear();
        self.scratch.extend(src.iter().map(|&j| self.particles[j]));
        std::mem::swap(&mut self.particles, &mut self.scratch);
        if biases {
            self.scratch_offset.clear();
            self.scratch_offset
                .extend(src.iter().map(|&j| self.heading_offset[j]));
            self.scratch_scale.clear();
            self.scratch_scale
                .extend(src.iter().map(|&j| self.step_scale[j]));
            std::mem::swap(&mut self.heading_offset, &mut self.scratch_offset);
            std::mem::swap(&mut self.step_scale, &mut self.scratch_scale);
        }
        if self.state.len() == m {
            self.scratch_state.clear();
            self.scratch_state
                .extend(src.iter().map(|&j| self.state[j]));
            std::mem::swap(&mut self.state, &mut self.scratch_state);
        }
        self.weights.iter_mut().for_each(|w| *w = inv_m);
    }

    /// The weighted mean of the particles, eq. 35b (`None` without particles).
    pub fn mean(&self) -> Option<Vec2> {
        if self.particles.is_empty() {
            return None;
        }
        let mut s = Vec2::zeros();
        for (p, w) in self.particles.iter().zip(&self.weights) {
            s += p * *w;
        }
        Some(s)
    }

    /// Weighted geometric median of the particles (the point with the least
    /// weighted sum of distances: the estimate with the least expected
    /// error in metres), by `iters` Weiszfeld steps from the weighted mean.
    /// Distances are floored at 1 cm so a step never divides by zero.
    pub fn geometric_median(&self, iters: usize) -> Option<Vec2> {
        let mut x = self.mean()?;
        for _ in 0..iters {
            let (mut s, mut wsum) = (Vec2::zeros(), 0.0);
            for (p, w) in self.particles.iter().zip(&self.weights) {
                let k = w / (p - x).norm().max(0.01);
                s += p * k;
                wsum += k;
            }
            if wsum.is_nan() || wsum <= 0.0 {
                break;
            }
            let next = s / wsum;
            let moved = (next - x).norm();
            x = next;
            if moved < 1e-3 {
                break;
            }
        }
        Some(x)
    }

    /// Root-mean-square distance of the particles from their weighted mean, metres.
    pub fn spread_m(&self) -> f64 {
        let Some(m) = self.mean() else { return 0.0 };
        self.particles
            .iter()
            .zip(&self.weights)
            .map(|(p, w)| w * (p - m).norm_squared())
            .sum::<f64>()
            .sqrt()
    }

    /// Eq. 44: shifts every particle by `delta` (= x^(k) - x̂).
    pub fn shift(&mut self, delta: Vec2) {
        for p in &mut self.particles {
            *p += delta;
        }
    }

    /// Replaces every particle for which `bad` holds by a copy of a random
    /// particle for which it does not (drawn with the filter's RNG), or by
    /// `fallback` when every particle is bad. Returns how many were replaced.
    pub fn replace_invalid(&mut self, bad: impl Fn(Vec2) -> bool, fallback: Vec2) -> usize {
        // good indices first, bad ones from the back of one reused buffer
        let m = self.particles.len();
        self.index_scratch.clear();
        self.index_scratch.resize(m, 0);
        let (mut n_good, mut n_bad) = (0usize, 0usize);
        for (i, p) in self.particles.iter().enumerate() {
            if bad(*p) {
                n_bad += 1;
                self.index_scratch[m - n_bad] = i;
            } else {
                self.index_scratch[n_good] = i;
                n_good += 1;
            }
        }
        // bad indices in increasing order, as drawn before
        self.index_scratch[n_good..].reverse();
        // (offsets and scales are all 0 and 1 without biases: see resample)
        let biases = self.has_particle_biases();
        for b in n_good..m {
            let i = self.index_scratch[b];
            if n_good == 0 {
                self.particles[i] = fallback;
            } else {
                let k = ((self.rng.random::<f64>() * n_good as f64) as usize).min(n_good - 1);
                let src = self.index_scratch[k];
                self.particles[i] = self.particles[src];
                if biases {
                    self.heading_offset[i] = self.heading_offset[src];
                    self.step_scale[i] = self.step_scale[src];
                }
                if self.state.len() == m {
                    self.state[i] = self.state[src];
                }
                if self.accumulates_weights() {
                    self.weights[i] = self.weights[src];
                }
            }
        }
        if self.accumulates_weights() && n_bad > 0 {
            self.normalize();
        }
        n_bad
    }

    /// Mean over the particles of the unnormalised eq. 36 likelihood
    /// exp(-|x_i - x_B|^2 / (2 sigma^2)) with standard deviation `sigma_m`
    /// (0 without particles). With equal weights (after resampling) this is
    /// the measurement likelihood of the whole cloud that augmented MCL
    /// tracks (recovery extension).
    pub fn mean_likelihood(&self, x_b: Vec2, sigma_m: f64) -> f64 {
        if self.particles.is_empty() || sigma_m.is_nan() || sigma_m <= 0.0 {
            return 0.0;
        }
        let inv = 1.0 / (2.0 * sigma_m * sigma_m);
        let s: f64 = self
            .particles
            .iter()
            .map(|p| (-(p - x_b).norm_squared() * inv).exp())
            .sum();
        s / self.particles.len() as f64
    }

    /// Sets sigma_x of eq. 36 for the following [`ParticleFilter::weight`]
    /// calls, metres (ignored unless finite and > 0).
    pub fn set_sigma_x(&mut self, sigma_m: f64) {
        if sigma_m.is_finite() && sigma_m > 0.0 {
            self.sigma_x_m = sigma_m;
        }
    }

    /// Recovery extension (sensor-resetting / augmented MCL): replaces
    /// `round(fraction * m)` particles, chosen at random, by draws from an
    /// isotropic Gaussian around `center` with standard deviation `sigma_m`
    /// that `accept` takes (up to 16 tries each; a particle whose draws are
    /// all rejected stays). Weights are left as they are (call after
    /// resampling, when they are equal). Returns how many were replaced.
    pub fn inject(
        &mut self,
        fraction: f64,
        center: Vec2,
        sigma_m: f64,
        accept: impl Fn(Vec2) -> bool,
    ) -> usize {
        let m = self.particles.len();
        if m == 0 || fraction.is_nan() || fraction <= 0.0 {
            return 0;
        }
        let k = ((fraction.min(1.0) * m as f64).round() as usize).min(m);
        let mut n = 0;
        for _ in 0..k {
            let i = ((self.rng.random::<f64>() * m as f64) as usize).min(m - 1);
            for _ in 0..16 {
                // Box-Muller: two uniforms -> two independent N(0, 1).
                let u1: f64 = self.rng.random::<f64>().max(f64::MIN_POSITIVE);
                let u2: f64 = self.rng.random::<f64>();
                let r = sigma_m * (-2.0 * u1.ln()).sqrt();
                let a = std::f64::consts::TAU * u2;
                let q = center + Vec2::new(r * a.cos(), r * a.sin());
                if accept(q) {
                    self.particles[i] = q;
                    n += 1;
                    break;
                }
            }
        }
        n
    }

    /// Draws a point from `cells` with probability `probs` (cumulative,
    /// last = 1), jittered uniformly within +-`jitter_m` / 2 per axis while
    /// `accept` takes it (up to 8 tries, else the cell centre).
    fn draw_cell(
        rng: &mut Pcg64,
        cells: &[Vec2],
        cdf: &[f64],
        jitter_m: f64,
        accept: &impl Fn(Vec2) -> bool,
    ) -> (Vec2, usize) {
        let u: f64 = rng.random::<f64>();
        let k = cdf.partition_point(|&c| c < u).min(cells.len() - 1);
        let c = cells[k];
        for _ in 0..8 {
            let q = c + Vec2::new(
                jitter_m * (rng.random::<f64>() - 0.5),
                jitter_m * (rng.random::<f64>() - 0.5),
            );
            if accept(q) {
                return (q, k);
            }
        }
        (c, k)
    }

    /// Cumulative distribution of `weights` (non-negative; uniform when
    /// they sum to 0 or are not finite).
    pub fn cumulative(weights: &[f64]) -> Vec<f64> {
        let total: f64 = weights.iter().sum();
        let ok = total.is_finite() && total > 0.0;
        let n = weights.len().max(1) as f64;
        let mut acc = 0.0;
        weights
            .iter()
            .map(|w| {
                acc += if ok { w / total } else { 1.0 / n };
                acc
            })
            .collect()
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
        let cdf = Self::cumulative(weights);
        let first = cells[0];
        self.init_at(first, 0.0, |_| true);
        for i in 0..self.particles.len() {
            let (q, k) = Self::draw_cell(&mut self.rng, cells, &cdf, jitter_m, &accept);
            self.particles[i] = q;
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
        let m = self.particles.len();
        if m == 0
            || cells.is_empty()
            || cells.len() != weights.len()
            || fraction.is_nan()
            || fraction <= 0.0
        {
            return 0;
        }
        let cdf = Self::cumulative(weights);
        let k = ((fraction.min(1.0) * m as f64).round() as usize).min(m);
        self.cell_draws.clear();
        for _ in 0..k {
            let i = ((self.rng.random::<f64>() * m as f64) as usize).min(m - 1);
            let (q, c) = Self::draw_cell(&mut self.rng, cells, &cdf, jitter_m, &accept);
            self.particles[i] = q;
            self.cell_draws.push((i, c));
        }
        let u = 1.0 / m as f64;
        self.weights.iter_mut().for_each(|w| *w = u);
        k
    }

    /// Multiplies every weight by exp(`log_l[i]` - max) and renormalises
    /// (a measurement update given as log-likelihoods; non-finite entries
    /// count as -inf). Uniform when every particle gets 0.
    pub fn weight_log(&mut self, log_l: &[f64]) {
        if self.particles.is_empty() || log_l.len() != self.particles.len() {
            return;
        }
        let max =
            crate::fast_math::max_many(
                log_l,
                |v| {
                    if v.is_finite() { v } else { f64::NEG_INFINITY }
                },
            );
        if !max.is_finite() {
            return;
        }
        // exp(l - max) of every particle in one pass (non-finite: 0)
        let (xs, e) = (&mut self.exp_in, &mut self.exp_out);
        xs.clear();
        xs.extend(log_l.iter().map(|l| {
            if l.is_finite() {
                l - max
            } else {
                f64::NEG_INFINITY
            }
        }));
        e.resize(xs.len(), 0.0);
        crate::fast_math::exp_many(xs, e);
        for (w, f) in self.weights.iter_mut().zip(e.iter()) {
            *w *= f;
        }
        self.normalize();
    }

    /// Puts every particle back at `positions` (same length; a move every
    /// particle made through a wall is undone). Weights are kept.
    pub fn restore_positions(&mut self, positions: &[Vec2]) {
        if positions.len() == self.particles.len() {
            self.particles.copy_from_slice(positions);
        }
    }

    /// Particle positions.
    pub fn particles(&self) -> &[Vec2] {
        &self.particles
    }

    /// Normalised weights (same order as [`ParticleFilter::particles`]).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Per-particle heading offsets, rad (same order as the particles).
    pub fn heading_offsets(&self) -> &[f64] {
        &self.heading_offset
    }

    /// Per-particle step-length scales (same order as the particles).
    pub fn step_scales(&self) -> &[f64] {
        &self.step_scale
    }

    /// The owner's scalar per particle (same order as the particles;
    /// empty until [`ParticleFilter::set_state`], and after every
    /// (re)initialisation).
    pub fn state(&self) -> &[f64] {
        &self.state
    }

    /// Mutable access to the owner's scalars.
    pub fn state_mut(&mut self) -> &mut [f64] {
        &mut self.state
    }

    /// Sets the owner's scalar of every particle (`values` as long as the
    /// particles; otherwise the state is emptied).
    pub fn set_state(&mut self, values: Vec<f64>) {
        self.state = if values.len() == self.particles.len() {
            values
        } else {
            Vec::new()
        };
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
        std_normals(
            &mut self.rng,
            out,
            &mut self.draw_buf,
            &mut self.uniform_buf,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn filter(m: usize, resampling: Resampling, seed: u64) -> ParticleFilter {
        // eq. 34 alone: no per-particle heading offsets
        let cfg = FusionConfig {
            particle_count: m,
            resampling,
            heading_offset_sd_rad: 0.0,
            ..FusionConfig::default()
        };
        ParticleFilter::new(&cfg, seed)
    }

    fn filter_with_offsets(m: usize, offset_sd_rad: f64, seed: u64) -> ParticleFilter {
        let cfg = FusionConfig {
            particle_count: m,
            heading_offset_sd_rad: offset_sd_rad,
            ..FusionConfig::default()
        };
        ParticleFilter::new(&cfg, seed)
    }

    /// The biased predict and the extra noise as they were before the
    /// draws were batched: every draw inside the per-particle loop.
    fn predict_reference(pf: &mut ParticleFilter, step_length_m: f64, yaw_rad: f64) {
        let (ds, dth) = (pf.step_noise_m, pf.heading_noise_rad);
        let (walk_off, walk_scale) = (pf.heading_offset_walk_rad, pf.step_scale_walk);
        let a = pf.heading_offset_decay;
        let gm_sd = pf.heading_offset_sd_rad * (1.0 - a * a).sqrt();
        let (sy, cy) = yaw_rad.sin_cos();
        for ((p, off), scale) in pf
            .particles
            .iter_mut()
            .zip(&mut pf.heading_offset)
            .zip(&mut pf.step_scale)
        {
            if a > 0.0 {
                *off = (a * *off + gm_sd * std_normal(&mut pf.rng))
                    .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD);
            } else if walk_off > 0.0 {
                *off = (*off + walk_off * std_normal(&mut pf.rng))
                    .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD);
            }
            if walk_scale > 0.0 {
                *scale = (*scale + walk_scale * std_normal(&mut pf.rng))
                    .clamp(1.0 - MAX_SCALE_DEVIATION, 1.0 + MAX_SCALE_DEVIATION);
            }
            let nu_s = ds * (2.0 * pf.rng.random::<f64>() - 1.0);
            let nu_th = dth * (2.0 * pf.rng.random::<f64>() - 1.0);
            let len = (step_length_m * *scale + nu_s).max(0.0);
            *p += step_vector(len, *off + nu_th, sy, cy);
        }
        let sd = pf.extra_noise_m;
        if sd > 0.0 {
            for p in &mut pf.particles {
                let (a, b) = (std_normal(&mut pf.rng), std_normal(&mut pf.rng));
                *p += Vec2::new(sd * a, sd * b);
            }
        }
    }

    #[test]
    fn batched_draws_match_the_per_particle_loop() {
        // offsets random-walking or Gauss-Markov, scales walking or not,
        // extra noise or not: the same positions, offsets, scales and
        // RNG state to the bit
        for (corr, walk_scale, noise) in [(0.0, 0.005, 0.3), (20.0, 0.0, 0.0), (0.0, 0.0, 0.2)] {
            let cfg = FusionConfig {
                particle_count: 257,
                heading_offset_sd_rad: 0.15,
                heading_offset_walk_rad: 0.01,
                heading_offset_corr_steps: corr,
                step_scale_sd: 0.1,
                step_scale_walk: walk_scale,
                ..FusionConfig::default()
            };
            let mut pf = ParticleFilter::new(&cfg, 5);
            pf.init_at(Vec2::new(3.0, 4.0), 2.0, |_| true);
            pf.set_extra_noise(noise);
            let mut rf = pf.clone();
            for k in 0..6 {
                let yaw = 0.3 + 0.9 * f64::from(k);
                pf.predict(0.7, yaw);
                predict_reference(&mut rf, 0.7, yaw);
                assert_eq!(pf.particles, rf.particles);
                assert_eq!(pf.heading_offset, rf.heading_offset);
                assert_eq!(pf.step_scale, rf.step_scale);
                assert_eq!(pf.rng.random::<u64>(), rf.rng.random::<u64>());
            }
            let mut z = vec![0.0; 101];
            pf.draw_normals(&mut z);
            let r: Vec<f64> = (0..101).map(|_| rf.draw_normal()).collect();
            assert_eq!(z, r);
        }
    }

    /// Walks east 0.7 m per step while the PDR reports a yaw `bias_rad` off,
    /// weighting against BLE fixes on the true path every step; returns the
    /// final distance of the estimate from the truth and the weighted mean
    /// heading offset of the particles.
    fn walk_with_heading_bias(pf: &mut ParticleFilter, bias_rad: f64) -> (f64, f64) {
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
        let mut truth = Vec2::zeros();
        for _ in 0..60 {
            truth += Vec2::new(0.7, 0.0);
            pf.predict(0.7, bias_rad);
            pf.weight(truth);
            pf.resample();
        }
        let off: f64 = pf
            .heading_offsets()
            .iter()
            .zip(pf.weights())
            .map(|(o, w)| o * w)
            .sum();
        ((pf.mean().unwrap() - truth).norm(), off)
    }

    #[test]
    fn particle_heading_offsets_learn_a_constant_heading_error() {
        // 12 deg heading error, 42 m walk, BLE on the true path (sigma 3 m)
        let bias = 12f64.to_radians();
        let (err_on, off) = walk_with_heading_bias(&mut filter_with_offsets(1000, 0.15, 5), bias);
        let (err_off, _) = walk_with_heading_bias(&mut filter_with_offsets(1000, 0.0, 5), bias);
        assert!(
            (off + bias).abs() < 0.05,
            "learned offset {off}, expected {}",
            -bias
        );
        assert!(
            err_on < 0.5 * err_off,
            "error with offsets {err_on}, without {err_off}"
        );
    }

    #[test]
    fn heading_offsets_stay_with_their_particles() {
        let mut pf = filter_with_offsets(500, 0.2, 9);
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
        let sd = (pf.heading_offsets().iter().map(|o| o * o).sum::<f64>() / 500.0).sqrt();
        assert!((sd - 0.2).abs() < 0.03, "offset sd {sd}");
        pf.predict(1.0, 0.0);
        pf.weight(Vec2::new(1.0, 0.3));
        let pairs: Vec<(Vec2, f64)> = pf
            .particles()
            .iter()
            .copied()
            .zip(pf.heading_offsets().iter().copied())
            .collect();
        pf.resample();
        pf.replace_invalid(|p| p.y < 0.0, Vec2::zeros());
        for (p, o) in pf.particles().iter().zip(pf.heading_offsets()) {
            assert!(
                pairs.contains(&(*p, *o)),
                "{p:?} {o} is not a particle of before"
            );
        }
    }

    #[test]
    fn the_owners_state_stays_with_its_particles_and_cell_draws_are_recorded() {
        let mut pf = filter(400, Resampling::Systematic, 3);
        let cells = [
            Vec2::new(0.0, 0.0),
            Vec2::new(10.0, 0.0),
            Vec2::new(0.0, 10.0),
        ];
        pf.init_from_cells(&cells, &[1.0, 2.0, 3.0], 1.0, |_| true);
        assert!(pf.state().is_empty());
        let draws = pf.cell_draws().to_vec();
        assert_eq!(draws.len(), 400);
        for (i, c) in &draws {
            assert!((pf.particles()[*i] - cells[*c]).norm() < 0.8);
        }
        // the state: the index of the cell each particle came from
        pf.set_state(draws.iter().map(|(_, c)| *c as f64).collect());
        pf.weight(Vec2::new(10.0, 0.0));
        pf.resample();
        pf.replace_invalid(|p| p.y > 5.0, Vec2::zeros());
        for (p, s) in pf.particles().iter().zip(pf.state()) {
            assert!((p - cells[*s as usize]).norm() < 0.8, "{p:?} {s}");
        }
        // re-seeding records its draws; a wrong length empties the state
        let n = pf.inject_from_cells(0.25, &cells[2..], &[1.0], 1.0, |_| true);
        assert_eq!(pf.cell_draws().len(), n);
        assert!(pf.cell_draws().iter().all(|(_, c)| *c == 0));
        pf.set_state(vec![0.0; 3]);
        assert!(pf.state().is_empty());
        pf.set_state(vec![1.0; 400]);
        pf.init_at(Vec2::zeros(), 1.0, |_| true);
        assert!(pf.state().is_empty() && pf.cell_draws().is_empty());
    }

    fn offset_stats(pf: &ParticleFilter) -> (f64, Vec<f64>) {
        let o = pf.heading_offsets().to_vec();
        let sd = (o.iter().map(|x| x * x).sum::<f64>() / o.len() as f64).sqrt();
        (sd, o)
    }

    #[test]
    fn gauss_markov_heading_offsets_keep_their_spread_and_decorrelate() {
        let (sd, corr) = (0.1, 10.0);
        let cfg = FusionConfig {
            particle_count: 2000,
            heading_offset_sd_rad: sd,
            heading_offset_corr_steps: corr,
            ..FusionConfig::default()
        };
        let mut pf = ParticleFilter::new(&cfg, 3);
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
        let (_, start) = offset_stats(&pf);
        pf.predict(0.7, 0.0);
        let (_, next) = offset_stats(&pf);
        // lag-1 correlation a = exp(-1 / corr)
        let c1 = start.iter().zip(&next).map(|(a, b)| a * b).sum::<f64>()
            / start.iter().map(|a| a * a).sum::<f64>();
        assert!(
            (c1 - (-1.0 / corr).exp()).abs() < 0.03,
            "lag-1 correlation {c1}"
        );
        for _ in 0..199 {
            pf.predict(0.7, 0.0);
        }
        // stationary: the spread stays sd (a random walk with the same
        // per-step sd would have grown to ~0.6 rad, the clamp)
        let (sd_end, end) = offset_stats(&pf);
        assert!(
            (sd_end - sd).abs() < 0.015,
            "offset sd after 200 steps {sd_end}"
        );
        let c200 = start.iter().zip(&end).map(|(a, b)| a * b).sum::<f64>()
            / start.iter().map(|a| a * a).sum::<f64>();
        assert!(
            c200.abs() < 0.1,
            "offsets still correlated after 200 steps: {c200}"
        );
    }

    #[test]
    fn gauss_markov_and_random_walk_offsets_are_exclusive() {
        let cfg = FusionConfig {
            heading_offset_sd_rad: 0.1,
            heading_offset_corr_steps: 10.0,
            heading_offset_walk_rad: 0.01,
            ..FusionConfig::default()
        };
        let e = cfg.validate().unwrap_err().to_string();
        assert!(e.contains("fusion.heading_offset_corr_steps"), "{e}");
    }

    fn ess_filter(m: usize, fraction: f64) -> ParticleFilter {
        let cfg = FusionConfig {
            particle_count: m,
            resample_ess_fraction: fraction,
            sigma_x_m: 3.0,
            ..FusionConfig::default()
        };
        cfg.validate().unwrap();
        ParticleFilter::new(&cfg, 11)
    }

    #[test]
    fn ess_resampling_waits_until_the_weights_degenerate() {
        let mut pf = ess_filter(1000, 0.5);
        pf.init_at(Vec2::zeros(), 2.0, |_| true);
        // a fix at the cloud's centre barely changes the weights: no resampling
        pf.weight(Vec2::zeros());
        let ess = pf.effective_sample_size();
        assert!(ess > 500.0, "ess {ess}");
        assert!(!pf.resample_if_degenerate());
        let w = pf.weights().to_vec();
        assert!(
            w.iter().any(|x| (x - 1e-3).abs() > 1e-5),
            "weights were reset"
        );
        // the next fix multiplies those weights: w_i ~ L_i^2 for the same fix
        pf.weight(Vec2::zeros());
        let inv = 1.0 / (2.0 * 9.0);
        let l: Vec<f64> = pf
            .particles()
            .iter()
            .map(|p| (-(p.norm_squared()) * inv).exp())
            .collect();
        let z: f64 = l.iter().map(|x| x * x).sum();
        for (wi, li) in pf.weights().iter().zip(&l) {
            assert!((wi - li * li / z).abs() < 1e-12, "{wi} vs {}", li * li / z);
        }
        // a far fix concentrates the weight: resampled, weights uniform
        pf.weight(Vec2::new(15.0, 0.0));
        assert!(
            pf.effective_sample_size() < 500.0,
            "ess {}",
            pf.effective_sample_size()
        );
        assert!(pf.resample_if_degenerate());
        assert!(pf.weights().iter().all(|x| (x - 1e-3).abs() < 1e-15));
    }

    #[test]
    fn ess_fraction_one_resamples_every_step_like_the_paper() {
        let (mut a, mut b) = (ess_filter(300, 1.0), ess_filter(300, 1.0));
        for pf in [&mut a, &mut b] {
            pf.init_at(Vec2::zeros(), 2.0, |_| true);
        }
        for k in 0..20 {
            let x_b = Vec2::new(0.5 * k as f64, 0.3);
            a.predict(0.5, 0.0);
            b.predict(0.5, 0.0);
            a.weight(x_b);
            b.weight(x_b);
            assert!(a.resample_if_degenerate());
            b.resample();
            assert_eq!(a.particles(), b.particles());
        }
        let e = FusionConfig {
            resample_ess_fraction: 0.0,
            ..FusionConfig::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("fusion.resample_ess_fraction"), "{e}");
    }

    #[test]
    fn extra_noise_spreads_the_moves_and_zero_adds_none() {
        let mut a = filter(2000, Resampling::Systematic, 5);
        let mut b = filter(2000, Resampling::Systematic, 5);
        for pf in [&mut a, &mut b] {
            pf.init_at(Vec2::zeros(), 0.0, |_| true);
        }
        // 0 (and garbage) adds nothing: the same draws as eq. 34 alone
        a.set_extra_noise(f64::NAN);
        a.predict(0.7, 0.3);
        b.predict(0.7, 0.3);
        assert_eq!(a.particles(), b.particles());
        let mut c = filter(2000, Resampling::Systematic, 5);
        c.init_at(Vec2::zeros(), 0.0, |_| true);
        c.set_extra_noise(0.5);
        c.predict(0.0, 0.0);
        // step 0 +- 0.15 m along x, N(0, 0.5^2) per axis on top: y shows it alone
        let sd_y = (c.particles().iter().map(|p| p.y * p.y).sum::<f64>() / 2000.0).sqrt();
        assert!((sd_y - 0.5).abs() < 0.03, "sd of y {sd_y}");
    }

    #[test]
    fn penalized_moves_keep_a_fraction_of_their_weight() {
        let mut pf = filter(4, Resampling::Systematic, 1);
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
        let mut before = pf.particles().to_vec();
        // every particle "crossed": uniform again after normalising
        assert_eq!(pf.penalize_moves(&before, 0.1, |_, _| true), 4);
        assert!(pf.weights().iter().all(|w| (w - 0.25).abs() < 1e-12));
        // only the first particle's move (marked by its start) crossed
        before[0] = Vec2::new(-1.0, 0.0);
        let n = pf.penalize_moves(&before, 0.1, |a, _| a.x < 0.0);
        assert_eq!(n, 1);
        // 0.1 : 1 : 1 : 1
        assert!(
            (pf.weights()[0] - 0.1 / 3.1).abs() < 1e-12,
            "{:?}",
            pf.weights()
        );
        assert!((pf.weights()[1] - 1.0 / 3.1).abs() < 1e-12);
    }

    #[test]
    fn penalize_flagged_equals_penalize_moves() {
        let mut a = filter(500, Resampling::Systematic, 4);
        a.init_at(Vec2::zeros(), 3.0, |_| true);
        a.weight(Vec2::new(1.0, 0.5));
        let mut b = a.clone();
        let before = vec![Vec2::zeros(); 500];
        let crossed = |_: Vec2, p: Vec2| p.x > 1.0 && p.y < 0.5;
        let flags: Vec<bool> = a
            .particles()
            .iter()
            .map(|p| crossed(Vec2::zeros(), *p))
            .collect();
        for factor in [0.01, 0.0, 1.0] {
            let n = a.penalize_moves(&before, factor, crossed);
            assert!(n > 0);
            assert_eq!(b.penalize_flagged(&flags, factor), n);
            assert_eq!(a.weights(), b.weights());
        }
    }

    #[test]
    fn without_biases_offsets_and_scales_stay_0_and_1() {
        // resample and replace_invalid skip copying them then
        let mut pf = filter(300, Resampling::Stratified, 2);
        pf.init_at(Vec2::zeros(), 4.0, |_| true);
        for k in 0..5 {
            pf.predict(0.7, k as f64);
            pf.weight(Vec2::new(1.0, 1.0));
            pf.resample();
            pf.replace_invalid(|p| p.x < 0.0, Vec2::zeros());
            assert_eq!(pf.heading_offsets().len(), 300);
            assert!(pf.heading_offsets().iter().all(|o| *o == 0.0));
            assert!(pf.step_scales().iter().all(|s| *s == 1.0));
        }
    }

    #[test]
    fn init_puts_all_particles_on_start() {
        let mut pf = filter(100, Resampling::Systematic, 1);
        pf.init_at(Vec2::new(3.0, 4.0), 0.0, |_| true);
        assert_eq!(pf.particles().len(), 100);
        assert!(pf.particles().iter().all(|p| *p == Vec2::new(3.0, 4.0)));
        assert!((pf.weights().iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn predict_moves_mean_by_step() {
        let mut pf = filter(2000, Resampling::Systematic, 7);
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
        for _ in 0..10 {
            pf.predict(0.7, std::f64::consts::FRAC_PI_2);
        }
        let m = pf.mean().unwrap();
        // 10 steps of 0.7 m north, shortened slightly by the heading noise (E cos nu ~ 0.98).
        assert!(m.x.abs() < 0.1, "{m:?}");
        assert!((m.y - 6.86).abs() < 0.15, "{m:?}");
    }

    #[test]
    fn weighting_and_resampling_pull_towards_ble() {
        let mut pf = filter(1000, Resampling::Stratified, 3);
        pf.init_at(Vec2::zeros(), 5.0, |_| true);
        pf.weight(Vec2::new(3.0, 0.0));
        let m = pf.mean().unwrap();
        assert!(m.x > 1.0, "weighted mean moves towards x_B: {m:?}");
        pf.resample();
        let m2 = pf.mean().unwrap();
        assert!(
            (m2 - m).norm() < 0.5,
            "resampling keeps the mean: {m:?} {m2:?}"
        );
    }

    #[test]
    fn far_fix_does_not_underflow() {
        let mut pf = filter(50, Resampling::Systematic, 3);
        pf.init_at(Vec2::zeros(), 1.0, |_| true);
        pf.weight(Vec2::new(1e4, 0.0));
        let s: f64 = pf.weights().iter().sum();
        assert!((s - 1.0).abs() < 1e-9 && pf.weights().iter().all(|w| w.is_finite()));
    }

    #[test]
    fn same_seed_same_particles() {
        let run = |seed| {
            let mut pf = filter(200, Resampling::Systematic, seed);
            pf.init_at(Vec2::new(1.0, 1.0), 1.0, |_| true);
            for k in 0..20 {
                pf.predict(0.7, k as f64 * 0.1);
                pf.weight(Vec2::new(k as f64 * 0.5, 2.0));
                pf.resample();
            }
            pf.particles().to_vec()
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5), run(6));
    }

    #[test]
    fn small_sin_cos_matches_libm() {
        for k in -1000..=1000 {
            let x = k as f64 * 0.5e-3;
            let (s, c) = small_sin_cos(x);
            assert!((s - x.sin()).abs() < 4e-16, "sin {x}");
            assert!((c - x.cos()).abs() < 4e-16, "cos {x}");
        }
    }

    #[test]
    fn predict_fast_branch_matches_the_general_one() {
        // same seed, same draws: the angle-sum branch equals sin_cos(yaw + nu)
        // to rounding, and a wider noise takes the general branch
        for (dth, fast) in [(0.35, true), (0.5, true), (0.9, false)] {
            let cfg = FusionConfig {
                particle_count: 500,
                heading_noise_rad: dth,
                heading_offset_sd_rad: 0.0,
                ..FusionConfig::default()
            };
            let mut pf = ParticleFilter::new(&cfg, 11);
            pf.init_at(Vec2::zeros(), 0.0, |_| true);
            let mut rng = Pcg64::seed_from_u64(11);
            pf.predict(0.7, 2.0);
            for p in pf.particles() {
                let nu_s = cfg.step_noise_m * (2.0 * rng.random::<f64>() - 1.0);
                let nu_th = dth * (2.0 * rng.random::<f64>() - 1.0);
                let len = 0.7 + nu_s;
                let q = Vec2::new(len * (2.0 + nu_th).cos(), len * (2.0 + nu_th).sin());
                let tol = if fast { 1e-15 } else { 0.0 };
                assert!((p - q).norm() <= tol, "{dth}: {p:?} vs {q:?}");
            }
        }
    }

    #[test]
    fn replace_invalid_copies_good_particles_in_draw_order() {
        let mut pf = filter(300, Resampling::Systematic, 9);
        pf.init_at(Vec2::zeros(), 5.0, |_| true);
        let before = pf.particles().to_vec();
        let bad = |p: Vec2| p.x > 1.0;
        let n = pf.replace_invalid(bad, Vec2::new(9.0, 9.0));
        // reference: the former two-vector version with the same RNG stream
        let mut rng = Pcg64::seed_from_u64(9);
        for _ in 0..2 * 300 {
            let _: f64 = rng.random();
        }
        let good: Vec<usize> = (0..300).filter(|&i| !bad(before[i])).collect();
        let mut expect = before.clone();
        let mut count = 0;
        for i in 0..300 {
            if bad(before[i]) {
                count += 1;
                let k = ((rng.random::<f64>() * good.len() as f64) as usize).min(good.len() - 1);
                expect[i] = before[good[k]];
            }
        }
        assert!(count > 0);
        assert_eq!(n, count);
        assert_eq!(pf.particles(), &expect[..]);
        // all bad: the fallback
        assert_eq!(pf.replace_invalid(|_| true, Vec2::new(9.0, 9.0)), 300);
        assert!(pf.particles().iter().all(|p| *p == Vec2::new(9.0, 9.0)));
    }

    proptest! {
        #[test]
        fn weights_sum_to_one_and_resampling_keeps_count(
            m in 1usize..400,
            seed in 0u64..1000,
            stratified in any::<bool>(),
            bx in -50.0f64..50.0, by in -50.0f64..50.0,
            spread in 0.0f64..20.0,
        ) {
            let scheme = if stratified { Resampling::Stratified } else { Resampling::Systematic };
            let mut pf = filter(m, scheme, seed);
            pf.init_at(Vec2::zeros(), spread, |_| true);
            pf.predict(0.7, 0.3);
            pf.weight(Vec2::new(bx, by));
            let s: f64 = pf.weights().iter().sum();
            prop_assert!((s - 1.0).abs() < 1e-9);
            prop_assert!(pf.weights().iter().all(|w| *w >= 0.0));
            let before: Vec<Vec2> = pf.particles().to_vec();
            pf.resample();
            prop_assert_eq!(pf.particles().len(), m);
            let s: f64 = pf.weights().iter().sum();
            prop_assert!((s - 1.0).abs() < 1e-9);
            // Resampling only copies existing particles.
            prop_assert!(pf.particles().iter().all(|p| before.contains(p)));
        }
    }

    #[test]
    fn inject_replaces_the_fraction_with_accepted_points_near_the_centre() {
        let mut pf = filter(1000, Resampling::Systematic, 3);
        pf.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
        let c = Vec2::new(20.0, 5.0);
        // Only the half-plane x >= 20 is accepted.
        let n = pf.inject(0.2, c, 1.0, |p| p.x >= 20.0);
        let moved: Vec<_> = pf.particles().iter().filter(|p| p.x != 0.0).collect();
        // Random indices may repeat: at most n distinct particles move.
        assert!(n > 150 && n <= 200, "{n}");
        assert!(moved.len() <= n && moved.len() > 150, "{}", moved.len());
        assert!(moved.iter().all(|p| p.x >= 20.0 && (**p - c).norm() < 6.0));
        let mut again = filter(1000, Resampling::Systematic, 3);
        again.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
        again.inject(0.2, c, 1.0, |p| p.x >= 20.0);
        assert_eq!(pf.particles(), again.particles());
        assert_eq!(pf.inject(0.0, c, 1.0, |_| true), 0);
        assert_eq!(pf.inject(0.5, c, 1.0, |_| false), 0);
    }

    #[test]
    fn geometric_median_stays_with_the_heavier_place() {
        // 7 particles at the origin, 3 at 10 m: the mean lies between
        // them, the median with the seven
        let mut pf = filter(10, Resampling::Systematic, 1);
        pf.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
        for p in pf.particles.iter_mut().skip(7) {
            *p = Vec2::new(10.0, 0.0);
        }
        let mean = pf.mean().unwrap();
        assert!((mean - Vec2::new(3.0, 0.0)).norm() < 1e-9, "{mean:?}");
        assert_eq!(pf.geometric_median(0), Some(mean));
        let med = pf.geometric_median(50).unwrap();
        assert!(med.norm() < 0.1, "{med:?}");
        // one place: the median is the place
        pf.init_at(Vec2::new(2.0, -1.0), 0.0, |_| true);
        let one = pf.geometric_median(50).unwrap();
        assert!((one - Vec2::new(2.0, -1.0)).norm() < 1e-9);
    }

    #[test]
    fn mean_likelihood_falls_with_distance() {
        let mut pf = filter(100, Resampling::Systematic, 1);
        pf.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
        assert!((pf.mean_likelihood(Vec2::new(0.0, 0.0), 3.0) - 1.0).abs() < 1e-12);
        let near = pf.mean_likelihood(Vec2::new(3.0, 0.0), 3.0);
        assert!((near - (-0.5f64).exp()).abs() < 1e-12);
        assert!(pf.mean_likelihood(Vec2::new(9.0, 0.0), 3.0) < near);
    }
}
