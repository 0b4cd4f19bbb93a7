//! Weighted-centroid estimators: FRBW and the plain weighted centroid.

use crate::Vec2;
use crate::ble::config::BleConfig;
use crate::ble::frontend::FilteredBeacon;
use crate::ble::positioner::{BlePositioner, finite};

/// Centroid of the `top_n` strongest beacons (0 = all) weighted by
/// range^-exponent, ranges from the filtered RSSI (floored at `min_d_m`).
pub fn weighted_centroid(
    beacons: &[FilteredBeacon],
    top_n: usize,
    exponent: f64,
    min_d_m: f64,
) -> Option<Vec2> {
    let n = if top_n == 0 {
        beacons.len()
    } else {
        top_n.min(beacons.len())
    };
    if n == 0 {
        return None;
    }
    let mut sum = Vec2::zeros();
    let mut wsum = 0.0;
    for b in &beacons[..n] {
        let d = b.range_m().max(min_d_m);
        let w = d.powf(-exponent);
        if w.is_finite() && w > 0.0 {
            sum += b.pos * w;
            wsum += w;
        }
    }
    if wsum > 0.0 { finite(sum / wsum) } else { None }
}

/// Weighted centroid of the strongest beacons with weights d^-exponent
/// (`wcentroid`, and FRBW with its own settings). Needs 3 beacons.
#[derive(Debug, Clone)]
pub struct WeightedCentroid {
    name: &'static str,
    top_n: usize,
    exponent: f64,
    min_d_m: f64,
}

impl WeightedCentroid {
    pub fn new(cfg: &BleConfig) -> Self {
        WeightedCentroid {
            name: "wcentroid",
            top_n: cfg.wcentroid.top_n,
            exponent: cfg.wcentroid.exponent,
            min_d_m: cfg.min_distance_m,
        }
    }

    /// FRBW (Alsmadi et al. 2021, as configured in FP-BP Sec. V): the
    /// weighted centroid of the `frbw.top_n` (3) strongest beacons with
    /// weights d^-g, g = `frbw.g` (5).
    pub fn frbw(cfg: &BleConfig) -> Self {
        WeightedCentroid {
            name: "frbw",
            top_n: cfg.frbw.top_n,
            exponent: cfg.frbw.g,
            min_d_m: cfg.min_distance_m,
        }
    }
}

impl BlePositioner for WeightedCentroid {
    fn name(&self) -> &'static str {
        self.name
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
        weighted_centroid(beacons, self.top_n, self.exponent, self.min_d_m)
    }
}
