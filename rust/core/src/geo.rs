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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
