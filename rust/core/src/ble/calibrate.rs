//! Beacon calibration from survey logs with ground truth: every advertiser is
//! a candidate; its position (x, y, floor), R0 and n (eq. 1) are fitted, and
//! transmitters that do not behave like fixed ones are rejected.
//!
//! 1. Each observation gets the walker's position by linear interpolation in
//!    time between the two truth points around it (none across gaps longer
//!    than `max_truth_gap_s`, none before the first or after the last point).
//! 2. Adverts of one transmitter on one path are averaged into `bin_s` bins
//!    (mean RSSI, mean position); the transmitter's floor is the floor of most
//!    of its bins, and only those bins are used.
//! 3. Candidates heard on fewer than `min_paths` paths or in fewer than
//!    `min_bins` bins are reported and left out.
//! 4. Position: coarse grid search over the box of the bin positions grown
//!    by `search_margin_m`, then a pattern search down to 0.1 m; at each
//!    candidate position R0 and n come from a Huber-weighted (IRLS) line fit
//!    of RSSI against log10(range), n clamped to [min_exponent, max_exponent];
//!    the cost is the Huber loss of the residuals (plus, with
//!    `exponent_prior_bins`, a Gaussian prior on n: 0.5 W (n - n0)^2, which
//!    the line fit takes as a ridge on the slope).
//! 5. Rejections, in this order: fitted n at a bound (no real distance
//!    dependence), R0 >= 0 dBm (no site file takes it), correlation of RSSI with log10(range) above
//!    `max_correlation`, robust residual spread (1.4826 MAD) above
//!    `max_residual_dbm`, spread of per-path mean residuals above
//!    `max_path_bias_dbm`, per-path excess residual above `max_path_excess_dbm`
//!    (moving or carried devices: each path would put them somewhere else;
//!    each path gets its own RSSI offset in this test, so phones with
//!    different gains do not look like moving transmitters).
//!
//! Ranges are horizontal (calibrated beacons are written at the phone's
//! height, so dz = 0), floored at `min_distance_m`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::config::{BleConfig, CalibrationConfig};
use crate::events::{BleObservation, TruthPoint};
use crate::radio_id::normalize_beacon_id;
use crate::site::{BeaconSpec, SiteSpec};
use crate::{Error, Result, Vec2};

/// One survey walk: its BLE observations and its truth points (MCS).
#[derive(Debug, Clone, Default)]
pub struct SurveyPath {
    /// Name used in messages (e.g. the log file).
    pub name: String,
    pub observations: Vec<BleObservation>,
    pub truth: Vec<TruthPoint>,
}

/// What calibration found about one transmitter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransmitterReport {
    /// Canonical id.
    pub id: String,
    pub floor: i32,
    /// Paths and bins it was heard in (on `floor`).
    pub paths: usize,
    pub bins: usize,
    /// Raw adverts used.
    pub samples: usize,
    /// Fitted model and position, when a fit was made.
    pub x_m: Option<f64>,
    pub y_m: Option<f64>,
    pub rssi_1m_dbm: Option<f64>,
    pub path_loss_exponent: Option<f64>,
    /// Robust residual spread of the fit (1.4826 MAD), dBm.
    pub residual_dbm: Option<f64>,
    /// Pearson correlation of RSSI with log10(range).
    pub correlation: Option<f64>,
    /// Spread (standard deviation) of the per-path mean residuals, dBm.
    pub path_bias_dbm: Option<f64>,
    /// RMS over paths of the excess residual of the common position over each
    /// path's own best position, dBm.
    pub path_excess_dbm: Option<f64>,
    /// `None` when accepted, else why it was left out.
    pub rejected: Option<String>,
}

impl TransmitterReport {
    pub fn accepted(&self) -> bool {
        self.rejected.is_none()
    }

    /// The site entry of an accepted transmitter (z at the phone's height).
    pub fn to_spec(&self, z_m: f64) -> Option<BeaconSpec> {
        if !self.accepted() {
            return None;
        }
        Some(BeaconSpec {
            id: self.id.clone(),
            floor: self.floor,
            x_m: self.x_m?,
            y_m: self.y_m?,
            z_m,
            rssi_1m_dbm: self.rssi_1m_dbm?,
            path_loss_exponent: self.path_loss_exponent?,
        })
    }
}

/// Counters of a calibration run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CalibrationSummary {
    pub paths: usize,
    pub observations: usize,
    /// Observations without truth around them (before/after the walk, long gaps).
    pub without_truth: usize,
    /// Unparsable ids or invalid RSSI.
    pub invalid: usize,
    pub transmitters: usize,
    pub accepted: usize,
}

#[derive(Default, Clone, Copy)]
struct Acc {
    n: usize,
    rssi: f64,
    pos: Vec2,
    floor: i32,
}

#[derive(Clone, Copy)]
struct Bin {
    path: usize,
    pos: Vec2,
    rssi: f64,
}

/// Position on a path at `t_ns` by linear interpolation of the truth (sorted).
pub(crate) fn interpolate(truth: &[TruthPoint], t_ns: i64, max_gap_ns: i64) -> Option<(Vec2, i32)> {
    let i = truth.partition_point(|p| p.t_ns <= t_ns);
    if i == 0 {
        return None;
    }
    let a = &truth[i - 1];
    if a.t_ns == t_ns {
        return Some((Vec2::new(a.x_m, a.y_m), a.floor.unwrap_or(0)));
    }
    let b = truth.get(i)?;
    if b.t_ns - a.t_ns > max_gap_ns {
        return None;
    }
    let f = (t_ns - a.t_ns) as f64 / (b.t_ns - a.t_ns) as f64;
    let p = Vec2::new(a.x_m + f * (b.x_m - a.x_m), a.y_m + f * (b.y_m - a.y_m));
    let floor = if f < 0.5 { a.floor } else { b.floor };
    Some((p, floor.unwrap_or(0)))
}

struct Fit {
    pos: Vec2,
    r0: f64,
    n: f64,
    cost: f64,
}

/// Huber-IRLS line fit rssi = r0 - 10 n x (x = log10 range), n clamped.
fn fit_model(xs: &[f64], ys: &[f64], cfg: &CalibrationConfig) -> (f64, f64, f64) {
    let mut w = vec![1.0; xs.len()];
    let (mut r0, mut n) = (-60.0, 2.0);
    // the prior on n as lambda (s - s0)^2 on the slope s = -10 n
    let (lambda, s0) = (cfg.exponent_prior_bins / 100.0, -10.0 * cfg.exponent_prior);
    for _ in 0..4 {
        let sw: f64 = w.iter().sum();
        let mx = xs.iter().zip(&w).map(|(x, w)| x * w).sum::<f64>() / sw;
        let my = ys.iter().zip(&w).map(|(y, w)| y * w).sum::<f64>() / sw;
        let sxx: f64 = xs.iter().zip(&w).map(|(x, w)| w * (x - mx).powi(2)).sum();
        let sxy: f64 = xs
            .iter()
            .zip(ys)
            .zip(&w)
            .map(|((x, y), w)| w * (x - mx) * (y - my))
            .sum();
        let slope = if sxx + lambda > 1e-12 {
            (sxy + lambda * s0) / (sxx + lambda)
        } else {
            0.0
        };
        n = (-slope / 10.0).clamp(cfg.min_exponent, cfg.max_exponent);
        r0 = my + 10.0 * n * mx;
        for ((x, y), wi) in xs.iter().zip(ys).zip(w.iter_mut()) {
            let r = (y - (r0 - 10.0 * n * x)).abs();
            *wi = if r <= cfg.huber_k_dbm {
                1.0
            } else {
                cfg.huber_k_dbm / r
            };
        }
    }
    let k = cfg.huber_k_dbm;
    let prior = 0.5 * cfg.exponent_prior_bins * (n - cfg.exponent_prior).powi(2);
    let cost = prior
        + xs.iter()
            .zip(ys)
            .map(|(x, y)| huber(y - (r0 - 10.0 * n * x), k))
            .sum::<f64>();
    (r0, n, cost)
}

fn fit_at(
    q: Vec2,
    bins: &[Bin],
    min_d: f64,
    cfg: &CalibrationConfig,
    xs: &mut Vec<f64>,
    ys: &[f64],
) -> Fit {
    xs.clear();
    xs.extend(bins.iter().map(|b| (b.pos - q).norm().max(min_d).log10()));
    let (r0, n, cost) = fit_model(xs, ys, cfg);
    Fit {
        pos: q,
        r0,
        n,
        cost,
    }
}

/// The median of `v` ([`crate::stats::median`]; 0 for none).
pub(crate) fn median(v: Vec<f64>) -> f64 {
    crate::stats::median(&v).unwrap_or(0.0)
}

fn fit_transmitter(bins: &[Bin], min_d: f64, cfg: &CalibrationConfig) -> Fit {
    let ys: Vec<f64> = bins.iter().map(|b| b.rssi).collect();
    let mut xs = Vec::with_capacity(bins.len());
    let (mut lo, mut hi) = (
        Vec2::new(f64::INFINITY, f64::INFINITY),
        Vec2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for b in bins {
        lo = lo.inf(&b.pos);
        hi = hi.sup(&b.pos);
    }
    let m = cfg.search_margin_m;
    lo -= Vec2::new(m, m);
    hi += Vec2::new(m, m);
    let extent = (hi - lo).max();
    let step = cfg.coarse_step_m.max(extent / 80.0);
    let nx = ((hi.x - lo.x) / step).ceil() as usize + 1;
    let ny = ((hi.y - lo.y) / step).ceil() as usize + 1;
    let mut best: Option<Fit> = None;
    for j in 0..ny {
        for i in 0..nx {
            let q = lo + Vec2::new(i as f64 * step, j as f64 * step);
            let f = fit_at(q, bins, min_d, cfg, &mut xs, &ys);
            if best.as_ref().is_none_or(|b| f.cost < b.cost) {
                best = Some(f);
            }
        }
    }
    let mut best = best.unwrap_or(Fit {
        pos: lo,
        r0: -60.0,
        n: 2.0,
        cost: f64::INFINITY,
    });
    // pattern search refinement
    let mut h = step / 2.0;
    while h >= 0.1 {
        let mut moved = true;
        while moved {
            moved = false;
            for d in [
                Vec2::new(h, 0.0),
                Vec2::new(-h, 0.0),
                Vec2::new(0.0, h),
                Vec2::new(0.0, -h),
            ] {
                let f = fit_at(best.pos + d, bins, min_d, cfg, &mut xs, &ys);
                if f.cost < best.cost - 1e-9 {
                    best = f;
                    moved = true;
                }
            }
        }
        h /= 2.0;
    }
    best
}

/// Huber cost of one path's bins at position `q` with the exponent fixed and
/// the path's own offset (its mean residual: phone and body effects differ
/// between walks) removed.
fn huber_cost(bins: &[&Bin], q: Vec2, r0: f64, n: f64, min_d: f64, k: f64) -> f64 {
    let resid = |b: &Bin| b.rssi - (r0 - 10.0 * n * (b.pos - q).norm().max(min_d).log10());
    let offset = bins.iter().map(|b| resid(b)).sum::<f64>() / bins.len().max(1) as f64;
    bins.iter().map(|b| huber(resid(b) - offset, k)).sum()
}

/// The Huber loss of residual `r` with threshold `k`: quadratic within
/// +-k, linear beyond.
fn huber(r: f64, k: f64) -> f64 {
    let r = r.abs();
    if r <= k {
        0.5 * r * r
    } else {
        k * (r - 0.5 * k)
    }
}

/// RMS over paths (>= 5 bins) of sqrt(2 (cost at the common position - cost at
/// the path's own best position) / bins), exponent fixed, per-path offset free; own best position by a
/// grid search over the common search box at the coarse step, then a pattern search.
fn path_excess(
    bins: &[Bin],
    path_ids: &[usize],
    fit: &Fit,
    min_d: f64,
    cc: &CalibrationConfig,
) -> f64 {
    let (mut lo, mut hi) = (
        Vec2::new(f64::INFINITY, f64::INFINITY),
        Vec2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for b in bins {
        lo = lo.inf(&b.pos);
        hi = hi.sup(&b.pos);
    }
    let m = cc.search_margin_m;
    lo -= Vec2::new(m, m);
    hi += Vec2::new(m, m);
    let step = cc.coarse_step_m.max((hi - lo).max() / 80.0);
    let nx = ((hi.x - lo.x) / step).ceil() as usize + 1;
    let ny = ((hi.y - lo.y) / step).ceil() as usize + 1;
    let k = cc.huber_k_dbm;
    let mut sum = 0.0;
    let mut count = 0usize;
    for p in path_ids {
        let pb: Vec<&Bin> = bins.iter().filter(|b| b.path == *p).collect();
        if pb.len() < 5 {
            continue;
        }
        let at_common = huber_cost(&pb, fit.pos, fit.r0, fit.n, min_d, k);
        let mut best = (at_common, fit.pos);
        for j in 0..ny {
            for i in 0..nx {
                let q = lo + Vec2::new(i as f64 * step, j as f64 * step);
                let c = huber_cost(&pb, q, fit.r0, fit.n, min_d, k);
                if c < best.0 {
                    best = (c, q);
                }
            }
        }
        let mut h = step / 2.0;
        while h >= 0.25 {
            for d in [
                Vec2::new(h, 0.0),
                Vec2::new(-h, 0.0),
                Vec2::new(0.0, h),
                Vec2::new(0.0, -h),
            ] {
                let c = huber_cost(&pb, best.1 + d, fit.r0, fit.n, min_d, k);
                if c < best.0 {
                    best = (c, best.1 + d);
                }
            }
            h /= 2.0;
        }
        sum += 2.0 * (at_common - best.0).max(0.0) / pb.len() as f64;
        count += 1;
    }
    if count == 0 {
        0.0
    } else {
        (sum / count as f64).sqrt()
    }
}

fn pearson(xs: &[f64], ys: &[f64]) -> f64 {
    let n = xs.len() as f64;
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let syy: f64 = ys.iter().map(|y| (y - my).powi(2)).sum();
    if sxx > 0.0 && syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        0.0
    }
}

/// Calibrates every BLE transmitter heard in `paths`. Reports are sorted by id.
pub fn calibrate(
    paths: &[SurveyPath],
    cfg: &BleConfig,
) -> Result<(Vec<TransmitterReport>, CalibrationSummary)> {
    calibrate_with(paths, cfg, &cfg.calibration, &|id| {
        normalize_beacon_id(id).ok()
    })
}

/// [`calibrate`] for any kind of transmitter (BLE beacons, WiFi access
/// points): `id_of` maps an observation's id to the transmitter it belongs
/// to (`None`: invalid, counted), `cc` sets the fit and the acceptance tests;
/// `cfg` gives `min_rssi_dbm` and `min_distance_m`.
pub fn calibrate_with(
    paths: &[SurveyPath],
    cfg: &BleConfig,
    cc: &CalibrationConfig,
    id_of: &dyn Fn(&str) -> Option<String>,
) -> Result<(Vec<TransmitterReport>, CalibrationSummary)> {
    cc.validate()?;
    if paths.is_empty() {
        return Err(Error::Calibration("no survey paths given".into()));
    }
    let mut summary = CalibrationSummary {
        paths: paths.len(),
        ..Default::default()
    };
    let max_gap_ns = (cc.max_truth_gap_s * 1e9) as i64;
    let bin_ns = ((cc.bin_s * 1e9) as i64).max(1);
    // id -> (path, bin) -> accumulator
    let mut acc: BTreeMap<String, BTreeMap<(usize, i64), Acc>> = BTreeMap::new();
    let mut id_cache: BTreeMap<String, Option<String>> = BTreeMap::new();
    for (pi, path) in paths.iter().enumerate() {
        let mut truth: Vec<TruthPoint> = path
            .truth
            .iter()
            .copied()
            .filter(|t| t.x_m.is_finite() && t.y_m.is_finite())
            .collect();
        truth.sort_by_key(|t| t.t_ns);
        for o in &path.observations {
            summary.observations += 1;
            let id = id_cache
                .entry(o.beacon_id.clone())
                .or_insert_with(|| id_of(&o.beacon_id))
                .clone();
            let Some(id) = id else {
                summary.invalid += 1;
                continue;
            };
            if !(o.rssi_dbm.is_finite() && o.rssi_dbm < 0.0 && o.rssi_dbm >= cfg.min_rssi_dbm) {
                summary.invalid += 1;
                continue;
            }
            let Some((pos, floor)) = interpolate(&truth, o.t_ns, max_gap_ns) else {
                summary.without_truth += 1;
                continue;
            };
            let a = acc
                .entry(id)
                .or_default()
                .entry((pi, o.t_ns.div_euclid(bin_ns)))
                .or_default();
            a.n += 1;
            a.rssi += o.rssi_dbm;
            a.pos += pos;
            a.floor = floor;
        }
    }
    let mut reports = Vec::with_capacity(acc.len());
    for (id, bins) in acc {
        // floor with most bins
        let mut per_floor: BTreeMap<i32, usize> = BTreeMap::new();
        for a in bins.values() {
            *per_floor.entry(a.floor).or_default() += 1;
        }
        let floor = per_floor
            .iter()
            .max_by_key(|(f, c)| (**c, -**f))
            .map(|(f, _)| *f)
            .unwrap_or(0);
        let bins: Vec<(Bin, usize)> = bins
            .iter()
            .filter(|(_, a)| a.floor == floor && a.n > 0)
            .map(|((p, _), a)| {
                (
                    Bin {
                        path: *p,
                        pos: a.pos / a.n as f64,
                        rssi: a.rssi / a.n as f64,
                    },
                    a.n,
                )
            })
            .collect();
        let samples = bins.iter().map(|(_, n)| n).sum();
        let bins: Vec<Bin> = bins.into_iter().map(|(b, _)| b).collect();
        let mut path_ids: Vec<usize> = bins.iter().map(|b| b.path).collect();
        path_ids.dedup();
        path_ids.sort_unstable();
        path_ids.dedup();
        let mut rep = TransmitterReport {
            id,
            floor,
            paths: path_ids.len(),
            bins: bins.len(),
            samples,
            x_m: None,
            y_m: None,
            rssi_1m_dbm: None,
            path_loss_exponent: None,
            residual_dbm: None,
            correlation: None,
            path_bias_dbm: None,
            path_excess_dbm: None,
            rejected: None,
        };
        if rep.paths < cc.min_paths || rep.bins < cc.min_bins {
            rep.rejected = Some(format!(
                "too little data: {} paths (need {}), {} bins (need {})",
                rep.paths, cc.min_paths, rep.bins, cc.min_bins
            ));
            reports.push(rep);
            continue;
        }
        let fit = fit_transmitter(&bins, cfg.min_distance_m, cc);
        let xs: Vec<f64> = bins
            .iter()
            .map(|b| (b.pos - fit.pos).norm().max(cfg.min_distance_m).log10())
            .collect();
        let ys: Vec<f64> = bins.iter().map(|b| b.rssi).collect();
        let resid: Vec<f64> = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| y - (fit.r0 - 10.0 * fit.n * x))
            .collect();
        let med = median(resid.clone());
        let mad = 1.4826 * median(resid.iter().map(|r| (r - med).abs()).collect());
        let corr = pearson(&xs, &ys);
        let mut path_means = Vec::new();
        for p in &path_ids {
            let r: Vec<f64> = bins
                .iter()
                .zip(&resid)
                .filter(|(b, _)| b.path == *p)
                .map(|(_, r)| *r)
                .collect();
            if r.len() >= 3 {
                path_means.push(r.iter().sum::<f64>() / r.len() as f64);
            }
        }
        let bias = if path_means.len() >= 2 {
            let m = path_means.iter().sum::<f64>() / path_means.len() as f64;
            (path_means.iter().map(|v| (v - m).powi(2)).sum::<f64>()
                / (path_means.len() - 1) as f64)
                .sqrt()
        } else {
            0.0
        };
        rep.x_m = Some(fit.pos.x);
        rep.y_m = Some(fit.pos.y);
        rep.rssi_1m_dbm = Some(fit.r0);
        rep.path_loss_exponent = Some(fit.n);
        rep.residual_dbm = Some(mad);
        rep.correlation = Some(corr);
        rep.path_bias_dbm = Some(bias);
        let excess = path_excess(&bins, &path_ids, &fit, cfg.min_distance_m, cc);
        rep.path_excess_dbm = Some(excess);
        let at_bound =
            (fit.n - cc.min_exponent).abs() < 1e-9 || (fit.n - cc.max_exponent).abs() < 1e-9;
        rep.rejected = if at_bound {
            Some(format!("path-loss exponent at its bound ({:.2})", fit.n))
        } else if fit.r0 >= 0.0 {
            // site files need R0 < 0: a steep fit far from where it was heard
            Some(format!("RSSI at 1 m is not negative ({:.1} dBm)", fit.r0))
        } else if corr > cc.max_correlation {
            Some(format!(
                "RSSI barely depends on range (r = {corr:.2} > {})",
                cc.max_correlation
            ))
        } else if mad > cc.max_residual_dbm {
            Some(format!(
                "poor path-loss fit (residual {mad:.1} dB > {})",
                cc.max_residual_dbm
            ))
        } else if bias > cc.max_path_bias_dbm {
            Some(format!(
                "path-dependent offsets (spread {bias:.1} dB > {}): moving or carried",
                cc.max_path_bias_dbm
            ))
        } else if excess > cc.max_path_excess_dbm {
            Some(format!(
                "paths disagree on its position (excess {excess:.1} dB > {}): moving or carried",
                cc.max_path_excess_dbm
            ))
        } else {
            None
        };
        reports.push(rep);
    }
    summary.transmitters = reports.len();
    summary.accepted = reports.iter().filter(|r| r.accepted()).count();
    Ok((reports, summary))
}

/// `site` with the accepted transmitters added (same id: replaced). Beacons
/// on floors the site does not have are left out.
pub fn apply_to_site(site: &SiteSpec, reports: &[TransmitterReport], z_m: f64) -> SiteSpec {
    let mut out = site.clone();
    for spec in reports.iter().filter_map(|r| r.to_spec(z_m)) {
        if !out.floors.iter().any(|f| f.id == spec.floor) {
            continue;
        }
        let same =
            |b: &BeaconSpec| normalize_beacon_id(&b.id).ok().as_deref() == Some(spec.id.as_str());
        out.beacons.retain(|b| !same(b));
        out.beacons.push(spec);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn gauss(rng: &mut Pcg64) -> f64 {
        let u1: f64 = rng.random::<f64>().max(1e-12);
        let u2: f64 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// Paths walk back and forth across a 50 x 30 m area at 1 m/s with a truth
    /// point every 5 s; fixed transmitters advertise 5 times a second.
    fn survey(seed: u64) -> (Vec<SurveyPath>, Vec<(String, Vec2, PathLoss)>) {
        let mut rng = Pcg64::seed_from_u64(seed);
        let fixed = vec![
            (
                "mac:00:00:00:00:00:01".to_string(),
                Vec2::new(10.0, 8.0),
                PathLoss {
                    rssi_1m_dbm: -60.0,
                    exponent: 2.2,
                },
            ),
            (
                "mac:00:00:00:00:00:02".to_string(),
                Vec2::new(35.0, 20.0),
                PathLoss {
                    rssi_1m_dbm: -55.0,
                    exponent: 2.8,
                },
            ),
            (
                "mac:00:00:00:00:00:03".to_string(),
                Vec2::new(25.0, 5.0),
                PathLoss {
                    rssi_1m_dbm: -65.0,
                    exponent: 1.8,
                },
            ),
        ];
        let mut paths = Vec::new();
        for p in 0..6 {
            let y0 = 3.0 + 5.0 * p as f64;
            let (a, b) = if p % 2 == 0 {
                (Vec2::new(2.0, y0), Vec2::new(48.0, y0 + 2.0))
            } else {
                (Vec2::new(48.0, y0), Vec2::new(2.0, y0 - 1.0))
            };
            let dur_s = (b - a).norm();
            let mut path = SurveyPath {
                name: format!("p{p}"),
                ..Default::default()
            };
            let t0 = p as i64 * 1_000_000_000_000;
            let mut k = 0;
            while (k as f64) * 5.0 <= dur_s {
                let f = (k as f64 * 5.0 / dur_s).min(1.0);
                let q = a + (b - a) * f;
                path.truth.push(TruthPoint {
                    t_ns: t0 + (k as f64 * 5e9) as i64,
                    x_m: q.x,
                    y_m: q.y,
                    floor: Some(0),
                });
                k += 1;
            }
            let t_end = path.truth.last().map(|t| t.t_ns).unwrap_or(t0);
            let mut t = t0;
            while t <= t_end {
                let f = (t - t0) as f64 * 1e-9 / dur_s;
                let q = a + (b - a) * f;
                for (id, pos, m) in &fixed {
                    let r = m.rssi_at((q - pos).norm(), 0.5) + 3.0 * gauss(&mut rng);
                    path.observations.push(BleObservation {
                        t_ns: t,
                        beacon_id: id.clone(),
                        rssi_dbm: r,
                        tx_power_dbm: None,
                    });
                }
                // a device carried by the surveyor: strong everywhere
                path.observations.push(BleObservation {
                    t_ns: t,
                    beacon_id: "mac:00:00:00:00:00:0C".into(),
                    rssi_dbm: -62.0 + 3.0 * gauss(&mut rng),
                    tx_power_dbm: None,
                });
                // a device that sits at a different place on every path
                let moving = Vec2::new(5.0 + 8.0 * p as f64, 25.0 - 4.0 * p as f64);
                path.observations.push(BleObservation {
                    t_ns: t,
                    beacon_id: "mac:00:00:00:00:00:0D".into(),
                    rssi_dbm: -60.0 - 22.0 * (q - moving).norm().max(0.5).log10()
                        + 2.0 * gauss(&mut rng),
                    tx_power_dbm: None,
                });
                // a MAC-rotating phone: a new id on every path
                path.observations.push(BleObservation {
                    t_ns: t,
                    beacon_id: format!("mac:00:00:00:00:01:{p:02X}"),
                    rssi_dbm: -70.0 + 3.0 * gauss(&mut rng),
                    tx_power_dbm: None,
                });
                t += 200_000_000;
            }
            paths.push(path);
        }
        (paths, fixed)
    }

    #[test]
    fn recovers_fixed_transmitters_and_rejects_the_others() {
        let (paths, fixed) = survey(7);
        let (reports, summary) = calibrate(&paths, &BleConfig::default()).unwrap();
        for r in &reports {
            eprintln!(
                "{} paths {} bins {} {:?} {:?} {:?} n {:?} mad {:?} r {:?} bias {:?} excess {:?} {:?}",
                r.id,
                r.paths,
                r.bins,
                r.x_m,
                r.y_m,
                r.rssi_1m_dbm,
                r.path_loss_exponent,
                r.residual_dbm,
                r.correlation,
                r.path_bias_dbm,
                r.path_excess_dbm,
                r.rejected
            );
        }
        for (id, pos, m) in &fixed {
            let r = reports.iter().find(|r| &r.id == id).unwrap();
            assert!(r.accepted(), "{id}: {:?}", r.rejected);
            let p = Vec2::new(r.x_m.unwrap(), r.y_m.unwrap());
            assert!((p - pos).norm() < 1.5, "{id}: {p:?} vs {pos:?}");
            assert!(
                (r.path_loss_exponent.unwrap() - m.exponent).abs() < 0.3,
                "{id} n"
            );
            assert!(
                (r.rssi_1m_dbm.unwrap() - m.rssi_1m_dbm).abs() < 3.0,
                "{id} r0"
            );
        }
        for bad in [
            "mac:00:00:00:00:00:0C",
            "mac:00:00:00:00:00:0D",
            "mac:00:00:00:00:01:00",
        ] {
            let r = reports.iter().find(|r| r.id == bad).unwrap();
            assert!(!r.accepted(), "{bad} accepted");
        }
        assert_eq!(summary.accepted, 3);
        assert_eq!(summary.paths, 6);
    }

    /// A transmitter 11 m beyond the surveyed strip, heard only from 20 m
    /// and more through 5 dB noise and a -90 dBm sensitivity: the range of
    /// log-distances is narrow, so the fit trades distance against the
    /// curve's slope; the prior on n brings both nearer the truth.
    #[test]
    fn the_exponent_prior_keeps_a_transmitter_heard_from_afar_where_it_is() {
        let pos = Vec2::new(25.0, 30.0);
        let m = PathLoss {
            rssi_1m_dbm: -42.0,
            exponent: 2.6,
        };
        let mut rng = Pcg64::seed_from_u64(11);
        let (mut paths, _) = survey(7);
        paths.truncate(3);
        for p in &mut paths {
            let truth = p.truth.clone();
            let (t0, t1) = (truth[0].t_ns, truth[truth.len() - 1].t_ns);
            let mut t = t0;
            while t <= t1 {
                let (q, _) = interpolate(&truth, t, i64::MAX).unwrap();
                let r = m.rssi_at((q - pos).norm(), 0.5) + 5.0 * gauss(&mut rng);
                if r > -90.0 {
                    p.observations.push(BleObservation {
                        t_ns: t,
                        beacon_id: "mac:00:00:00:00:00:0F".into(),
                        rssi_dbm: r,
                        tx_power_dbm: None,
                    });
                }
                t += 200_000_000;
            }
            p.observations.sort_by_key(|o| o.t_ns);
        }
        let fit = |w: f64| {
            let mut cfg = BleConfig::default();
            cfg.calibration.exponent_prior_bins = w;
            cfg.calibration.search_margin_m = 30.0;
            let (reports, _) = calibrate(&paths, &cfg).unwrap();
            let r = reports
                .iter()
                .find(|r| r.id == "mac:00:00:00:00:00:0F")
                .unwrap()
                .clone();
            let p = Vec2::new(r.x_m.unwrap(), r.y_m.unwrap());
            eprintln!(
                "W {w}: {p:?} n {:?} r0 {:?} {:?}",
                r.path_loss_exponent, r.rssi_1m_dbm, r.rejected
            );
            ((p - pos).norm(), r.path_loss_exponent.unwrap())
        };
        let (e0, n0) = fit(0.0);
        let (e1, n1) = fit(50.0);
        assert!(e1 < 0.5 * e0, "{e1:.1} m vs {e0:.1} m without the prior");
        assert!(
            (n1 - m.exponent).abs() < (n0 - m.exponent).abs(),
            "n {n1} vs {n0}"
        );
    }

    #[test]
    fn interpolation_and_site_update() {
        let truth = [
            TruthPoint {
                t_ns: 0,
                x_m: 0.0,
                y_m: 0.0,
                floor: Some(1),
            },
            TruthPoint {
                t_ns: 10,
                x_m: 10.0,
                y_m: 20.0,
                floor: Some(1),
            },
            TruthPoint {
                t_ns: 100,
                x_m: 0.0,
                y_m: 0.0,
                floor: Some(1),
            },
        ];
        assert_eq!(
            interpolate(&truth, 5, 50).map(|p| p.0),
            Some(Vec2::new(5.0, 10.0))
        );
        assert_eq!(interpolate(&truth, 10, 50).map(|p| p.1), Some(1));
        assert_eq!(interpolate(&truth, -1, 50), None);
        assert_eq!(interpolate(&truth, 50, 50), None); // gap of 90 > 50
        assert_eq!(interpolate(&truth, 101, 500), None);
        assert!(calibrate(&[], &BleConfig::default()).is_err());
    }
}
