//! One GML call (FP-BP Sec. III) on the demo site (maps/demo, its walkable
//! 1 m grid and its beacons, noise-free RSSI from the site's models): start-up
//! (whole grid) and tracking (candidates within d0 of the previous position);
//! plus the same on a generated 60 x 40 m open floor (2400 points) with 24
//! beacons on a 10 m lattice, for comparison across map changes. The fast
//! search (f32 tables, `ble/gml_tables.rs`) is timed with its tables built;
//! `*_reference_f64` is the exhaustive oracle, `first_call` a call on a
//! fresh positioner (table building included).

use std::hint::black_box;
use std::path::Path;

mod common;

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
        common::run(b, || gml.locate(black_box(&fb), &grid, None))
    });
    eprintln!(
        "gml tables after the demo calls: {} columns, {} bytes (grid copy {} bytes); last call re-checked {} of {} candidates in f64",
        gml.table_columns(),
        gml.table_bytes(),
        grid.len() * std::mem::size_of::<Vec2>(),
        gml.last_rechecked,
        gml.last_candidates
    );
    let prev = truth + Vec2::new(1.0, -1.0);
    c.bench_function("gml_demo_local_d0", |b| {
        common::run(b, || gml.locate(black_box(&fb), &grid, Some(prev)))
    });
    // The exhaustive f64 oracle, and a first call on a fresh positioner
    // (builds the N columns it needs).
    c.bench_function("gml_demo_whole_grid_reference_f64", |b| {
        common::run(b, || gml.locate_reference(black_box(&fb), &grid, None))
    });
    c.bench_function("gml_demo_local_d0_reference_f64", |b| {
        common::run(b, || {
            gml.locate_reference(black_box(&fb), &grid, Some(prev))
        })
    });
    c.bench_function("gml_demo_first_call_builds_6_columns", |b| {
        common::run(b, || Gml::new(&cfg).locate(black_box(&fb), &grid, None))
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
        common::run(b, || gml.locate(black_box(&fb), &grid, None))
    });
}

/// With `FPBP_BENCH_SITE=path/to/site.json` (e.g. a generated ILC site, see
/// docs/sites.md): per floor, the grid size and the table memory when every
/// beacon of the floor has been heard (the worst case), and one tracking call.
fn other_site(c: &mut Criterion) {
    let Ok(path) = std::env::var("FPBP_BENCH_SITE") else {
        return;
    };
    let path = Path::new(&path);
    let dir = path.parent().expect("site folder");
    let bytes = std::fs::read(path).expect("FPBP_BENCH_SITE");
    let spec = SiteSpec::from_json(&bytes, "site.json").expect("site spec");
    let site =
        Site::build(spec, "site.json", &mut |p: &str| std::fs::read(dir.join(p))).expect("site");
    let cfg = BleConfig::default();
    for (fspec, map) in site.spec.floors.iter().zip(&site.floors) {
        let grid = map.grid().to_vec();
        let beacons: Vec<(Vec2, f64, PathLoss)> = site
            .spec
            .beacons
            .iter()
            .filter(|b| b.floor == fspec.id)
            .map(|b| {
                let m = PathLoss {
                    rssi_1m_dbm: b.rssi_1m_dbm,
                    exponent: b.path_loss_exponent,
                };
                (Vec2::new(b.x_m, b.y_m), b.z_m, m)
            })
            .collect();
        if beacons.len() < 3 || grid.is_empty() {
            continue;
        }
        let mut gml = Gml::new(&cfg);
        let truth = grid[grid.len() / 2];
        // every beacon once among the top N: all columns built
        let all = filtered(&beacons, truth, &cfg);
        for k in (0..all.len()).step_by(cfg.gml.top_n) {
            let mut v = all.clone();
            v.rotate_left(k);
            gml.locate(&v, &grid, None);
        }
        eprintln!(
            "site {} floor {}: {} grid points, {} beacons, tables {} columns {} bytes ({:.1} MB)",
            path.display(),
            fspec.id,
            grid.len(),
            beacons.len(),
            gml.table_columns(),
            gml.table_bytes(),
            gml.table_bytes() as f64 / 1e6
        );
        let fb = filtered(&beacons, truth, &cfg);
        let prev = truth + Vec2::new(1.0, -1.0);
        c.bench_function(&format!("gml_site_floor{}_local_d0", fspec.id), |b| {
            common::run(b, || gml.locate(black_box(&fb), &grid, Some(prev)))
        });
        c.bench_function(
            &format!("gml_site_floor{}_whole_grid_{}pts", fspec.id, grid.len()),
            |b| common::run(b, || gml.locate(black_box(&fb), &grid, None)),
        );
    }
}

criterion_group!(benches, bench, other_site);
criterion_main!(benches);
