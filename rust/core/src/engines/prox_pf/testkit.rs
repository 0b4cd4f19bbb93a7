//! Synthetic sites and walks shared by the `prox-pf` and `ppsa` tests
//! (and other engines' tests).

use std::sync::Arc;

use nalgebra::{UnitQuaternion, Vector3};

use crate::Vec2;
use crate::ble::pathloss::{PathLoss, range_m};
use crate::events::{BleObservation, LogEvent, SensorData, SensorEvent, TruthPoint};
use crate::map::{Feature, FloorMap};
use crate::pdr::orientation::to_android;
use crate::site::Site;
use crate::site::testkit::beacon_site;

pub const MODEL: PathLoss = PathLoss {
    rssi_1m_dbm: -59.0,
    exponent: 2.0,
};
/// Step length the PDR measures on [`walk_north`]'s signal (see engines::pdr tests).
pub const STEP_M: f64 = 0.616;
pub const STEP_HZ: f64 = 1.8;

/// A 20 x 40 m floor (2 px/m) with a full-height wall at x in [10, 10.5).
pub fn walled_map() -> FloorMap {
    let (w, h) = (40usize, 80usize);
    let mut f = vec![Feature::Walkable; w * h];
    for j in 0..h {
        f[j * w + 20] = Feature::Wall;
    }
    FloorMap::from_features(w, h, 2.0, f)
}

/// Beacons along x = 5 (left room) every 4 m from y = 2, plus one at
/// (12, 20) behind the wall; all at phone height (dz = 0).
pub fn beacons() -> Vec<Vec2> {
    let mut v: Vec<Vec2> = (0..10)
        .map(|k| Vec2::new(5.0, 2.0 + 4.0 * k as f64))
        .collect();
    v.push(Vec2::new(12.0, 20.0));
    v
}

pub fn site() -> Arc<Site> {
    let bs: Vec<(f64, f64)> = beacons().iter().map(|p| (p.x, p.y)).collect();
    beacon_site("nlos-test", vec![walled_map()], &bs, MODEL)
}

/// `seconds` of walking north along x = 7 from y = 4 (phone flat, top
/// north), sensors at 50 Hz, adverts of every beacon every 0.2 s
/// (noise-free model RSSI, or `rssi(i, t)` when given), truth every second.
pub fn walk_north(seconds: i64, rssi: Option<&dyn Fn(usize, f64) -> f64>) -> Vec<LogEvent> {
    let q = UnitQuaternion::identity();
    let bs = beacons();
    let mut ev = Vec::new();
    let truth = |t: f64| Vec2::new(7.0, 4.0 + STEP_HZ * STEP_M * t);
    for i in 0..seconds * 50 {
        let t_ns = i * 20_000_000;
        let t = t_ns as f64 * 1e-9;
        let acc = Vector3::new(
            0.0,
            0.0,
            9.81 + 2.5 * (std::f64::consts::TAU * STEP_HZ * t).sin(),
        );
        ev.push(LogEvent::Sensor(SensorEvent {
            t_ns,
            data: SensorData::Accelerometer(acc.into()),
        }));
        ev.push(LogEvent::Sensor(SensorEvent {
            t_ns,
            data: SensorData::RotationVector(to_android(&q)),
        }));
        if i % 10 == 0 {
            let p = truth(t);
            for (k, b) in bs.iter().enumerate() {
                let r = match rssi {
                    Some(f) => f(k, t),
                    None => MODEL.rssi_at(range_m(p, *b, 0.0, 0.5), 0.5),
                };
                ev.push(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: format!("mac:00:00:00:00:00:{k:02X}"),
                    rssi_dbm: r,
                    tx_power_dbm: None,
                }));
            }
        }
        if i % 50 == 0 {
            let p = truth(t);
            ev.push(LogEvent::Truth(TruthPoint {
                t_ns,
                x_m: p.x,
                y_m: p.y,
                floor: Some(0),
            }));
        }
    }
    ev
}
