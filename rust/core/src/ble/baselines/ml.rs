//! Continuous maximum likelihood: the eq. 19 cost (equal eta, the top-N
//! beacons) minimised over the plane by Levenberg-Marquardt from the
//! weighted centroid (the "ML" of FP-BP's comparison, no grid, no map).

use super::centroid::weighted_centroid;
use crate::Vec2;
use crate::ble::config::BleConfig;
use crate::ble::frontend::FilteredBeacon;
use crate::ble::pathloss::range_m;
use crate::ble::positioner::{BlePositioner, finite};

#[derive(Debug, Clone)]
pub struct MlContinuous {
    top_n: usize,
    max_iterations: u32,
    min_d_m: f64,
}

impl MlContinuous {
    pub fn new(cfg: &BleConfig) -> Self {
        MlContinuous {
            top_n: cfg.ml.top_n,
            max_iterations: cfg.ml.max_iterations,
            min_d_m: cfg.min_distance_m,
        }
    }
}

struct Term {
    pos: Vec2,
    dz: f64,
    /// log10 range implied by RSSI, weighted by n (so the cost is in dB / 10).
    log_d: f64,
    w: f64,
}

fn cost(terms: &[Term], y: Vec2, min_d: f64) -> f64 {
    terms
        .iter()
        .map(|t| t.w * (t.log_d - range_m(y, t.pos, t.dz, min_d).log10()).powi(2))
        .sum()
}

impl BlePositioner for MlContinuous {
    fn name(&self) -> &'static str {
        "ml"
    }

    fn locate(
        &mut self,
        beacons: &[FilteredBeacon],
        _grid: &[Vec2],
        _prev: Option<Vec2>,
    ) -> Option<Vec2> {
        if beacons.len() < 3 {
            return None;
        }
        let n = self.top_n.min(beacons.len());
        let terms: Vec<Term> = beacons[..n]
            .iter()
            .map(|b| Term {
                pos: b.pos,
                dz: b.dz_m,
                log_d: b.model.log10_distance(b.rssi_dbm),
                // equal sigma: eta_i proportional to 1 / n_i
                w: b.model.exponent.powi(2),
            })
            .collect();
        let mut y = weighted_centroid(beacons, n, 1.0, self.min_d_m)?;
        let mut c = cost(&terms, y, self.min_d_m);
        let mut lambda = 1e-3;
        let ln10 = std::f64::consts::LN_10;
        for _ in 0..self.max_iterations {
            // Gauss-Newton normal equations of residuals r_i = sqrt(w)(log_d - log10 rho)
            let (mut h11, mut h12, mut h22, mut g1, mut g2) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for t in &terms {
                let rho = range_m(y, t.pos, t.dz, self.min_d_m);
                let sw = t.w.sqrt();
                let r = sw * (t.log_d - rho.log10());
                let jx = -sw * (y.x - t.pos.x) / (rho * rho * ln10);
                let jy = -sw * (y.y - t.pos.y) / (rho * rho * ln10);
                h11 += jx * jx;
                h12 += jx * jy;
                h22 += jy * jy;
                g1 += jx * r;
                g2 += jy * r;
            }
            let mut improved = false;
            for _ in 0..10 {
                let (a11, a22) = (h11 * (1.0 + lambda) + 1e-12, h22 * (1.0 + lambda) + 1e-12);
                let det = a11 * a22 - h12 * h12;
                if !(det.is_finite() && det > 0.0) {
                    lambda *= 10.0;
                    continue;
                }
                let dx = -(a22 * g1 - h12 * g2) / det;
                let dy = -(a11 * g2 - h12 * g1) / det;
                let cand = y + Vec2::new(dx, dy);
                let cc = cost(&terms, cand, self.min_d_m);
                if cc.is_finite() && cc < c {
                    let step = (cand - y).norm();
                    y = cand;
                    c = cc;
                    lambda = (lambda * 0.3).max(1e-9);
                    improved = step > 1e-4;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        finite(y)
    }
}
