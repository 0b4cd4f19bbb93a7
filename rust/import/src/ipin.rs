//! `fpbp import ipin DATASET_DIR --out SITE_DIR`: the IPIN 2023 Track 3
//! building (Museum Industriekultur, Nuremberg) as an fpbp site: floors 0, -1,
//! -2 in one MCS (the .cal image frame), their heights from the barometer,
//! the six beacons, the mezzanine plan and open-floor plans bounded by the
//! surveyed area where no image exists. See docs/sites.md.

use crate::raster::{Grid, floor_map, write_plan_png};
use crate::truth::{PosiAndPressure, ipin_posi_and_pressure, list_files};
use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::map::Feature;
use fpbp_core::site::{BeaconSpec, FloorSpec, GeoRef, Legend, SiteSpec};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Arguments of `fpbp import ipin`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct IpinImport {
    /// The IPIN 2023 folder: BLE_Locations.csv, maps/*.cal (+ the floor
    /// images it names that exist), logs/*.txt[.gz] (truth and pressure).
    pub dataset_dir: PathBuf,
    /// Output folder: site.json, plan_<floor>.png, import_report.json.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
    /// Resolution r of the generated plans, pixels per metre.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 10.0))]
    pub pixels_per_meter: f64,
    /// Margin around the surveyed area of an open floor, metres.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DEFAULT_OPEN_MARGIN_M))]
    pub open_margin_m: f64,
}

/// Margin added around the bounding box of the truth points and beacons of
/// a floor without an image, metres.
pub const DEFAULT_OPEN_MARGIN_M: f64 = 3.0;

/// iBeacon UUID of the six IPIN 2023 beacons (major 1, minor 1..6).
pub const IPIN_BEACON_UUID: &str = "11111111-1111-BEAC-2023-111111111111";

/// RSSI at 1 m of the imported beacons, dBm. See docs/sites.md.
pub const DEFAULT_RSSI_1M_DBM: f64 = -67.0;
/// Path-loss exponent of the imported beacons. See docs/sites.md.
pub const DEFAULT_PATH_LOSS_EXPONENT: f64 = 1.6;

/// Scale height R_d T / g of the hypsometric equation at 15 degC, metres:
/// dh = H ln(p_ref / p).
pub const SCALE_HEIGHT_M: f64 = 287.05 * 288.15 / 9.80665;

/// One column of the organisers' .cal file.
#[derive(Debug, Clone, PartialEq)]
pub struct CalEntry {
    pub image: String,
    pub floor: i32,
    pub building: i32,
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Rotation of the image to geometric north, degrees (image up points
    /// `-rotation_deg` ... see the module doc of docs/sites.md).
    pub rotation_deg: f64,
    /// Metres per pixel.
    pub scale_m_per_px: f64,
}

/// Parses a .cal file: `%` comment lines, then 7 whitespace-separated rows
/// (image, floor, building, lat, lon, rotation deg, scale m/px), one column
/// per floor image.
pub fn parse_cal(text: &str, file: &str) -> Result<Vec<CalEntry>> {
    let rows: Vec<(usize, Vec<&str>)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with('%') && !l.trim().is_empty())
        .map(|(n, l)| (n + 1, l.split_whitespace().collect()))
        .collect();
    if rows.len() < 7 {
        bail!(
            "{file}: {} data rows, want 7 (image, floor, building, lat, lon, rotation, scale)",
            rows.len()
        );
    }
    let n = rows[0].1.len();
    if let Some((line, r)) = rows[..7].iter().find(|(_, r)| r.len() != n) {
        bail!(
            "{file}: line {line}: {} columns, want {n} like the image row",
            r.len()
        );
    }
    let num = |row: usize, col: usize| -> Result<f64> {
        let (line, r) = &rows[row];
        r[col]
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .with_context(|| {
                format!(
                    "{file}: line {line} column {}: `{}` is not a number",
                    col + 1,
                    r[col]
                )
            })
    };
    let mut out = Vec::with_capacity(n);
    for c in 0..n {
        let e = CalEntry {
            image: rows[0].1[c].to_string(),
            floor: num(1, c)? as i32,
            building: num(2, c)? as i32,
            lat_deg: num(3, c)?,
            lon_deg: num(4, c)?,
            rotation_deg: num(5, c)?,
            scale_m_per_px: num(6, c)?,
        };
        if !(e.lat_deg.abs() <= 90.0 && e.lon_deg.abs() <= 180.0 && e.scale_m_per_px > 0.0) {
            bail!(
                "{file}: column {}: latitude, longitude or scale out of range",
                c + 1
            );
        }
        out.push(e);
    }
    Ok(out)
}

/// One row of BLE_Locations.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct BleLocation {
    pub name: String,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub floor: i32,
}

/// Parses BLE_Locations.csv (`bleID,Lat,Lon,floor`, quoted names allowed).
pub fn parse_ble_locations(text: &str, file: &str) -> Result<Vec<BleLocation>> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line
            .split(',')
            .map(|s| s.trim().trim_matches('"'))
            .collect();
        let bad = || {
            format!(
                "{file}: line {}: want bleID,Lat,Lon,floor, got `{line}`",
                n + 1
            )
        };
        if f.len() != 4 {
            bail!(bad());
        }
        let lat_deg: f64 = f[1].parse().with_context(bad)?;
        let lon_deg: f64 = f[2].parse().with_context(bad)?;
        let floor: i32 = f[3].parse().with_context(bad)?;
        if !(lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0) {
            bail!(bad());
        }
        out.push(BleLocation {
            name: f[0].to_string(),
            lat_deg,
            lon_deg,
            floor,
        });
    }
    if out.is_empty() {
        bail!("{file}: no beacon rows");
    }
    Ok(out)
}

/// The log minor of a BLE_Locations.csv name: BLEn -> n, except that BLE2
/// and BLE3 are minors 3 and 2 (../shared/datasets/README.md "BLE beacon id
/// mapping", derived from RSSI vs distance).
pub fn minor_of(name: &str) -> Option<u32> {
    let n: u32 = name.strip_prefix("BLE")?.parse().ok()?;
    Some(match n {
        2 => 3,
        3 => 2,
        n => n,
    })
}

/// The beacon id the log readers produce for an IPIN 2023 beacon.
pub fn beacon_id(minor: u32) -> String {
    format!("ibeacon:{IPIN_BEACON_UUID}:1:{minor}")
}

/// The MCS of the site: the .cal image frame, metres, origin at the image's
/// bottom-left, x right, y up (eq. 23 with r = 1 / scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalFrame {
    pub width_m: f64,
    pub height_m: f64,
    pub georef: GeoRef,
    pub map_from_enu_rad: f64,
}

impl CalFrame {
    /// The frame of `cal` for an image of `width_px` x `height_px`: the image
    /// centre lies at the .cal latitude/longitude, and image up points
    /// `-rotation` from north, so a vector [e, n] is R(rotation)[e, n] in the
    /// MCS (the convention checked in ../shared/datasets/README.md).
    pub fn new(cal: &CalEntry, width_px: u32, height_px: u32) -> CalFrame {
        let s = cal.scale_m_per_px;
        let (w, h) = (width_px as f64 * s, height_px as f64 * s);
        CalFrame {
            width_m: w,
            height_m: h,
            georef: GeoRef {
                lat_deg: cal.lat_deg,
                lon_deg: cal.lon_deg,
                x_m: w / 2.0,
                y_m: h / 2.0,
            },
            map_from_enu_rad: cal.rotation_deg.to_radians(),
        }
    }

    /// WGS-84 -> MCS.
    pub fn mcs(&self, lat_deg: f64, lon_deg: f64) -> Vec2 {
        fpbp_core::geo::mcs_from_wgs84(&self.georef, self.map_from_enu_rad, lat_deg, lon_deg)
    }
}

/// Floor heights from the barometer: in every log whose truth visits more
/// than one floor, the pressure at each POSI point (median over +-1 s) is
/// averaged per floor and turned into heights relative to floor 0 with the
/// hypsometric equation; the result per floor is the median over logs.
/// Returns floor -> (height m, number of logs).
pub fn floor_heights(logs: &[PosiAndPressure]) -> BTreeMap<i32, (f64, usize)> {
    let mut per_floor: BTreeMap<i32, Vec<f64>> = BTreeMap::new();
    for (posi, pres) in logs {
        let mut by_floor: BTreeMap<i32, Vec<f64>> = BTreeMap::new();
        for p in posi {
            let mut near: Vec<f64> = pres
                .iter()
                .filter(|(t, _)| (t - p.t_s).abs() <= 1.0)
                .map(|(_, hpa)| *hpa)
                .collect();
            if near.is_empty() {
                continue;
            }
            near.sort_by(f64::total_cmp);
            by_floor
                .entry(p.floor)
                .or_default()
                .push(near[near.len() / 2]);
        }
        let Some(p0) = by_floor
            .get(&0)
            .map(|v| v.iter().sum::<f64>() / v.len() as f64)
        else {
            continue;
        };
        if by_floor.len() < 2 {
            continue;
        }
        for (f, v) in &by_floor {
            let pf = v.iter().sum::<f64>() / v.len() as f64;
            per_floor
                .entry(*f)
                .or_default()
                .push(SCALE_HEIGHT_M * (p0 / pf).ln());
        }
    }
    per_floor
        .into_iter()
        .map(|(f, mut v)| {
            v.sort_by(f64::total_cmp);
            let n = v.len();
            let med = if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            };
            (f, (med, n))
        })
        .collect()
}

/// Downsamples an RGBA floor image of the .cal frame onto `grid`: the
/// fraction of "ink" (opaque pixels darker than 200 in every channel) in
/// the source block under each target pixel.
pub fn ink_fraction(img: &image::RgbaImage, grid: &Grid) -> Vec<f64> {
    let (sw, sh) = (img.width() as usize, img.height() as usize);
    let (gw, gh) = (grid.width_px, grid.height_px);
    // Target column of each source column, target row of each source row.
    let col: Vec<usize> = (0..sw).map(|u| (u * gw / sw).min(gw - 1)).collect();
    let mut ink = vec![0u32; grid.len()];
    let mut cnt = vec![0u32; grid.len()];
    for (v, row) in img.as_raw().chunks_exact(4 * sw).enumerate() {
        let base = (v * gh / sh).min(gh - 1) * gw;
        for (px, &c) in row.chunks_exact(4).zip(&col) {
            let k = base + c;
            cnt[k] += 1;
            ink[k] += u32::from(px[3] > 128 && px[0] < 200 && px[1] < 200 && px[2] < 200);
        }
    }
    ink.iter()
        .zip(&cnt)
        .map(|(&a, &c)| if c == 0 { 0.0 } else { a as f64 / c as f64 })
        .collect()
}

/// Figures of the IPIN import (also written to import_report.json).
#[derive(Debug, Clone, Serialize)]
pub struct IpinReport {
    pub site_dir: String,
    pub width_m: f64,
    pub height_m: f64,
    pub map_from_enu_rad: f64,
    pub floors: Vec<FloorReport>,
    pub beacons: Vec<BeaconReport>,
    pub logs: usize,
}

/// One floor of [`IpinReport`].
#[derive(Debug, Clone, Serialize)]
pub struct FloorReport {
    pub id: i32,
    pub plan: String,
    /// "image" (from the organisers' map) or "open" (surveyed bbox + margin).
    pub source: String,
    pub height_m: f64,
    /// Logs that measured the height (0: fallback).
    pub height_from_logs: usize,
    pub truth_points: usize,
    /// Truth points on walkable, door, wall pixels of the plan.
    pub truth_walkable: usize,
    pub truth_door: usize,
    pub truth_wall: usize,
    /// [xmin, ymin, xmax, ymax] of the truth points, metres.
    pub truth_bbox_m: [f64; 4],
    /// [xmin, ymin, xmax, ymax] of the walkable pixels of the plan, metres.
    pub walkable_bbox_m: [f64; 4],
}

/// One beacon of [`IpinReport`].
#[derive(Debug, Clone, Serialize)]
pub struct BeaconReport {
    pub name: String,
    pub id: String,
    pub floor: i32,
    pub x_m: f64,
    pub y_m: f64,
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
}

/// Imports the IPIN dataset; writes site.json, plan_*.png, import_report.json.
pub fn import(args: &IpinImport) -> Result<IpinReport> {
    let r = args.pixels_per_meter;
    if !(r.is_finite() && (0.5..=100.0).contains(&r)) {
        bail!("--pixels-per-meter {r}: want 0.5..=100");
    }
    if !(args.open_margin_m.is_finite() && args.open_margin_m >= 0.0) {
        bail!("--open-margin-m {}: want >= 0", args.open_margin_m);
    }
    let dir = &args.dataset_dir;
    let maps = dir.join("maps");
    let cal_path = list_files(&maps, &[".cal"])?
        .into_iter()
        .next()
        .with_context(|| format!("{}: no .cal file", maps.display()))?;
    let cal = parse_cal(&read_text(&cal_path)?, &cal_path.display().to_string())?;
    // The reference image: the first .cal image that exists; its size fixes
    // the MCS (all columns of this .cal share centre, rotation and scale).
    let mut images: BTreeMap<i32, image::RgbaImage> = BTreeMap::new();
    for e in &cal {
        let p = maps.join(&e.image);
        if p.is_file() {
            let img = image::open(&p)
                .with_context(|| format!("reading {}", p.display()))?
                .to_rgba8();
            images.insert(e.floor, img);
        }
    }
    let Some((ref_floor, ref_img)) = images.iter().next() else {
        bail!(
            "{}: none of the images named in {} exists",
            maps.display(),
            cal_path.display()
        );
    };
    let ref_cal = cal
        .iter()
        .find(|e| e.floor == *ref_floor)
        .context("reference image without .cal entry")?;
    for e in &cal {
        if (e.lat_deg - ref_cal.lat_deg).abs() > 1e-9
            || (e.lon_deg - ref_cal.lon_deg).abs() > 1e-9
            || (e.rotation_deg - ref_cal.rotation_deg).abs() > 1e-9
            || (e.scale_m_per_px - ref_cal.scale_m_per_px).abs() > 1e-12
        {
            bail!(
                "{}: floor {} has a different georeference from floor {}: one MCS for all floors \
                 needs equal centre, rotation and scale",
                cal_path.display(),
                e.floor,
                ref_cal.floor
            );
        }
    }
    let frame = CalFrame::new(ref_cal, ref_img.width(), ref_img.height());

    // Truth and pressure of every log.
    let log_files = list_files(&dir.join("logs"), &[".txt", ".txt.gz"])?;
    let mut logs = Vec::with_capacity(log_files.len());
    for f in &log_files {
        logs.push(ipin_posi_and_pressure(f)?);
    }
    let heights = floor_heights(&logs);
    let mut truth: BTreeMap<i32, Vec<Vec2>> = BTreeMap::new();
    for (posi, _) in &logs {
        for p in posi {
            truth
                .entry(p.floor)
                .or_default()
                .push(frame.mcs(p.lat_deg, p.lon_deg));
        }
    }

    // Beacons.
    let csv_path = dir.join("BLE_Locations.csv");
    let locs = parse_ble_locations(&read_text(&csv_path)?, &csv_path.display().to_string())?;
    let mut beacons = Vec::new();
    let mut beacon_reports = Vec::new();
    for b in &locs {
        let minor = minor_of(&b.name).with_context(|| {
            format!(
                "{}: beacon `{}` is not named BLE<n>",
                csv_path.display(),
                b.name
            )
        })?;
        let p = frame.mcs(b.lat_deg, b.lon_deg);
        let id = beacon_id(minor);
        beacons.push(BeaconSpec {
            id: id.clone(),
            floor: b.floor,
            x_m: p.x,
            y_m: p.y,
            z_m: 0.0,
            rssi_1m_dbm: DEFAULT_RSSI_1M_DBM,
            path_loss_exponent: DEFAULT_PATH_LOSS_EXPONENT,
        });
        beacon_reports.push(BeaconReport {
            name: b.name.clone(),
            id,
            floor: b.floor,
            x_m: p.x,
            y_m: p.y,
        });
    }

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let legend = Legend::default();
    let grid = Grid::covering(frame.width_m, frame.height_m, r);
    let mut floor_ids: Vec<i32> = cal.iter().map(|e| e.floor).collect();
    floor_ids.sort_unstable_by(|a, b| b.cmp(a));
    floor_ids.dedup();
    let mut floors = Vec::new();
    let mut floor_reports = Vec::new();
    for id in floor_ids {
        let pts = truth.get(&id).cloned().unwrap_or_default();
        let (features, source) = match images.get(&id) {
            Some(img) => (
                plan_from_image(img, &grid)
                    .with_context(|| format!("floor {id}: the map image has no drawing"))?,
                "image",
            ),
            None => {
                let mut area: Vec<Vec2> = pts.clone();
                area.extend(
                    beacons
                        .iter()
                        .filter(|b| b.floor == id)
                        .map(|b| Vec2::new(b.x_m, b.y_m)),
                );
                if area.is_empty() {
                    bail!(
                        "floor {id}: no image, no truth point and no beacon: cannot bound an open floor"
                    );
                }
                (open_plan(&grid, &area, args.open_margin_m), "open")
            }
        };
        let plan = format!("plan_{id}.png");
        write_plan_png(&args.out.join(&plan), &grid, &features, &legend)?;
        let (height_m, n_logs) = match heights.get(&id) {
            Some(h) => (h.0, h.1),
            None => {
                log::warn!(
                    "floor {id}: no multi-floor log measured its height; using 4 m per level"
                );
                (4.0 * id as f64, 0)
            }
        };
        let mut wb = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for (k, f) in features.iter().enumerate() {
            if *f == Feature::Walkable {
                let (i, j) = ((k % grid.width_px) as f64, (k / grid.width_px) as f64);
                let (x0, y1) = (i / r, (grid.height_px as f64 - j) / r);
                wb = [
                    wb[0].min(x0),
                    wb[1].min(y1 - 1.0 / r),
                    wb[2].max(x0 + 1.0 / r),
                    wb[3].max(y1),
                ];
            }
        }
        let map = floor_map(&grid, features);
        let count = |f: Feature| pts.iter().filter(|p| map.feature(**p) == f).count();
        let mut bbox = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in &pts {
            bbox = [
                bbox[0].min(p.x),
                bbox[1].min(p.y),
                bbox[2].max(p.x),
                bbox[3].max(p.y),
            ];
        }
        floor_reports.push(FloorReport {
            id,
            plan: plan.clone(),
            source: source.into(),
            height_m,
            height_from_logs: n_logs,
            truth_points: pts.len(),
            truth_walkable: count(Feature::Walkable),
            truth_door: count(Feature::Door),
            truth_wall: count(Feature::Wall),
            truth_bbox_m: bbox,
            walkable_bbox_m: wb,
        });
        floors.push(FloorSpec {
            id,
            name: match source {
                "image" => format!("level {id} (plan from the organisers' map image)"),
                _ => format!(
                    "level {id} (no map image: open floor bounded by the surveyed area + {} m)",
                    args.open_margin_m
                ),
            },
            plan: Some(plan),
            pixels_per_meter: Some(r),
            target_pixels_per_meter: None,
            open_area_m: None,
            height_m,
        });
    }
    let spec = SiteSpec {
        format: "fpbp-site".into(),
        version: 1,
        name: "IPIN 2023 Track 3, Museum Industriekultur Nuremberg (imported; levels 0 and -2 \
               are open floors: no map images)"
            .into(),
        map_from_enu_rad: frame.map_from_enu_rad,
        heading_bias_rad: 0.0,
        legend,
        grid_interval_m: 1.0,
        floors,
        beacons,
        access_points: vec![],
        georef: Some(frame.georef),
    };
    std::fs::write(
        args.out.join("site.json"),
        serde_json::to_string_pretty(&spec)? + "\n",
    )
    .with_context(|| format!("writing {}", args.out.join("site.json").display()))?;
    let report = IpinReport {
        site_dir: args.out.display().to_string(),
        width_m: frame.width_m,
        height_m: frame.height_m,
        map_from_enu_rad: frame.map_from_enu_rad,
        floors: floor_reports,
        beacons: beacon_reports,
        logs: log_files.len(),
    };
    std::fs::write(
        args.out.join("import_report.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )?;
    Ok(report)
}

/// An open floor: walkable inside the bounding box of `area` grown by
/// `margin_m`, Wall elsewhere (and on the image border).
pub fn open_plan(grid: &Grid, area: &[Vec2], margin_m: f64) -> Vec<Feature> {
    let (mut x0, mut y0, mut x1, mut y1) = (
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    );
    for p in area {
        x0 = x0.min(p.x);
        y0 = y0.min(p.y);
        x1 = x1.max(p.x);
        y1 = y1.max(p.y);
    }
    let (x0, y0, x1, y1) = (x0 - margin_m, y0 - margin_m, x1 + margin_m, y1 + margin_m);
    let r = grid.pixels_per_meter;
    let mut out = Vec::with_capacity(grid.len());
    for j in 0..grid.height_px {
        let y = (grid.height_px as f64 - j as f64 - 0.5) / r;
        for i in 0..grid.width_px {
            let x = (i as f64 + 0.5) / r;
            let border = i == 0 || j == 0 || i + 1 == grid.width_px || j + 1 == grid.height_px;
            let inside = x >= x0 && x <= x1 && y >= y0 && y <= y1;
            out.push(if inside && !border {
                Feature::Walkable
            } else {
                Feature::Wall
            });
        }
    }
    out
}

/// Radius by which ink is grown before the drawing's parts are joined into
/// connected components, metres (joins dotted and dashed lines).
pub const INK_JOIN_RADIUS_M: f64 = 0.5;
/// Margin around the main drawing of an image plan, metres.
pub const IMAGE_MARGIN_M: f64 = 1.0;

/// The plan of a floor that has an image. The IPIN images are white sheets
/// with line drawings (stairs, handrails, reference markers), not wall plans:
/// the floor is the bounding box of the main drawing (the largest connected
/// group of ink after growing it by [`INK_JOIN_RADIUS_M`]) plus
/// [`IMAGE_MARGIN_M`], walkable inside (drawn lines included: steps and
/// handrails, not walls), Wall outside. Returns None when the image has no ink.
pub fn plan_from_image(img: &image::RgbaImage, grid: &Grid) -> Option<Vec<Feature>> {
    let ink = ink_fraction(img, grid);
    let (w, h) = (grid.width_px, grid.height_px);
    let rad = (INK_JOIN_RADIUS_M * grid.pixels_per_meter).round() as isize;
    // Grown ink mask.
    let mut grown = vec![false; w * h];
    for j in 0..h {
        for i in 0..w {
            if ink[j * w + i] <= 0.0 {
                continue;
            }
            for dj in -rad..=rad {
                for di in -rad..=rad {
                    let (ii, jj) = (i as isize + di, j as isize + dj);
                    if ii >= 0 && jj >= 0 && (ii as usize) < w && (jj as usize) < h {
                        grown[jj as usize * w + ii as usize] = true;
                    }
                }
            }
        }
    }
    // Connected components (8-neighbour) of the grown mask, weighted by ink.
    let mut comp = vec![usize::MAX; w * h];
    let mut best: Option<(f64, [usize; 4])> = None;
    let mut stack = Vec::new();
    let mut n_comp = 0;
    for start in 0..w * h {
        if !grown[start] || comp[start] != usize::MAX {
            continue;
        }
        let (mut weight, mut bb) = (0.0, [usize::MAX, usize::MAX, 0, 0]);
        comp[start] = n_comp;
        stack.push(start);
        while let Some(k) = stack.pop() {
            let (i, j) = (k % w, k / w);
            weight += ink[k];
            if ink[k] > 0.0 {
                bb = [bb[0].min(i), bb[1].min(j), bb[2].max(i), bb[3].max(j)];
            }
            for dj in -1isize..=1 {
                for di in -1isize..=1 {
                    let (ii, jj) = (i as isize + di, j as isize + dj);
                    if ii < 0 || jj < 0 || ii as usize >= w || jj as usize >= h {
                        continue;
                    }
                    let kk = jj as usize * w + ii as usize;
                    if grown[kk] && comp[kk] == usize::MAX {
                        comp[kk] = n_comp;
                        stack.push(kk);
                    }
                }
            }
        }
        if best.is_none_or(|(bw, _)| weight > bw) {
            best = Some((weight, bb));
        }
        n_comp += 1;
    }
    let (_, bb) = best?;
    let m = (IMAGE_MARGIN_M * grid.pixels_per_meter).round() as usize;
    let (i0, j0) = (bb[0].saturating_sub(m), bb[1].saturating_sub(m));
    let (i1, j1) = ((bb[2] + m).min(w - 1), (bb[3] + m).min(h - 1));
    let mut out = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let border = i == 0 || j == 0 || i + 1 == w || j + 1 == h;
            let inside = (i0..=i1).contains(&i) && (j0..=j1).contains(&j);
            out.push(if inside && !border {
                Feature::Walkable
            } else {
                Feature::Wall
            });
        }
    }
    Some(out)
}

#[cfg(test)]
#[path = "ipin_tests.rs"]
mod tests;
