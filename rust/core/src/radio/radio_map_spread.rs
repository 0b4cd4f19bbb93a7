//! The radio map's spread calibrated on its own survey
//! (`RadioMapConfig::spread_calibration`): leave one walk out. For every
//! survey walk w and transmitter, the kernel mean of the other walks' bins
//! (the map's smoothing, [`super::radio_map_build`], at each of w's bins)
//! predicts what w read there; the residuals, grouped by the distance d
//! from w's bin to the nearest bin of the other walks, give the spread a
//! walk that was not in the survey meets at distance d (the walk-to-walk
//! variation included). Per radio kind a curve
//! sd(d) = sqrt(s0^2 + (k d)^2) is fitted to the residual variance of 1 m
//! distance bins (weighted least squares in s0^2 and k^2, both at least 0),
//! and the residuals beyond `max_distance_m` (where the map answers with its
//! fallback) give the fallback's spread. The map's cells then hold sd(d) of
//! their distance d to the nearest bin ([`SpreadCurve`]).
//!
//! Pure: the builder's bins in, the curves out.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::model::{PathLossModel, RadioModel, TxKind};
use super::radio_map_build::{Fallback, TxAcc, disagreement, fallback_tx};
use super::radio_map_config::RadioMapConfig;
use crate::Vec2;

/// Fewest residual readings for a curve (fewer: the kind keeps the
/// uncalibrated spread).
pub const MIN_READINGS: f64 = 200.0;
/// Fewest readings beyond `max_distance_m` for the fallback spread.
pub const MIN_FAR_READINGS: f64 = 100.0;
/// Bounds of a calibrated spread, dB.
pub const SD_BOUNDS_DB: (f64, f64) = (1.0, 30.0);

/// sd(d) = sqrt(s0^2 + (k d)^2), clamped to [`SD_BOUNDS_DB`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpreadCurve {
    /// Spread on the survey, dB.
    pub s0_db: f64,
    /// Growth with the distance from the survey, dB/m.
    pub k_db_per_m: f64,
}

impl SpreadCurve {
    /// The spread at `d_m` from the survey, dB.
    pub fn at(&self, d_m: f64) -> f64 {
        let g = self.k_db_per_m * d_m;
        (self.s0_db * self.s0_db + g * g)
            .sqrt()
            .clamp(SD_BOUNDS_DB.0, SD_BOUNDS_DB.1)
    }
}

/// What leave-one-walk-out found for one radio kind.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SpreadFit {
    /// The curve, when there were [`MIN_READINGS`] residuals.
    pub curve: Option<SpreadCurve>,
    /// RMS of the residuals beyond `max_distance_m` (against the
    /// path-loss fallback), dB, with [`MIN_FAR_READINGS`] of them.
    pub fallback_sd_db: Option<f64>,
    /// Residual readings within `max_distance_m` and beyond it.
    pub readings: f64,
    pub far_readings: f64,
    /// Per 1 m distance bin: (readings, RMS residual dB).
    pub by_distance: Vec<(f64, f64)>,
}

/// One bin of one transmitter on one floor, as leave-one-walk-out sees it.
pub(super) struct WalkBin {
    pub pos: Vec2,
    /// walk -> (count, sum, sum of squares) of its (offset-removed) readings
    pub walks: BTreeMap<usize, (f64, f64, f64)>,
}

/// The smoothing of the map ([`super::radio_map_build::SmoothParams`]).
pub(super) struct Kernel {
    pub bandwidth_m: f64,
    pub max_distance_m: f64,
    pub prior_weight: f64,
}

/// Residual sums of one kind: per 1 m distance bin (readings, sum of
/// d^2 readings, sum of squared residuals), and beyond `max_distance_m`.
#[derive(Debug, Clone, Default)]
pub(super) struct Residuals {
    near: BTreeMap<i64, (f64, f64, f64)>,
    /// (readings, sum of squared residuals); only transmitters with a
    /// path-loss fallback.
    far: (f64, f64),
}

impl Residuals {
    /// Adds the leave-one-walk-out residuals of one transmitter's bins on
    /// one floor; `fallback(p)` is its fallback (mean, sd) at `p`,
    /// `pathloss` whether that is a path-loss model.
    pub fn add(
        &mut self,
        bins: &[WalkBin],
        k: &Kernel,
        fallback: &dyn Fn(Vec2) -> (f64, f64),
        pathloss: bool,
        survey_distance: &dyn Fn(Vec2, usize) -> f64,
    ) {
        let h = k.bandwidth_m;
        let radius = (3.0 * h).max(k.max_distance_m).max(1e-3);
        let key = |p: Vec2| ((p.x / radius).floor() as i64, (p.y / radius).floor() as i64);
        let mut buckets: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
        for (i, b) in bins.iter().enumerate() {
            buckets.entry(key(b.pos)).or_default().push(i);
        }
        let walks: std::collections::BTreeSet<usize> =
            bins.iter().flat_map(|b| b.walks.keys().copied()).collect();
        if walks.len() < 2 {
            return;
        }
        for b in bins {
            let (bx, by) = key(b.pos);
            for (&w, &(nw, sw_r, s2w)) in &b.walks {
                let (mut sw, mut s1) = (0.0, 0.0);
                let mut dmin = f64::INFINITY;
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        for &j in buckets.get(&(bx + dx, by + dy)).into_iter().flatten() {
                            let o = &bins[j];
                            // the other walks' readings of bin j
                            let (mut n, mut s) = (0.0, 0.0);
                            for (&v, &(nv, sv, _)) in &o.walks {
                                if v != w {
                                    n += nv;
                                    s += sv;
                                }
                            }
                            if n <= 0.0 {
                                continue;
                            }
                            let d2 = (o.pos - b.pos).norm_squared();
                            dmin = dmin.min(d2);
                            if d2 <= 9.0 * h * h {
                                let kw = (-0.5 * d2 / (h * h)).exp();
                                sw += kw * n;
                                s1 += kw * s;
                            }
                        }
                    }
                }
                let dmin = dmin.sqrt();
                let (mu_fb, _) = fallback(b.pos);
                let mu = if dmin > k.max_distance_m {
                    mu_fb
                } else if sw > 1e-12 {
                    let lambda = sw / (sw + k.prior_weight);
                    lambda * (s1 / sw) + (1.0 - lambda) * mu_fb
                } else {
                    mu_fb
                };
                // sum over w's readings r of (r - mu)^2
                let ss = (s2w - 2.0 * mu * sw_r + nw * mu * mu).max(0.0);
                if dmin > k.max_distance_m {
                    if pathloss {
                        self.far.0 += nw;
                        self.far.1 += ss;
                    }
                } else {
                    // binned by the distance from where the other walks went
                    let d = survey_distance(b.pos, w).min(dmin);
                    let e = self.near.entry(d.floor() as i64).or_default();
                    e.0 += nw;
                    e.1 += nw * d * d;
                    e.2 += ss;
                }
            }
        }
    }

    /// The fit (module docs).
    pub fn fit(&self) -> SpreadFit {
        let readings: f64 = self.near.values().map(|e| e.0).sum();
        let by_distance = self
            .near
            .values()
            .map(|e| (e.0, (e.2 / e.0.max(1e-12)).sqrt()))
            .collect();
        let far = (self.far.1 / self.far.0.max(1e-12)).sqrt();
        SpreadFit {
            curve: (readings >= MIN_READINGS).then(|| fit_curve(&self.near)),
            fallback_sd_db: (self.far.0 >= MIN_FAR_READINGS)
                .then(|| far.clamp(SD_BOUNDS_DB.0, SD_BOUNDS_DB.1)),
            readings,
            far_readings: self.far.0,
            by_distance,
        }
    }
}

/// The fits of both radio kinds (BLE, WiFi) from the builder's bins
/// (walk offsets already removed) of every transmitter the map keeps
/// (the same tests as [`super::radio_map_build::RadioMapBuilder::finish`]
/// but the grid's).
pub(super) fn calibrate(
    ids: &BTreeMap<(TxKind, String), usize>,
    acc: &[TxAcc],
    cfg: &RadioMapConfig,
    site_model: &PathLossModel,
) -> [SpreadFit; 2] {
    let footprint = WalkFootprint::of(acc, cfg.bin_m, cfg.max_distance_m);
    let mut res = [Residuals::default(), Residuals::default()];
    let k = Kernel {
        bandwidth_m: cfg.bandwidth_m,
        max_distance_m: cfg.max_distance_m,
        prior_weight: cfg.prior_weight,
    };
    for ((kind, id), i) in ids {
        let Some(a) = acc.get(*i) else { continue };
        let in_site = site_model.lookup(*kind, id).is_some();
        if (cfg.site_transmitters_only && !in_site)
            || a.samples < cfg.min_samples
            || a.walks.len() < cfg.min_walks.max(2)
            || disagreement(a, cfg.moving_min_bins).is_some_and(|d| d > cfg.moving_max_db)
        {
            continue;
        }
        let (fb_t, site_t) = fallback_tx(*kind, id, a, site_model, cfg);
        let fb = Fallback {
            t: &fb_t,
            has_pathloss: site_t.is_some(),
            params: &cfg.fallback,
            floor_rank: site_model,
        };
        let r = &mut res[usize::from(*kind == TxKind::Wifi)];
        for (floor, bins) in &a.bins {
            let wb: Vec<WalkBin> = bins
                .values()
                .filter(|b| b.n > 0.0)
                .map(|b| WalkBin {
                    pos: b.pos_sum / b.n,
                    walks: b.walks.clone(),
                })
                .collect();
            r.add(&wb, &k, &|p| fb.at(*floor, p), fb.has_pathloss, &|p, w| {
                footprint.distance(*floor, p, Some(w))
            });
        }
    }
    [res[0].fit(), res[1].fit()]
}

/// Where the survey walked: every transmitter's bins per floor (their
/// `bin_m` squares), with the walks that read there.
pub(super) struct WalkFootprint {
    bin_m: f64,
    rings: i64,
    keys: BTreeMap<(i32, i64, i64), Vec<usize>>,
}

impl WalkFootprint {
    /// The footprint of every transmitter's bins; distances are searched
    /// up to `max_distance_m` (and a bin) away.
    pub fn of(acc: &[TxAcc], bin_m: f64, max_distance_m: f64) -> Self {
        let mut keys: BTreeMap<(i32, i64, i64), Vec<usize>> = BTreeMap::new();
        for a in acc {
            for (floor, bins) in &a.bins {
                for ((i, j), b) in bins {
                    let v = keys.entry((*floor, *i, *j)).or_default();
                    for w in b.walks.keys() {
                        if let Err(k) = v.binary_search(w) {
                            v.insert(k, *w);
                        }
                    }
                }
            }
        }
        WalkFootprint {
            bin_m,
            rings: (max_distance_m / bin_m).ceil() as i64 + 1,
            keys,
        }
    }

    /// Distance from `p` on `floor` to the centre of the nearest bin a walk
    /// (other than `except`) read in, m; infinite beyond the search.
    pub fn distance(&self, floor: i32, p: Vec2, except: Option<usize>) -> f64 {
        let b = self.bin_m;
        let (ci, cj) = ((p.x / b).floor() as i64, (p.y / b).floor() as i64);
        let mut best = f64::INFINITY;
        for r in 0..=self.rings {
            if ((r - 1) as f64) * b > best {
                break;
            }
            for di in -r..=r {
                for dj in -r..=r {
                    if di.abs() != r && dj.abs() != r {
                        continue;
                    }
                    let (i, j) = (ci + di, cj + dj);
                    let Some(ws) = self.keys.get(&(floor, i, j)) else {
                        continue;
                    };
                    if except.is_some_and(|w| ws.len() == 1 && ws[0] == w) {
                        continue;
                    }
                    let q = Vec2::new((i as f64 + 0.5) * b, (j as f64 + 0.5) * b);
                    best = best.min((q - p).norm());
                }
            }
        }
        best
    }
}

/// Weighted least squares of v = a + b d^2 over the distance bins (weight:
/// readings), a, b >= 0.
fn fit_curve(near: &BTreeMap<i64, (f64, f64, f64)>) -> SpreadCurve {
    // per bin: weight n, x = mean d^2, y = mean squared residual
    let pts: Vec<(f64, f64, f64)> = near
        .values()
        .filter(|e| e.0 > 0.0)
        .map(|e| (e.0, e.1 / e.0, e.2 / e.0))
        .collect();
    let sw: f64 = pts.iter().map(|p| p.0).sum();
    let mx = pts.iter().map(|p| p.0 * p.1).sum::<f64>() / sw;
    let my = pts.iter().map(|p| p.0 * p.2).sum::<f64>() / sw;
    let sxx: f64 = pts.iter().map(|p| p.0 * (p.1 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| p.0 * (p.1 - mx) * (p.2 - my)).sum();
    let mut b = if sxx > 1e-12 { sxy / sxx } else { 0.0 };
    let mut a = my - b * mx;
    if b < 0.0 {
        b = 0.0;
        a = my;
    }
    if a < 0.0 {
        // through the origin: b = sum w x y / sum w x^2
        a = 0.0;
        let sxx0: f64 = pts.iter().map(|p| p.0 * p.1 * p.1).sum();
        let sxy0: f64 = pts.iter().map(|p| p.0 * p.1 * p.2).sum();
        b = if sxx0 > 1e-12 { sxy0 / sxx0 } else { 0.0 };
    }
    SpreadCurve {
        s0_db: a.max(0.0).sqrt(),
        k_db_per_m: b.max(0.0).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curve_recovers_a_growing_variance() {
        let mut near = BTreeMap::new();
        for d in 0..8 {
            let x = d as f64 + 0.5;
            near.insert(d, (100.0, 100.0 * x * x, 100.0 * (16.0 + 0.25 * x * x)));
        }
        let c = fit_curve(&near);
        assert!((c.s0_db - 4.0).abs() < 1e-6, "{c:?}");
        assert!((c.k_db_per_m - 0.5).abs() < 1e-6, "{c:?}");
        assert!((c.at(6.0) - (16.0f64 + 9.0).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn a_shrinking_variance_gives_a_flat_curve() {
        let mut near = BTreeMap::new();
        near.insert(0, (100.0, 0.0, 100.0 * 25.0));
        near.insert(5, (100.0, 2500.0, 100.0 * 9.0));
        let c = fit_curve(&near);
        assert_eq!(c.k_db_per_m, 0.0);
        assert!((c.s0_db - 17.0f64.sqrt()).abs() < 1e-9);
    }
}
