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
//!
//! Layout: this file holds the measurement, the configuration, the
//! per-point likelihood and the misses; `cloud` the same over a whole
//! particle cloud ([`CloudLikelihood`]), `profiled` with the phone offset
//! profiled per point ([`profiled`], [`profiled_many`]).

use serde::{Deserialize, Serialize};

use super::fast_ln::{fast_ln, ln_normal};
use super::model::RadioModel;
use crate::{Result, Vec2};

mod cloud;
mod profiled;

pub use cloud::{CloudLikelihood, PRODUCT_TERMS};
pub use profiled::{profiled, profiled_many};

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
        for (f, v, lo, hi) in [("sd_norm_weight", self.sd_norm_weight, 0.0, 1.0)] {
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

#[cfg(test)]
mod tests;
