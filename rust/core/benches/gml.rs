//! One GML call (FP-BP Sec. III) on the demo site (maps/demo, its walkable
//! 1 m grid and its beacons, noise-free RSSI from the site's models): start-up
//! (whole grid) and tracking (candidates within d0 of the previous position);
//! plus the same on a generated 60 x 40 m open floor (2400 points) with 24
//! beacons on a 10 m lattice, for comparison across map changes.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::Vec2;
use fpbp_core::ble::gml::Gml;
use fpbp_core::ble::grid::rect_grid;
use fpbp_core::ble::pathloss::{PathLoss, range_m};
use fpbp_core::ble::{BleConfig, BlePositioner, FilteredBeacon};
use fpbp_core::site::{Site, SiteSpec};

fn demo_site() -> Site {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let site = std::fs::read(dir.join("site.json")).expect("maps/demo/site.json");
    let plan = std::fs::read(dir.join("plan.png")).expect("maps/demo/plan.png");
    let spec = SiteSpec::from_json(&site, "site.json").expect("demo spec");
    Site::build(spec, "site.json", &mut |_| Ok(plan.clone())).expect("demo site")
}

fn filtered(beacons: &[(Vec2, f64, PathLoss)], at: Vec2, cfg: &BleConfig) -> Vec<FilteredBeacon> {
    let mut v: Vec<FilteredBeacon> = beacons
        .iter()
        .enumerate()
        .map(|(index, &(pos, z, model))| {
            let dz_m = z - cfg.phone_height_m;
            FilteredBeacon {
                index,
                floor: 0,
                pos,
                dz_m,
                model,
                rssi_dbm: model.rssi_at(
                    range_m(at, pos, dz_m, cfg.min_distance_m),
                    cfg.min_distance_m,
                ),
                var_dbm2: 4.0,
                samples: 5,
                last_t_ns: 0,
            }
        })
        .collect();
    v.sort_by(|a, b| b.rssi_dbm.total_cmp(&a.rssi_dbm));
    v
}

fn bench(c: &mut Criterion) {
    let cfg = BleConfig::default();
    let mut gml = Gml::new(&cfg);

    let site = demo_site();
    let grid = site.floor(0).expect("floor 0").grid().to_vec();
    let beacons: Vec<(Vec2, f64, PathLoss)> = site
        .spec
        .beacons
        .iter()
        .filter(|b| b.floor == 0)
        .map(|b| {
            let m = PathLoss {
                rssi_1m_dbm: b.rssi_1m_dbm,
                exponent: b.path_loss_exponent,
            };
            (Vec2::new(b.x_m, b.y_m), b.z_m, m)
        })
        .collect();
    let truth = grid[grid.len() / 2];
    let fb = filtered(&beacons, truth, &cfg);
    assert_eq!(gml.locate(&fb, &grid, None), Some(truth));
    let label = format!(
        "gml_demo_whole_grid_{}pts_{}beacons",
        grid.len(),
        beacons.len()
    );
    c.bench_function(&label, |b| {
        b.iter(|| gml.locate(black_box(&fb), &grid, None))
    });
    let prev = truth + Vec2::new(1.0, -1.0);
    c.bench_function("gml_demo_local_d0", |b| {
        b.iter(|| gml.locate(black_box(&fb), &grid, Some(prev)))
    });

    let grid = rect_grid(60.0, 40.0, 1.0);
    let model = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };
    let mut lattice = Vec::new();
    for j in 0..4 {
        for i in 0..6 {
            lattice.push((
                Vec2::new(5.0 + 10.0 * i as f64, 5.0 + 10.0 * j as f64),
                2.5,
                model,
            ));
        }
    }
    let fb = filtered(&lattice, Vec2::new(23.5, 17.5), &cfg);
    c.bench_function("gml_open_60x40_whole_grid_2400pts_24beacons", |b| {
        b.iter(|| gml.locate(black_box(&fb), &grid, None))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
