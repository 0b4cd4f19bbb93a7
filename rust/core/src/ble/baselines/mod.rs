//! Baselines of the paper's GML comparison (Sec. V): LLS trilateration over
//! all heard beacons, FRBW (weighted centroid with d^-g weights, top 3,
//! g = 5), continuous maximum likelihood on the eq. 19 cost, and a plain
//! weighted centroid. All get the same mean filter as GML (in the task).

mod centroid;
mod ml;
mod trilat;

pub use centroid::{WeightedCentroid, weighted_centroid};
pub use ml::MlContinuous;
pub use trilat::LlsTrilateration;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec2;
    use crate::ble::config::BleConfig;
    use crate::ble::positioner::BlePositioner;
    use crate::ble::testutil::{lattice_24, noise_free};

    #[test]
    fn exact_positioners_recover_noise_free_positions() {
        let cfg = BleConfig::default();
        let beacons = lattice_24();
        for truth in [Vec2::new(12.3, 17.9), Vec2::new(41.0, 8.2)] {
            let fb = noise_free(&beacons, truth);
            let t = LlsTrilateration::new(&cfg).locate(&fb, &[], None).unwrap();
            assert!((t - truth).norm() < 1e-6, "trilat {t:?}");
            let m = MlContinuous::new(&cfg).locate(&fb, &[], None).unwrap();
            assert!((m - truth).norm() < 1e-3, "ml {m:?}");
            // centroids are biased towards the beacons but stay near the truth
            let f = WeightedCentroid::frbw(&cfg).locate(&fb, &[], None).unwrap();
            assert!((f - truth).norm() < 6.0, "frbw {f:?}");
            let w = WeightedCentroid::new(&cfg).locate(&fb, &[], None).unwrap();
            assert!((w - truth).norm() < 6.0, "wcentroid {w:?}");
        }
    }

    #[test]
    fn collinear_and_too_few_beacons() {
        let cfg = BleConfig::default();
        let line = [
            Vec2::new(0.0, 0.0),
            Vec2::new(10.0, 0.0),
            Vec2::new(20.0, 0.0),
            Vec2::new(30.0, 0.0),
        ];
        let fb = noise_free(&line, Vec2::new(12.0, 5.0));
        assert_eq!(LlsTrilateration::new(&cfg).locate(&fb, &[], None), None);
        let m = MlContinuous::new(&cfg).locate(&fb, &[], None).unwrap();
        assert!(m.x.is_finite() && m.y.is_finite());
        let two = noise_free(&line[..2], Vec2::new(5.0, 1.0));
        assert_eq!(LlsTrilateration::new(&cfg).locate(&two, &[], None), None);
        assert_eq!(MlContinuous::new(&cfg).locate(&two, &[], None), None);
        assert_eq!(WeightedCentroid::frbw(&cfg).locate(&two, &[], None), None);
        assert_eq!(WeightedCentroid::new(&cfg).locate(&two, &[], None), None);
    }

    #[test]
    fn coincident_beacons_do_not_give_nan() {
        let cfg = BleConfig::default();
        let same = [Vec2::new(5.0, 5.0); 4];
        let fb = noise_free(&same, Vec2::new(5.0, 5.0));
        assert_eq!(LlsTrilateration::new(&cfg).locate(&fb, &[], None), None);
        for p in [
            MlContinuous::new(&cfg).locate(&fb, &[], None),
            WeightedCentroid::frbw(&cfg).locate(&fb, &[], None),
        ] {
            assert!(p.is_some_and(|p| p.x.is_finite() && p.y.is_finite()));
        }
    }
}
