//! The magnetic update.

use super::*;

/// The test site's radio map with a magnetic grid on floor 0: |B| 30 uT
/// south of y = 20 m, 60 uT north of it (sd 2 uT), over 20 x 40 m.
fn magnetic_engine(weight: f64) -> TcpfEngine {
    use crate::radio::magnetic_map::MagneticMap;
    use crate::radio::radio_map::Grid;
    let (site, map) = site_with_scans(1, 0, 0.0);
    let mut map = (*map).clone();
    let (nx, ny) = (20usize, 40usize);
    let mean = (0..nx * ny)
        .map(|k| if k / nx < 20 { 300 } else { 600 })
        .collect();
    map.set_magnetic(Some(MagneticMap::new(vec![Grid {
        floor: 0,
        x0_m: 0.0,
        y0_m: 0.0,
        cell_m: 1.0,
        nx,
        ny,
        mean_dbm_x10: mean,
        sd_dbm_x10: vec![20; nx * ny],
    }])));
    let mut cfg = EngineConfig::default();
    cfg.tcpf.magnetic.weight = weight;
    let init = InitialPosition {
        x_m: 7.0,
        y_m: 20.0,
        floor: 0,
        heading_rad: None,
    };
    let mut e = TcpfEngine::with_model(site.clone(), &cfg, Some(init), Arc::new(map)).unwrap();
    let m = site.floor(0).unwrap();
    e.pf.init_at(Vec2::new(7.0, 20.0), 8.0, |q| m.is_walkable(q));
    e
}

/// Weighted share of the particles north of y = 20 m.
fn north_share(e: &TcpfEngine) -> f64 {
    let (ps, ws) = e.particles();
    let all: f64 = ws.iter().sum();
    ps.iter()
        .zip(ws)
        .filter(|(p, _)| p.y >= 20.0)
        .map(|(_, w)| w)
        .sum::<f64>()
        / all
}

#[test]
fn the_magnetic_map_weighs_the_particles_and_learns_the_phone_offset() {
    let mut e = magnetic_engine(0.5);
    let before = north_share(&e);
    assert!((0.3..0.7).contains(&before), "share before {before:.2}");
    // a phone reading 5 uT high in the north half
    for _ in 0..5 {
        e.magnetic_update(65.0);
    }
    let after = north_share(&e);
    assert!(after > 0.95, "share north {before:.2} -> {after:.2}");
    assert_eq!(e.counts.magnetic_updates, 5);
    for _ in 0..100 {
        e.magnetic_update(65.0);
    }
    let o = e.magnetic_offset_ut();
    assert!((o - 5.0).abs() < 0.5, "offset {o:.2} uT");
    // without a grid on the track's floor, or off: no evidence, no update
    let mut off = magnetic_engine(0.5);
    off.floor = 1;
    off.magnetic_update(65.0);
    assert_eq!(off.counts.magnetic_updates, 0);
}

#[test]
fn a_walker_standing_still_is_not_weighed_by_the_magnetic_field() {
    use crate::events::{SensorData, SensorEvent};
    for weight in [0.0, 0.5] {
        let mut e = magnetic_engine(weight);
        let share = north_share(&e);
        // standing still: samples, fusion runs, no steps
        for k in 0..50 {
            e.on_sensor(&SensorEvent {
                t_ns: k * 20_000_000,
                data: SensorData::Magnetometer([0.0, 0.0, -60.0]),
            });
            if k % 10 == 9 {
                e.run_task(Task::Fusion, k * 20_000_000);
            }
        }
        assert_eq!(e.counts.magnetic_updates, 0, "weight {weight}");
        assert!((north_share(&e) - share).abs() < 1e-12);
        // walking: one update per fusion run with steps, when asked
        let mut ev = walk_north(10, None);
        ev.extend((0..500).map(|k| {
            LogEvent::Sensor(SensorEvent {
                t_ns: 2_000_000_000 + k * 20_000_000,
                data: SensorData::Magnetometer([0.0, 18.0, -24.0]),
            })
        }));
        ev.sort_by_key(LogEvent::t_ns);
        let out = replay(&mut e, ev);
        let n = e.counts.magnetic_updates;
        if weight > 0.0 {
            assert!(
                n > 0 && n <= out.stats.steps,
                "{n} updates, {} steps",
                out.stats.steps
            );
        } else {
            assert_eq!(n, 0);
        }
    }
}
