//! `fpbp import overlay SITE_DIR --truth LOG... --out DIR`: each floor's plan
//! (lightened) with the ground truth of logs drawn on top (green points, blue
//! walks, orange walks that cross a wall, magenta points on a wall; beacons
//! as red squares) (ILC waypoints, IPIN POSI
//! points through the site's georeference), so a person can see that the
//! truth lies in walkable space; prints where the truth points fall.
//!
//! The site is loaded with `fpbp_core::site::files::load_site` (`Site::build`), truth with
//! `fpbp_logs`. `fpbp map check SITE --truth LOG...` (map module) draws the
//! truth points too; this command adds the walks, wall-crossing counts,
//! beacons, folder arguments and a JSON summary.

use crate::raster::{colour_of, wall_crossings};
use crate::truth::list_files;
use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::events::LogEvent;
use fpbp_core::map::Feature;
use fpbp_core::site::SiteSpec;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Arguments of `fpbp import overlay`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct OverlayRequest {
    /// Site folder holding site.json (plans relative to it).
    pub site_dir: PathBuf,
    /// Logs (ILC traces or IPIN logfiles, plain or .gz) or folders of them.
    #[cfg_attr(feature = "cli", arg(long, num_args = 1.., required = true))]
    pub truth: Vec<PathBuf>,
    /// Output folder: overlay_<floor>.png, overlay.json.
    #[cfg_attr(feature = "cli", arg(long))]
    pub out: PathBuf,
}

/// Where the truth of one floor falls.
#[derive(Debug, Clone, Serialize)]
pub struct FloorOverlay {
    pub floor: i32,
    pub image: String,
    pub logs: usize,
    pub points: usize,
    pub on_walkable: usize,
    pub on_door: usize,
    pub on_wall: usize,
    /// Truth-to-truth segments of a log on this floor, and Wall crossings.
    pub segments: usize,
    pub segments_crossing_wall: usize,
}

/// Truth of one log: floor -> points in order.
type LogTruth = BTreeMap<i32, Vec<Vec2>>;

/// Reads one log's truth in the site's MCS with the project's log readers
/// (`fpbp_logs`, the same conversions replay and eval use): IPIN POSI through
/// the site's georeference, ILC waypoints on the site's first floor.
fn read_truth(path: &Path, spec: &SiteSpec) -> Result<LogTruth> {
    let opts = fpbp_logs::ReadOptions {
        site_georef: spec.georef.map(|g| (g, spec.map_from_enu_rad)),
        default_floor: spec.floors.first().map(|f| f.id),
        ..Default::default()
    };
    let mut reader = fpbp_logs::open_log(path, &opts)?;
    let mut out = LogTruth::new();
    // Consecutive points on the same floor form a walk; a floor change
    // starts a new walk (kept apart by a NaN separator).
    let mut last_floor = None;
    while let Some(e) = reader.try_next()? {
        let LogEvent::Truth(t) = e else { continue };
        let floor = t.floor.or(opts.default_floor).unwrap_or(0);
        let v = out.entry(floor).or_default();
        if last_floor.is_some_and(|f| f != floor) && !v.is_empty() {
            v.push(Vec2::new(f64::NAN, f64::NAN));
        }
        v.push(Vec2::new(t.x_m, t.y_m));
        last_floor = Some(floor);
    }
    let report = reader.report();
    if report.truth_without_georef > 0 {
        bail!(
            "{}: {} lat/lon truth points but the site has no georef",
            path.display(),
            report.truth_without_georef
        );
    }
    Ok(out)
}

fn put(img: &mut image::RgbImage, x: i64, y: i64, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, image::Rgb(c));
    }
}

fn line(img: &mut image::RgbImage, a: Vec2, b: Vec2, c: [u8; 3]) {
    let n = ((b - a).norm().ceil() as usize).max(1);
    for k in 0..=n {
        let p = a + (b - a) * (k as f64 / n as f64);
        put(img, p.x.floor() as i64, p.y.floor() as i64, c);
    }
}

/// Draws and counts; writes overlay_<floor>.png and overlay.json into `out`.
pub fn overlay(args: &OverlayRequest) -> Result<Vec<FloorOverlay>> {
    let site = fpbp_core::site::files::load_site(&args.site_dir.join("site.json"))?;
    let spec = &site.spec;
    let mut files = Vec::new();
    for t in &args.truth {
        if t.is_dir() {
            files.extend(list_files(t, &[".txt", ".txt.gz"])?);
        } else {
            files.push(t.clone());
        }
    }
    let mut truth: BTreeMap<i32, Vec<Vec<Vec2>>> = BTreeMap::new();
    for f in &files {
        for (floor, pts) in read_truth(f, spec)? {
            truth.entry(floor).or_default().push(pts);
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut rows = Vec::new();
    for (fl, map) in spec.floors.iter().zip(&site.floors) {
        // The built map (Site::build), lightened so the truth stands out.
        let mut img = image::RgbImage::new(map.width_px() as u32, map.height_px() as u32);
        for (i, j, p) in img.enumerate_pixels_mut() {
            let c = colour_of(&spec.legend, map.feature_px(i as isize, j as isize));
            *p = image::Rgb(c.map(|v| 255 - (255 - v) / 2));
        }
        let walks = truth.get(&fl.id).cloned().unwrap_or_default();
        let mut row = FloorOverlay {
            floor: fl.id,
            image: format!("overlay_{}.png", fl.id),
            logs: walks.len(),
            points: 0,
            on_walkable: 0,
            on_door: 0,
            on_wall: 0,
            segments: 0,
            segments_crossing_wall: 0,
        };
        for w in &walks {
            for s in w.windows(2) {
                if s[0].x.is_nan() || s[1].x.is_nan() {
                    continue;
                }
                row.segments += 1;
                let crossed = wall_crossings(map, s[0], s[1]) > 0;
                row.segments_crossing_wall += usize::from(crossed);
                let c = if crossed { [255, 140, 0] } else { [0, 90, 255] };
                line(&mut img, map.mcs_to_ics(s[0]), map.mcs_to_ics(s[1]), c);
            }
        }
        for w in &walks {
            for p in w.iter().filter(|p| !p.x.is_nan()) {
                row.points += 1;
                let f = map.feature(*p);
                match f {
                    Feature::Walkable => row.on_walkable += 1,
                    Feature::Door => row.on_door += 1,
                    Feature::Wall => row.on_wall += 1,
                }
                let c = if f == Feature::Wall {
                    [255, 0, 255]
                } else {
                    [0, 160, 0]
                };
                let q = map.mcs_to_ics(*p);
                for dy in -2..=2 {
                    for dx in -2..=2 {
                        put(
                            &mut img,
                            q.x.floor() as i64 + dx,
                            q.y.floor() as i64 + dy,
                            c,
                        );
                    }
                }
            }
        }
        // Beacons of this floor: red squares with a black rim.
        for b in spec.beacons.iter().filter(|b| b.floor == fl.id) {
            let q = map.mcs_to_ics(Vec2::new(b.x_m, b.y_m));
            for dy in -4i64..=4 {
                for dx in -4i64..=4 {
                    let rim = dx.abs() == 4 || dy.abs() == 4;
                    let c = if rim { [0, 0, 0] } else { [230, 0, 0] };
                    put(
                        &mut img,
                        q.x.floor() as i64 + dx,
                        q.y.floor() as i64 + dy,
                        c,
                    );
                }
            }
        }
        let out_path = args.out.join(&row.image);
        img.save(&out_path)
            .with_context(|| format!("writing {}", out_path.display()))?;
        rows.push(row);
    }
    std::fs::write(
        args.out.join("overlay.json"),
        serde_json::to_string_pretty(&rows)? + "\n",
    )?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_truth_on_a_small_site() {
        let dir = std::env::temp_dir().join(format!("fpbp-import-overlay-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        // 20 x 10 px at 1 px/m: a wall column at x = 10 m, a door pixel at y = 5 m.
        let mut img = image::RgbImage::from_pixel(20, 10, image::Rgb([255, 255, 255]));
        for v in 0..10 {
            img.put_pixel(10, v, image::Rgb([0, 0, 0]));
        }
        img.put_pixel(10, 4, image::Rgb([250, 5, 5]));
        img.save(dir.join("p.png")).unwrap();
        let site = r#"{"format":"fpbp-site","version":1,"name":"t",
            "floors":[{"id":3,"plan":"p.png","pixels_per_meter":1.0}]}"#;
        std::fs::write(dir.join("site.json"), site).unwrap();
        // Through the door (y = 5.5: row 4), then through the wall (y = 8.5), then onto it.
        std::fs::write(
            dir.join("w.txt"),
            "1\tTYPE_WAYPOINT\t5\t5.5\n2\tTYPE_WAYPOINT\t15\t5.5\n3\tTYPE_WAYPOINT\t5\t8.5\n4\tTYPE_WAYPOINT\t10.5\t2\n",
        )
        .unwrap();
        let rows = overlay(&OverlayRequest {
            site_dir: dir.clone(),
            truth: vec![dir.join("w.txt")],
            out: dir.join("o"),
        })
        .unwrap();
        assert_eq!(rows.len(), 1);
        let r = &rows[0];
        assert_eq!((r.floor, r.logs, r.points, r.segments), (3, 1, 4, 3));
        assert_eq!((r.on_walkable, r.on_door, r.on_wall), (3, 0, 1));
        assert_eq!(r.segments_crossing_wall, 2);
        assert!(dir.join("o/overlay_3.png").is_file() && dir.join("o/overlay.json").is_file());
        std::fs::remove_dir_all(&dir).ok();
    }
}
