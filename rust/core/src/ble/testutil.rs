//! Synthetic geometry for the BLE tests.

use super::frontend::FilteredBeacon;
use super::pathloss::{PathLoss, range_m};
use crate::Vec2;

pub const MODEL: PathLoss = PathLoss {
    rssi_1m_dbm: -59.0,
    exponent: 2.0,
};

/// Noise-free filtered beacons at `positions` seen from `at` (dz = 0),
/// strongest first.
pub fn noise_free(positions: &[Vec2], at: Vec2) -> Vec<FilteredBeacon> {
    let mut v: Vec<FilteredBeacon> = positions
        .iter()
        .enumerate()
        .map(|(index, &pos)| FilteredBeacon {
            index,
            floor: 0,
            pos,
            dz_m: 0.0,
            model: MODEL,
            rssi_dbm: MODEL.rssi_at(range_m(at, pos, 0.0, 0.5), 0.5),
            var_dbm2: 4.0,
            samples: 5,
            last_t_ns: 0,
        })
        .collect();
    v.sort_by(|a, b| {
        b.rssi_dbm
            .total_cmp(&a.rssi_dbm)
            .then(a.index.cmp(&b.index))
    });
    v
}

/// 24 beacons on a 6 x 4 lattice over a 60 x 40 m area.
pub fn lattice_24() -> Vec<Vec2> {
    let mut v = Vec::new();
    for j in 0..4 {
        for i in 0..6 {
            v.push(Vec2::new(5.0 + 10.0 * i as f64, 5.0 + 10.0 * j as f64));
        }
    }
    v
}
