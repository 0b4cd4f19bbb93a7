//! The radio update's likelihood over a whole cloud, transmitter by
//! transmitter ([`CloudLikelihood`]).

use super::{LikelihoodConfig, Measurement, drain_products};
use crate::Vec2;
use crate::radio::model::RadioModel;

/// The per-particle work of a radio update over a whole cloud: the
/// [`super::log_likelihood`] of every particle (the same values), each heard
/// transmitter's expected (mean, sd) computed once per particle through
/// [`RadioModel::expected_many`] and kept for the residuals
/// ([`CloudLikelihood::weighted_expected`]). Reuse one across updates to
/// keep its buffers.
#[derive(Debug, Clone, Default)]
pub struct CloudLikelihood {
    /// Particles of the last [`CloudLikelihood::evaluate`].
    n: usize,
    /// Per measurement: whether the model knows its transmitter.
    known: Vec<bool>,
    /// Expected mean and sd, measurement-major: `[k * n + i]`.
    mean: Vec<f64>,
    sd: Vec<f64>,
    /// Per particle: prod (1 + z^2/nu) and prod sd of the transmitters
    /// not yet in the sum.
    prod: Vec<f64>,
    sd_prod: Vec<f64>,
}

/// The phone offset of a [`CloudLikelihood`] evaluation: one for the
/// whole cloud, or each particle's own.
#[derive(Debug, Clone, Copy)]
enum Offsets<'a> {
    One(f64),
    Each(&'a [f64]),
}

/// Transmitters per product in [`CloudLikelihood::evaluate`]: a factor
/// 1 + z^2/nu overflows 8 at a time only for |z| > 1e19.
pub const PRODUCT_TERMS: usize = 8;

impl CloudLikelihood {
    /// Untempered log-likelihood of `meas` at every particle of `ps` on
    /// `floor` with phone offset `offset_db` into `out` (cleared first):
    /// [`super::log_likelihood`] point by point, computed per transmitter over
    /// the cloud as -(nu+1)/2 ln prod(1 + z^2/nu) - ln prod(sd) (one
    /// logarithm per particle and group of [`PRODUCT_TERMS`] transmitters,
    /// [`crate::radio::fast_ln::fast_ln`]; ln sd once for a transmitter whose spread is the same
    /// at every particle) and the model's [`RadioModel::expected_many`].
    /// Within 1e-6 of `log_likelihood` (unit test).
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate(
        &mut self,
        model: &dyn RadioModel,
        cfg: &LikelihoodConfig,
        meas: &[Measurement],
        floor: i32,
        ps: &[Vec2],
        offset_db: f64,
        out: &mut Vec<f64>,
    ) {
        self.evaluate_with(model, cfg, meas, floor, ps, Offsets::One(offset_db), out);
    }

    /// [`CloudLikelihood::evaluate`] with each particle's own phone offset
    /// (`offsets_db[i]` for `ps[i]`, same length).
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate_each(
        &mut self,
        model: &dyn RadioModel,
        cfg: &LikelihoodConfig,
        meas: &[Measurement],
        floor: i32,
        ps: &[Vec2],
        offsets_db: &[f64],
        out: &mut Vec<f64>,
    ) {
        assert_eq!(offsets_db.len(), ps.len(), "one offset per particle");
        self.evaluate_with(model, cfg, meas, floor, ps, Offsets::Each(offsets_db), out);
    }

    #[allow(clippy::too_many_arguments)]
    fn evaluate_with(
        &mut self,
        model: &dyn RadioModel,
        cfg: &LikelihoodConfig,
        meas: &[Measurement],
        floor: i32,
        ps: &[Vec2],
        offsets: Offsets<'_>,
        out: &mut Vec<f64>,
    ) {
        evaluate_dispatched(self, model, cfg, meas, floor, ps, offsets, out);
    }

    /// [`CloudLikelihood::evaluate_with`]'s work (through
    /// [`evaluate_dispatched`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn evaluate_in(
        &mut self,
        model: &dyn RadioModel,
        cfg: &LikelihoodConfig,
        meas: &[Measurement],
        floor: i32,
        ps: &[Vec2],
        offsets: Offsets<'_>,
        out: &mut Vec<f64>,
    ) {
        let n = ps.len();
        self.n = n;
        self.known.clear();
        self.mean.resize(meas.len() * n, 0.0);
        self.sd.resize(meas.len() * n, 0.0);
        self.prod.clear();
        self.prod.resize(n, 1.0);
        self.sd_prod.clear();
        self.sd_prod.resize(n, 1.0);
        out.clear();
        out.resize(n, 0.0);
        let half_nu1 = 0.5 * (cfg.student_nu + 1.0);
        let inv_nu = 1.0 / cfg.student_nu;
        let sd_w = cfg.sd_norm_weight;
        let (mut terms, mut sd_varies, mut ln_sd_sum) = (0usize, false, 0.0);
        for (k, m) in meas.iter().enumerate() {
            let mean = &mut self.mean[k * n..(k + 1) * n];
            let sd = &mut self.sd[k * n..(k + 1) * n];
            let known = model.expected_many(m.tx, floor, ps, mean, sd);
            self.known.push(known);
            if !known || n == 0 {
                continue;
            }
            let sd0 = sd[0];
            // without an early exit, so that it vectorises (`all` compared
            // one value at a time: 7 % of the bench's engine task)
            let same_sd = sd.iter().fold(true, |same, s| same & (*s == sd0));
            match offsets {
                Offsets::One(offset_db) => {
                    let r = m.rssi_dbm - offset_db;
                    if same_sd {
                        let inv = 1.0 / sd0;
                        ln_sd_sum += sd0.ln();
                        for (q, mu) in self.prod.iter_mut().zip(mean.iter()) {
                            let z = (r - mu) * inv;
                            *q *= 1.0 + z * z * inv_nu;
                        }
                    } else {
                        sd_varies = true;
                        let it = self.prod.iter_mut().zip(self.sd_prod.iter_mut());
                        for ((q, qs), (mu, s)) in it.zip(mean.iter().zip(sd.iter())) {
                            let z = (r - mu) / s;
                            *q *= 1.0 + z * z * inv_nu;
                            *qs *= s;
                        }
                    }
                }
                Offsets::Each(offs) => {
                    let r = m.rssi_dbm;
                    if same_sd {
                        let inv = 1.0 / sd0;
                        ln_sd_sum += sd0.ln();
                        let it = self.prod.iter_mut().zip(mean.iter());
                        for ((q, mu), o) in it.zip(offs) {
                            let z = (r - o - mu) * inv;
                            *q *= 1.0 + z * z * inv_nu;
                        }
                    } else {
                        sd_varies = true;
                        let it = self.prod.iter_mut().zip(self.sd_prod.iter_mut());
                        let it = it.zip(mean.iter().zip(sd.iter())).zip(offs);
                        for (((q, qs), (mu, s)), o) in it {
                            let z = (r - o - mu) / s;
                            *q *= 1.0 + z * z * inv_nu;
                            *qs *= s;
                        }
                    }
                }
            }
            terms += 1;
            if terms == PRODUCT_TERMS {
                self.flush(out, half_nu1, sd_w, sd_varies);
                (terms, sd_varies) = (0, false);
            }
        }
        if terms > 0 {
            self.flush(out, half_nu1, sd_w, sd_varies);
        }
        if ln_sd_sum != 0.0 {
            let c = sd_w * ln_sd_sum;
            out.iter_mut().for_each(|u| *u -= c);
        }
    }

    /// Moves the products into `out` and resets them.
    #[inline(always)]
    fn flush(&mut self, out: &mut [f64], half_nu1: f64, sd_w: f64, sd_varies: bool) {
        let sd_prod = if sd_varies {
            Some(&mut self.sd_prod[..])
        } else {
            None
        };
        drain_products(out, &mut self.prod, sd_prod, half_nu1, sd_w);
    }

    /// For the `k`-th measurement of the last
    /// [`CloudLikelihood::evaluate`]: (sum of w * mean, sum of w * sd, sum
    /// of w) over the particles with weights `weights` (same order and
    /// length); `None` when the model did not know the transmitter.
    pub fn weighted_expected(&self, k: usize, weights: &[f64]) -> Option<(f64, f64, f64)> {
        if !self.known.get(k).copied().unwrap_or(false) {
            return None;
        }
        let n = self.n;
        let (mean, sd) = (&self.mean[k * n..(k + 1) * n], &self.sd[k * n..(k + 1) * n]);
        Some(weighted_sums(weights, mean, sd))
    }
}

crate::simd::avx2_dispatch! {
    /// [`CloudLikelihood::evaluate_in`] of `this`.
    #[allow(clippy::too_many_arguments)]
    fn evaluate_dispatched(
        this: &mut CloudLikelihood,
        model: &dyn RadioModel,
        cfg: &LikelihoodConfig,
        meas: &[Measurement],
        floor: i32,
        ps: &[Vec2],
        offsets: Offsets<'_>,
        out: &mut Vec<f64>,
    ) {
        this.evaluate_in(model, cfg, meas, floor, ps, offsets, out)
    }
}

crate::simd::avx2_dispatch! {
    /// (sum of w * mean, sum of w * sd, sum of w) over the first
    /// min(len) entries of the three slices.
    fn weighted_sums(weights: &[f64], mean: &[f64], sd: &[f64]) -> (f64, f64, f64) {
        // four partial sums each (independent chains: the loop runs at the
        // adder's throughput instead of its latency)
        let n = mean.len().min(sd.len()).min(weights.len());
        let (mut mu, mut s, mut ws) = ([0.0; 4], [0.0; 4], [0.0; 4]);
        let split = n - n % 4;
        let quads = weights[..split]
            .chunks_exact(4)
            .zip(mean[..split].chunks_exact(4))
            .zip(sd[..split].chunks_exact(4));
        for ((w, a), b) in quads {
            for l in 0..4 {
                mu[l] += w[l] * a[l];
                s[l] += w[l] * b[l];
                ws[l] += w[l];
            }
        }
        for i in split..n {
            mu[0] += weights[i] * mean[i];
            s[0] += weights[i] * sd[i];
            ws[0] += weights[i];
        }
        let total = |v: [f64; 4]| (v[0] + v[1]) + (v[2] + v[3]);
        (total(mu), total(s), total(ws))
    }
}
