//! BLE: beacons advertising at a fixed interval (plus the spec's random
//! advDelay), an Android scanner (duty-cycled scan window, partial reception,
//! drop-outs, optional batched reports, integer RSSI) and the channel: the
//! site's log-distance model (FP-BP eq. 1), spatially correlated log-normal
//! shadowing, fast fading, an attenuation per wall crossed on the straight
//! line (from the map), per floor between beacon and phone, a device bias,
//! and an optional injected NLOS attenuation (PPSA eq. 4).

use fpbp_core::Vec2;
use fpbp_core::events::BleObservation;
use fpbp_core::map::{Feature, FloorMap};
use fpbp_core::site::{BeaconSpec, Site};
use rand_pcg::Pcg64;

use crate::imu::to_ns;
use crate::noise::{chance, exponential, normal, uniform};
use crate::profile::BleConfig;
use crate::walk::Trajectory;

/// Shortest distance the path-loss model is evaluated at, m.
const MIN_DISTANCE_M: f64 = 0.1;

/// Number of walls and doors crossed on the straight line a-b of `map`:
/// the number of runs of Wall (resp. Door) samples, sampled at half a pixel
/// (at most 5 cm) with `FloorMap::feature`. A point starting inside a wall
/// counts that wall.
pub fn obstacles_crossed(map: &FloorMap, a: Vec2, b: Vec2) -> (usize, usize) {
    let step = (0.5 / map.pixels_per_meter()).min(0.05);
    let len = (b - a).norm();
    let n = (len / step).ceil().max(1.0) as usize;
    let (mut walls, mut doors) = (0, 0);
    let mut prev = Feature::Walkable;
    for k in 0..=n {
        let f = map.feature(a + (b - a) * (k as f64 / n as f64));
        if f != prev {
            match f {
                Feature::Wall => walls += 1,
                Feature::Door => doors += 1,
                Feature::Walkable => {}
            }
        }
        prev = f;
    }
    (walls, doors)
}

/// Everything about one beacon-phone link at one moment, before the random terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// 3-D distance, m (at least 0.1).
    pub distance_m: f64,
    pub walls: usize,
    pub doors: usize,
    /// Floors between beacon and phone.
    pub floors: usize,
    /// Mean RSSI of the model with the wall, door and floor terms and the device bias, dBm.
    pub model_rssi_dbm: f64,
}

/// The deterministic part of the channel for `beacon` seen from `phone` on `floor`.
pub fn link(
    site: &Site,
    cfg: &BleConfig,
    beacon: &BeaconSpec,
    floor: i32,
    phone: Vec2,
    phone_height_m: f64,
) -> Link {
    let height = |id: i32| {
        site.spec
            .floors
            .iter()
            .find(|f| f.id == id)
            .map_or(0.0, |f| f.height_m)
    };
    let bpos = Vec2::new(beacon.x_m, beacon.y_m);
    let dz = (height(beacon.floor) + beacon.z_m) - (height(floor) + phone_height_m);
    let distance_m = ((bpos - phone).norm_squared() + dz * dz)
        .sqrt()
        .max(MIN_DISTANCE_M);
    let (walls, doors) = if beacon.floor == floor {
        site.floor(floor)
            .map_or((0, 0), |m| obstacles_crossed(m, bpos, phone))
    } else {
        (0, 0)
    };
    let floors = {
        let ids: Vec<i32> = site.spec.floors.iter().map(|f| f.id).collect();
        let pa = ids.iter().position(|&i| i == beacon.floor);
        let pb = ids.iter().position(|&i| i == floor);
        match (pa, pb) {
            (Some(a), Some(b)) => a.abs_diff(b),
            _ => (beacon.floor - floor).unsigned_abs() as usize,
        }
    };
    let model_rssi_dbm = beacon.rssi_1m_dbm
        - 10.0 * beacon.path_loss_exponent * distance_m.log10()
        - cfg.wall_attenuation_db * walls as f64
        - cfg.door_attenuation_db * doors as f64
        - cfg.floor_attenuation_db * floors as f64
        + cfg.device_bias_dbm;
    Link {
        distance_m,
        walls,
        doors,
        floors,
        model_rssi_dbm,
    }
}

/// Scanner drop-outs: [start, end) spans in seconds.
fn dropouts(cfg: &BleConfig, duration_s: f64, rng: &mut Pcg64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    if cfg.dropout_rate_per_s <= 0.0 {
        return out;
    }
    let mut t = exponential(rng, 1.0 / cfg.dropout_rate_per_s);
    while t < duration_s {
        let len = exponential(rng, cfg.dropout_mean_s);
        out.push((t, t + len));
        t += len + exponential(rng, 1.0 / cfg.dropout_rate_per_s);
    }
    out
}

/// Per-beacon burst losses: [start, end) spans in seconds, alternating
/// exponential good spans (mean bad * (1 - f) / f) and bad spans (mean bad).
fn burst_losses(cfg: &BleConfig, duration_s: f64, rng: &mut Pcg64) -> Vec<(f64, f64)> {
    let f = cfg.burst_loss_fraction;
    let mut out = Vec::new();
    if f <= 0.0 || cfg.burst_loss_mean_s <= 0.0 {
        return out;
    }
    let good_mean = cfg.burst_loss_mean_s * (1.0 - f) / f;
    // Start in a random state with the stationary probabilities.
    let mut t = if chance(rng, f) {
        0.0
    } else {
        exponential(rng, good_mean)
    };
    while t < duration_s {
        let len = exponential(rng, cfg.burst_loss_mean_s);
        out.push((t, t + len));
        t += len + exponential(rng, good_mean);
    }
    out
}

fn inside(spans: &[(f64, f64)], t: f64) -> bool {
    let k = spans.partition_point(|d| d.1 <= t);
    k < spans.len() && spans[k].0 <= t
}

/// The scan reports of the whole log, in time order.
#[allow(clippy::too_many_arguments)]
pub fn scans(
    site: &Site,
    cfg: &BleConfig,
    traj: &Trajectory,
    floor: i32,
    phone_height_m: f64,
    t0_ns: i64,
    rng: &mut Pcg64,
) -> Vec<BleObservation> {
    let drops = dropouts(cfg, traj.duration_s, rng);
    // Scanner duty cycle phase (the scan started at some point before the log).
    let scan_phase = uniform(rng, 0.0, cfg.scan_interval_s);
    let mut out: Vec<(f64, usize, BleObservation)> = Vec::new();
    for (bi, b) in site.spec.beacons.iter().enumerate() {
        let tx_power_dbm = b.id.starts_with("ibeacon:").then(|| b.rssi_1m_dbm.round());
        let bursts = burst_losses(cfg, traj.duration_s, rng);
        let mut shadow = normal(rng, 0.0, cfg.shadowing_sigma_db);
        let mut last_pos: Option<Vec2> = None;
        let mut t = uniform(rng, 0.0, cfg.advert_interval_s);
        while t <= traj.duration_s {
            let t_adv = t;
            t += cfg.advert_interval_s + uniform(rng, 0.0, cfg.advert_delay_max_s);
            let in_window = (t_adv + scan_phase) % cfg.scan_interval_s < cfg.scan_window_s;
            // Draw the reception lot for every advert so the random sequence
            // does not depend on the geometry.
            let heard = chance(rng, cfg.reception_probability);
            if !in_window || inside(&drops, t_adv) || inside(&bursts, t_adv) {
                continue;
            }
            let pos = traj.position_at(t_adv);
            // Shadowing: AR(1) in the distance walked since this beacon's last advert.
            let moved = last_pos.map_or(f64::INFINITY, |p| (pos - p).norm());
            if moved > 0.0 {
                let rho = (-moved / cfg.shadowing_decorrelation_m).exp();
                shadow = rho * shadow
                    + (1.0 - rho * rho).sqrt() * normal(rng, 0.0, cfg.shadowing_sigma_db);
            }
            last_pos = Some(pos);
            let fading = normal(rng, 0.0, cfg.fast_fading_sigma_db);
            let nlos = if chance(rng, cfg.nlos_rate) {
                normal(rng, cfg.nlos_mean_db, cfg.nlos_sigma_db).max(0.0)
            } else {
                0.0
            };
            if !heard {
                continue;
            }
            let l = link(site, cfg, b, floor, pos, phone_height_m);
            let mut rssi = l.model_rssi_dbm + shadow + fading - nlos;
            if cfg.integer_rssi {
                rssi = rssi.round();
            }
            if rssi < cfg.sensitivity_dbm {
                continue;
            }
            let t_rep = if cfg.report_delay_s > 0.0 {
                (t_adv / cfg.report_delay_s).ceil() * cfg.report_delay_s
            } else {
                t_adv
            };
            if t_rep > traj.duration_s {
                continue;
            }
            out.push((
                t_rep,
                bi,
                BleObservation {
                    t_ns: to_ns(t0_ns, t_rep),
                    beacon_id: b.id.clone(),
                    rssi_dbm: rssi,
                    tx_power_dbm,
                },
            ));
        }
    }
    out.sort_by(|a, b| a.2.t_ns.cmp(&b.2.t_ns).then(a.1.cmp(&b.1)));
    out.into_iter().map(|(_, _, o)| o).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testmap::two_rooms;

    #[test]
    fn walls_are_counted_on_the_straight_line() {
        let m = two_rooms();
        assert_eq!(
            obstacles_crossed(&m, Vec2::new(2.0, 1.0), Vec2::new(8.0, 1.0)),
            (1, 0)
        );
        assert_eq!(
            obstacles_crossed(&m, Vec2::new(2.0, 3.0), Vec2::new(8.0, 3.0)),
            (0, 1)
        );
        assert_eq!(
            obstacles_crossed(&m, Vec2::new(2.0, 1.0), Vec2::new(4.0, 5.0)),
            (0, 0)
        );
        // Through the inner wall and out of the building: two walls.
        assert_eq!(
            obstacles_crossed(&m, Vec2::new(2.0, 1.0), Vec2::new(11.0, 1.0)),
            (2, 0)
        );
    }
}
