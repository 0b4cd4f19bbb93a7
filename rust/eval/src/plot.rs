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

/// One pose of a track: MCS metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPoint {
    pub x_m: f64,
    pub y_m: f64,
}

/// One engine's track in its own panel.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Engine name (the panel's caption).
    pub label: String,
    /// Second caption line: start mode, jumps, wall crossings.
    pub note: String,
    pub points: Vec<TrackPoint>,
    /// `jump[k]`: the segment from point k to k + 1 is a jump (drawn dashed).
    /// Missing entries count as no jump.
    pub jump: Vec<bool>,
    /// `gap[k]`: no segment from point k to k + 1 (a floor change between
    /// them, or a break in the track): nothing is drawn there.
    pub gap: Vec<bool>,
}

/// A track plot: one panel per engine over the whole floor plan, truth
/// points, start / end markers, direction ticks, jumps dashed, and a legend
/// below the panels (never over the data).
#[derive(Debug, Clone)]
pub struct TrackPlot<'a> {
    pub title: String,
    /// The floor drawn underneath (walkable white, door pink, wall grey).
    pub map: Option<&'a FloorMap>,
    pub panels: Vec<Panel>,
    /// Truth points, drawn as red dots joined by a thin line.
    pub truth: Vec<(f64, f64)>,
}

/// The drawn extent: the whole plan plus any data outside it, with a margin.
fn bounds(plot: &TrackPlot) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = match plot.map {
        Some(m) => (0.0, m.width_m(), 0.0, m.height_m()),
        None => (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
    };
    let pts = plot
        .panels
        .iter()
        .flat_map(|s| s.points.iter().map(|p| (p.x_m, p.y_m)))
        .chain(plot.truth.iter().copied());
    for (x, y) in pts.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return (0.0, 1.0, 0.0, 1.0);
    }
    let span = (x1 - x0).max(y1 - y0).max(1.0);
    let m = 0.02 * span;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hw, hh) = (
        ((x1 - x0) / 2.0).max(0.5) + m,
        ((y1 - y0) / 2.0).max(0.5) + m,
    );
    (cx - hw, cx + hw, cy - hh, cy + hh)
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

/// Start marker colour (end markers are black squares).
pub const START_COLOR: RGBColor = RGBColor(0, 170, 60);

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn e<E: std::fmt::Display>(err: E) -> anyhow::Error {
    anyhow!("{err}")
}

/// Paints the floor map under the chart's plotting area, pixel by pixel.
fn draw_map(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    chart: &Chart,
    map: &FloorMap,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
) -> anyhow::Result<()> {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let (pw, ph) = (
        (xr.end - xr.start).max(1) as f64,
        (yr.end - yr.start).max(1) as f64,
    );
    for py in yr.clone() {
        let y = y1 - (py - yr.start) as f64 / ph * (y1 - y0);
        for px in xr.clone() {
            let x = x0 + (px - xr.start) as f64 / pw * (x1 - x0);
            let c = match map.pixel_of(Vec2::new(x, y)) {
                Some(_) => feature_color(map.feature(Vec2::new(x, y))),
                // outside the plan: light grey, so the plan's edge shows
                None => RGBColor(235, 235, 235),
            };
            root.draw_pixel((px, py), &c).map_err(e)?;
        }
    }
    Ok(())
}

/// Draws one panel's track: segments one by one (no thick-line joins, which
/// drew spikes off the track), jumps dashed, direction ticks, start and end.
fn draw_track(chart: &mut Chart, p: &Panel, c: RGBColor, span: f64) -> anyhow::Result<()> {
    let pts: Vec<(f64, f64)> = p.points.iter().map(|q| (q.x_m, q.y_m)).collect();
    let mut length = 0.0;
    for k in 1..pts.len() {
        if !p.gap.get(k - 1).copied().unwrap_or(false) {
            length += (pts[k].0 - pts[k - 1].0).hypot(pts[k].1 - pts[k - 1].1);
        }
    }
    let tick_every = (length / 15.0).max(span / 40.0);
    let mut since_tick = 0.0;
    for k in 1..pts.len() {
        if p.gap.get(k - 1).copied().unwrap_or(false) {
            continue;
        }
        let (a, b) = (pts[k - 1], pts[k]);
        if p.jump.get(k - 1).copied().unwrap_or(false) {
            chart
                .draw_series(DashedLineSeries::new([a, b], 6, 5, c.stroke_width(2)))
                .map_err(e)?;
            continue;
        }
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![a, b],
                c.stroke_width(2),
            )))
            .map_err(e)?;
        let d = (b.0 - a.0).hypot(b.1 - a.1);
        since_tick += d;
        if since_tick >= tick_every && d > 0.0 {
            since_tick = 0.0;
            // an arrowhead at the segment's end, pointing along it
            let (ux, uy) = ((b.0 - a.0) / d, (b.1 - a.1) / d);
            let s = span / 90.0;
            let tip = (b.0, b.1);
            let l = (b.0 - s * ux - 0.6 * s * uy, b.1 - s * uy + 0.6 * s * ux);
            let r = (b.0 - s * ux + 0.6 * s * uy, b.1 - s * uy - 0.6 * s * ux);
            chart
                .draw_series(std::iter::once(Polygon::new(vec![tip, l, r], c.filled())))
                .map_err(e)?;
        }
    }
    if let (Some(&s), Some(&t)) = (pts.first(), pts.last()) {
        chart
            .draw_series(std::iter::once(Circle::new(s, 7, START_COLOR.filled())))
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(Circle::new(s, 7, BLACK.stroke_width(1))))
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(t) + Rectangle::new([(-6, -6), (6, 6)], BLACK.filled()),
            ))
            .map_err(e)?;
    }
    Ok(())
}

/// Draws the legend strip: one glyph and label per item, left to right.
fn draw_legend(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    colors: &[RGBColor],
) -> anyhow::Result<()> {
    let text = ("sans-serif", 15).into_font().color(&BLACK);
    let mut x = 20i32;
    let y = 20i32;
    let mut item = |label: &str, draw: &dyn Fn(i32) -> anyhow::Result<()>| -> anyhow::Result<()> {
        draw(x)?;
        area.draw(&Text::new(label.to_string(), (x + 28, y - 8), text.clone()))
            .map_err(e)?;
        x += 40 + 8 * label.len() as i32;
        Ok(())
    };
    let c0 = colors.first().copied().unwrap_or(PALETTE[0]);
    item("track", &|x| {
        area.draw(&PathElement::new(
            vec![(x, y), (x + 22, y)],
            c0.stroke_width(2),
        ))
        .map_err(e)
    })?;
    item("jump (dashed)", &|x| {
        area.draw(&plotters::element::DashedPathElement::new(
            vec![(x, y), (x + 22, y)],
            6,
            5,
            c0.stroke_width(2),
        ))
        .map_err(e)
    })?;
    item("direction", &|x| {
        area.draw(&Polygon::new(
            vec![(x + 18, y), (x + 8, y - 6), (x + 8, y + 6)],
            c0.filled(),
        ))
        .map_err(e)
    })?;
    item("start", &|x| {
        area.draw(&Circle::new((x + 11, y), 7, START_COLOR.filled()))
            .map_err(e)
    })?;
    item("end", &|x| {
        area.draw(&Rectangle::new(
            [(x + 5, y - 6), (x + 17, y + 6)],
            BLACK.filled(),
        ))
        .map_err(e)
    })?;
    item("truth", &|x| {
        area.draw(&Circle::new((x + 11, y), 4, TRUTH_COLOR.filled()))
            .map_err(e)
    })?;
    item("wall / door / walkable / outside plan", &|x| {
        for (k, c) in [
            feature_color(Feature::Wall),
            feature_color(Feature::Door),
            RGBColor(255, 255, 255),
            RGBColor(235, 235, 235),
        ]
        .iter()
        .enumerate()
        {
            let x = x + 6 * k as i32 - 6;
            area.draw(&Rectangle::new([(x, y - 6), (x + 6, y + 6)], c.filled()))
                .map_err(e)?;
        }
        area.draw(&Rectangle::new(
            [(x - 6, y - 6), (x + 18, y + 6)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)
    })?;
    Ok(())
}

/// Draws `plot` into a PNG at `path`: one panel per engine (two columns
/// when there are several), each over the whole plan, with the legend in a
/// strip below the panels.
pub fn track_png(path: &Path, plot: &TrackPlot) -> anyhow::Result<()> {
    ensure_font()?;
    let (x0, x1, y0, y1) = bounds(plot);
    let n = plot.panels.len().max(1);
    let cols = if n == 1 { 1 } else { 2 };
    let rows = n.div_ceil(cols);
    let panel_w = if cols == 1 { 1000.0 } else { 760.0 };
    let plot_h = (panel_w * (y1 - y0) / (x1 - x0)).clamp(220.0, 1100.0);
    let (pw, ph) = (panel_w as u32 + 70, plot_h as u32 + 95);
    let legend_h = 40u32;
    let title_h = 34u32;
    let (w, h) = (pw * cols as u32, title_h + ph * rows as u32 + legend_h);
    let span = (x1 - x0).max(y1 - y0);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let (top, rest) = root.split_vertically(title_h);
        top.draw(&Text::new(
            plot.title.clone(),
            (10, 8),
            ("sans-serif", 20).into_font().color(&BLACK),
        ))
        .map_err(e)?;
        let (grid, legend) = rest.split_vertically(ph * rows as u32);
        let cells = grid.split_evenly((rows, cols));
        let empty = Panel {
            label: "no track".into(),
            note: String::new(),
            points: Vec::new(),
            jump: Vec::new(),
            gap: Vec::new(),
        };
        let panels: Vec<&Panel> = if plot.panels.is_empty() {
            vec![&empty]
        } else {
            plot.panels.iter().collect()
        };
        let mut colors = Vec::new();
        for (i, (p, cell)) in panels.iter().zip(cells.iter()).enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            colors.push(c);
            let caption = if p.note.is_empty() {
                p.label.clone()
            } else {
                format!("{}: {}", p.label, p.note)
            };
            let mut chart = ChartBuilder::on(cell)
                .caption(caption, ("sans-serif", 16))
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(45)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(e)?;
            if let Some(map) = plot.map {
                draw_map(&root, &chart, map, (x0, x1, y0, y1))?;
            }
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("x (m)")
                .y_desc("y (m)")
                .draw()
                .map_err(e)?;
            if !plot.truth.is_empty() {
                chart
                    .draw_series(LineSeries::new(
                        plot.truth.iter().copied(),
                        TRUTH_COLOR.mix(0.5).stroke_width(1),
                    ))
                    .map_err(e)?;
                chart
                    .draw_series(
                        plot.truth
                            .iter()
                            .map(|p| Circle::new(*p, 2, TRUTH_COLOR.mix(0.8).filled())),
                    )
                    .map_err(e)?;
            }
            draw_track(&mut chart, p, c, span)?;
        }
        draw_legend(&legend, &colors)?;
        root.present().map_err(e)?;
    }
    save_rgb(path, w, h, buf)
}

/// A raster of a floor (one image pixel per plan pixel, row 0 at the top)
/// drawn as a figure: axes in metres, a scale bar, `points` (MCS metres)
/// as outlined dots that stay visible at any plan size, and a legend strip
/// below the plan (colour patches with labels).
pub struct FloorFigure<'a> {
    pub title: String,
    pub image: &'a image::RgbaImage,
    pub width_m: f64,
    pub height_m: f64,
    pub points: &'a [(f64, f64)],
    pub point_label: &'a str,
    pub point_color: RGBColor,
    pub legend: Vec<(String, RGBColor)>,
}

/// A round length near a fifth of `span` (1, 2 or 5 times a power of ten), metres.
pub fn scale_bar_m(span: f64) -> f64 {
    let target = (span / 5.0).max(1e-3);
    let p = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .iter()
        .map(|k| k * p)
        .find(|&l| l <= target)
        .unwrap_or(p)
}

/// Draws a [`FloorFigure`] into a PNG at `path` (about 1100 px wide).
pub fn floor_figure_png(path: &Path, fig: &FloorFigure) -> anyhow::Result<()> {
    ensure_font()?;
    let (x0, x1, y0, y1) = (0.0, fig.width_m.max(1e-3), 0.0, fig.height_m.max(1e-3));
    let plot_w = 1000.0;
    let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(200.0, 1300.0);
    let legend_h = 40u32;
    let (w, h) = (plot_w as u32 + 90, plot_h as u32 + 100 + legend_h);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let (top, legend) = root.split_vertically(h - legend_h);
        let mut chart = ChartBuilder::on(&top)
            .caption(fpbp_core::bounds::cut(&fig.title, 110), ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(e)?;
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let (pw, ph) = (
            (xr.end - xr.start).max(1) as f64,
            (yr.end - yr.start).max(1) as f64,
        );
        let (iw, ih) = (fig.image.width() as f64, fig.image.height() as f64);
        for py in yr.clone() {
            let v = ((py - yr.start) as f64 / ph * ih) as u32;
            for px in xr.clone() {
                let u = ((px - xr.start) as f64 / pw * iw) as u32;
                if u < fig.image.width() && v < fig.image.height() {
                    let c = fig.image.get_pixel(u, v).0;
                    root.draw_pixel((px, py), &RGBColor(c[0], c[1], c[2]))
                        .map_err(e)?;
                }
            }
        }
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .draw()
            .map_err(e)?;
        chart
            .draw_series(
                fig.points
                    .iter()
                    .map(|p| Circle::new(*p, 4, WHITE.filled())),
            )
            .map_err(e)?;
        chart
            .draw_series(
                fig.points
                    .iter()
                    .map(|p| Circle::new(*p, 3, fig.point_color.filled())),
            )
            .map_err(e)?;
        // scale bar in the lower left corner, on a white box
        let len = scale_bar_m(x1 - x0);
        let (bx, by) = (x0 + 0.03 * (x1 - x0), y0 + 0.04 * (y1 - y0));
        let pad = 0.012 * (x1 - x0);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [
                    (bx - pad, by - pad),
                    (bx + len + pad, by + 0.05 * (y1 - y0)),
                ],
                WHITE.mix(0.9).filled(),
            )))
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(bx, by), (bx + len, by)],
                BLACK.stroke_width(3),
            )))
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{len} m"),
                (bx, by + 0.015 * (y1 - y0)),
                ("sans-serif", 14).into_font().color(&BLACK),
            )))
            .map_err(e)?;
        let text = ("sans-serif", 15).into_font().color(&BLACK);
        let mut x = 20i32;
        let mut items: Vec<(String, RGBColor)> = fig.legend.clone();
        if !fig.points.is_empty() {
            items.push((
                format!("{} ({})", fig.point_label, fig.points.len()),
                fig.point_color,
            ));
        }
        for (label, c) in &items {
            legend
                .draw(&Rectangle::new([(x, 12), (x + 16, 28)], c.filled()))
                .map_err(e)?;
            legend
                .draw(&Rectangle::new(
                    [(x, 12), (x + 16, 28)],
                    BLACK.stroke_width(1),
                ))
                .map_err(e)?;
            legend
                .draw(&Text::new(label.clone(), (x + 22, 12), text.clone()))
                .map_err(e)?;
            x += 34 + 8 * label.len() as i32;
        }
        root.present().map_err(e)?;
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

/// One engine's errors for [`cdf_png`].
#[derive(Debug, Clone)]
pub struct CdfSeries {
    /// Engine name and its start mode, e.g. "fpbp (own start)".
    pub label: String,
    /// Errors at the points with a pose, metres.
    pub errors: Vec<f64>,
    /// All scored points (with and without a pose): the curve rises to the
    /// coverage, errors.len() / points, not to 1.
    pub points: usize,
}

/// Draws the empirical CDF of each series' errors (metres) into a PNG. The
/// y axis is the share of all scored points, so an engine without a pose at
/// some points levels off at its coverage; the legend gives n with a pose
/// of all points and the coverage.
pub fn cdf_png(path: &Path, title: &str, series: &[CdfSeries]) -> anyhow::Result<()> {
    let x_max = series
        .iter()
        .flat_map(|s| s.errors.iter().copied())
        .filter(|e| e.is_finite())
        .fold(1.0f64, f64::max)
        * 1.05;
    let steps: Vec<(String, Vec<(f64, f64)>)> = series
        .iter()
        .map(|s| {
            let mut v: Vec<f64> = s.errors.iter().copied().filter(|e| e.is_finite()).collect();
            v.sort_by(f64::total_cmp);
            let n = s.points.max(v.len()).max(1) as f64;
            let mut pts = vec![(0.0, 0.0)];
            for (k, e) in v.iter().enumerate() {
                pts.push((*e, k as f64 / n));
                pts.push((*e, (k + 1) as f64 / n));
            }
            let top = v.len() as f64 / n;
            pts.push((x_max, top));
            (
                format!(
                    "{}: {} of {} points with a pose ({:.0}%)",
                    s.label,
                    v.len(),
                    s.points.max(v.len()),
                    100.0 * top
                ),
                pts,
            )
        })
        .collect();
    let spec = LineChart {
        title,
        x_desc: "error (m)",
        y_desc: "share of all scored points",
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
        let pt = |x_m, y_m| TrackPoint { x_m, y_m };
        let plot = TrackPlot {
            title: "test track".into(),
            map: Some(&map),
            panels: vec![Panel {
                label: "pdr".into(),
                note: "truth start".into(),
                points: vec![pt(2.0, 2.0), pt(10.0, 5.0), pt(18.0, 8.0)],
                jump: vec![false, true],
                gap: vec![],
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
        // start marker and the end marker
        assert!(px.contains(&[0, 170, 60]) && px.contains(&[0, 0, 0]));
        // two panels side by side
        let two = TrackPlot {
            panels: vec![plot.panels[0].clone(), plot.panels[0].clone()],
            ..plot.clone()
        };
        track_png(&d.join("two.png"), &two).unwrap();
        assert!(image::open(d.join("two.png")).unwrap().width() > 1500);
        let c = d.join("cdf.png");
        cdf_png(
            &c,
            "cdf",
            &[
                CdfSeries {
                    label: "a".into(),
                    errors: vec![1.0, 2.0, 3.0],
                    points: 4,
                },
                CdfSeries {
                    label: "b".into(),
                    errors: vec![],
                    points: 4,
                },
            ],
        )
        .unwrap();
        assert!(image::open(&c).unwrap().width() == 900);
        // Without a map the bounds come from the data.
        let plot = TrackPlot { map: None, ..plot };
        track_png(&d.join("nomap.png"), &plot).unwrap();
        std::fs::remove_dir_all(&d).ok();
    }
}
