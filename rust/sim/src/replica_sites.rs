//! The replica testbeds of the five papers (issue 18): one stylized plan and
//! site.json per paper, drawn from what each paper states (area, layout,
//! beacon count, spacing and height, path-loss figures). Written by
//! `cargo run -p fpbp-cli --example make_replica_sites -- maps` into
//! maps/replica-<paper>/; the walks and radio channel are the simulator
//! profiles `replica-<paper>` (crate::replica). Every choice the papers
//! leave open is listed in docs/reproduction.md. Deterministic: the files
//! are pinned by rust/cli/tests/replicas.rs.

use anyhow::{Context, bail};
use fpbp_core::Vec2;
use fpbp_core::site::{BeaconSpec, FloorSpec, Legend, SiteSpec};

use crate::plan_draw::{Block, Drawing, Stroke, is_walkable, seg};

/// The replica names, in `fpbp reproduce all` order.
pub const REPLICAS: &[&str] = &["fpbp", "prox-pf", "ppsa", "bmw", "tc"];

/// One replica: its plan(s) and site spec.
pub struct Replica {
    /// Folder name under maps/ (`replica-<name>`).
    pub dir: String,
    /// One rendered plan per distinct plan file (all floors share `plan.png`).
    pub plan: image::RgbImage,
    pub spec: SiteSpec,
}

fn block(x0: f64, y0: f64, x1: f64, y1: f64) -> Block {
    Block { x0, y0, x1, y1 }
}

/// A horizontal door of width `w` centred at (cx, y).
fn door_h(cx: f64, y: f64, w: f64) -> Stroke {
    seg(cx - w / 2.0, y, cx + w / 2.0, y)
}

/// A vertical door of height `w` centred at (x, cy).
fn door_v(x: f64, cy: f64, w: f64) -> Stroke {
    seg(x, cy - w / 2.0, x, cy + w / 2.0)
}

/// The outer boundary, inset by half a wall so the band lies in the image.
fn boundary(w: f64, h: f64, wall: f64) -> Vec<Stroke> {
    let e = wall / 2.0;
    vec![
        seg(e, e, w - e, e),
        seg(e, h - e, w - e, h - e),
        seg(e, e, e, h - e),
        seg(w - e, e, w - e, h - e),
    ]
}

/// A beacon spec; ids are iBeacon minors 1, 2, ... with one UUID per replica.
struct BeaconDraft {
    floor: i32,
    x_m: f64,
    y_m: f64,
    z_m: f64,
    rssi_1m_dbm: f64,
    path_loss_exponent: f64,
}

fn site_spec(
    name: &str,
    uuid: &str,
    ppm: f64,
    floors: &[(i32, &str, f64)],
    beacons: Vec<BeaconDraft>,
) -> SiteSpec {
    SiteSpec {
        format: "fpbp-site".into(),
        version: 1,
        name: name.into(),
        map_from_enu_rad: 0.0,
        heading_bias_rad: 0.0,
        legend: Legend::default(),
        grid_interval_m: 1.0,
        floors: floors
            .iter()
            .map(|&(id, fname, height_m)| FloorSpec {
                id,
                name: fname.into(),
                plan: Some("plan.png".into()),
                pixels_per_meter: Some(ppm),
                target_pixels_per_meter: None,
                open_area_m: None,
                height_m,
            })
            .collect(),
        beacons: beacons
            .into_iter()
            .enumerate()
            .map(|(k, b)| BeaconSpec {
                id: format!("ibeacon:{uuid}:1:{}", k + 1),
                floor: b.floor,
                x_m: b.x_m,
                y_m: b.y_m,
                z_m: b.z_m,
                rssi_1m_dbm: b.rssi_1m_dbm,
                path_loss_exponent: b.path_loss_exponent,
            })
            .collect(),
        access_points: Vec::new(),
        georef: None,
    }
}

/// Moves a lattice point off obstacles (first free of a few nudges).
fn nudge(img: &image::RgbImage, ppm: f64, x: f64, y: f64) -> anyhow::Result<(f64, f64)> {
    let legend = Legend::default();
    let nudges = [
        (0.0, 0.0),
        (0.5, 0.0),
        (-0.5, 0.0),
        (0.0, 0.5),
        (0.0, -0.5),
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
    ];
    nudges
        .iter()
        .map(|&(dx, dy)| (x + dx, y + dy))
        .find(|&(a, b)| is_walkable(img, &legend, ppm, a, b))
        .with_context(|| format!("no free spot for a beacon near ({x}, {y})"))
}

/// FP-BP (Pan et al.): "a public area with a total area of over 5,000 m^2
/// in a building", ceiling beacons dense enough for the candidate set
/// G'_1 (eq. 20: the user always inside the hull of the strongest beacons).
/// 100 x 50 m: a 4 m corridor, a hall with pillars and two doors, eight
/// rooms (one diagonal wall, one partial partition), a cross corridor;
/// 0.3 m walls, 1.2 m doors, 200 beacons on a 5 m lattice at 3 m.
pub fn fpbp() -> anyhow::Result<Replica> {
    let (w, h, ppm, wall) = (100.0, 50.0, 10.0, 0.3);
    let mut walls = boundary(w, h, wall);
    walls.extend([
        // corridor y 22-26, the cross corridor x 45-49 below it
        seg(0.0, 22.0, 45.0, 22.0),
        seg(49.0, 22.0, w, 22.0),
        seg(0.0, 26.0, w, 26.0),
        seg(45.0, 0.0, 45.0, 22.0),
        seg(49.0, 0.0, 49.0, 22.0),
        // bottom rooms: a straight and a diagonal divider left, a wall and a
        // partial partition right
        seg(20.0, 0.0, 20.0, 22.0),
        seg(32.0, 0.0, 38.0, 22.0),
        seg(75.0, 0.0, 75.0, 22.0),
        seg(62.0, 0.0, 62.0, 12.0),
        // top: the hall x 0-40, four rooms
        seg(40.0, 26.0, 40.0, h),
        seg(55.0, 26.0, 55.0, h),
        seg(70.0, 26.0, 70.0, h),
        seg(85.0, 26.0, 85.0, h),
    ]);
    let diag_a = Vec2::new(32.0, 0.0);
    let diag_u = (Vec2::new(38.0, 22.0) - diag_a).normalize();
    let doors = vec![
        door_h(8.6, 22.0, 1.2),
        door_h(26.6, 22.0, 1.2),
        door_h(40.6, 22.0, 1.2),
        door_h(60.6, 22.0, 1.2),
        door_h(86.6, 22.0, 1.2),
        door_h(13.0, 26.0, 2.0),
        door_h(31.0, 26.0, 2.0),
        door_h(46.6, 26.0, 1.2),
        door_h(61.6, 26.0, 1.2),
        door_h(76.6, 26.0, 1.2),
        door_h(91.6, 26.0, 1.2),
        door_v(45.0, 10.6, 1.2),
        door_v(49.0, 15.6, 1.2),
        door_v(75.0, 6.6, 1.2),
        Stroke::Seg {
            a: diag_a + diag_u * 11.0,
            b: diag_a + diag_u * 12.2,
        },
    ];
    let mut blocks = Vec::new();
    for (x, y) in [(10.0, 36.0), (20.0, 36.0), (30.0, 36.0), (10.0, 43.0)] {
        blocks.push(block(x - 0.5, y - 0.5, x + 0.5, y + 0.5));
    }
    let d = Drawing {
        width_m: w,
        height_m: h,
        pixels_per_meter: ppm,
        wall_m: wall,
        walls,
        doors,
        blocks,
        openings: Vec::new(),
    };
    let img = d.render(&Legend::default());
    let mut beacons = Vec::new();
    for j in 0..10 {
        for i in 0..20 {
            let (x, y) = nudge(&img, ppm, 2.5 + 5.0 * i as f64, 2.5 + 5.0 * j as f64)?;
            beacons.push(BeaconDraft {
                floor: 0,
                x_m: x,
                y_m: y,
                z_m: 3.0,
                rssi_1m_dbm: -59.0,
                path_loss_exponent: 2.0,
            });
        }
    }
    Ok(Replica {
        dir: "replica-fpbp".into(),
        spec: site_spec(
            "replica of the FP-BP testbed (Pan et al.)",
            "F0B0F0B0-0000-4000-8000-000000000001",
            ppm,
            &[(0, "ground", 0.0)],
            beacons,
        ),
        plan: img,
    })
}

/// The centre line of the proximity-PF walking course: 70 m with six turns
/// (Momose et al., Sec. IV-A, Fig. 6), MCS metres; the replica walk's route
/// (`crate::replica`, profile `replica-prox-pf-1`) is the one source.
pub fn prox_pf_course() -> Vec<[f64; 2]> {
    crate::replica::replica_profile("replica-prox-pf-1")
        .map(|p| p.walk.waypoints_m)
        .unwrap_or_default()
}

/// Point at arc length `s` along a polyline.
fn along(poly: &[[f64; 2]], mut s: f64) -> (Vec2, Vec2) {
    for w in poly.windows(2) {
        let (a, b) = (Vec2::new(w[0][0], w[0][1]), Vec2::new(w[1][0], w[1][1]));
        let l = (b - a).norm();
        if s <= l + 1e-9 {
            let u = (b - a) / l;
            return (a + u * s.min(l), u);
        }
        s -= l;
    }
    let n = poly.len();
    let (a, b) = (
        Vec2::new(poly[n - 2][0], poly[n - 2][1]),
        Vec2::new(poly[n - 1][0], poly[n - 1][1]),
    );
    (b, (b - a).normalize())
}

/// Proximity PF (Momose et al.): building No. 55, Nishi-Waseda; a 70 m
/// course with six turns, 9 beacons along it, floor-mounted as in the
/// paper's preliminary experiment (phone at breast height, 1 m above).
/// 40 x 18 m: 2.4 m corridors along the course, three rooms off them (one
/// door each), everything else an un-enterable grey block (Fig. 6).
pub fn prox_pf() -> anyhow::Result<Replica> {
    let (w, h, ppm, wall) = (40.0, 18.0, 10.0, 0.3);
    let half = 1.2;
    let course = prox_pf_course();
    if course.len() < 2 {
        bail!("the proximity-PF course has no route");
    }
    let mut openings = Vec::new();
    for s in course.windows(2) {
        let (x0, x1) = (s[0][0].min(s[1][0]), s[0][0].max(s[1][0]));
        let (y0, y1) = (s[0][1].min(s[1][1]), s[0][1].max(s[1][1]));
        openings.push(block(x0 - half, y0 - half, x1 + half, y1 + half));
    }
    // rooms, 0.3 m from the corridors (the wall between), one door each
    openings.push(block(4.5, 5.0, 11.5, 10.0));
    openings.push(block(15.5, 4.5, 23.5, 10.5));
    openings.push(block(26.5, 4.5, 34.5, 16.5));
    let doors = vec![
        door_v(4.35, 7.5, 1.0),
        door_h(19.5, 4.35, 1.0),
        door_v(26.35, 8.5, 1.0),
    ];
    let d = Drawing {
        width_m: w,
        height_m: h,
        pixels_per_meter: ppm,
        wall_m: wall,
        walls: boundary(w, h, wall),
        doors,
        blocks: vec![block(0.0, 0.0, w, h)],
        openings,
    };
    let img = d.render(&Legend::default());
    // 9 beacons every 70 / 8 m along the course, 0.9 m to its left side
    let mut beacons = Vec::new();
    for k in 0..9 {
        let (p, u) = along(&course, 70.0 * k as f64 / 8.0);
        let q = p + Vec2::new(-u.y, u.x) * 0.9;
        let (x, y) = nudge(&img, ppm, q.x, q.y)?;
        beacons.push(BeaconDraft {
            floor: 0,
            x_m: x,
            y_m: y,
            z_m: 0.0,
            rssi_1m_dbm: -59.0,
            path_loss_exponent: 2.0,
        });
    }
    Ok(Replica {
        dir: "replica-prox-pf".into(),
        spec: site_spec(
            "replica of the proximity-PF testbed (Momose et al.)",
            "F0B0F0B0-0000-4000-8000-000000000002",
            ppm,
            &[(0, "floor", 0.0)],
            beacons,
        ),
        plan: img,
    })
}

/// PPSA Table 1: the 32 beacon coordinates, metres (23 and 26 are printed
/// with the same coordinates; both are kept).
pub const PPSA_TABLE_1: [[f64; 2]; 32] = [
    [63.8, 30.5],
    [63.8, 38.5],
    [63.8, 44.5],
    [63.8, 50.0],
    [63.8, 55.6],
    [63.8, 59.9],
    [63.8, 63.2],
    [55.8, 63.6],
    [63.8, 66.6],
    [63.8, 71.3],
    [68.0, 71.3],
    [63.8, 76.5],
    [63.8, 82.0],
    [63.8, 87.5],
    [71.7, 86.8],
    [76.1, 87.5],
    [76.1, 83.1],
    [69.8, 81.2],
    [68.8, 76.5],
    [71.9, 76.5],
    [68.8, 38.5],
    [47.7, 50.0],
    [51.5, 51.4],
    [60.2, 49.1],
    [47.5, 53.8],
    [51.5, 51.4],
    [59.1, 54.0],
    [72.9, 53.6],
    [69.4, 53.6],
    [69.4, 49.8],
    [72.9, 50.6],
    [70.5, 38.6],
];

/// PPSA (Sun et al.): the ninth floor of the BUPT research building, 32
/// ceiling beacons at the Table 1 coordinates (about 6 m apart), RSSI at 1 m
/// -55 dBm and n = 2.7 (Table 3). The plan keeps Table 1's coordinates: a
/// 3 m corridor along x = 63.8 (y 28-90), rooms west (x 44-62.3) and east
/// (x 65.3-80), one door per room; outside the floor is solid.
pub fn ppsa() -> anyhow::Result<Replica> {
    let (w, h, ppm, wall) = (84.0, 94.0, 10.0, 0.3);
    let (xw, xe) = (62.3, 65.3);
    let mut walls = vec![
        seg(44.0, 28.0, 80.0, 28.0),
        seg(44.0, 90.0, 80.0, 90.0),
        seg(44.0, 28.0, 44.0, 90.0),
        seg(80.0, 28.0, 80.0, 90.0),
        seg(xw, 28.0, xw, 90.0),
        seg(xe, 28.0, xe, 90.0),
    ];
    let west = [28.0, 36.0, 44.0, 48.0, 56.0, 64.0, 72.0, 80.0, 90.0];
    let east = [28.0, 36.0, 44.0, 48.0, 56.0, 62.0, 74.0, 84.0, 90.0];
    let mut doors = Vec::new();
    for r in west.windows(2) {
        walls.push(seg(44.0, r[1], xw, r[1]));
        doors.push(door_v(xw, (r[0] + r[1]) / 2.0, 1.0));
    }
    for r in east.windows(2) {
        walls.push(seg(xe, r[1], 80.0, r[1]));
        doors.push(door_v(xe, (r[0] + r[1]) / 2.0, 1.0));
    }
    let d = Drawing {
        width_m: w,
        height_m: h,
        pixels_per_meter: ppm,
        wall_m: wall,
        walls,
        doors,
        blocks: vec![block(0.0, 0.0, w, h)],
        openings: vec![block(44.0, 28.0, 80.0, 90.0)],
    };
    let img = d.render(&Legend::default());
    let legend = Legend::default();
    let mut beacons = Vec::new();
    for (k, p) in PPSA_TABLE_1.iter().enumerate() {
        if !is_walkable(&img, &legend, ppm, p[0], p[1]) {
            bail!(
                "PPSA beacon {} at ({}, {}) is not on walkable space",
                k + 1,
                p[0],
                p[1]
            );
        }
        beacons.push(BeaconDraft {
            floor: 0,
            x_m: p[0],
            y_m: p[1],
            z_m: 2.8,
            rssi_1m_dbm: -55.0,
            path_loss_exponent: 2.7,
        });
    }
    Ok(Replica {
        dir: "replica-ppsa".into(),
        spec: site_spec(
            "replica of the PPSA testbed (BUPT research building, 9th floor)",
            "F0B0F0B0-0000-4000-8000-000000000003",
            ppm,
            &[(0, "9th floor", 0.0)],
            beacons,
        ),
        plan: img,
    })
}

/// BMW (robust EKF): two adjacent floors, 11 anchors (CC2540, 0 dBm,
/// 10 Hz), 514 reference points at 0.6 m. 34 x 16 m per floor: a corridor
/// loop 2.4 m wide around a solid core (182 m^2 of corridor = 507 points at
/// 0.6 m), a staircase room with a door; anchors 1-6 on floor 0, 7-11 on
/// floor 1, 2.6 m up.
pub fn bmw() -> anyhow::Result<Replica> {
    let (w, h, ppm, wall) = (34.0, 16.0, 10.0, 0.3);
    let openings = vec![
        block(1.8, 1.8, 32.2, 4.2),
        block(1.8, 11.8, 32.2, 14.2),
        block(1.8, 1.8, 4.2, 14.2),
        block(29.8, 1.8, 32.2, 14.2),
        block(14.0, 4.5, 20.0, 11.5),
    ];
    let d = Drawing {
        width_m: w,
        height_m: h,
        pixels_per_meter: ppm,
        wall_m: wall,
        walls: boundary(w, h, wall),
        doors: vec![door_h(17.0, 4.35, 1.0)],
        blocks: vec![block(0.0, 0.0, w, h)],
        openings,
    };
    let img = d.render(&Legend::default());
    let floor0 = [
        (3.0, 3.0),
        (17.0, 3.0),
        (31.0, 3.0),
        (31.0, 13.0),
        (17.0, 13.0),
        (3.0, 13.0),
    ];
    let floor1 = [
        (3.0, 8.0),
        (10.0, 13.0),
        (24.0, 13.0),
        (31.0, 8.0),
        (17.0, 3.0),
    ];
    let mut beacons = Vec::new();
    for (floor, pts) in [(0, &floor0[..]), (1, &floor1[..])] {
        for &(x, y) in pts {
            let (x, y) = nudge(&img, ppm, x, y)?;
            beacons.push(BeaconDraft {
                floor,
                x_m: x,
                y_m: y,
                z_m: 2.6,
                rssi_1m_dbm: -60.0,
                path_loss_exponent: 2.2,
            });
        }
    }
    Ok(Replica {
        dir: "replica-bmw".into(),
        spec: site_spec(
            "replica of the BMW testbed (two adjacent floors)",
            "F0B0F0B0-0000-4000-8000-000000000004",
            ppm,
            &[(0, "lower floor", 0.0), (1, "upper floor", 3.5)],
            beacons,
        ),
        plan: img,
    })
}

/// x of the TC replica's lampposts and canopy columns.
pub const TC_LAMPPOSTS_X: [f64; 4] = [10.0, 74.0, 138.0, 202.0];
pub const TC_COLUMNS_X: [f64; 3] = [42.0, 106.0, 170.0];

/// TC BLE/GNSS/PDR (Wang et al.): an urban route past lampposts and canopy
/// columns, weak-signal transmitters (TP -20 dBm, 2.5 m up, one in front
/// and one behind along the road) on every lamppost and column,
/// strong-signal ones (TP +4 dBm, 4 m up, two) on every lamppost; about 32
/// m between structures (5 lampposts and 7 columns on 380 m). 220 x 24 m
/// at 5 px/m, 0.4 m walls: a building along the north side (solid), the
/// road's kerb along the south, lampposts at the kerb (y 2), canopy
/// columns on the other side of the 3.6 m walkway (y 5.6); 4 lampposts, 3
/// columns: 14 weak and 8 strong transmitters.
pub fn tc() -> anyhow::Result<Replica> {
    let (w, h, ppm, wall) = (220.0, 24.0, 5.0, 0.4);
    let mut blocks = vec![block(0.0, 18.0, w, h)];
    for &x in &TC_LAMPPOSTS_X {
        blocks.push(block(x - 0.2, 1.8, x + 0.2, 2.2));
    }
    for &x in &TC_COLUMNS_X {
        blocks.push(block(x - 0.3, 5.3, x + 0.3, 5.9));
    }
    let d = Drawing {
        width_m: w,
        height_m: h,
        pixels_per_meter: ppm,
        wall_m: wall,
        walls: boundary(w, h, wall),
        doors: Vec::new(),
        blocks,
        openings: Vec::new(),
    };
    let img = d.render(&Legend::default());
    let mut beacons = Vec::new();
    let weak = |x: f64, y: f64| BeaconDraft {
        floor: 0,
        x_m: x,
        y_m: y,
        z_m: 2.5,
        rssi_1m_dbm: -79.0,
        path_loss_exponent: 2.0,
    };
    for &x in &TC_LAMPPOSTS_X {
        for dx in [-0.6, 0.6] {
            beacons.push(weak(x + dx, 2.0));
        }
    }
    for &x in &TC_COLUMNS_X {
        for dx in [-0.7, 0.7] {
            beacons.push(weak(x + dx, 5.6));
        }
    }
    for &x in &TC_LAMPPOSTS_X {
        for dy in [-0.5, 0.5] {
            beacons.push(BeaconDraft {
                floor: 0,
                x_m: x,
                y_m: 2.0 + dy,
                z_m: 4.0,
                rssi_1m_dbm: -55.0,
                path_loss_exponent: 2.0,
            });
        }
    }
    let legend = Legend::default();
    for b in &beacons {
        if !is_walkable(&img, &legend, ppm, b.x_m, b.y_m) {
            bail!(
                "TC beacon at ({}, {}) is not on walkable space",
                b.x_m,
                b.y_m
            );
        }
    }
    Ok(Replica {
        dir: "replica-tc".into(),
        spec: site_spec(
            "replica of the TC BLE/GNSS/PDR route (Hong Kong, semi-outdoor)",
            "F0B0F0B0-0000-4000-8000-000000000005",
            ppm,
            &[(0, "street level", 0.0)],
            beacons,
        ),
        plan: img,
    })
}

/// Builds replica `name` (one of [`REPLICAS`]).
pub fn build(name: &str) -> anyhow::Result<Replica> {
    match name {
        "fpbp" => fpbp(),
        "prox-pf" => prox_pf(),
        "ppsa" => ppsa(),
        "bmw" => bmw(),
        "tc" => tc(),
        other => bail!("unknown replica `{other}` (known: {})", REPLICAS.join(", ")),
    }
}
