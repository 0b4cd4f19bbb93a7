//! The likelihood with the phone offset profiled per point (the start's
//! and re-seeding's surface, where no offset is known yet).

use super::{LikelihoodConfig, Measurement, PRODUCT_TERMS, drain_products, log_likelihood};
use crate::Vec2;
use crate::radio::model::RadioModel;

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
    /// log-likelihood as [`super::CloudLikelihood::evaluate`] forms it (products of
    /// [`PRODUCT_TERMS`] factors, one [`crate::radio::fast_ln::fast_ln`] each).
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
