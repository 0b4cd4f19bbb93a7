//! `fpbp import ilc FLOOR_DIR --out SITE_DIR`: an ILC 2.0 floor
//! (geojson_map.json + floor_info.json) as an fpbp site with a stylized plan
//! in the waypoints' frame. See docs/sites.md for the rule and the checks.

use crate::geojson::{IlcFrame, parse_features};
use crate::raster::{
    CORRIDOR, Grid, LabelGrid, OUTSIDE, UnitKind, floor_map, wall_crossings, write_plan_png,
};
use crate::truth::{ilc_waypoints, list_files};
use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::map::Feature;
use fpbp_core::site::{FloorSpec, Legend, SiteSpec};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `fpbp import ilc`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct IlcImport {
    /// An ILC floor folder: geojson_map.json, floor_info.json, optionally
    /// floor_image.png and path_data_files/ (used for the checks only).
    pub floor_dir: PathBuf,
    /// Output folder: site.json, plan.png, import_report.json.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Resolution r of the generated plan, pixels per metre.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DEFAULT_PIXELS_PER_METER))]
    pub pixels_per_meter: f64,
    /// Floor id written to the site (default: from the folder name, F4 -> 4,
    /// B1 -> -1, else 0).
    #[cfg_attr(feature = "cli", arg(long, allow_hyphen_values = true))]
    pub floor_id: Option<i32>,
}

/// Default r of imported ILC plans: 5 px/m (0.2 m pixels; unit boundaries are
/// one pixel, party walls two). See docs/sites.md.
pub const DEFAULT_PIXELS_PER_METER: f64 = 5.0;

/// Unit names (pinyin, as in the ILC GeoJSON `name`) of units a shopper does
/// not walk into from the corridor: their whole boundary is Wall. See
/// docs/sites.md for the evidence behind the list.
pub const CLOSED_UNIT_NAMES: &[&str] = &[
    "zidongfuti",          // escalator
    "dianti",              // lift
    "huoti",               // goods lift
    "louti",               // stairwell
    "feikaifangquyu",      // non-public area
    "fuzhumian",           // back-of-house area
    "xishoujianfuzhumian", // toilet back-of-house area
];

/// Gaps between unit polygons up to this width are digitising slivers, not
/// corridors (no mall corridor is this narrow), metres.
pub const MAX_SLIVER_M: f64 = 0.5;

/// Figures of one ILC import (also written to import_report.json).
#[derive(Debug, Clone, Serialize)]
pub struct IlcReport {
    pub site_dir: String,
    pub floor_id: i32,
    pub width_m: f64,
    pub height_m: f64,
    /// floor_info.json size minus the GeoJSON bbox size, metres ([dw, dh]).
    pub floor_info_minus_geojson_m: [f64; 2],
    pub width_px: usize,
    pub height_px: usize,
    pub pixels_per_meter: f64,
    pub units: usize,
    pub closed_units: usize,
    /// Corridor pixels relabelled as unit by the sliver rule.
    pub sliver_pixels: usize,
    /// Fractions of plan pixels: walkable, door, wall.
    pub walkable_fraction: f64,
    pub door_fraction: f64,
    pub wall_fraction: f64,
    /// Frame check against floor_image.png (None when the image is absent).
    pub image_check: Option<ImageCheck>,
    /// Waypoint checks (None when path_data_files/ is absent).
    pub waypoint_check: Option<WaypointCheck>,
}

/// Agreement of floor_image.png with the rasterised polygons.
#[derive(Debug, Clone, Serialize)]
pub struct ImageCheck {
    /// Light-blue (unit) image pixels that land inside a unit polygon.
    pub unit_pixels_in_units: f64,
    /// The same with the image flipped vertically (wrong-frame control).
    pub unit_pixels_in_units_flipped: f64,
    /// Transparent image pixels inside the outline that land on corridor.
    pub transparent_pixels_on_corridor: f64,
}

/// Waypoints against the imported plan.
#[derive(Debug, Clone, Serialize)]
pub struct WaypointCheck {
    pub paths: usize,
    pub waypoints: usize,
    /// Fractions of waypoints on corridor, inside a unit, outside the outline.
    pub on_corridor: f64,
    pub in_unit: f64,
    pub outside_outline: f64,
    /// Waypoint-to-waypoint segments, and those crossing at least one Wall.
    pub segments: usize,
    pub segments_crossing_wall: usize,
    /// Total Wall crossings over all segments.
    pub wall_crossings: usize,
    /// Paths with at least one crossing.
    pub paths_crossing_wall: usize,
    /// Segment length walked, metres, and crossings per 100 m.
    pub walked_m: f64,
    pub crossings_per_100m: f64,
}

/// Floor id from an ILC folder name: F4 -> 4, B2 -> -2, else 0.
fn floor_id_from_dir(dir: &Path) -> i32 {
    let name = dir
        .canonicalize()
        .ok()
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_default();
    let num = |s: &str| s.parse::<i32>().ok();
    match name.as_bytes().first() {
        Some(b'F') => num(&name[1..]).unwrap_or(0),
        Some(b'B') => num(&name[1..]).map(|n| -n).unwrap_or(0),
        _ => 0,
    }
}

/// Reads floor_info.json: (width_m, height_m).
fn read_floor_info(path: &Path) -> Result<(f64, f64)> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_slice(&bytes).with_context(|| format!("{}: not JSON", path.display()))?;
    let get = |k: &str| {
        v.get("map_info")
            .and_then(|m| m.get(k))
            .and_then(serde_json::Value::as_f64)
            .filter(|x| x.is_finite() && *x > 0.0)
            .with_context(|| {
                format!(
                    "{}: field `map_info.{k}` missing or not > 0",
                    path.display()
                )
            })
    };
    Ok((get("width")?, get("height")?))
}

/// The kind of a unit from its name: unnamed units (atrium voids, structure
/// and service areas in the ILC plans) and [`CLOSED_UNIT_NAMES`] are Closed,
/// every other (named) unit is an Enterable shop or room.
pub fn unit_kind(name: &str) -> UnitKind {
    let name = name.trim();
    if name.is_empty() || CLOSED_UNIT_NAMES.contains(&name) {
        UnitKind::Closed
    } else {
        UnitKind::Enterable
    }
}

/// Imports one ILC floor; writes site.json, plan.png, import_report.json.
pub fn import(args: &IlcImport) -> Result<IlcReport> {
    let r = args.pixels_per_meter;
    if !(r.is_finite() && (0.5..=100.0).contains(&r)) {
        bail!("--pixels-per-meter {r}: want 0.5..=100");
    }
    let dir = &args.floor_dir;
    let gj_path = dir.join("geojson_map.json");
    let gj = std::fs::read(&gj_path).with_context(|| format!("reading {}", gj_path.display()))?;
    let feats = parse_features(&gj, &gj_path.display().to_string())?;
    let (width_m, height_m) = read_floor_info(&dir.join("floor_info.json"))?;
    let frame = IlcFrame::of(&feats);
    let dw = width_m - frame.width_m;
    let dh = height_m - frame.height_m;
    if dw.abs() > 1.0 || dh.abs() > 1.0 {
        bail!(
            "{}: floor_info.json size {width_m:.3} x {height_m:.3} m differs from the GeoJSON bbox \
             {:.3} x {:.3} m by more than 1 m: not the ILC frame",
            dir.display(),
            frame.width_m,
            frame.height_m
        );
    }
    let outline: Vec<_> = frame.project_feature(&feats[0]);
    let mut units = Vec::new();
    let mut names = Vec::new();
    for f in &feats[1..] {
        for poly in frame.project_feature(f) {
            units.push(poly);
            names.push(f.name.as_str());
        }
    }
    let grid = Grid::covering(width_m, height_m, r);
    let mut labels = LabelGrid::rasterise(grid, &outline, &units);
    let max_gap_px = (MAX_SLIVER_M * r).floor().max(1.0) as usize;
    let sliver_pixels = labels.close_slivers(max_gap_px);
    let kinds: Vec<UnitKind> = names.iter().map(|n| unit_kind(n)).collect();
    let features = labels.features(&kinds);
    let n = features.len() as f64;
    let frac = |f: Feature| features.iter().filter(|&&x| x == f).count() as f64 / n;
    let (walkable_fraction, door_fraction, wall_fraction) = (
        frac(Feature::Walkable),
        frac(Feature::Door),
        frac(Feature::Wall),
    );

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let legend = Legend::default();
    write_plan_png(&args.out.join("plan.png"), &grid, &features, &legend)?;
    let floor_id = args.floor_id.unwrap_or_else(|| floor_id_from_dir(dir));
    let dir_name = |p: &Path| {
        p.canonicalize()
            .ok()
            .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_default()
    };
    let site_name = format!(
        "ILC {}/{} (imported from geojson_map.json; storefront rule; no beacons: run fpbp calibrate)",
        dir.parent().map(dir_name).unwrap_or_default(),
        dir_name(dir)
    );
    let spec = SiteSpec {
        format: "fpbp-site".into(),
        version: 1,
        name: site_name,
        map_from_enu_rad: 0.0,
        heading_bias_rad: 0.0,
        legend,
        grid_interval_m: 1.0,
        floors: vec![FloorSpec {
            id: floor_id,
            name: dir_name(dir),
            plan: Some("plan.png".into()),
            pixels_per_meter: Some(r),
            target_pixels_per_meter: None,
            open_area_m: None,
            height_m: 0.0,
        }],
        beacons: vec![],
        access_points: vec![],
        georef: Some(frame.georef()),
    };
    std::fs::write(
        args.out.join("site.json"),
        serde_json::to_string_pretty(&spec)? + "\n",
    )
    .with_context(|| format!("writing {}", args.out.join("site.json").display()))?;

    let image_path = dir.join("floor_image.png");
    let image_check = if image_path.is_file() {
        Some(check_image(&image_path, &labels, width_m, height_m)?)
    } else {
        None
    };
    let map = floor_map(&grid, features);
    let paths_dir = dir.join("path_data_files");
    let waypoint_check = if paths_dir.is_dir() {
        Some(check_waypoints(&paths_dir, &labels, &map)?)
    } else {
        None
    };
    let report = IlcReport {
        site_dir: args.out.display().to_string(),
        floor_id,
        width_m,
        height_m,
        floor_info_minus_geojson_m: [dw, dh],
        width_px: grid.width_px,
        height_px: grid.height_px,
        pixels_per_meter: r,
        units: units.len(),
        closed_units: kinds.iter().filter(|k| **k == UnitKind::Closed).count(),
        sliver_pixels,
        walkable_fraction,
        door_fraction,
        wall_fraction,
        image_check,
        waypoint_check,
    };
    std::fs::write(
        args.out.join("import_report.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )?;
    Ok(report)
}

/// Label at an MCS point (OUTSIDE beyond the grid).
fn label_at(labels: &LabelGrid, p: Vec2) -> u32 {
    let g = &labels.grid;
    let i = (p.x * g.pixels_per_meter).floor();
    let j = (g.height_px as f64 - p.y * g.pixels_per_meter).floor();
    if i < 0.0 || j < 0.0 || i >= g.width_px as f64 || j >= g.height_px as f64 {
        return OUTSIDE;
    }
    labels.labels[j as usize * g.width_px + i as usize]
}

/// Compares floor_image.png with the label grid (see [`ImageCheck`]).
fn check_image(path: &Path, labels: &LabelGrid, width_m: f64, height_m: f64) -> Result<ImageCheck> {
    let img = image::open(path)
        .with_context(|| format!("reading {}", path.display()))?
        .to_rgba8();
    let (w, h) = (img.width() as f64, img.height() as f64);
    let (mut blue, mut blue_in, mut blue_in_flip) = (0usize, 0usize, 0usize);
    let (mut clear, mut clear_on_corridor) = (0usize, 0usize);
    for (u, v, px) in img.enumerate_pixels() {
        let x = (u as f64 + 0.5) / w * width_m;
        let y = (1.0 - (v as f64 + 0.5) / h) * height_m;
        let p = Vec2::new(x, y);
        let [r, g, b, a] = px.0;
        let is_blue =
            a > 200 && r.abs_diff(195) <= 8 && g.abs_diff(235) <= 8 && b.abs_diff(245) <= 8;
        let l = label_at(labels, p);
        if is_blue {
            blue += 1;
            blue_in += usize::from(l >= 2);
            blue_in_flip += usize::from(label_at(labels, Vec2::new(x, height_m - y)) >= 2);
        } else if a == 0 && l != OUTSIDE {
            clear += 1;
            clear_on_corridor += usize::from(l == CORRIDOR);
        }
    }
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    Ok(ImageCheck {
        unit_pixels_in_units: ratio(blue_in, blue),
        unit_pixels_in_units_flipped: ratio(blue_in_flip, blue),
        transparent_pixels_on_corridor: ratio(clear_on_corridor, clear),
    })
}

/// Waypoint positions and wall crossings over every path of the floor.
fn check_waypoints(
    paths_dir: &Path,
    labels: &LabelGrid,
    map: &fpbp_core::map::FloorMap,
) -> Result<WaypointCheck> {
    let files = list_files(paths_dir, &[".txt", ".txt.gz"])?;
    let mut c = WaypointCheck {
        paths: 0,
        waypoints: 0,
        on_corridor: 0.0,
        in_unit: 0.0,
        outside_outline: 0.0,
        segments: 0,
        segments_crossing_wall: 0,
        wall_crossings: 0,
        paths_crossing_wall: 0,
        walked_m: 0.0,
        crossings_per_100m: 0.0,
    };
    let (mut corr, mut unit, mut out) = (0usize, 0usize, 0usize);
    for f in &files {
        let wps = ilc_waypoints(f)?;
        c.paths += 1;
        let mut path_crossings = 0;
        for w in &wps {
            match label_at(labels, Vec2::new(w.x_m, w.y_m)) {
                OUTSIDE => out += 1,
                CORRIDOR => corr += 1,
                _ => unit += 1,
            }
        }
        for s in wps.windows(2) {
            let a = Vec2::new(s[0].x_m, s[0].y_m);
            let b = Vec2::new(s[1].x_m, s[1].y_m);
            let k = wall_crossings(map, a, b);
            c.segments += 1;
            c.walked_m += (b - a).norm();
            c.wall_crossings += k;
            c.segments_crossing_wall += usize::from(k > 0);
            path_crossings += k;
        }
        c.paths_crossing_wall += usize::from(path_crossings > 0);
    }
    c.waypoints = corr + unit + out;
    let n = c.waypoints.max(1) as f64;
    c.on_corridor = corr as f64 / n;
    c.in_unit = unit as f64 / n;
    c.outside_outline = out as f64 / n;
    c.crossings_per_100m = if c.walked_m > 0.0 {
        100.0 * c.wall_crossings as f64 / c.walked_m
    } else {
        0.0
    };
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::geo::EARTH_RADIUS_M;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fpbp-import-ilc-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// Degrees of longitude / latitude per metre at 30 deg N (mid latitude).
    fn deg(x_m: f64, y_m: f64) -> [f64; 2] {
        let k = std::f64::consts::PI / 180.0 * EARTH_RADIUS_M;
        let lat_mid = 30.0 + 20.0 / k / 2.0;
        [
            120.0 + x_m / (k * lat_mid.to_radians().cos()),
            30.0 + y_m / k,
        ]
    }

    fn ring(pts: &[(f64, f64)]) -> String {
        let v: Vec<String> = pts
            .iter()
            .map(|&(x, y)| {
                let d = deg(x, y);
                format!("[{},{}]", d[0], d[1])
            })
            .collect();
        format!("[{}]", v.join(","))
    }

    /// A two-polygon GeoJSON: an L-shaped 40 x 20 m outline and one named
    /// shop (x 10..20, y 10..20) in its corner, fronts to the south and west,
    /// walls to the north and east (the outline); one trace walking along the
    /// corridor and into the shop through its front, one leaving it through
    /// its east wall.
    #[test]
    fn imports_a_two_polygon_floor() {
        let dir = tmp("two").join("F2");
        std::fs::create_dir_all(dir.join("path_data_files")).unwrap();
        // L-shaped outline: the notch x 20..40, y 10..20 is outside.
        let outline = ring(&[
            (0.0, 0.0),
            (40.0, 0.0),
            (40.0, 10.0),
            (20.0, 10.0),
            (20.0, 20.0),
            (0.0, 20.0),
            (0.0, 0.0),
        ]);
        let shop = ring(&[(10.0, 10.0), (20.0, 10.0), (20.0, 20.0), (10.0, 20.0)]);
        let gj = format!(
            r#"{{"type":"FeatureCollection","features":[
              {{"type":"Feature","properties":{{}},"geometry":{{"type":"MultiPolygon","coordinates":[[{outline}]]}}}},
              {{"type":"Feature","properties":{{"name":"SHOP"}},"geometry":{{"type":"Polygon","coordinates":[{shop}]}}}}]}}"#
        );
        std::fs::write(dir.join("geojson_map.json"), gj).unwrap();
        std::fs::write(
            dir.join("floor_info.json"),
            r#"{"map_info":{"height":20.0,"width":40.0}}"#,
        )
        .unwrap();
        std::fs::write(
            dir.join("path_data_files/a.txt"),
            "1\tTYPE_WAYPOINT\t2.0\t5.0\n2\tTYPE_WAYPOINT\t15.0\t5.0\n3\tTYPE_WAYPOINT\t15.0\t15.0\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("path_data_files/b.txt"),
            "1\tTYPE_WAYPOINT\t15.0\t15.0\n2\tTYPE_WAYPOINT\t30.0\t5.0\n",
        )
        .unwrap();
        let out = dir.parent().unwrap().join("site");
        let rep = import(&IlcImport {
            floor_dir: dir.clone(),
            out: out.clone(),
            pixels_per_meter: 5.0,
            floor_id: None,
        })
        .unwrap();
        assert_eq!(rep.floor_id, 2, "from the folder name F2");
        assert_eq!(
            (rep.width_px, rep.height_px, rep.units, rep.closed_units),
            (200, 100, 1, 0)
        );
        assert!(rep.floor_info_minus_geojson_m[0].abs() < 1e-6);
        let w = rep.waypoint_check.clone().unwrap();
        assert_eq!((w.paths, w.waypoints, w.segments), (2, 5, 3));
        // Into the shop through its front: free; out through its side wall: one crossing.
        assert_eq!(
            (
                w.segments_crossing_wall,
                w.wall_crossings,
                w.paths_crossing_wall
            ),
            (1, 1, 1)
        );
        assert!(
            (w.in_unit - 0.4).abs() < 1e-9,
            "2 of 5 waypoints in the shop"
        );
        // The plan: shop fronts red, back walls black, outside the outline black.
        let img = image::open(out.join("plan.png")).unwrap().to_rgb8();
        let px = |x: f64, y: f64| img.get_pixel((x * 5.0) as u32, ((20.0 - y) * 5.0) as u32).0;
        assert_eq!(px(15.0, 10.1), [255, 0, 0]);
        assert_eq!(px(10.1, 15.0), [255, 0, 0]);
        assert_eq!(px(19.9, 15.0), [0, 0, 0]);
        assert_eq!(px(15.0, 19.9), [0, 0, 0]);
        assert_eq!(px(30.0, 15.0), [0, 0, 0]);
        assert_eq!(px(15.0, 15.0), [255, 255, 255]);
        assert_eq!(px(30.0, 5.0), [255, 255, 255]);
        let spec: SiteSpec =
            serde_json::from_str(&std::fs::read_to_string(out.join("site.json")).unwrap()).unwrap();
        assert_eq!(spec.floors[0].plan.as_deref(), Some("plan.png"));
        assert_eq!(spec.floors[0].pixels_per_meter, Some(5.0));
        assert!(spec.beacons.is_empty() && spec.map_from_enu_rad == 0.0);
        // An unnamed unit is closed: its front becomes a wall.
        let gj2 = std::fs::read_to_string(dir.join("geojson_map.json"))
            .unwrap()
            .replace("SHOP", "");
        std::fs::write(dir.join("geojson_map.json"), gj2).unwrap();
        let rep = import(&IlcImport {
            floor_dir: dir.clone(),
            out: out.clone(),
            pixels_per_meter: 5.0,
            floor_id: Some(-3),
        })
        .unwrap();
        assert_eq!((rep.floor_id, rep.closed_units), (-3, 1));
        assert_eq!(rep.waypoint_check.unwrap().wall_crossings, 2);
        // A floor_info.json that does not match the GeoJSON is refused.
        std::fs::write(
            dir.join("floor_info.json"),
            r#"{"map_info":{"height":30.0,"width":40.0}}"#,
        )
        .unwrap();
        let e = import(&IlcImport {
            floor_dir: dir.clone(),
            out,
            pixels_per_meter: 5.0,
            floor_id: None,
        });
        assert!(format!("{:#}", e.unwrap_err()).contains("not the ILC frame"));
        std::fs::remove_dir_all(dir.parent().unwrap()).ok();
    }

    /// The real ILC floors, regenerated from ../shared/datasets: the frame
    /// agrees with floor_image.png and the waypoints, and waypoint-to-waypoint
    /// walks rarely cross a wall.
    #[test]
    fn imports_the_real_ilc_floors() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets/ilc");
        if !data.is_dir() {
            println!("skipped: ../shared/datasets not found");
            return;
        }
        let out = tmp("real");
        for (floor, id, paths) in [("site2/F4", 4, 26), ("site1/F1", 1, 106)] {
            let rep = import(&IlcImport {
                floor_dir: data.join(floor),
                out: out.join(floor),
                pixels_per_meter: DEFAULT_PIXELS_PER_METER,
                floor_id: None,
            })
            .unwrap();
            assert_eq!(rep.floor_id, id);
            let ic = rep.image_check.clone().unwrap();
            assert!(
                ic.unit_pixels_in_units > 0.99 && ic.unit_pixels_in_units_flipped < 0.5,
                "{ic:?}"
            );
            assert!(ic.transparent_pixels_on_corridor > 0.95, "{ic:?}");
            let w = rep.waypoint_check.clone().unwrap();
            assert_eq!(w.paths, paths);
            assert!(w.on_corridor > 0.95, "{floor}: {w:?}");
            assert!(
                w.segments_crossing_wall * 50 <= w.segments,
                "{floor}: {w:?} (more than 2 %)"
            );
            // The site loads and validates with the project's loader (Site::build).
            let site =
                fpbp_core::site::files::load_site(&out.join(floor).join("site.json")).unwrap();
            let map = site.floor(id).unwrap();
            assert_eq!(
                (map.width_px(), map.height_px()),
                (rep.width_px, rep.height_px)
            );
            assert_eq!(map.build_report().unclassified_count, 0);
            assert!(
                map.rooms().len() > 20,
                "shops are rooms: {}",
                map.rooms().len()
            );
        }
        std::fs::remove_dir_all(&out).ok();
    }
}
