//! Small synthetic floors for the unit tests (built in code, no files).

use fpbp_core::map::{Feature, FloorMap};
use fpbp_core::site::{BeaconSpec, FloorSpec, Legend, Site, SiteSpec};

/// A 10 m x 6 m floor at 10 px/m: a 0.2 m wall border, an inner wall at
/// x = 4.9..5.1 m with a door at y = 2.5..3.5 m.
pub fn two_rooms() -> FloorMap {
    let r = 10.0;
    let (w, h) = (100usize, 60usize);
    let mut f = vec![Feature::Walkable; w * h];
    for j in 0..h {
        for i in 0..w {
            let x = (i as f64 + 0.5) / r;
            let y = (h as f64 - j as f64 - 0.5) / r;
            let border = !(0.2..=9.8).contains(&x) || !(0.2..=5.8).contains(&y);
            let inner = (4.9..5.1).contains(&x);
            f[j * w + i] = if border {
                Feature::Wall
            } else if inner && (2.5..3.5).contains(&y) {
                Feature::Door
            } else if inner {
                Feature::Wall
            } else {
                Feature::Walkable
            };
        }
    }
    FloorMap::from_features(w, h, r, f)
}

/// A site with the [`two_rooms`] floor (id 0) and four beacons.
pub fn two_rooms_site() -> Site {
    let beacon = |k: u32, x: f64, y: f64| BeaconSpec {
        id: format!("ibeacon:11111111-2222-3333-4444-555555555555:1:{k}"),
        floor: 0,
        x_m: x,
        y_m: y,
        z_m: 2.5,
        rssi_1m_dbm: -60.0,
        path_loss_exponent: 2.2,
    };
    Site {
        spec: SiteSpec {
            format: "fpbp-site".into(),
            version: 1,
            name: "two-rooms".into(),
            map_from_enu_rad: 0.3,
            heading_bias_rad: 0.0,
            legend: Legend::default(),
            grid_interval_m: 1.0,
            floors: vec![FloorSpec {
                id: 0,
                name: "ground".into(),
                plan: None,
                pixels_per_meter: Some(10.0),
                target_pixels_per_meter: None,
                open_area_m: None,
                height_m: 0.0,
            }],
            beacons: vec![
                beacon(1, 1.0, 1.0),
                beacon(2, 3.0, 5.0),
                beacon(3, 7.0, 1.0),
                beacon(4, 9.0, 5.0),
            ],
            access_points: vec![],
            georef: None,
        },
        floors: vec![two_rooms()],
    }
}
