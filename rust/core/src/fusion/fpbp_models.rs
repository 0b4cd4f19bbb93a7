//! FP-BP's models (Sec. IV-C) for the particle filter: the state
//! transition of eq. 34 ([`Eq34Motion`]) and the weights of eq. 36 against
//! the BLE position x_B ([`Eq36Weights`]).
//!
//! Extension (not in the paper, off in [`FusionConfig::paper`]): every
//! particle may also carry its own heading offset and step-length scale
//! (cloud columns [`HEADING_OFFSET`] and [`STEP_SCALE`]), drawn at the
//! start and random-walking a little per step, so that the cloud holds
//! hypotheses about the phone's persistent heading and step-length errors
//! and BLE and walls select the right ones (eq. 34 draws fresh noise every
//! step and cannot learn a constant 10 deg offset). Another: extra
//! isotropic Gaussian position noise after eq. 34
//! ([`Eq34Motion::set_extra_noise`]).

use rand::RngExt;
use rand_pcg::Pcg64;

use super::cloud::Cloud;
use super::config::FusionConfig;
use super::model::{MeasurementModel, MotionModel};
use super::random::{box_muller_in_place, rows, std_normal, symmetric};
use super::uniforms::fill_interleaved;
use crate::Vec2;

/// Cloud column of the per-particle heading offsets, rad.
pub const HEADING_OFFSET: usize = 0;
/// Cloud column of the per-particle step-length scales.
pub const STEP_SCALE: usize = 1;

/// Largest per-particle heading offset, rad (draws are clamped to it).
const MAX_HEADING_OFFSET_RAD: f64 = 0.6;
/// Per-particle step-length scales are clamped to [1 - this, 1 + this].
const MAX_SCALE_DEVIATION: f64 = 0.4;

/// Largest heading-noise half-width for which [`Eq34Motion`] uses
/// [`small_sin_cos`], rad.
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

/// One PDR step: the control input of [`Eq34Motion`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PdrStep {
    /// s, step length, metres.
    pub length_m: f64,
    /// theta, heading in the MCS, rad.
    pub yaw_rad: f64,
}

/// Eq. 34: every particle moves by (s + nu_s) [cos(theta + nu_theta),
/// sin(theta + nu_theta)] with nu_s, nu_theta uniform in ±step_noise_m,
/// ±heading_noise_rad. With per-particle biases: (s * scale_i + nu_s)
/// along theta + offset_i + nu_theta, after offset_i and scale_i took
/// their random-walk (or Gauss-Markov) step. Then the extra noise, if any.
///
/// Draws per particle, particle by particle: the offset's normal and the
/// scale's normal (two uniforms each, when they walk), nu_s, nu_theta; then
/// per particle the extra noise's two normals.
#[derive(Debug, Clone)]
pub struct Eq34Motion {
    step_noise_m: f64,
    heading_noise_rad: f64,
    heading_offset_sd_rad: f64,
    heading_offset_walk_rad: f64,
    /// Gauss-Markov factor a = exp(-1 / heading_offset_corr_steps) of the
    /// heading offsets (0 = the random walk `heading_offset_walk_rad`).
    heading_offset_decay: f64,
    step_scale_sd: f64,
    step_scale_walk: f64,
    /// Extra isotropic Gaussian position noise of the next moves, metres
    /// (innovation-driven process noise; 0 = eq. 34 alone).
    extra_noise_m: f64,
    /// Uniform draws of one propagation (step length, heading), reused.
    draw_s: Vec<f64>,
    draw_th: Vec<f64>,
    /// Uniform draws of one propagation with particle biases or extra
    /// noise (then their normals), reused.
    draw_buf: Vec<f64>,
    /// The same draws as they come from the RNG, particle by particle
    /// ([`fill_interleaved`]), reused.
    uniform_buf: Vec<f64>,
}

impl Eq34Motion {
    /// The model of `config` (validated), for `count` particles.
    pub fn new(config: &FusionConfig, count: usize) -> Self {
        Eq34Motion {
            step_noise_m: config.step_noise_m,
            heading_noise_rad: config.heading_noise_rad,
            heading_offset_sd_rad: config.heading_offset_sd_rad,
            heading_offset_walk_rad: config.heading_offset_walk_rad,
            heading_offset_decay: if config.heading_offset_corr_steps > 0.0 {
                (-1.0 / config.heading_offset_corr_steps).exp()
            } else {
                0.0
            },
            step_scale_sd: config.step_scale_sd,
            step_scale_walk: config.step_scale_walk,
            extra_noise_m: 0.0,
            draw_s: Vec::with_capacity(count),
            draw_th: Vec::with_capacity(count),
            draw_buf: Vec::new(),
            uniform_buf: Vec::new(),
        }
    }

    /// Whether the particles carry their own heading offsets or step
    /// scales (without, every offset stays 0 and every scale 1: the
    /// columns need not travel with their particles).
    pub fn has_particle_biases(&self) -> bool {
        self.heading_offset_sd_rad > 0.0
            || self.heading_offset_walk_rad > 0.0
            || self.step_scale_sd > 0.0
            || self.step_scale_walk > 0.0
    }

    /// Fills the columns [`HEADING_OFFSET`] and [`STEP_SCALE`] (emptied
    /// before) with one value per particle: offset ~ N(0,
    /// `heading_offset_sd_rad`) and scale ~ 1 + N(0, `step_scale_sd`),
    /// particle by particle (no draw when the sd is 0: 0 and 1).
    pub fn draw_biases(&self, cloud: &mut Cloud, rng: &mut Pcg64) {
        for _ in 0..cloud.len() {
            let off = if self.heading_offset_sd_rad > 0.0 {
                (self.heading_offset_sd_rad * std_normal(rng))
                    .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD)
            } else {
                0.0
            };
            let scale = if self.step_scale_sd > 0.0 {
                (1.0 + self.step_scale_sd * std_normal(rng))
                    .clamp(1.0 - MAX_SCALE_DEVIATION, 1.0 + MAX_SCALE_DEVIATION)
            } else {
                1.0
            };
            cloud.column_vec_mut(HEADING_OFFSET).push(off);
            cloud.column_vec_mut(STEP_SCALE).push(scale);
        }
    }

    /// Sets the extra position noise (standard deviation per axis, metres)
    /// that every following propagation adds after eq. 34; 0 (the
    /// default) adds none. Not finite or negative counts as 0.
    pub fn set_extra_noise(&mut self, sd_m: f64) {
        self.extra_noise_m = if sd_m.is_finite() { sd_m.max(0.0) } else { 0.0 };
    }

    fn predict_eq34(
        &mut self,
        cloud: &mut Cloud,
        rng: &mut Pcg64,
        step_length_m: f64,
        yaw_rad: f64,
    ) {
        let (ds, dth) = (self.step_noise_m, self.heading_noise_rad);
        if self.has_particle_biases() {
            self.predict_biased(cloud, rng, step_length_m, yaw_rad);
            return;
        }
        let particles = cloud.positions_mut();
        if dth <= SMALL_ANGLE_MAX_RAD {
            // cos/sin of yaw + nu by the angle-sum rule, with nu's from
            // series accurate to ~1e-16 on |nu| <= 0.5 (no libm call per
            // particle); same draws in the same order as the general branch
            let (sy, cy) = yaw_rad.sin_cos();
            // The draws first (one serial chain through the RNG state), then
            // the arithmetic, which has no dependence between particles and
            // vectorises: the same operations on the same values.
            let m = particles.len();
            self.draw_s.resize(m, 0.0);
            self.draw_th.resize(m, 0.0);
            let outs = &mut [&mut self.draw_s[..], &mut self.draw_th[..]];
            fill_interleaved(rng, &mut self.uniform_buf, m, outs);
            for ((p, &u_s), &u_th) in particles.iter_mut().zip(&self.draw_s).zip(&self.draw_th) {
                let nu_s = symmetric(ds, u_s);
                let nu_th = symmetric(dth, u_th);
                let len = (step_length_m + nu_s).max(0.0);
                let (sn, cn) = small_sin_cos(nu_th);
                let (s, c) = (sy * cn + cy * sn, cy * cn - sy * sn);
                *p += Vec2::new(len * c, len * s);
            }
            return;
        }
        for p in particles {
            let nu_s = symmetric(ds, rng.random::<f64>());
            let nu_th = symmetric(dth, rng.random::<f64>());
            let len = (step_length_m + nu_s).max(0.0);
            let (s, c) = (yaw_rad + nu_th).sin_cos();
            *p += Vec2::new(len * c, len * s);
        }
    }

    fn predict_biased(
        &mut self,
        cloud: &mut Cloud,
        rng: &mut Pcg64,
        step_length_m: f64,
        yaw_rad: f64,
    ) {
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
        let (particles, [offsets, scales]) =
            cloud.positions_and_columns_mut([HEADING_OFFSET, STEP_SCALE]);
        let m = particles.len();
        let [o1, o2, s1, s2, us, uth] = rows(&mut self.draw_buf, m);
        let buf = &mut self.uniform_buf;
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
        for (((((p, off), scale), &z_off), &z_scale), (&u_s, &u_th)) in particles
            .iter_mut()
            .zip(offsets.iter_mut())
            .zip(scales.iter_mut())
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
            let nu_s = symmetric(ds, u_s);
            let nu_th = symmetric(dth, u_th);
            let len = (step_length_m * *scale + nu_s).max(0.0);
            *p += step_vector(len, *off + nu_th, sy, cy);
        }
    }
}

impl MotionModel<PdrStep> for Eq34Motion {
    fn propagate(&mut self, cloud: &mut Cloud, rng: &mut Pcg64, step: &PdrStep) {
        self.predict_eq34(cloud, rng, step.length_m, step.yaw_rad);
        let sd = self.extra_noise_m;
        if sd > 0.0 {
            // per particle the draws of a then b (two uniforms each), as
            // two calls of std_normal would take them; Box-Muller batched
            let particles = cloud.positions_mut();
            let m = particles.len();
            let [a1, a2, b1, b2] = rows(&mut self.draw_buf, m);
            let outs = &mut [&mut *a1, &mut *a2, &mut *b1, &mut *b2];
            fill_interleaved(rng, &mut self.uniform_buf, m, outs);
            box_muller_in_place(a1, a2);
            box_muller_in_place(b1, b2);
            for ((p, a), b) in particles.iter_mut().zip(&*a1).zip(&*b1) {
                *p += Vec2::new(sd * a, sd * b);
            }
        }
    }
}

/// Eq. 36: w_i = exp(-|x_i - x_B|^2 / (2 sigma_x^2)) against the BLE
/// position x_B, normalised to sum 1. The constant 1/sqrt(2 pi sigma^2)
/// cancels in the normalisation; the exponent is shifted by its minimum
/// distance so far-away fixes do not underflow. With weights carried
/// between steps (ESS-triggered resampling) the likelihood multiplies
/// them instead of replacing them. No draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eq36Weights {
    sigma_x_m: f64,
    /// Multiply the weights the cloud carries instead of setting them.
    carry: bool,
}

impl Eq36Weights {
    /// sigma_x = `sigma_x_m`; `carry`: weights accumulate between resamplings.
    pub fn new(sigma_x_m: f64, carry: bool) -> Self {
        Eq36Weights { sigma_x_m, carry }
    }

    /// Sets sigma_x for the following updates, metres (ignored unless
    /// finite and > 0).
    pub fn set_sigma_x(&mut self, sigma_m: f64) {
        if sigma_m.is_finite() && sigma_m > 0.0 {
            self.sigma_x_m = sigma_m;
        }
    }
}

impl MeasurementModel<Vec2> for Eq36Weights {
    fn update(&mut self, cloud: &mut Cloud, x_b: &Vec2) {
        if cloud.is_empty() {
            return;
        }
        let x_b = *x_b;
        let inv = 1.0 / (2.0 * self.sigma_x_m * self.sigma_x_m);
        let (particles, weights) = cloud.positions_and_weights_mut();
        let d2min = particles
            .iter()
            .map(|p| (p - x_b).norm_squared())
            .fold(f64::INFINITY, f64::min);
        let carry = self.carry;
        for (w, p) in weights.iter_mut().zip(particles.iter()) {
            let l = (-((p - x_b).norm_squared() - d2min) * inv).exp();
            *w = if carry { *w * l } else { l };
        }
        cloud.normalize();
    }
}

/// Mean over the particles of the unnormalised eq. 36 likelihood
/// exp(-|x_i - x_B|^2 / (2 sigma^2)) with standard deviation `sigma_m`
/// (0 without particles). With equal weights (after resampling) this is
/// the measurement likelihood of the whole cloud that augmented MCL
/// tracks (recovery extension).
pub fn mean_likelihood(cloud: &Cloud, x_b: Vec2, sigma_m: f64) -> f64 {
    if cloud.is_empty() || sigma_m.is_nan() || sigma_m <= 0.0 {
        return 0.0;
    }
    let inv = 1.0 / (2.0 * sigma_m * sigma_m);
    let s: f64 = cloud
        .positions()
        .iter()
        .map(|p| (-(p - x_b).norm_squared() * inv).exp())
        .sum();
    s / cloud.len() as f64
}

#[cfg(test)]
mod tests;
