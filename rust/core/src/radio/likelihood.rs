//! How likely a set of heard RSSIs is at a position.
//!
//! Each heard transmitter k contributes a Student-t log density of its
//! residual z_k = (r_k - o - mu_k(x)) / sd_k (r_k heard, o the phone's RSSI
//! offset, mu_k and sd_k from the [`RadioModel`]): heavy tails, so one
//! reflected or body-shadowed reading (NLOS: 10-20 dB off) costs a bounded
//! amount instead of dragging the position. The sum is tempered by
//! alpha(m) = tempering * (ref / m)^decay for m transmitters (capped at
//! `max_transmitters`, the strongest): readings of one scan share the body,
//! the phone and the walk's multipath, so they are far from independent,
//! and a few transmitters must give a broad likelihood that leaves the
//! filter to PDR and the map.

use serde::{Deserialize, Serialize};

use super::fast_ln::{fast_ln, ln_normal};
use super::model::RadioModel;
use crate::{Result, Vec2};

/// One transmitter heard in a radio update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Index in the [`RadioModel`].
    pub tx: usize,
    /// Mean RSSI of the readings in the update, dBm.
    pub rssi_dbm: f64,
    /// Readings averaged.
    pub readings: u32,
}

/// Settings of the measurement model (docs/parameters.md "tcpf").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LikelihoodConfig {
    /// Degrees of freedom of the Student-t residual (heavier tails below ~5).
    pub student_nu: f64,
    /// Spread of a BLE reading around the path-loss curve, dB.
    pub ble_sd_db: f64,
    /// Spread of a WiFi reading around the path-loss curve, dB.
    pub wifi_sd_db: f64,
    /// Extra loss per floor between phone and transmitter, dB.
    pub floor_loss_db: f64,
    /// Extra spread for a transmitter on another floor, dB.
    pub other_floor_sd_db: f64,
    /// Ranges are floored at this, metres.
    pub min_range_m: f64,
    /// alpha(m) = tempering * (tempering_ref / m)^tempering_decay.
    pub tempering: f64,
    pub tempering_ref: f64,
    pub tempering_decay: f64,
    /// At most this many transmitters (the strongest) per update.
    pub max_transmitters: usize,
    /// Non-detection: a transmitter of a radio that was scanning but was
    /// not heard is evidence against positions where it should be strong.
    /// P(detect) = logistic((mu + offset - sensitivity) / scale); a miss
    /// contributes `miss_weight` * ln max(1 - P(detect), `miss_prob_min`).
    pub ble_sensitivity_dbm: f64,
    pub wifi_sensitivity_dbm: f64,
    pub sensitivity_scale_db: f64,
    pub miss_prob_min: f64,
    pub miss_weight: f64,
    /// Weight of the -ln sd normaliser of each residual (1: the density
    /// as it is). Below 1 a place whose spread is wide because it lies
    /// far from the survey walks pays less for that width on every scan:
    /// the width there is mostly doubt about the mean, which one walk
    /// past it shares across all its scans, not fresh noise per scan.
    pub sd_norm_weight: f64,
}

impl Default for LikelihoodConfig {
    fn default() -> Self {
        LikelihoodConfig {
            student_nu: 4.0,
            ble_sd_db: 6.0,
            wifi_sd_db: 6.0,
            floor_loss_db: 15.0,
            other_floor_sd_db: 4.0,
            min_range_m: 0.5,
            tempering: 1.0,
            tempering_ref: 4.0,
            tempering_decay: 0.5,
            max_transmitters: 40,
            ble_sensitivity_dbm: -92.0,
            wifi_sensitivity_dbm: -88.0,
            sensitivity_scale_db: 4.0,
            miss_prob_min: 0.1,
            miss_weight: 0.0,
            sd_norm_weight: 1.0,
        }
    }
}

impl LikelihoodConfig {
    /// Checks every field's range; errors name `tcpf.likelihood.<field>`.
    pub fn validate(&self) -> Result<()> {
        let pos = [
            ("student_nu", self.student_nu),
            ("ble_sd_db", self.ble_sd_db),
            ("wifi_sd_db", self.wifi_sd_db),
            ("min_range_m", self.min_range_m),
            ("tempering", self.tempering),
            ("tempering_ref", self.tempering_ref),
        ];
        for (f, v) in pos {
            if !(v.is_finite() && v > 0.0 && v <= 1e4) {
                return Err(crate::Error::config(
                    format!("tcpf.likelihood.{f}"),
                    format!("must be in (0, 1e4], got {v}"),
                ));
            }
        }
        for (f, v) in [
            ("floor_loss_db", self.floor_loss_db),
            ("other_floor_sd_db", self.other_floor_sd_db),
            ("tempering_decay", self.tempering_decay),
        ] {
            if !(v.is_finite() && (0.0..=1e3).contains(&v)) {
                return Err(crate::Error::config(
                    format!("tcpf.likelihood.{f}"),
                    format!("must be in [0, 1000], got {v}"),
                ));
            }
        }
        for (f, v, lo, hi) in [
            ("ble_sensitivity_dbm", self.ble_sensitivity_dbm, -200.0, 0.0),
            (
                "wifi_sensitivity_dbm",
                self.wifi_sensitivity_dbm,
                -200.0,
                0.0,
            ),
            (
                "sensitivity_scale_db",
                self.sensitivity_scale_db,
                0.1,
                100.0,
            ),
            ("miss_prob_min", self.miss_prob_min, 1e-6, 1.0),
            ("miss_weight", self.miss_weight, 0.0, 100.0),
            ("sd_norm_weight", self.sd_norm_weight, 0.0, 1.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(crate::Error::config(
                    format!("tcpf.likelihood.{f}"),
                    format!("must be in [{lo}, {hi}], got {v}"),
                ));
            }
        }
        if !(1..=256).contains(&self.max_transmitters) {
            return Err(crate::Error::config(
                "tcpf.likelihood.max_transmitters",
                format!("must be in 1..=256, got {}", self.max_transmitters),
            ));
        }
        Ok(())
    }

    /// The tempering exponent for `m` transmitters.
    pub fn alpha(&self, m: usize) -> f64 {
        if m == 0 {
            return 0.0;
        }
        self.tempering * (self.tempering_ref / m as f64).powf(self.tempering_decay)
    }

    /// Log Student-t density of a standardised residual, up to a constant.
    #[inline]
    pub fn log_t(&self, z: f64) -> f64 {
        -0.5 * (self.student_nu + 1.0) * (z * z / self.student_nu).ln_1p()
    }
}

/// Untempered log-likelihood of `meas` at `p` on `floor` with phone offset
/// `offset_db`: the sum of [`LikelihoodConfig::log_t`] of the residuals
/// (the -ln sd terms do not depend on the position for the path-loss model
/// but do for a model whose spread varies, so they are included).
pub fn log_likelihood(
    model: &dyn RadioModel,
    cfg: &LikelihoodConfig,
    meas: &[Measurement],
    floor: i32,
    p: Vec2,
    offset_db: f64,
) -> f64 {
    let mut s = 0.0;
    for m in meas {
        if let Some((mu, sd)) = model.expected(m.tx, floor, p) {
            let z = (m.rssi_dbm - offset_db - mu) / sd;
            s += cfg.log_t(z) - cfg.sd_norm_weight * sd.ln();
        }
    }
    s
}

/// The per-particle work of a radio update over a whole cloud: the
/// [`log_likelihood`] of every particle (the same values), each heard
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
    /// [`log_likelihood`] point by point, computed per transmitter over
    /// the cloud as -(nu+1)/2 ln prod(1 + z^2/nu) - ln prod(sd) (one
    /// logarithm per particle and group of [`PRODUCT_TERMS`] transmitters,
    /// [`fast_ln`]; ln sd once for a transmitter whose spread is the same
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

/// Log-likelihood at `p` of not having heard the transmitters `missing`
/// (indices in `model`, each with its radio's sensitivity) with phone
/// offset `offset_db`, untempered: sum of `miss_weight` * ln P(miss).
pub fn missing_log_likelihood(
    model: &dyn RadioModel,
    cfg: &LikelihoodConfig,
    missing: &[(usize, f64)],
    floor: i32,
    p: Vec2,
    offset_db: f64,
) -> f64 {
    if cfg.miss_weight == 0.0 {
        return 0.0;
    }
    let inv = 1.0 / cfg.sensitivity_scale_db;
    let mut s = 0.0;
    for &(tx, sens) in missing {
        if let Some((mu, _)) = model.expected(tx, floor, p) {
            let z = (mu + offset_db - sens) * inv;
            if z < -6.0 {
                continue;
            }
            let p_det = 1.0 / (1.0 + (-z).exp());
            s += (1.0 - p_det).max(cfg.miss_prob_min).ln();
        }
    }
    cfg.miss_weight * s
}

/// The phone offset that best explains `meas` at `p` under a Gaussian
/// prior N(`prior_db`, `prior_sd_db`^2) (least squares of the residuals
/// weighted by 1/sd^2), the untempered log-likelihood there, and the
/// offset's posterior standard deviation (1 / sqrt(1/prior_sd^2 + sum
/// 1/sd_k^2), dB). Used where
/// no offset is known yet (the global start, re-seeding): each candidate
/// position gets its own best offset.
pub fn profiled(
    model: &dyn RadioModel,
    cfg: &LikelihoodConfig,
    meas: &[Measurement],
    floor: i32,
    p: Vec2,
    prior_db: f64,
    prior_sd_db: f64,
) -> (f64, f64, f64) {
    let ip = 1.0 / (prior_sd_db * prior_sd_db).max(1e-6);
    let (mut num, mut den) = (prior_db * ip, ip);
    for m in meas {
        if let Some((mu, sd)) = model.expected(m.tx, floor, p) {
            let w = 1.0 / (sd * sd);
            num += (m.rssi_dbm - mu) * w;
            den += w;
        }
    }
    let o = num / den;
    let z0 = (o - prior_db) / prior_sd_db.max(1e-3);
    (
        o,
        log_likelihood(model, cfg, meas, floor, p, o) - 0.5 * z0 * z0,
        1.0 / den.sqrt(),
    )
}

crate::simd::avx2_dispatch! {
    /// [`profiled`] at every point of `ps` into `offsets` and `lls` (cleared
    /// first), within 1e-6 of it (unit test): each transmitter's expected
    /// RSSI computed once per point through [`RadioModel::expected_many`] (the
    /// likelihood surface of a start or a re-seeding over thousands of
    /// cells), the offsets by the same sums in the same order, the
    /// log-likelihood as [`CloudLikelihood::evaluate`] forms it (products of
    /// [`PRODUCT_TERMS`] factors, one [`fast_ln`] each).
    #[allow(clippy::too_many_arguments)]
    pub fn profiled_many(
        model: &dyn RadioModel,
        cfg: &LikelihoodConfig,
        meas: &[Measurement],
        floor: i32,
        ps: &[Vec2],
        prior_db: f64,
        prior_sd_db: f64,
        offsets: &mut Vec<f64>,
        sds: &mut Vec<f64>,
        lls: &mut Vec<f64>,
    ) {
        profiled_many_in(model, cfg, meas, floor, ps, prior_db, prior_sd_db, offsets, sds, lls)
    }
}

/// `out -= half_nu1 ln(prod) + sd_w ln(sd_prod)` (without `sd_prod`: `out -=
/// half_nu1 ln(prod)`), the products reset to 1, with [`fast_ln`]'s values:
/// the branch-free logarithm (vectorises) when every product is normal.
/// The cloud's flush and the likelihood surface's.
#[inline(always)]
fn drain_products(
    out: &mut [f64],
    prod: &mut [f64],
    sd_prod: Option<&mut [f64]>,
    half_nu1: f64,
    sd_w: f64,
) {
    let normal = |v: &[f64]| {
        v.iter().fold(true, |ok, q| {
            ok & (f64::MIN_POSITIVE..=f64::MAX).contains(q)
        })
    };
    // two calls with a constant logarithm each, so each inlines and vectorises
    if normal(prod) && sd_prod.as_deref().is_none_or(normal) {
        drain_with(out, prod, sd_prod, half_nu1, sd_w, ln_normal);
    } else {
        drain_with(out, prod, sd_prod, half_nu1, sd_w, fast_ln);
    }
}

/// [`drain_products`] with the logarithm `ln`.
#[inline(always)]
fn drain_with(
    out: &mut [f64],
    prod: &mut [f64],
    sd_prod: Option<&mut [f64]>,
    half_nu1: f64,
    sd_w: f64,
    ln: fn(f64) -> f64,
) {
    match sd_prod {
        Some(sd_prod) => {
            for ((u, q), qs) in out.iter_mut().zip(prod.iter_mut()).zip(sd_prod.iter_mut()) {
                *u -= half_nu1 * ln(*q) + sd_w * ln(*qs);
                (*q, *qs) = (1.0, 1.0);
            }
        }
        None => {
            for (u, q) in out.iter_mut().zip(prod.iter_mut()) {
                *u -= half_nu1 * ln(*q);
                *q = 1.0;
            }
        }
    }
}

/// [`profiled_many`]'s work.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn profiled_many_in(
    model: &dyn RadioModel,
    cfg: &LikelihoodConfig,
    meas: &[Measurement],
    floor: i32,
    ps: &[Vec2],
    prior_db: f64,
    prior_sd_db: f64,
    offsets: &mut Vec<f64>,
    sds: &mut Vec<f64>,
    lls: &mut Vec<f64>,
) {
    let n = ps.len();
    let ip = 1.0 / (prior_sd_db * prior_sd_db).max(1e-6);
    let (mut mean, mut sd) = (vec![0.0; n * meas.len()], vec![0.0; n * meas.len()]);
    let mut known = Vec::with_capacity(meas.len());
    let (mut num, mut den) = (vec![prior_db * ip; n], vec![ip; n]);
    for (k, m) in meas.iter().enumerate() {
        let (mu, s) = (&mut mean[k * n..(k + 1) * n], &mut sd[k * n..(k + 1) * n]);
        let ok = model.expected_many(m.tx, floor, ps, mu, s);
        known.push(ok);
        if !ok {
            continue;
        }
        for (((a, b), mu), s) in num
            .iter_mut()
            .zip(den.iter_mut())
            .zip(mu.iter())
            .zip(s.iter())
        {
            let w = 1.0 / (s * s);
            *a += (m.rssi_dbm - mu) * w;
            *b += w;
        }
    }
    offsets.clear();
    offsets.extend(num.iter().zip(&den).map(|(a, b)| a / b));
    sds.clear();
    sds.extend(den.iter().map(|b| 1.0 / b.sqrt()));
    lls.clear();
    lls.resize(n, 0.0);
    let half_nu1 = 0.5 * (cfg.student_nu + 1.0);
    let inv_nu = 1.0 / cfg.student_nu;
    let sd_w = cfg.sd_norm_weight;
    let (mut prod, mut sd_prod) = (vec![1.0; n], vec![1.0; n]);
    let mut terms = 0;
    for (k, m) in meas.iter().enumerate() {
        if !known[k] {
            continue;
        }
        let (mu, s) = (&mean[k * n..(k + 1) * n], &sd[k * n..(k + 1) * n]);
        let it = prod.iter_mut().zip(sd_prod.iter_mut()).zip(offsets.iter());
        for (((q, qs), o), (mu, s)) in it.zip(mu.iter().zip(s)) {
            let z = (m.rssi_dbm - o - mu) / s;
            *q *= 1.0 + z * z * inv_nu;
            *qs *= s;
        }
        terms += 1;
        if terms == PRODUCT_TERMS {
            drain_products(lls, &mut prod, Some(&mut sd_prod), half_nu1, sd_w);
            terms = 0;
        }
    }
    if terms > 0 {
        drain_products(lls, &mut prod, Some(&mut sd_prod), half_nu1, sd_w);
    }
    for (l, o) in lls.iter_mut().zip(offsets.iter()) {
        let z0 = (o - prior_db) / prior_sd_db.max(1e-3);
        *l -= 0.5 * z0 * z0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use crate::radio::model::{PathLossModel, PathLossParams};
    use crate::site::testkit;

    fn model() -> PathLossModel {
        let pl = PathLoss {
            rssi_1m_dbm: -60.0,
            exponent: 2.0,
        };
        let bs = [(2.0, 2.0), (18.0, 2.0), (10.0, 18.0)];
        let site = testkit::beacon_site("lik", vec![testkit::open_map(20, 20)], &bs, pl);
        PathLossModel::for_site(
            &site,
            PathLossParams {
                ble_sd_db: 6.0,
                wifi_sd_db: 6.0,
                floor_loss_db: 15.0,
                other_floor_sd_db: 4.0,
                min_range_m: 0.5,
                phone_height_m: 1.2,
            },
        )
    }

    fn heard(m: &PathLossModel, at: Vec2, offset: f64) -> Vec<Measurement> {
        (0..m.transmitters().len())
            .map(|tx| Measurement {
                tx,
                rssi_dbm: m.expected(tx, 0, at).unwrap().0 + offset,
                readings: 1,
            })
            .collect()
    }

    #[test]
    fn truth_is_most_likely_and_offset_is_profiled() {
        let m = model();
        let cfg = LikelihoodConfig::default();
        let at = Vec2::new(6.0, 9.0);
        let meas = heard(&m, at, -8.0);
        let l_true = log_likelihood(&m, &cfg, &meas, 0, at, -8.0);
        for q in [
            Vec2::new(12.0, 9.0),
            Vec2::new(6.0, 15.0),
            Vec2::new(15.0, 3.0),
        ] {
            assert!(log_likelihood(&m, &cfg, &meas, 0, q, -8.0) < l_true);
        }
        let (o, _, _) = profiled(&m, &cfg, &meas, 0, at, 0.0, 100.0);
        assert!((o + 8.0).abs() < 0.01, "{o}");
        // a tight prior pulls it back towards 0
        let (o2, _, _) = profiled(&m, &cfg, &meas, 0, at, 0.0, 1.0);
        assert!(o2 > -8.0 && o2 < 0.0);
    }

    /// A model whose spread varies with the position (as a radio map's),
    /// through the trait's default `expected_many`.
    struct Wavy(PathLossModel);

    impl RadioModel for Wavy {
        fn transmitters(&self) -> &[crate::radio::model::Transmitter] {
            self.0.transmitters()
        }
        fn lookup(&self, kind: crate::radio::model::TxKind, id: &str) -> Option<usize> {
            self.0.lookup(kind, id)
        }
        fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
            let (mu, _) = self.0.expected(tx, floor, p)?;
            Some((
                mu,
                3.0 + 2.0 * (0.7 * p.x + 0.3 * p.y + tx as f64).sin().abs(),
            ))
        }
    }

    #[test]
    fn the_cloud_likelihood_is_the_per_particle_one() {
        let pl = PathLossParams {
            ble_sd_db: 6.0,
            wifi_sd_db: 5.0,
            floor_loss_db: 15.0,
            other_floor_sd_db: 4.0,
            min_range_m: 0.5,
            phone_height_m: 1.2,
        };
        // 20 transmitters (more than PRODUCT_TERMS), BLE and WiFi
        let bs: Vec<(f64, f64)> = (0..20)
            .map(|k| (1.0 + (k % 5) as f64 * 4.5, 1.0 + (k / 5) as f64 * 5.5))
            .collect();
        let curve = PathLoss {
            rssi_1m_dbm: -60.0,
            exponent: 2.3,
        };
        let site = testkit::beacon_site("cloud", vec![testkit::open_map(20, 20)], &bs, curve);
        let m = PathLossModel::for_site(&site, pl);
        let wavy = Wavy(m.clone());
        let ps: Vec<Vec2> = (0..400)
            .map(|i| Vec2::new((i % 20) as f64 * 1.03, (i / 20) as f64 * 0.97))
            .chain(bs.iter().map(|b| Vec2::new(b.0, b.1)))
            .collect();
        let mut cloud = CloudLikelihood::default();
        let mut out = Vec::new();
        let cfgs = [1.0, 0.4, 0.75].map(|sd_norm_weight| LikelihoodConfig {
            sd_norm_weight,
            ..LikelihoodConfig::default()
        });
        let cfg = &cfgs[0];
        let cases = [&m as &dyn RadioModel, &wavy].into_iter().enumerate();
        for ((k, model), cfg) in cases.flat_map(|c| cfgs.iter().map(move |g| (c, g))) {
            for n_heard in [1usize, 7, 8, 9, 20] {
                // heard at (7, 11) with an offset, one 25 dB outlier, one
                // unknown transmitter index
                let mut meas: Vec<Measurement> = (0..n_heard)
                    .map(|tx| Measurement {
                        tx,
                        rssi_dbm: model.expected(tx, 0, Vec2::new(7.0, 11.0)).unwrap().0 - 5.0
                            + (tx as f64 * 1.7).sin() * 4.0,
                        readings: 1,
                    })
                    .collect();
                meas[0].rssi_dbm -= 25.0;
                meas.push(Measurement {
                    tx: 999,
                    rssi_dbm: -70.0,
                    readings: 1,
                });
                cloud.evaluate(model, cfg, &meas, 0, &ps, -5.0, &mut out);
                assert_eq!(out.len(), ps.len());
                let mut worst: f64 = 0.0;
                for (p, l) in ps.iter().zip(&out) {
                    let exact = log_likelihood(model, cfg, &meas, 0, *p, -5.0);
                    worst = worst.max((l - exact).abs());
                }
                assert!(worst < 1e-6, "model {k}, {n_heard} heard: {worst}");
                // each particle with its own offset
                let offs: Vec<f64> = (0..ps.len()).map(|i| -9.0 + (i % 7) as f64).collect();
                let mut each = Vec::new();
                cloud.evaluate_each(model, cfg, &meas, 0, &ps, &offs, &mut each);
                for ((p, l), o) in ps.iter().zip(&each).zip(&offs) {
                    let exact = log_likelihood(model, cfg, &meas, 0, *p, *o);
                    assert!((l - exact).abs() < 1e-6, "{l} {exact}");
                }
                cloud.evaluate(model, cfg, &meas, 0, &ps, -5.0, &mut out);
                // the residual sums are those of `expected`
                let w: Vec<f64> = (0..ps.len()).map(|i| 1.0 + (i % 3) as f64).collect();
                for (j, mm) in meas.iter().enumerate() {
                    let got = cloud.weighted_expected(j, &w);
                    if mm.tx == 999 {
                        assert!(got.is_none());
                        continue;
                    }
                    let (mu, sd, ws) = got.unwrap();
                    let (mut mu0, mut sd0, mut ws0) = (0.0, 0.0, 0.0);
                    for (p, wi) in ps.iter().zip(&w) {
                        let (a, b) = model.expected(mm.tx, 0, *p).unwrap();
                        (mu0, sd0, ws0) = (mu0 + wi * a, sd0 + wi * b, ws0 + wi);
                    }
                    assert!((mu / ws - mu0 / ws0).abs() < 1e-8, "{mu} {mu0}");
                    assert!((sd / ws - sd0 / ws0).abs() < 1e-9 && ws == ws0);
                }
            }
        }
        // an empty cloud and no measurement
        cloud.evaluate(&m, cfg, &[], 0, &ps, 0.0, &mut out);
        assert!(out.iter().all(|l| *l == 0.0) && out.len() == ps.len());
        cloud.evaluate(&m, cfg, &heard(&m, ps[0], 0.0), 0, &[], 0.0, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn the_profiled_surface_is_the_per_point_one() {
        let m = model();
        let wavy = Wavy(m.clone());
        let ps: Vec<Vec2> = (0..400)
            .map(|i| Vec2::new((i % 20) as f64 * 1.03, (i / 20) as f64 * 0.97))
            .collect();
        let (mut offs, mut sds, mut lls) = (Vec::new(), Vec::new(), Vec::new());
        for (model, w) in [(&m as &dyn RadioModel, 1.0), (&wavy, 1.0), (&wavy, 0.3)] {
            let cfg = LikelihoodConfig {
                sd_norm_weight: w,
                ..LikelihoodConfig::default()
            };
            let mut meas = heard(&m, Vec2::new(6.0, 9.0), -7.0);
            meas[1].rssi_dbm -= 20.0;
            meas.push(Measurement {
                tx: 999,
                rssi_dbm: -70.0,
                readings: 1,
            });
            profiled_many(
                model, &cfg, &meas, 0, &ps, -2.0, 4.0, &mut offs, &mut sds, &mut lls,
            );
            assert_eq!((offs.len(), lls.len()), (ps.len(), ps.len()));
            for (((p, o), sd), l) in ps.iter().zip(&offs).zip(&sds).zip(&lls) {
                let (o0, l0, sd0) = profiled(model, &cfg, &meas, 0, *p, -2.0, 4.0);
                assert!((o - o0).abs() < 1e-8 && (l - l0).abs() < 1e-6, "{p:?}");
                assert!((sd - sd0).abs() < 1e-12, "{p:?}");
            }
        }
    }

    #[test]
    fn the_spread_normaliser_is_weighted() {
        let wavy = Wavy(model());
        let meas = heard(&wavy.0, Vec2::new(6.0, 9.0), 0.0);
        let p = Vec2::new(11.0, 4.0);
        let full = LikelihoodConfig {
            sd_norm_weight: 1.0,
            ..LikelihoodConfig::default()
        };
        let none = LikelihoodConfig {
            sd_norm_weight: 0.0,
            ..full.clone()
        };
        let (mut sum_t, mut sum_ln_sd) = (0.0, 0.0);
        for m in &meas {
            let (mu, sd) = wavy.expected(m.tx, 0, p).unwrap();
            sum_t += full.log_t((m.rssi_dbm - mu) / sd);
            sum_ln_sd += sd.ln();
        }
        // weight 0: the residuals alone, a wide spread costs nothing
        assert!((log_likelihood(&wavy, &none, &meas, 0, p, 0.0) - sum_t).abs() < 1e-12);
        let l_full = log_likelihood(&wavy, &full, &meas, 0, p, 0.0);
        assert!((l_full - (sum_t - sum_ln_sd)).abs() < 1e-12);
        let bad = LikelihoodConfig {
            sd_norm_weight: 1.5,
            ..full
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("tcpf.likelihood.sd_norm_weight"), "{e}");
    }

    #[test]
    fn a_missed_transmitter_counts_against_being_near_it() {
        let m = model();
        let cfg = LikelihoodConfig {
            miss_weight: 1.0,
            ..Default::default()
        };
        assert_eq!(LikelihoodConfig::default().miss_weight, 0.0);
        let tx0 = m.transmitters()[0].pos;
        let miss = [(0, cfg.ble_sensitivity_dbm)];
        let near = missing_log_likelihood(&m, &cfg, &miss, 0, tx0, 0.0);
        let far = missing_log_likelihood(&m, &cfg, &miss, 0, tx0 + Vec2::new(500.0, 0.0), 0.0);
        assert!(near < far - 1.0, "{near} {far}");
        assert!((near - cfg.miss_prob_min.ln()).abs() < 0.05, "{near}");
        assert!(far > -0.01, "{far}");
    }

    #[test]
    fn one_outlier_costs_a_bounded_amount() {
        let m = model();
        let cfg = LikelihoodConfig::default();
        let at = Vec2::new(6.0, 9.0);
        let mut meas = heard(&m, at, 0.0);
        let base = log_likelihood(&m, &cfg, &meas, 0, at, 0.0);
        meas[0].rssi_dbm -= 20.0;
        let a = log_likelihood(&m, &cfg, &meas, 0, at, 0.0);
        meas[0].rssi_dbm -= 20.0;
        let b = log_likelihood(&m, &cfg, &meas, 0, at, 0.0);
        // Gaussian: 20 -> 40 dB would cost 3x more; Student-t far less
        assert!(
            base - a > 0.0 && (base - b) < 2.0 * (base - a),
            "{base} {a} {b}"
        );
        assert!(cfg.alpha(1) > cfg.alpha(16));
        assert_eq!(cfg.alpha(0), 0.0);
        assert!(LikelihoodConfig::default().validate().is_ok());
        let bad = LikelihoodConfig {
            student_nu: 0.0,
            ..Default::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("student_nu")
        );
    }
}
