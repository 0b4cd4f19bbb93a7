//! LLS trilateration over all heard beacons: the range equations
//! |y - b_i|^2 = r_i^2 (horizontal ranges from the filtered RSSI) minus the
//! strongest beacon's equation give a linear system A y = c, solved by least
//! squares. Degenerate (collinear) geometry is refused by a condition-number test.

use crate::Vec2;
use crate::ble::config::BleConfig;
use crate::ble::frontend::FilteredBeacon;
use crate::ble::pathloss::horizontal_m;
use crate::ble::positioner::{BlePositioner, finite};

#[derive(Debug, Clone)]
pub struct LlsTrilateration {
    max_beacons: usize,
    max_condition: f64,
}

impl LlsTrilateration {
    pub fn new(cfg: &BleConfig) -> Self {
        LlsTrilateration {
            max_beacons: cfg.trilat.max_beacons,
            max_condition: cfg.trilat.max_condition,
        }
    }
}

impl BlePositioner for LlsTrilateration {
    fn name(&self) -> &'static str {
        "trilat"
    }

    fn locate(
        &mut self,
        beacons: &[FilteredBeacon],
        _grid: &[Vec2],
        _prev: Option<Vec2>,
    ) -> Option<Vec2> {
        let n = if self.max_beacons == 0 {
            beacons.len()
        } else {
            self.max_beacons.min(beacons.len())
        };
        if n < 3 {
            return None;
        }
        let bs = &beacons[..n];
        // centre the coordinates for conditioning
        let centre = bs.iter().fold(Vec2::zeros(), |a, b| a + b.pos) / n as f64;
        let r = |b: &FilteredBeacon| horizontal_m(b.range_m(), b.dz_m);
        let ref_b = &bs[0];
        let p0 = ref_b.pos - centre;
        let r0 = r(ref_b);
        let (mut a11, mut a12, mut a22, mut c1, mut c2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for b in &bs[1..] {
            let p = b.pos - centre;
            let ax = 2.0 * (p.x - p0.x);
            let ay = 2.0 * (p.y - p0.y);
            let c = p.norm_squared() - p0.norm_squared() - r(b).powi(2) + r0 * r0;
            a11 += ax * ax;
            a12 += ax * ay;
            a22 += ay * ay;
            c1 += ax * c;
            c2 += ay * c;
        }
        let det = a11 * a22 - a12 * a12;
        let tr = a11 + a22;
        let disc = ((a11 - a22).powi(2) + 4.0 * a12 * a12).sqrt();
        let (l_max, l_min) = ((tr + disc) / 2.0, (tr - disc) / 2.0);
        if !(det.is_finite() && l_min > 0.0 && l_max / l_min <= self.max_condition) {
            return None;
        }
        let x = (a22 * c1 - a12 * c2) / det;
        let y = (a11 * c2 - a12 * c1) / det;
        finite(Vec2::new(x, y) + centre)
    }
}
