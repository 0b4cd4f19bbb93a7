//! WGS-84 <-> MCS conversions through a site's georeference: an
//! equirectangular projection at the reference latitude (R = 6378137 m),
//! then the ENU -> MCS rotation of the site.

use crate::{Vec2, geometry::rotate, site::GeoRef};

/// Earth radius of the equirectangular projection, metres (WGS-84 a).
pub const EARTH_RADIUS_M: f64 = 6_378_137.0;

/// East/north offsets, metres, of (lat, lon) from (lat0, lon0).
pub fn enu_from_wgs84(lat0_deg: f64, lon0_deg: f64, lat_deg: f64, lon_deg: f64) -> Vec2 {
    let k = std::f64::consts::PI / 180.0 * EARTH_RADIUS_M;
    Vec2::new(
        (lon_deg - lon0_deg) * k * (lat0_deg.to_radians()).cos(),
        (lat_deg - lat0_deg) * k,
    )
}

/// Inverse of [`enu_from_wgs84`]: (lat, lon) in degrees.
pub fn wgs84_from_enu(lat0_deg: f64, lon0_deg: f64, en: Vec2) -> (f64, f64) {
    let k = std::f64::consts::PI / 180.0 * EARTH_RADIUS_M;
    (
        lat0_deg + en.y / k,
        lon0_deg + en.x / (k * (lat0_deg.to_radians()).cos()),
    )
}

/// WGS-84 -> MCS with a site's georeference and ENU -> MCS rotation.
pub fn mcs_from_wgs84(georef: &GeoRef, map_from_enu_rad: f64, lat_deg: f64, lon_deg: f64) -> Vec2 {
    let en = enu_from_wgs84(georef.lat_deg, georef.lon_deg, lat_deg, lon_deg);
    Vec2::new(georef.x_m, georef.y_m) + rotate(en, map_from_enu_rad)
}

/// MCS -> WGS-84, inverse of [`mcs_from_wgs84`].
pub fn wgs84_from_mcs(georef: &GeoRef, map_from_enu_rad: f64, p: Vec2) -> (f64, f64) {
    let en = rotate(p - Vec2::new(georef.x_m, georef.y_m), -map_from_enu_rad);
    wgs84_from_enu(georef.lat_deg, georef.lon_deg, en)
}

/// Bearing from true north, degrees clockwise in [0, 360), of an MCS heading
/// (radians, atan2(dy, dx) in the MCS); the MCS is the ENU frame rotated by
/// `map_from_enu_rad`, so the ENU angle is `heading - map_from_enu_rad`.
pub fn bearing_deg_from_mcs(heading_rad: f64, map_from_enu_rad: f64) -> f64 {
    let enu_deg = (heading_rad - map_from_enu_rad).to_degrees();
    let b = (90.0 - enu_deg).rem_euclid(360.0);
    // rem_euclid of a value just below 0 may round to exactly 360
    if b >= 360.0 { 0.0 } else { b }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn bearings_of_mcs_headings() {
        use std::f64::consts::FRAC_PI_2;
        // MCS = ENU: x east (90 deg), y north (0 deg), -x west (270 deg)
        assert!((bearing_deg_from_mcs(0.0, 0.0) - 90.0).abs() < 1e-12);
        assert!(bearing_deg_from_mcs(FRAC_PI_2, 0.0).abs() < 1e-12);
        assert!((bearing_deg_from_mcs(std::f64::consts::PI, 0.0) - 270.0).abs() < 1e-12);
        // MCS x axis pointing north (ENU rotated by +90 deg into the MCS)
        assert!(bearing_deg_from_mcs(0.0, -FRAC_PI_2).abs() < 1e-12);
        assert!((bearing_deg_from_mcs(0.0, FRAC_PI_2) - 180.0).abs() < 1e-12);
        assert!(bearing_deg_from_mcs(-1e-17, -FRAC_PI_2 - 1e-17) < 360.0);
    }

    proptest! {
        #[test]
        fn bearing_in_range_and_matches_the_enu_vector(h in -10.0f64..10.0, rot in -3.2f64..3.2) {
            let b = bearing_deg_from_mcs(h, rot);
            prop_assert!((0.0..360.0).contains(&b));
            // the MCS unit vector of h, rotated back to ENU, has this bearing
            let en = rotate(Vec2::new(h.cos(), h.sin()), -rot);
            let want = en.x.atan2(en.y).to_degrees().rem_euclid(360.0);
            let d = (b - want).rem_euclid(360.0);
            prop_assert!(d.min(360.0 - d) < 1e-9);
        }
    }

    proptest! {
        #[test]
        fn round_trip(lat in -60.0f64..60.0, lon in -170.0f64..170.0, dx in -500.0f64..500.0, dy in -500.0f64..500.0, rot in -3.2f64..3.2) {
            let g = GeoRef { lat_deg: lat, lon_deg: lon, x_m: 10.0, y_m: -4.0 };
            let p = Vec2::new(dx, dy);
            let (la, lo) = wgs84_from_mcs(&g, rot, p);
            let q = mcs_from_wgs84(&g, rot, la, lo);
            prop_assert!((p - q).norm() < 1e-6);
        }
    }

    #[test]
    fn one_degree_of_latitude_is_about_111_km() {
        let en = enu_from_wgs84(49.0, 11.0, 50.0, 11.0);
        assert!((en.y - 111_319.5).abs() < 1.0);
        assert_eq!(en.x, 0.0);
    }
}
