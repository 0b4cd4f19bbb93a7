//! A multi-wall path-loss prior under the radio map (docs/tcpf.md, "The
//! wall prior"): where the survey never went, the expected RSSI of a
//! transmitter with the walls between it and the phone counted on the
//! floor plan ([`crate::map::Crossings`]), in the manner of the COST 231
//! multi-wall model:
//!
//! mean(p) = R0 - 10 n log10 d(p) - L_wall min(walls, c) - L_door min(doors, c)
//!
//! with d the 3-D range to the transmitter's site position, `c` =
//! `max_crossings`. R0 and n are refitted per transmitter and the two
//! losses per radio kind (BLE, WiFi), by least squares on the survey's
//! bins (the transmitter's own floor), alternating: given the losses, each
//! transmitter's (R0, n) with n held in [`MIN_EXPONENT`, `MAX_EXPONENT`];
//! given those, the two losses (each at least 0). The radio map builder
//! ([`super::radio_map_build`]) then smooths the survey's residuals from
//! this prior instead of the readings themselves, so the survey is a
//! correction that fades to the prior away from the walks, and fills the
//! grid cells beyond `max_distance_m` of the survey with the prior.
//!
//! Pure: bins and crossings in, the fit out.

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::ble::pathloss::PathLoss;
use crate::map::Crossings;

/// The path-loss exponent is refitted within these bounds.
pub const MIN_EXPONENT: f64 = 1.0;
pub const MAX_EXPONENT: f64 = 5.0;
/// Alternations of the fit after the joint start (they matter only where
/// an exponent meets its bounds).
const ITERATIONS: usize = 5;
/// A bin weighs as many readings as it holds, up to this many.
const MAX_BIN_WEIGHT: f64 = 10.0;

/// Settings of the wall prior (`radio_map.wall_prior`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WallPriorConfig {
    /// Fit the prior and build the map on it. Default false.
    pub enabled: bool,
    /// Walls (and, separately, doors) counted at most on one path; more
    /// add nothing (signal through many walls arrives round them). Default 4.
    pub max_crossings: u32,
    /// A transmitter's (R0, n) are refitted only with at least this many
    /// bins on its floor; else the site's model is kept. Default 10.
    pub min_bins: usize,
}

impl Default for WallPriorConfig {
    fn default() -> Self {
        WallPriorConfig {
            enabled: false,
            max_crossings: 4,
            min_bins: 10,
        }
    }
}

impl WallPriorConfig {
    /// Checks every field, naming the bad one under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        use crate::bounds::check_count;
        check_count(
            &format!("{prefix}.max_crossings"),
            self.max_crossings as usize,
            0,
            1000,
        )?;
        check_count(&format!("{prefix}.min_bins"), self.min_bins, 2, 1 << 30)
    }

    /// The crossings counted: each kind capped at `max_crossings`.
    pub fn counted(&self, c: Crossings) -> (f64, f64) {
        (
            f64::from(c.walls.min(self.max_crossings)),
            f64::from(c.doors.min(self.max_crossings)),
        )
    }
}

/// Losses per crossing of one radio kind, dB.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct WallLoss {
    pub wall_db: f64,
    pub door_db: f64,
}

impl WallLoss {
    /// The loss over `walls` and `doors` counted crossings, dB.
    pub fn loss_db(&self, (walls, doors): (f64, f64)) -> f64 {
        self.wall_db * walls + self.door_db * doors
    }
}

/// One survey bin of a transmitter: its mean reading, weight, the range
/// term 10 log10 d and the counted crossings.
#[derive(Debug, Clone, Copy)]
pub struct PriorBin {
    pub rssi_dbm: f64,
    pub weight: f64,
    pub log_range: f64,
    pub crossings: (f64, f64),
}

impl PriorBin {
    /// A bin of `n` readings of mean `rssi_dbm` at 3-D range `d_m`.
    pub fn new(rssi_dbm: f64, n: f64, d_m: f64, crossings: (f64, f64)) -> Self {
        PriorBin {
            rssi_dbm,
            weight: n.min(MAX_BIN_WEIGHT),
            log_range: 10.0 * d_m.log10(),
            crossings,
        }
    }
}

/// What the fit of one radio kind found (printed by `fpbp calibrate`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WallFit {
    pub loss: WallLoss,
    /// Transmitters refitted and their bins.
    pub transmitters: usize,
    pub bins: usize,
    /// Weighted RMS residual of the bins from the site's path-loss models
    /// and from the prior, dB (in-sample: the same bins).
    pub rms_site_db: f64,
    pub rms_prior_db: f64,
}

/// Fits one radio kind: `txs[k]` is transmitter k's site model and bins.
/// Returns the losses, each transmitter's refitted model (the site's
/// when it has fewer than `min_bins` bins) and the summary.
pub fn fit(txs: &[(PathLoss, Vec<PriorBin>)], cfg: &WallPriorConfig) -> (Vec<PathLoss>, WallFit) {
    let fitted = |bins: &[PriorBin]| bins.len() >= cfg.min_bins;
    let mut models: Vec<PathLoss> = txs.iter().map(|(m, _)| *m).collect();
    let mut loss = joint_loss(txs, &fitted);
    for _ in 0..ITERATIONS {
        for ((site, bins), m) in txs.iter().zip(models.iter_mut()) {
            if fitted(bins) {
                *m = fit_model(bins, &loss).unwrap_or(*site);
            }
        }
        loss = fit_loss(txs, &models, &fitted);
    }
    let mut out = WallFit {
        loss,
        ..WallFit::default()
    };
    let (mut sw, mut s_site, mut s_prior) = (0.0, 0.0, 0.0);
    for ((site, bins), m) in txs.iter().zip(&models) {
        if !fitted(bins) {
            continue;
        }
        out.transmitters += 1;
        out.bins += bins.len();
        for b in bins {
            let e_site = b.rssi_dbm - mean(site, &WallLoss::default(), b.log_range, b.crossings);
            let e_prior = b.rssi_dbm - mean(m, &loss, b.log_range, b.crossings);
            sw += b.weight;
            s_site += b.weight * e_site * e_site;
            s_prior += b.weight * e_prior * e_prior;
        }
    }
    if sw > 0.0 {
        out.rms_site_db = (s_site / sw).sqrt();
        out.rms_prior_db = (s_prior / sw).sqrt();
    }
    (models, out)
}

/// The prior's mean with `m`, `loss`, range term 10 log10 d and counted
/// crossings, dBm.
pub fn mean(m: &PathLoss, loss: &WallLoss, log_range: f64, crossings: (f64, f64)) -> f64 {
    m.rssi_1m_dbm - m.exponent * log_range - loss.loss_db(crossings)
}

/// (R0, n) by weighted least squares of rssi + loss on -10 log10 d, n
/// held in its bounds; `None` when the bins do not determine it.
fn fit_model(bins: &[PriorBin], loss: &WallLoss) -> Option<PathLoss> {
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for b in bins {
        let (x, y) = (-b.log_range, b.rssi_dbm + loss.loss_db(b.crossings));
        sw += b.weight;
        sx += b.weight * x;
        sy += b.weight * y;
        sxx += b.weight * x * x;
        sxy += b.weight * x * y;
    }
    if sw <= 0.0 {
        return None;
    }
    let (mx, my) = (sx / sw, sy / sw);
    let vxx = sxx / sw - mx * mx;
    if vxx <= 1e-9 {
        return None;
    }
    let n = ((sxy / sw - mx * my) / vxx).clamp(MIN_EXPONENT, MAX_EXPONENT);
    // R0 for the (maybe clamped) exponent
    Some(PathLoss {
        rssi_1m_dbm: my - n * mx,
        exponent: n,
    })
}

/// The two losses of the joint least-squares fit (every transmitter's R0
/// and n free): each transmitter's readings and crossings with their
/// weighted regression on -10 log10 d removed (Frisch-Waugh-Lovell), then
/// the losses on what is left.
fn joint_loss(txs: &[(PathLoss, Vec<PriorBin>)], fitted: &dyn Fn(&[PriorBin]) -> bool) -> WallLoss {
    let mut acc = Normal::default();
    for (_, bins) in txs.iter().filter(|(_, b)| fitted(b)) {
        let sw: f64 = bins.iter().map(|b| b.weight).sum();
        if sw <= 0.0 {
            continue;
        }
        let mean =
            |f: &dyn Fn(&PriorBin) -> f64| bins.iter().map(|b| b.weight * f(b)).sum::<f64>() / sw;
        let mx = mean(&|b| -b.log_range);
        let sxx = mean(&|b| (-b.log_range - mx).powi(2));
        let (my, mw, mo) = (
            mean(&|b| -b.rssi_dbm),
            mean(&|b| b.crossings.0),
            mean(&|b| b.crossings.1),
        );
        let slope = |f: &dyn Fn(&PriorBin) -> f64, m: f64| {
            if sxx > 1e-9 {
                bins.iter()
                    .map(|b| b.weight * (-b.log_range - mx) * (f(b) - m))
                    .sum::<f64>()
                    / sw
                    / sxx
            } else {
                0.0
            }
        };
        let (ky, kw, ko) = (
            slope(&|b| -b.rssi_dbm, my),
            slope(&|b| b.crossings.0, mw),
            slope(&|b| b.crossings.1, mo),
        );
        for b in bins {
            let dx = -b.log_range - mx;
            acc.add(
                b.weight,
                b.crossings.0 - mw - kw * dx,
                b.crossings.1 - mo - ko * dx,
                -b.rssi_dbm - my - ky * dx,
            );
        }
    }
    acc.solve()
}

/// Normal equations of z = a w + b o (weighted, through the origin).
#[derive(Default)]
struct Normal {
    ww: f64,
    wo: f64,
    oo: f64,
    wz: f64,
    oz: f64,
}

impl Normal {
    fn add(&mut self, weight: f64, w: f64, o: f64, z: f64) {
        self.ww += weight * w * w;
        self.wo += weight * w * o;
        self.oo += weight * o * o;
        self.wz += weight * w * z;
        self.oz += weight * o * z;
    }

    /// (a, b) each at least 0: a negative one is held at 0 and the other
    /// refitted alone; one the bins do not determine is 0.
    fn solve(&self) -> WallLoss {
        let Normal { ww, wo, oo, wz, oz } = *self;
        let one = |szz: f64, sz: f64| if szz > 1e-9 { (sz / szz).max(0.0) } else { 0.0 };
        let det = ww * oo - wo * wo;
        let (a, b) = if det > 1e-9 * (ww * oo).max(1e-12) {
            ((oo * wz - wo * oz) / det, (ww * oz - wo * wz) / det)
        } else {
            (one(ww, wz), one(oo, oz))
        };
        match (a >= 0.0, b >= 0.0) {
            (true, true) => WallLoss {
                wall_db: a,
                door_db: b,
            },
            (true, false) => WallLoss {
                wall_db: one(ww, wz),
                door_db: 0.0,
            },
            (false, true) => WallLoss {
                wall_db: 0.0,
                door_db: one(oo, oz),
            },
            (false, false) => WallLoss::default(),
        }
    }
}

/// The two losses by weighted least squares of each bin's shortfall from
/// its transmitter's model on its counted crossings (through the origin),
/// each at least 0.
fn fit_loss(
    txs: &[(PathLoss, Vec<PriorBin>)],
    models: &[PathLoss],
    fitted: &dyn Fn(&[PriorBin]) -> bool,
) -> WallLoss {
    let mut acc = Normal::default();
    for ((_, bins), m) in txs.iter().zip(models) {
        if !fitted(bins) {
            continue;
        }
        for b in bins {
            let z = m.rssi_1m_dbm - m.exponent * b.log_range - b.rssi_dbm;
            acc.add(b.weight, b.crossings.0, b.crossings.1, z);
        }
    }
    acc.solve()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bins of a transmitter with `m` behind walls costing `wall_db`, at
    /// ranges 1..=30 m, walls every 6 m, doors every 10 m, plus `noise`.
    fn bins(
        m: PathLoss,
        wall_db: f64,
        door_db: f64,
        noise: &dyn Fn(usize) -> f64,
    ) -> Vec<PriorBin> {
        (1..=30)
            .map(|k| {
                let d = k as f64;
                let c = ((k / 6) as f64, (k / 10) as f64);
                let r = m.rssi_at(d, 0.5) - wall_db * c.0 - door_db * c.1 + noise(k);
                PriorBin::new(r, 5.0, d, c)
            })
            .collect()
    }

    #[test]
    fn recovers_the_losses_and_each_model() {
        let truth = [
            PathLoss {
                rssi_1m_dbm: -45.0,
                exponent: 2.0,
            },
            PathLoss {
                rssi_1m_dbm: -55.0,
                exponent: 2.6,
            },
        ];
        // the site's models were fitted without walls: steeper, no matter
        let site = PathLoss {
            rssi_1m_dbm: -40.0,
            exponent: 3.5,
        };
        let txs: Vec<_> = truth
            .iter()
            .map(|m| (site, bins(*m, 4.0, 1.5, &|_| 0.0)))
            .collect();
        let (models, f) = fit(&txs, &WallPriorConfig::default());
        assert!((f.loss.wall_db - 4.0).abs() < 0.05, "{f:?}");
        assert!((f.loss.door_db - 1.5).abs() < 0.05, "{f:?}");
        for (m, t) in models.iter().zip(&truth) {
            assert!((m.exponent - t.exponent).abs() < 0.02, "{m:?}");
            assert!((m.rssi_1m_dbm - t.rssi_1m_dbm).abs() < 0.2, "{m:?}");
        }
        assert!(f.rms_prior_db < 0.05 && f.rms_site_db > 1.0, "{f:?}");
        assert_eq!((f.transmitters, f.bins), (2, 60));
    }

    #[test]
    fn no_walls_no_loss_and_sparse_transmitters_keep_the_site_model() {
        let m = PathLoss {
            rssi_1m_dbm: -50.0,
            exponent: 2.2,
        };
        let noise = |k: usize| if k % 2 == 0 { 1.0 } else { -1.0 };
        let few = bins(m, 0.0, 0.0, &noise)[..5].to_vec();
        let site = PathLoss {
            rssi_1m_dbm: -60.0,
            exponent: 3.0,
        };
        let txs = vec![(site, bins(m, 0.0, 0.0, &noise)), (site, few)];
        let (models, f) = fit(&txs, &WallPriorConfig::default());
        assert!(f.loss.wall_db < 0.5 && f.loss.door_db < 0.5, "{f:?}");
        assert_eq!(models[1], site);
        assert_eq!(f.transmitters, 1);
        // a loss that would be negative is held at 0
        let gain = bins(m, -3.0, 0.0, &|_| 0.0);
        let (_, f) = fit(&[(site, gain)], &WallPriorConfig::default());
        assert_eq!(f.loss.wall_db, 0.0);
    }

    #[test]
    fn crossings_are_capped() {
        let cfg = WallPriorConfig {
            max_crossings: 3,
            ..WallPriorConfig::default()
        };
        let c = Crossings { walls: 7, doors: 2 };
        assert_eq!(cfg.counted(c), (3.0, 2.0));
        assert!(
            WallPriorConfig { min_bins: 1, ..cfg }
                .validate("radio_map.wall_prior")
                .is_err()
        );
    }
}
