//! One fusion step (move + weight + resample + PPC + particle shift) with the
//! default 1000 particles, on an office-like plan: rooms off a corridor with
//! doors. Target: 100 us per step (the paper reports 4.67 ms on a phone).
//!
//! Run: `cargo bench -p fpbp-core --bench fusion`.

use std::hint::black_box;

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::Vec2;
use fpbp_core::fusion::{FusionConfig, ParticleFilter, ppc};
use fpbp_core::map::{Feature, FloorMap};

/// 40 m x 20 m at 10 px/m: a corridor along y in [9, 11] m, rooms of 5 m
/// above and below it, each with a 1 m door onto the corridor.
fn office() -> FloorMap {
    let (w, h, r) = (400usize, 200usize, 10.0);
    let mut f = vec![Feature::Walkable; w * h];
    for j in 0..h {
        for i in 0..w {
            let (x, y) = ((i as f64 + 0.5) / r, ((h - j) as f64 - 0.5) / r);
            let border = !(0.2..39.8).contains(&x) || !(0.2..19.8).contains(&y);
            let corridor_wall = (8.8..9.0).contains(&y) || (11.0..11.2).contains(&y);
            let room_wall = (x % 5.0) < 0.2 && !(9.0..11.0).contains(&y);
            let door = corridor_wall && (x % 5.0 - 2.0).abs() < 0.5;
            f[j * w + i] = if border || room_wall || (corridor_wall && !door) {
                Feature::Wall
            } else if door {
                Feature::Door
            } else {
                Feature::Walkable
            };
        }
    }
    FloorMap::from_features(w, h, r, f)
}

/// The demo site (maps/demo, built by the map module), if present.
fn demo_site() -> Option<fpbp_core::site::Site> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let bytes = std::fs::read(dir.join("site.json")).ok()?;
    let spec = fpbp_core::site::SiteSpec::from_json(&bytes, "site.json").ok()?;
    fpbp_core::site::Site::build(spec, "site.json", &mut |p: &str| std::fs::read(dir.join(p))).ok()
}

/// The demo site's plan (maps/demo/plan.png, built by the map module), or
/// the synthetic office when the file is missing.
fn demo_or_office() -> (FloorMap, &'static str) {
    let built = demo_site().and_then(|site| site.floors.into_iter().next());
    match built {
        Some(m) => (m, "demo"),
        None => (office(), "office"),
    }
}

/// Per-particle wall check of a fusion step.
#[derive(Clone, Copy, PartialEq)]
enum WallCheck {
    /// The engine's default: `ppc::crosses_wall_each` (doors pass,
    /// `particles_pass_doors`), crossing particles keep
    /// `wall_crossing_weight` of their weight, replacement counts Wall
    /// pixels only.
    Default,
    /// `FloorMap::raycast` (Walls and Doors stop a particle, which dies).
    Raycast,
    /// The literal Function 1 loop `FloorMap::raycast_reference` (the speed before the clearance table).
    ReferenceRaycast,
    /// No per-particle check (`particle_wall_check: false`).
    Off,
}

fn fusion_step(c: &mut Criterion) {
    for (name, check) in [
        ("fusion_step_1000_particles_ppc", WallCheck::Default),
        ("fusion_step_1000_particles_ppc_raycast", WallCheck::Raycast),
        (
            "fusion_step_1000_particles_ppc_reference_raycast",
            WallCheck::ReferenceRaycast,
        ),
        (
            "fusion_step_1000_particles_ppc_no_wall_check",
            WallCheck::Off,
        ),
    ] {
        fusion_step_with(c, name, check);
    }
}

fn fusion_step_with(c: &mut Criterion, name: &str, check: WallCheck) {
    let (map, plan) = demo_or_office();
    eprintln!("fusion bench plan: {plan}");
    let cfg = FusionConfig::default();
    let mut pf = ParticleFilter::new(&cfg, 1);
    // The demo's and the office's corridors both run east at y ~ 20 / 10 m.
    let start = if plan == "demo" {
        Vec2::new(3.0, 20.5)
    } else {
        Vec2::new(2.5, 10.0)
    };
    pf.init_at(start, 1.0, |p| map.is_walkable(p));
    let mut prev = start;
    let mut k = 0u64;
    let mut before: Vec<Vec2> = Vec::new();
    let mut crossed: Vec<bool> = Vec::new();
    c.bench_function(name, |b| {
        common::run(b, || {
            // Walk east along the corridor, weaving into the walls now and then.
            k += 1;
            let yaw = if k % 8 < 4 { 0.6 } else { -0.6 };
            let x_b = prev + Vec2::new(1.0, 0.0);
            // (x_B leads the walker by 1 m along the corridor.)
            before.clear();
            before.extend_from_slice(pf.particles());
            pf.predict(0.7, yaw);
            pf.weight(x_b);
            // The default particle wall check (extension, see docs/fusion.md).
            let step = cfg.ppc.raycast_step_m;
            match check {
                WallCheck::Default => {
                    // as the engine (engines/fpbp.rs) does it
                    ppc::crosses_wall_each(&map, &before, pf.particles(), step, &mut crossed);
                    pf.penalize_flagged(&crossed, cfg.wall_crossing_weight);
                }
                WallCheck::Raycast => {
                    pf.penalize_moves(&before, 0.0, |a, b| map.raycast(a, b, step).is_some());
                }
                WallCheck::ReferenceRaycast => {
                    pf.penalize_moves(&before, 0.0, |a, b| {
                        map.raycast_reference(a, b, step).is_some()
                    });
                }
                WallCheck::Off => {}
            }
            let x_hat = pf.mean().unwrap_or(prev);
            pf.resample();
            let o = ppc::correct(&map, prev, x_hat, Some(x_b), &cfg.ppc);
            let doors_ok = check == WallCheck::Default && cfg.particles_pass_doors;
            ppc::apply_to_particles_with_doors(&map, &mut pf, x_hat, &o, true, doors_ok);
            prev = if o.position.x > 37.0 {
                start
            } else {
                o.position
            };
            if prev == start {
                pf.init_at(start, 1.0, |p| map.is_walkable(p));
            }
            black_box(prev)
        })
    });
}

/// The fusion task exactly as the `fpbp` engine runs it: one
/// `FusionSide::run_steps` call with one PDR step and a fresh x_B (particle
/// wall check, room-level estimate, room switch, PPC, eq. 44, replacement),
/// the default config, on the demo site; the walk weaves as above.
fn fusion_task_step(c: &mut Criterion) {
    use fpbp_core::ble::task::BleFix;
    use fpbp_core::engine::InitialPosition;
    use fpbp_core::engines::EngineConfig;
    use fpbp_core::engines::fpbp::FusionSide;
    let Some(site) = demo_site() else {
        eprintln!("fusion_task_step: maps/demo not found, skipped");
        return;
    };
    let site = std::sync::Arc::new(site);
    let cfg = EngineConfig::default();
    let start = InitialPosition {
        x_m: 3.0,
        y_m: 20.5,
        floor: 0,
        heading_rad: None,
    };
    let new_side = || FusionSide::new(site.clone(), &cfg, true, Some(start)).unwrap();
    let mut side = new_side();
    let mut k = 0i64;
    c.bench_function("fusion_task_step_1000_particles_engine", |b| {
        common::run(b, || {
            k += 1;
            let t = k * 500_000_000;
            let yaw = if k % 8 < 4 { 0.6 } else { -0.6 };
            let prev = side
                .pose()
                .map_or(Vec2::new(start.x_m, start.y_m), |p| Vec2::new(p.x_m, p.y_m));
            let x_b = prev + Vec2::new(1.0, 0.0);
            let fix = BleFix {
                t_ns: t,
                pos: x_b,
                raw: x_b,
                floor: 0,
                beacons: 4,
            };
            side.run_steps(t, Some(fix), &[(0.7, yaw)]);
            if side.pose().is_some_and(|p| p.x_m > 37.0) {
                side = new_side();
            }
            black_box(side.pose())
        })
    });
}

/// The filter alone (move + weight + resample), for comparison.
fn filter_only(c: &mut Criterion) {
    let cfg = FusionConfig::default();
    let mut pf = ParticleFilter::new(&cfg, 1);
    pf.init_at(Vec2::new(2.5, 10.0), 1.0, |_| true);
    c.bench_function("filter_only_1000_particles", |b| {
        common::run(b, || {
            pf.predict(0.7, 0.1);
            let x_b = pf.mean().unwrap_or_default() + Vec2::new(0.5, 0.0);
            pf.weight(x_b);
            pf.resample();
            black_box(pf.mean())
        })
    });
}

criterion_group!(benches, fusion_step, fusion_task_step, filter_only);
criterion_main!(benches);
