//! Weighted k-nearest-neighbour position estimate in RSSI space.

use super::db::FingerprintDb;
use super::scan_distance;
use crate::Vec2;

/// WKNN over the points `candidates` of `db`: the `k` nearest in RSSI
/// distance over the heard beacons ([`super::scan_distance`]), weighted by 1/(d + 1e-3). `None` without candidates.
pub fn wknn(db: &FingerprintDb, candidates: &[usize], scan: &[f64], k: usize) -> Option<Vec2> {
    let mut d: Vec<(usize, f64)> = candidates
        .iter()
        .filter_map(|&i| {
            db.points
                .get(i)
                .map(|p| (i, scan_distance(scan, &p.rssi_dbm)))
        })
        .filter(|(_, d)| d.is_finite())
        .collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    d.truncate(k.max(1));
    let (mut sum, mut wsum) = (Vec2::zeros(), 0.0);
    for (i, dist) in d {
        let w = 1.0 / (dist + 1e-3);
        sum += db.points[i].pos * w;
        wsum += w;
    }
    Some(sum / wsum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use crate::fingerprint::db::DbBeacon;

    #[test]
    fn wknn_recovers_a_grid_point() {
        let model = PathLoss {
            rssi_1m_dbm: -60.0,
            exponent: 2.0,
        };
        let beacons: Vec<DbBeacon> = [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0), (10.0, 10.0)]
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| DbBeacon {
                registry_index: i,
                pos: Vec2::new(x, y),
                dz_m: 1.0,
                model,
            })
            .collect();
        let grid: Vec<Vec2> = (0..11)
            .flat_map(|i| (0..11).map(move |j| Vec2::new(i as f64, j as f64)))
            .collect();
        let db = FingerprintDb::from_model(beacons, &grid, -100.0, 0.5);
        let truth = Vec2::new(3.0, 7.0);
        let scan: Vec<f64> = (0..4).map(|j| db.predicted(j, truth, 0.5)).collect();
        let all: Vec<usize> = (0..db.points.len()).collect();
        let est = wknn(&db, &all, &scan, 4).unwrap();
        assert!((est - truth).norm() < 0.5, "{est:?}");
        assert_eq!(wknn(&db, &[], &scan, 4), None);
    }
}
