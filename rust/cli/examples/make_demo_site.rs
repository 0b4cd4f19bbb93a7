//! Draws the demo site: `cargo run -p fpbp-cli --example make_demo_site -- maps/demo`
//! writes maps/demo/plan.png and maps/demo/site.json. Deterministic; no hand
//! drawing. Layout (MCS metres, 64 x 44, r = 10 px/m): a horizontal corridor
//! (y 19-22) crossing a vertical one (x 30-33), eleven rooms off them, one
//! diagonal wall (with a door in it), one curved wall (a quarter circle of
//! radius 13 m, with a door in it), 0.3 m walls, 1 m red doors, and 54
//! ceiling beacons on a 7 m lattice.

use std::path::PathBuf;

use anyhow::Context;
use fpbp_core::Vec2;
use fpbp_core::site::{BeaconSpec, FloorSpec, Legend, SiteSpec};
use fpbp_sim::plan_draw::{Drawing, Stroke, is_walkable, seg};

const W_M: f64 = 64.0;
const H_M: f64 = 44.0;
const R: f64 = 10.0;
const WALL_M: f64 = 0.3;

fn walls() -> Vec<Stroke> {
    let e = WALL_M / 2.0;
    let arc_c = Vec2::new(W_M, H_M);
    vec![
        // Outer boundary, inset by half a wall so the band lies in the image.
        seg(e, e, W_M - e, e),
        seg(e, H_M - e, W_M - e, H_M - e),
        seg(e, e, e, H_M - e),
        seg(W_M - e, e, W_M - e, H_M - e),
        // Horizontal corridor y 19..22, broken where the vertical one crosses.
        seg(0.0, 19.0, 30.0, 19.0),
        seg(33.0, 19.0, W_M, 19.0),
        seg(0.0, 22.0, 30.0, 22.0),
        seg(33.0, 22.0, W_M, 22.0),
        // Vertical corridor x 30..33.
        seg(30.0, 0.0, 30.0, 19.0),
        seg(33.0, 0.0, 33.0, 19.0),
        seg(30.0, 22.0, 30.0, H_M),
        seg(33.0, 22.0, 33.0, H_M),
        // Bottom-left: a diagonal divider.
        seg(13.0, 0.0, 17.0, 19.0),
        // Bottom-right: three rooms.
        seg(43.0, 0.0, 43.0, 19.0),
        seg(53.0, 0.0, 53.0, 19.0),
        // Top-left: three rooms.
        seg(10.0, 22.0, 10.0, H_M),
        seg(20.0, 22.0, 20.0, H_M),
        // Top-right: a divider and a curved wall around the corner room.
        seg(48.0, 22.0, 48.0, H_M),
        Stroke::Arc {
            c: arc_c,
            radius: 13.0,
            a0: std::f64::consts::PI,
            a1: 1.5 * std::f64::consts::PI,
        },
    ]
}

fn doors() -> Vec<Stroke> {
    let diag_a = Vec2::new(13.0, 0.0);
    let diag_u = (Vec2::new(17.0, 19.0) - diag_a).normalize();
    let mid = 1.25 * std::f64::consts::PI;
    let half = 0.5 / 13.0;
    vec![
        // Onto the horizontal corridor (y = 19 below, y = 22 above).
        seg(6.0, 19.0, 7.0, 19.0),
        seg(22.0, 19.0, 23.0, 19.0),
        seg(37.0, 19.0, 38.0, 19.0),
        seg(47.5, 19.0, 48.5, 19.0),
        seg(58.0, 19.0, 59.0, 19.0),
        seg(4.5, 22.0, 5.5, 22.0),
        seg(14.5, 22.0, 15.5, 22.0),
        seg(24.5, 22.0, 25.5, 22.0),
        seg(40.0, 22.0, 41.0, 22.0),
        seg(55.0, 22.0, 56.0, 22.0),
        // Onto the vertical corridor (x = 33).
        seg(33.0, 8.0, 33.0, 9.0),
        seg(33.0, 32.0, 33.0, 33.0),
        // In the diagonal wall, 8-9 m along it.
        Stroke::Seg {
            a: diag_a + diag_u * 8.0,
            b: diag_a + diag_u * 9.0,
        },
        // In the curved wall.
        Stroke::Arc {
            c: Vec2::new(W_M, H_M),
            radius: 13.0,
            a0: mid - half,
            a1: mid + half,
        },
    ]
}

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "maps/demo".into()),
    );
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let legend = Legend::default();
    let drawing = Drawing {
        width_m: W_M,
        height_m: H_M,
        pixels_per_meter: R,
        wall_m: WALL_M,
        walls: walls(),
        doors: doors(),
        blocks: Vec::new(),
        openings: Vec::new(),
    };
    let img = drawing.render(&legend);
    let (w, h) = img.dimensions();
    let plan_path = out.join("plan.png");
    img.save(&plan_path)
        .with_context(|| format!("cannot write {}", plan_path.display()))?;

    // Beacons on a 7 m lattice, nudged off any obstacle pixel.
    let is_free = |x: f64, y: f64| is_walkable(&img, &legend, R, x, y);
    let mut beacons = Vec::new();
    for jy in 0..6 {
        for ix in 0..9 {
            let (mut x, mut y) = (3.5 + 7.0 * ix as f64, 3.5 + 7.0 * jy as f64);
            let nudges = [(0.0, 0.0), (0.5, 0.0), (-0.5, 0.0), (0.0, 0.5), (0.0, -0.5)];
            let Some((dx, dy)) = nudges
                .iter()
                .copied()
                .find(|&(dx, dy)| is_free(x + dx, y + dy))
            else {
                anyhow::bail!("no free spot for the beacon near ({x}, {y})");
            };
            x += dx;
            y += dy;
            beacons.push(BeaconSpec {
                id: format!(
                    "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:{}",
                    beacons.len() + 1
                ),
                floor: 0,
                x_m: x,
                y_m: y,
                z_m: 2.8,
                rssi_1m_dbm: -59.0,
                path_loss_exponent: 2.0,
            });
        }
    }
    let spec = SiteSpec {
        format: "fpbp-site".into(),
        version: 1,
        name: "fpbp demo site".into(),
        map_from_enu_rad: 0.0,
        heading_bias_rad: 0.0,
        legend,
        grid_interval_m: 1.0,
        floors: vec![FloorSpec {
            id: 0,
            name: "ground".into(),
            plan: Some("plan.png".into()),
            pixels_per_meter: Some(R),
            target_pixels_per_meter: None,
            open_area_m: None,
            height_m: 0.0,
        }],
        beacons,
        access_points: vec![],
        georef: None,
    };
    let site_path = out.join("site.json");
    std::fs::write(&site_path, spec.to_json_pretty() + "\n")
        .with_context(|| format!("cannot write {}", site_path.display()))?;
    println!(
        "wrote {} ({w} x {h} px) and {} ({} beacons)",
        plan_path.display(),
        site_path.display(),
        spec.beacons.len()
    );
    Ok(())
}
