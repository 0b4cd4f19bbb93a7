//! Map benchmarks on the demo site (maps/demo): Raycast (Function 1) over
//! 10 m at the default 0.05 m step, in open space and hitting a wall, the
//! O(1) queries, and building the whole site from its bytes. `*_reference`:
//! the literal sample-by-sample loop (`FloorMap::raycast_reference`).

use std::hint::black_box;
use std::path::Path;

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::Vec2;
use fpbp_core::site::{Site, SiteSpec};

fn load_bytes() -> (Vec<u8>, Vec<u8>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let site = std::fs::read(dir.join("site.json")).expect("maps/demo/site.json");
    let plan = std::fs::read(dir.join("plan.png")).expect("maps/demo/plan.png");
    (site, plan)
}

fn build(site: &[u8], plan: &[u8]) -> Site {
    let spec = SiteSpec::from_json(site, "site.json").expect("demo spec");
    Site::build(spec, "site.json", &mut |_| Ok(plan.to_vec())).expect("demo site")
}

fn benches(c: &mut Criterion) {
    let (site_bytes, plan_bytes) = load_bytes();
    let site = build(&site_bytes, &plan_bytes);
    let map = site.floor(0).expect("floor 0");
    // Along the horizontal corridor (y 19..22): 10 m of free space.
    let (a, b) = (Vec2::new(2.0, 20.5), Vec2::new(12.0, 20.5));
    assert!(map.raycast(a, b, 0.05).is_none());
    c.bench_function("raycast_10m_free", |bch| {
        common::run(bch, || map.raycast(black_box(a), black_box(b), 0.05))
    });
    // From inside a room 10 m across its wall (hit after ~3.5 m).
    let (a2, b2) = (Vec2::new(35.0, 15.5), Vec2::new(35.0, 25.5));
    assert!(map.raycast(a2, b2, 0.05).is_some());
    c.bench_function("raycast_10m_hit", |bch| {
        common::run(bch, || map.raycast(black_box(a2), black_box(b2), 0.05))
    });
    c.bench_function("raycast_10m_free_reference", |bch| {
        common::run(bch, || {
            map.raycast_reference(black_box(a), black_box(b), 0.05)
        })
    });
    c.bench_function("raycast_10m_hit_reference", |bch| {
        common::run(bch, || {
            map.raycast_reference(black_box(a2), black_box(b2), 0.05)
        })
    });
    let p = Vec2::new(37.5, 19.0);
    c.bench_function("room_of+normal_at", |bch| {
        common::run(bch, || {
            (map.room_of(black_box(a)), map.normal_at(black_box(p)))
        })
    });
    let room = map.room_of(Vec2::new(36.0, 10.0)).expect("room");
    c.bench_function("nearest_walkable_in_room", |bch| {
        common::run(bch, || {
            map.nearest_walkable_in_room(room, black_box(Vec2::new(31.5, 20.5)))
        })
    });
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    g.bench_function("demo_site_from_bytes", |bch| {
        common::run(bch, || {
            build(black_box(&site_bytes), black_box(&plan_bytes))
        })
    });
    g.finish();
}

criterion_group!(map_benches, benches);
criterion_main!(map_benches);
