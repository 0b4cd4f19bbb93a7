//! One GML call (FP-BP Sec. III) on a generated 60 x 40 m open floor, 1 m grid
//! (2400 points), 24 beacons on a 10 m lattice, noise-free RSSI: start-up
//! (whole grid) and tracking (candidates within d0 of the previous position).
//! The demo site replaces this once maps/demo lands on main.

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::Vec2;
use fpbp_core::ble::gml::Gml;
use fpbp_core::ble::grid::rect_grid;
use fpbp_core::ble::pathloss::PathLoss;
use fpbp_core::ble::{BleConfig, BlePositioner, FilteredBeacon};

fn beacons(at: Vec2) -> Vec<FilteredBeacon> {
    let model = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };
    let mut v = Vec::new();
    for j in 0..4 {
        for i in 0..6 {
            let pos = Vec2::new(5.0 + 10.0 * i as f64, 5.0 + 10.0 * j as f64);
            v.push(FilteredBeacon {
                index: v.len(),
                floor: 0,
                pos,
                dz_m: 1.3,
                model,
                rssi_dbm: model.rssi_at(((pos - at).norm_squared() + 1.69).sqrt(), 0.5),
                var_dbm2: 4.0,
                samples: 5,
                last_t_ns: 0,
            });
        }
    }
    v.sort_by(|a, b| b.rssi_dbm.total_cmp(&a.rssi_dbm));
    v
}

fn bench(c: &mut Criterion) {
    let grid = rect_grid(60.0, 40.0, 1.0);
    let truth = Vec2::new(23.5, 17.5);
    let fb = beacons(truth);
    let mut gml = Gml::new(&BleConfig::default());
    c.bench_function("gml_whole_grid_2400pts_24beacons", |b| {
        b.iter(|| gml.locate(std::hint::black_box(&fb), &grid, None))
    });
    c.bench_function("gml_local_d0_10m", |b| {
        b.iter(|| {
            gml.locate(
                std::hint::black_box(&fb),
                &grid,
                Some(Vec2::new(22.0, 18.0)),
            )
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
