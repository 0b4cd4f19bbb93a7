//! `fpbp map check SITE.json --out DIR`: validates a site, prints its
//! figures per floor and writes DIR/overlay.png (first floor) plus
//! DIR/overlay-floor-ID.png for every further floor: a figure with axes in
//! metres, a scale bar and a legend; DIR/overlay-raw.png (and
//! overlay-floor-ID-raw.png) hold the same layers at one pixel per plan pixel.
//! With `--radio-map`, also how much of each floor's walkable area lies
//! near the survey (its reference scans), printed per distance band and
//! drawn in DIR/coverage.png (coverage-floor-ID.png).

use std::path::PathBuf;

use anyhow::Context;
use fpbp_core::Vec2;
use fpbp_core::map::{Feature, FloorMap};
use fpbp_core::site::Site;
use image::{Rgba, RgbaImage};

use fpbp_core::site::files::load_site;

/// Arguments of `fpbp map check`.
#[derive(clap::Args)]
pub struct Args {
    /// The site file (site.json).
    pub site: PathBuf,
    /// Output folder for overlay.png (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Logs (native, ILC, IPIN; plain or gzip) whose truth points are drawn
    /// in magenta on the floor they belong to (truth without a floor goes on
    /// the first floor).
    #[arg(long, num_args = 1..)]
    pub truth: Vec<PathBuf>,
    /// A radio map (`fpbp calibrate --radio-map`): the share of each
    /// floor's walkable area within 2 m, 2-5 m, 5-10 m and 10 m or more of
    /// its reference scans (docs/tcpf.md "Survey density: what a survey
    /// buys"), and DIR/coverage.png drawing it.
    #[arg(long)]
    pub radio_map: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let site = load_site(&args.site)?;
    println!(
        "site {} ({}): {} floor(s), {} beacon(s), grid interval {} m",
        site.spec.name,
        args.site.display(),
        site.floors.len(),
        site.spec.beacons.len(),
        site.spec.grid_interval_m
    );
    let mut truth: Vec<(Option<i32>, f64, f64)> = Vec::new();
    for log in &args.truth {
        let opts = fpbp_logs::ReadOptions {
            site_georef: site.spec.georef.map(|g| (g, site.spec.map_from_enu_rad)),
            ..Default::default()
        };
        let (events, _) = fpbp_logs::read_all(log, &opts)
            .with_context(|| format!("cannot read truth from {}", log.display()))?;
        let before = truth.len();
        truth.extend(
            events
                .iter()
                .filter_map(fpbp_core::events::LogEvent::as_truth)
                .map(|t| (t.floor, t.x_m, t.y_m)),
        );
        println!("truth {}: {} point(s)", log.display(), truth.len() - before);
    }
    let scans = match &args.radio_map {
        Some(path) => Some(survey_positions(path, &site)?),
        None => None,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    for (k, (fs, map)) in site.spec.floors.iter().zip(&site.floors).enumerate() {
        let rep = map.build_report();
        let beacons = site
            .spec
            .beacons
            .iter()
            .filter(|b| b.floor == fs.id)
            .count();
        println!("floor {} {:?}:", fs.id, fs.name);
        println!(
            "  size              {:.2} m x {:.2} m ({} x {} px, r = {} px/m)",
            map.width_m(),
            map.height_m(),
            map.width_px(),
            map.height_px(),
            map.pixels_per_meter()
        );
        if rep.downsample_factor > 1 {
            println!(
                "  downsampled       x{} from {} x {} px",
                rep.downsample_factor, rep.source_width_px, rep.source_height_px
            );
        }
        println!("  walkable area     {:.1} m2", map.walkable_area_m2());
        println!(
            "  rooms             {} (largest {:.1} m2, smallest {:.2} m2)",
            map.rooms().len(),
            map.rooms().iter().map(|r| r.area_m2).fold(0.0, f64::max),
            map.rooms()
                .iter()
                .map(|r| r.area_m2)
                .fold(f64::INFINITY, f64::min)
        );
        println!("  door pixels       {}", map.door_pixel_count());
        println!(
            "  grid points       {} (I_M = {} m)",
            map.grid().len(),
            map.grid_interval_m()
        );
        println!("  beacons           {beacons}");
        println!(
            "  unclassified px   {} ({:.3}%)",
            rep.unclassified_count,
            rep.unclassified_fraction * 100.0
        );
        let pts: Vec<(f64, f64)> = truth
            .iter()
            .filter(|(f, _, _)| f.unwrap_or(site.default_floor()) == fs.id)
            .map(|&(_, x, y)| (x, y))
            .collect();
        if !args.truth.is_empty() {
            let off = pts
                .iter()
                .filter(|&&(x, y)| !map.is_walkable(Vec2::new(x, y)))
                .count();
            println!("  truth points      {} ({} off Walkable)", pts.len(), off);
        }
        let img = draw_overlay(&site, fs.id, &pts);
        let name = if k == 0 {
            "overlay".to_string()
        } else {
            format!("overlay-floor-{}", fs.id)
        };
        // one image pixel per plan pixel (for exact checks) ...
        let raw = args.out.join(format!("{name}-raw.png"));
        img.save(&raw)
            .with_context(|| format!("cannot write {}", raw.display()))?;
        // ... and the figure: axes in metres, scale bar, legend
        let path = args.out.join(format!("{name}.png"));
        let c = |p: Rgba<u8>| plotters::style::RGBColor(p.0[0], p.0[1], p.0[2]);
        fpbp_eval::plot::floor_figure_png(
            &path,
            &fpbp_eval::plot::FloorFigure {
                title: format!("{}: floor {} ({})", site.spec.name, fs.id, fs.name),
                image: &img,
                width_m: map.width_m(),
                height_m: map.height_m(),
                points: &pts,
                point_label: "truth points",
                point_color: c(TRUTH_DOT),
                legend: vec![
                    ("rooms (one colour each)".into(), c(room_colour(0))),
                    ("wall".into(), c(WALL)),
                    ("door".into(), c(DOOR)),
                    ("grid point".into(), c(GRID_DOT)),
                    ("beacon".into(), c(BEACON)),
                    ("door normal (1 m)".into(), c(NORMAL)),
                ],
            },
        )?;
        println!(
            "  overlay           {} (plan pixels: {})",
            path.display(),
            raw.display()
        );
        if let Some(scans) = &scans {
            let name = if k == 0 {
                "coverage".to_string()
            } else {
                format!("coverage-floor-{}", fs.id)
            };
            write_coverage(&site, fs, map, scans, &args.out.join(format!("{name}.png")))?;
        }
    }
    Ok(())
}

/// The positions of the reference scans of the radio map at `path`, by
/// floor; an error when it has none (a map older than file version 2).
fn survey_positions(
    path: &std::path::Path,
    site: &Site,
) -> anyhow::Result<std::collections::BTreeMap<i32, Vec<Vec2>>> {
    use fpbp_core::radio::RadioModel;
    let map = fpbp_eval::radio_map::load(path, site)?;
    let Some(scans) = map.reference_scans().filter(|s| !s.is_empty()) else {
        anyhow::bail!(
            "{}: the radio map has no reference scans (rebuild it with fpbp calibrate --radio-map)",
            path.display()
        );
    };
    let mut by_floor: std::collections::BTreeMap<i32, Vec<Vec2>> = Default::default();
    for s in scans.scans() {
        by_floor
            .entry(s.floor)
            .or_default()
            .push(Vec2::new(s.x_m, s.y_m));
    }
    println!(
        "radio map {}: {} reference scans on {} floor(s)",
        path.display(),
        scans.scans().len(),
        by_floor.len()
    );
    Ok(by_floor)
}

/// Prints the floor's survey coverage by band and writes `path`: the plan
/// with its walkable area coloured by the distance to the survey.
fn write_coverage(
    site: &Site,
    fs: &fpbp_core::site::FloorSpec,
    map: &FloorMap,
    scans: &std::collections::BTreeMap<i32, Vec<Vec2>>,
    path: &std::path::Path,
) -> anyhow::Result<()> {
    use fpbp_core::map::survey_coverage::SurveyCoverage;
    let pts = scans.get(&fs.id).map(Vec::as_slice).unwrap_or(&[]);
    let cov = SurveyCoverage::of(map, pts);
    let s = cov.shares().map(|x| 100.0 * x);
    println!(
        "  survey coverage   {:.1} % of the walkable area within 2 m of the survey, {:.1} % 2-5 m, \
         {:.1} % 5-10 m, {:.1} % 10 m or more ({} reference scans; {} m cells)",
        s[0],
        s[1],
        s[2],
        s[3],
        pts.len(),
        cov.cell_m()
    );
    let img = plan_image(map, |i, j| {
        let p = map.ics_to_mcs(Vec2::new(i as f64 + 0.5, j as f64 + 0.5));
        cov.band_at(p).map_or(WHITE, |b| BAND[b as usize])
    });
    let points: Vec<(f64, f64)> = pts.iter().map(|p| (p.x, p.y)).collect();
    let c = |p: Rgba<u8>| plotters::style::RGBColor(p.0[0], p.0[1], p.0[2]);
    fpbp_eval::plot::floor_figure_png(
        path,
        &fpbp_eval::plot::FloorFigure {
            title: format!(
                "{}: floor {} ({}), distance to the survey",
                site.spec.name, fs.id, fs.name
            ),
            image: &img,
            width_m: map.width_m(),
            height_m: map.height_m(),
            points: &points,
            point_label: "reference scans",
            point_color: c(TRUTH_DOT),
            legend: vec![
                ("under 2 m".into(), c(BAND[0])),
                ("2-5 m".into(), c(BAND[1])),
                ("5-10 m".into(), c(BAND[2])),
                ("10 m or more".into(), c(BAND[3])),
                ("wall".into(), c(WALL)),
                ("door".into(), c(DOOR)),
            ],
        },
    )?;
    println!("  coverage          {}", path.display());
    Ok(())
}

/// The plan at one pixel per plan pixel: walls and doors in their
/// colours, each walkable pixel (i, j) in `walkable(i, j)`.
fn plan_image(map: &FloorMap, walkable: impl Fn(usize, usize) -> Rgba<u8>) -> RgbaImage {
    let (w, h) = (map.width_px(), map.height_px());
    let mut img = RgbaImage::new(w as u32, h as u32);
    for j in 0..h {
        for i in 0..w {
            let c = match map.feature_px(i as isize, j as isize) {
                Feature::Wall => WALL,
                Feature::Door => DOOR,
                Feature::Walkable => walkable(i, j),
            };
            img.put_pixel(i as u32, j as u32, c);
        }
    }
    img
}

const WHITE: Rgba<u8> = Rgba([255, 255, 255, 255]);

/// The survey-distance bands' colours: under 2 m, 2-5 m, 5-10 m, 10 m or more.
const BAND: [Rgba<u8>; 4] = [
    Rgba([120, 200, 120, 255]),
    Rgba([240, 210, 80, 255]),
    Rgba([245, 150, 60, 255]),
    Rgba([170, 110, 210, 255]),
];

const WALL: Rgba<u8> = Rgba([40, 40, 40, 255]);
const DOOR: Rgba<u8> = Rgba([230, 20, 20, 255]);
const GRID_DOT: Rgba<u8> = Rgba([60, 60, 90, 255]);
const NORMAL: Rgba<u8> = Rgba([0, 150, 0, 255]);
const BEACON: Rgba<u8> = Rgba([20, 60, 220, 255]);
const TRUTH_DOT: Rgba<u8> = Rgba([220, 0, 220, 255]);

/// A distinct pastel colour per room id (golden-angle hue walk).
fn room_colour(id: u32) -> Rgba<u8> {
    let h = (id as f64 * 0.618_033_988_75).fract() * 6.0;
    let (s, v) = (0.45, 0.97);
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let to = |u: f64| ((u + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    Rgba([to(r), to(g), to(b), 255])
}

fn put(img: &mut RgbaImage, x: i64, y: i64, c: Rgba<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn disc(img: &mut RgbaImage, q: Vec2, rad: f64, c: Rgba<u8>) {
    let r = rad.ceil() as i64;
    let (cx, cy) = (q.x.floor() as i64, q.y.floor() as i64);
    for dy in -r..=r {
        for dx in -r..=r {
            if ((dx * dx + dy * dy) as f64) <= rad * rad {
                put(img, cx + dx, cy + dy, c);
            }
        }
    }
}

fn line(img: &mut RgbaImage, a: Vec2, b: Vec2, c: Rgba<u8>) {
    let n = ((b - a).norm().ceil() as usize).max(1) * 2;
    for k in 0..=n {
        let p = a + (b - a) * (k as f64 / n as f64);
        put(img, p.x.floor() as i64, p.y.floor() as i64, c);
    }
}

/// One sample per door side: for every 4-connected Door component, its
/// pixels with a Walkable 4-neighbour are split by the sign of their normal
/// against the component's first normal, and the middle pixel of each side
/// (in scan order) is returned with its normal (MCS).
fn door_normal_samples(map: &FloorMap) -> Vec<(usize, usize, Vec2)> {
    let (w, h) = (map.width_px(), map.height_px());
    let mut seen = vec![false; w * h];
    let mut out = Vec::new();
    for start in 0..w * h {
        let (si, sj) = ((start % w) as isize, (start / w) as isize);
        if seen[start] || map.feature_px(si, sj) != Feature::Door {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![start];
        let mut sides: [Vec<(usize, usize, Vec2)>; 2] = [Vec::new(), Vec::new()];
        let mut first: Option<Vec2> = None;
        while let Some(k) = stack.pop() {
            let (i, j) = ((k % w) as isize, (k / w) as isize);
            let mut edge = false;
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (ni, nj) = (i + dx, j + dy);
                match map.feature_px(ni, nj) {
                    Feature::Door => {
                        let m = nj as usize * w + ni as usize;
                        if !seen[m] {
                            seen[m] = true;
                            stack.push(m);
                        }
                    }
                    Feature::Walkable => edge = true,
                    Feature::Wall => {}
                }
            }
            if !edge {
                continue;
            }
            let q = Vec2::new(i as f64 + 0.5, j as f64 + 0.5);
            if let Some(n) = map.normal_at(map.ics_to_mcs(q)) {
                let f = *first.get_or_insert(n);
                let side = usize::from(n.dot(&f) < 0.0);
                sides[side].push((i as usize, j as usize, n));
            }
        }
        for mut side in sides {
            if side.is_empty() {
                continue;
            }
            side.sort_by_key(|&(i, j, _)| (j, i));
            out.push(side[side.len() / 2]);
        }
    }
    out
}

/// The overlay of floor `floor` at the plan's resolution: rooms in distinct
/// colours, walls dark grey, doors red, GML grid points as dark dots,
/// beacons as blue discs, door normals (one per door side) as green 1 m lines, and
/// `extra_points` (MCS metres, e.g. truth) as magenta dots. An unknown floor
/// gives a 1 x 1 image.
pub fn draw_overlay(site: &Site, floor: i32, extra_points: &[(f64, f64)]) -> RgbaImage {
    let Some(map) = site.floor(floor) else {
        return RgbaImage::new(1, 1);
    };
    let mut img = plan_image(map, |i, j| map.room_of_px(i, j).map_or(WHITE, room_colour));
    let r = map.pixels_per_meter();
    for g in map.grid() {
        let q = map.mcs_to_ics(*g);
        disc(&mut img, q, (0.06 * r).max(0.5), GRID_DOT);
    }
    // Door normals: one per door side, 1 m long.
    for (i, j, n) in door_normal_samples(map) {
        let q = Vec2::new(i as f64 + 0.5, j as f64 + 0.5);
        // MCS normal -> ICS direction (flip y).
        let d = Vec2::new(n.x, -n.y) * r;
        line(&mut img, q, q + d, NORMAL);
    }
    for b in site.spec.beacons.iter().filter(|b| b.floor == floor) {
        let q = map.mcs_to_ics(Vec2::new(b.x_m, b.y_m));
        disc(&mut img, q, (0.3 * r).max(2.0), BEACON);
    }
    for &(x, y) in extra_points {
        let q = map.mcs_to_ics(Vec2::new(x, y));
        disc(&mut img, q, (0.15 * r).max(1.0), TRUTH_DOT);
    }
    img
}
