//! Plots: tracks over the floor plan and error CDFs, as PNG files.
//!
//! Drawing uses plotters' bitmap backend into a buffer, saved with `image`;
//! text uses DejaVu Sans compiled into the binary (assets/, Bitstream Vera
//! licence), so no system fonts are needed. `fpbp demo` reuses these.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, anyhow};
use fpbp_core::Vec2;
use fpbp_core::map::{Feature, FloorMap};
use plotters::prelude::*;
use plotters::style::FontStyle;

/// DejaVu Sans, registered as "sans-serif" for every plot.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn ensure_font() -> anyhow::Result<()> {
    static OK: OnceLock<bool> = OnceLock::new();
    let ok = *OK.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the compiled-in font could not be loaded"))
    }
}

/// Colours of the series, in order.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(23, 190, 207),
];

/// Truth colour.
pub const TRUTH_COLOR: RGBColor = RGBColor(214, 39, 40);

/// One named polyline in MCS metres.
#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// A track plot: estimated tracks and truth points over a floor map.
#[derive(Debug, Clone)]
pub struct TrackPlot<'a> {
    pub title: String,
    /// The floor drawn underneath (walkable white, door pink, wall grey).
    pub map: Option<&'a FloorMap>,
    pub tracks: Vec<Series>,
    /// Truth points, drawn as red dots joined by a thin line.
    pub truth: Vec<(f64, f64)>,
}

fn bounds(plot: &TrackPlot) -> (f64, f64, f64, f64) {
    let pts = plot
        .tracks
        .iter()
        .flat_map(|s| s.points.iter())
        .chain(plot.truth.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pts.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return match plot.map {
            Some(m) => (0.0, m.width_m(), 0.0, m.height_m()),
            None => (0.0, 1.0, 0.0, 1.0),
        };
    }
    // Zoom on the data (at least 20 m across) with a margin; the plan is drawn underneath.
    let span = (x1 - x0).max(y1 - y0).max(20.0);
    let (mx, my) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hw, hh) = (
        ((x1 - x0).max(1.0) / 2.0 + 0.05 * span),
        ((y1 - y0).max(1.0) / 2.0 + 0.05 * span),
    );
    (mx - hw, mx + hw, my - hh, my + hh)
}

fn save_rgb(path: &Path, w: u32, h: u32, buf: Vec<u8>) -> anyhow::Result<()> {
    let img = image::RgbImage::from_raw(w, h, buf)
        .ok_or_else(|| anyhow!("plot buffer has the wrong size"))?;
    img.save(path)
        .with_context(|| format!("cannot write {}", path.display()))
}

fn feature_color(f: Feature) -> RGBColor {
    match f {
        Feature::Walkable => RGBColor(255, 255, 255),
        Feature::Door => RGBColor(240, 150, 150),
        Feature::Wall => RGBColor(90, 90, 90),
    }
}

/// Draws `plot` into a PNG at `path` (about 1000 px wide, aspect kept).
pub fn track_png(path: &Path, plot: &TrackPlot) -> anyhow::Result<()> {
    ensure_font()?;
    let (x0, x1, y0, y1) = bounds(plot);
    let plot_w = 1000.0;
    let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(250.0, 1400.0);
    let (w, h) = (plot_w as u32 + 90, plot_h as u32 + 90);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&plot.title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(45)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| anyhow!("{e}"))?;
        if let Some(map) = plot.map {
            let (xr, yr) = chart.plotting_area().get_pixel_range();
            let (pw, ph) = (
                (xr.end - xr.start).max(1) as f64,
                (yr.end - yr.start).max(1) as f64,
            );
            for py in yr.clone() {
                let y = y1 - (py - yr.start) as f64 / ph * (y1 - y0);
                for px in xr.clone() {
                    let x = x0 + (px - xr.start) as f64 / pw * (x1 - x0);
                    let c = feature_color(map.feature(Vec2::new(x, y)));
                    root.draw_pixel((px, py), &c).map_err(|e| anyhow!("{e}"))?;
                }
            }
        }
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        if !plot.truth.is_empty() {
            chart
                .draw_series(LineSeries::new(
                    plot.truth.iter().copied(),
                    TRUTH_COLOR.mix(0.5).stroke_width(1),
                ))
                .map_err(|e| anyhow!("{e}"))?;
            chart
                .draw_series(
                    plot.truth
                        .iter()
                        .map(|p| Circle::new(*p, 4, TRUTH_COLOR.filled())),
                )
                .map_err(|e| anyhow!("{e}"))?
                .label("truth")
                .legend(|(x, y)| Circle::new((x + 10, y), 4, TRUTH_COLOR.filled()));
        }
        for (i, s) in plot.tracks.iter().enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(2)))
                .map_err(|e| anyhow!("{e}"))?
                .label(s.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        root.present().map_err(|e| anyhow!("{e}"))?;
    }
    save_rgb(path, w, h, buf)
}

/// Where a chart's legend goes.
pub use plotters::chart::SeriesLabelPosition as LegendPosition;

/// A line chart: axis titles, ranges and where the legend goes.
#[derive(Debug, Clone)]
pub struct LineChart<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub x_range: std::ops::Range<f64>,
    pub y_range: std::ops::Range<f64>,
    /// Also mark every point with a dot (for sparse series such as a sweep).
    pub markers: bool,
    pub legend: LegendPosition,
}

/// Draws named polylines into a 900 x 600 PNG at `path`.
pub fn lines_png(
    path: &Path,
    chart_spec: &LineChart,
    series: &[(String, Vec<(f64, f64)>)],
) -> anyhow::Result<()> {
    ensure_font()?;
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(chart_spec.title, ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(chart_spec.x_range.clone(), chart_spec.y_range.clone())
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_desc(chart_spec.x_desc)
            .y_desc(chart_spec.y_desc)
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        for (i, (label, pts)) in series.iter().enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
                .map_err(|e| anyhow!("{e}"))?
                .label(label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            if chart_spec.markers {
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
                    .map_err(|e| anyhow!("{e}"))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(chart_spec.legend.clone())
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        root.present().map_err(|e| anyhow!("{e}"))?;
    }
    save_rgb(path, w, h, buf)
}

/// Draws the empirical CDF of each series' errors (metres) into a PNG.
pub fn cdf_png(path: &Path, title: &str, series: &[(String, Vec<f64>)]) -> anyhow::Result<()> {
    let x_max = series
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .filter(|e| e.is_finite())
        .fold(1.0f64, f64::max)
        * 1.05;
    let steps: Vec<(String, Vec<(f64, f64)>)> = series
        .iter()
        .map(|(label, errors)| {
            let mut v: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
            v.sort_by(f64::total_cmp);
            let n = v.len().max(1) as f64;
            let mut pts = vec![(0.0, 0.0)];
            for (k, e) in v.iter().enumerate() {
                pts.push((*e, k as f64 / n));
                pts.push((*e, (k + 1) as f64 / n));
            }
            if let Some(last) = v.last() {
                pts.push((x_max.max(*last), 1.0));
            }
            (format!("{label} (n={})", v.len()), pts)
        })
        .collect();
    let spec = LineChart {
        title,
        x_desc: "error (m)",
        y_desc: "fraction of points",
        x_range: 0.0..x_max,
        y_range: 0.0..1.0,
        markers: false,
        legend: LegendPosition::LowerRight,
    };
    lines_png(path, &spec, &steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("fpbp-plot-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn track_over_a_map_and_cdf_write_pngs_with_the_plan_drawn() {
        let d = tmp("t");
        // 20 x 10 m at 2 px/m: walls on the border, a door in the middle of the top.
        let (w, h) = (40usize, 20usize);
        let mut f = vec![Feature::Walkable; w * h];
        for j in 0..h {
            for i in 0..w {
                if i == 0 || j == 0 || i == w - 1 || j == h - 1 {
                    f[j * w + i] = Feature::Wall;
                }
            }
        }
        f[20] = Feature::Door;
        let map = FloorMap::from_features(w, h, 2.0, f);
        let plot = TrackPlot {
            title: "test track".into(),
            map: Some(&map),
            tracks: vec![Series {
                label: "pdr".into(),
                points: vec![(2.0, 2.0), (10.0, 5.0), (18.0, 8.0)],
            }],
            truth: vec![(2.0, 2.0), (18.0, 8.0)],
        };
        let p = d.join("track.png");
        track_png(&p, &plot).unwrap();
        let img = image::open(&p).unwrap().to_rgb8();
        assert!(img.width() >= 1000);
        // The wall colour appears (the plan was drawn) and so does the truth colour.
        let px: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        assert!(px.contains(&[90, 90, 90]));
        assert!(px.contains(&[214, 39, 40]));
        let c = d.join("cdf.png");
        cdf_png(
            &c,
            "cdf",
            &[("a".into(), vec![1.0, 2.0, 3.0]), ("b".into(), vec![])],
        )
        .unwrap();
        assert!(image::open(&c).unwrap().width() == 900);
        // Without a map the bounds come from the data.
        let plot = TrackPlot { map: None, ..plot };
        track_png(&d.join("nomap.png"), &plot).unwrap();
        std::fs::remove_dir_all(&d).ok();
    }
}
