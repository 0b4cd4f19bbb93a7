//! The fingerprint database: RSSI vectors (one entry per beacon of the floor)
//! at known positions.

use crate::Vec2;
use crate::ble::pathloss::{PathLoss, range_m};

/// One reference point.
#[derive(Debug, Clone, PartialEq)]
pub struct Fingerprint {
    /// Position in the MCS of the floor, metres.
    pub pos: Vec2,
    /// RSSI per beacon of the database, dBm (missing values already filled).
    pub rssi_dbm: Vec<f64>,
}

/// One beacon a database covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DbBeacon {
    /// Index in the site's beacon registry.
    pub registry_index: usize,
    pub pos: Vec2,
    /// Beacon height minus phone height, metres.
    pub dz_m: f64,
    pub model: PathLoss,
}

/// The reference points of one floor.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FingerprintDb {
    pub beacons: Vec<DbBeacon>,
    pub points: Vec<Fingerprint>,
    /// RSSI floor: predicted or measured values below it are raised to it, dBm.
    pub missing_rssi_dbm: f64,
}

impl FingerprintDb {
    /// An empty database over `beacons`.
    pub fn new(beacons: Vec<DbBeacon>, missing_rssi_dbm: f64) -> Self {
        FingerprintDb {
            beacons,
            points: Vec::new(),
            missing_rssi_dbm,
        }
    }

    /// RSSI of beacon `j` at `pos` from its path-loss model (eqs. 4, 6),
    /// floored at `missing_rssi_dbm`.
    pub fn predicted(&self, j: usize, pos: Vec2, min_distance_m: f64) -> f64 {
        let b = &self.beacons[j];
        b.model
            .rssi_at(range_m(pos, b.pos, b.dz_m, min_distance_m), min_distance_m)
            .max(self.missing_rssi_dbm)
    }

    /// Adds a point from measured values (`None` = not heard): missing values
    /// are filled from the path-loss model (eq. 6). Non-finite positions are ignored.
    pub fn push(&mut self, pos: Vec2, measured: &[Option<f64>], min_distance_m: f64) -> bool {
        if !(pos.x.is_finite() && pos.y.is_finite()) || measured.len() != self.beacons.len() {
            return false;
        }
        let rssi_dbm = (0..self.beacons.len())
            .map(|j| match measured[j] {
                Some(r) if r.is_finite() => r.max(self.missing_rssi_dbm),
                _ => self.predicted(j, pos, min_distance_m),
            })
            .collect();
        self.points.push(Fingerprint { pos, rssi_dbm });
        true
    }

    /// A database from the path-loss models alone at `positions`.
    pub fn from_model(
        beacons: Vec<DbBeacon>,
        positions: &[Vec2],
        missing_rssi_dbm: f64,
        min_distance_m: f64,
    ) -> Self {
        let mut db = FingerprintDb::new(beacons, missing_rssi_dbm);
        let none = vec![None; db.beacons.len()];
        for p in positions {
            db.push(*p, &none, min_distance_m);
        }
        db
    }

    /// The scan as a vector over this database's beacons: `rssi_of(registry
    /// index)` gives the heard RSSI (raised to `missing_rssi_dbm`); beacons
    /// not heard are NaN (matching compares heard beacons only, see
    /// [`super::scan_distance`]).
    pub fn scan_vector(&self, rssi_of: impl Fn(usize) -> Option<f64>) -> Vec<f64> {
        self.beacons
            .iter()
            .map(|b| {
                rssi_of(b.registry_index)
                    .filter(|r| r.is_finite())
                    .map_or(f64::NAN, |r| r.max(self.missing_rssi_dbm))
            })
            .collect()
    }
}

/// Positions of a walked survey line (eq. 3) with the start/end error
/// compensation: `steps` are (length, heading) in the MCS (heading
/// atan2(dy, dx)), `start` and `end` the labelled points. The PDR track is
/// corrected so that it ends at `end`, each step's share of the correction
/// proportional to its share of the x (resp. y) displacement.
pub fn compensate_walk(start: Vec2, end: Vec2, steps: &[(f64, f64)]) -> Vec<Vec2> {
    let dx: Vec<f64> = steps.iter().map(|(l, h)| l * h.cos()).collect();
    let dy: Vec<f64> = steps.iter().map(|(l, h)| l * h.sin()).collect();
    let (sx, sy) = (dx.iter().sum::<f64>(), dy.iter().sum::<f64>());
    let (ex, ey) = (end.x - start.x - sx, end.y - start.y - sy);
    let (ax, ay) = (
        dx.iter().map(|v| v.abs()).sum::<f64>(),
        dy.iter().map(|v| v.abs()).sum::<f64>(),
    );
    let n = steps.len().max(1) as f64;
    let mut p = start;
    let mut out = Vec::with_capacity(steps.len());
    for i in 0..steps.len() {
        let cx = if ax > 1e-9 { dx[i].abs() / ax } else { 1.0 / n };
        let cy = if ay > 1e-9 { dy[i].abs() / ay } else { 1.0 / n };
        p += Vec2::new(dx[i] + ex * cx, dy[i] + ey * cy);
        out.push(p);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fills_missing_values_from_the_model_and_compensates_walks() {
        let b = DbBeacon {
            registry_index: 3,
            pos: Vec2::new(0.0, 0.0),
            dz_m: 0.0,
            model: PathLoss {
                rssi_1m_dbm: -60.0,
                exponent: 2.0,
            },
        };
        let mut db = FingerprintDb::new(vec![b, b], -100.0);
        assert!(db.push(Vec2::new(10.0, 0.0), &[Some(-75.0), None], 0.5));
        assert!(!db.push(Vec2::new(f64::NAN, 0.0), &[None, None], 0.5));
        assert!(!db.push(Vec2::new(1.0, 0.0), &[None], 0.5));
        assert_eq!(db.points[0].rssi_dbm, vec![-75.0, -80.0]);
        assert_eq!(
            db.scan_vector(|i| (i == 3).then_some(-130.0)),
            vec![-100.0, -100.0]
        );
        // a walk 10 m east whose PDR says 8 m, slightly north
        let steps = vec![(2.0, 0.05); 4];
        let track = compensate_walk(Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0), &steps);
        let last = track.last().unwrap();
        assert!((last - Vec2::new(10.0, 0.0)).norm() < 1e-9, "{last:?}");
        assert!((track[1].x - 5.0).abs() < 1e-9);
    }
}
