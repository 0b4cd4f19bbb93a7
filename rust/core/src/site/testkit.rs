//! Test sites: floors without plan files whose maps the test supplies, with
//! beacons of one path-loss model on floor 0. Shared by the engine,
//! fingerprint and BLE tests so each does not spell out a `SiteSpec`.

use std::sync::Arc;

use crate::ble::pathloss::PathLoss;
use crate::map::{Feature, FloorMap};
use crate::site::{BeaconSpec, FloorSpec, Legend, Site, SiteSpec};

/// An all-Walkable `width_m` x `height_m` map at 1 px/m.
pub(crate) fn open_map(width_m: usize, height_m: usize) -> FloorMap {
    FloorMap::from_features(
        width_m,
        height_m,
        1.0,
        vec![Feature::Walkable; width_m * height_m],
    )
}

/// A site named `name` whose floors are `maps` (ids 0, 1, ... at 4 m per
/// floor, open areas of the maps' size) and whose beacons stand at
/// `beacons` on floor 0, 1.2 m high, with ids `mac:00:00:00:00:00:NN` and
/// path-loss `model`.
pub(crate) fn beacon_site(
    name: &str,
    maps: Vec<FloorMap>,
    beacons: &[(f64, f64)],
    model: PathLoss,
) -> Arc<Site> {
    let floors = maps
        .iter()
        .enumerate()
        .map(|(id, m)| FloorSpec {
            id: id as i32,
            name: String::new(),
            plan: None,
            pixels_per_meter: None,
            target_pixels_per_meter: None,
            open_area_m: Some([m.width_m(), m.height_m()]),
            height_m: 4.0 * id as f64,
        })
        .collect();
    let spec = SiteSpec {
        format: "fpbp-site".into(),
        version: 1,
        name: name.into(),
        map_from_enu_rad: 0.0,
        heading_bias_rad: 0.0,
        legend: Legend::default(),
        grid_interval_m: 1.0,
        floors,
        beacons: beacons
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| BeaconSpec {
                id: format!("mac:00:00:00:00:00:{i:02X}"),
                floor: 0,
                x_m: x,
                y_m: y,
                z_m: 1.2,
                rssi_1m_dbm: model.rssi_1m_dbm,
                path_loss_exponent: model.exponent,
            })
            .collect(),
        access_points: vec![],
        georef: None,
    };
    Arc::new(Site { spec, floors: maps })
}
