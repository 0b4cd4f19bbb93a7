//! Drawing stylized plans from strokes: the shared part of the site
//! generators (`examples/make_demo_site.rs`, [`crate::replica_sites`]).
//! Walls are thick segments or arcs with round caps, doors thick segments
//! or arcs with flat ends, blocks filled rectangles of Wall (un-enterable
//! areas); everything else is Walkable. Deterministic: a pixel's class
//! depends only on its centre.

use fpbp_core::Vec2;
use fpbp_core::site::Legend;

/// A thick stroke: a segment or a circular arc (angles in radians, CCW from
/// a0 to a1).
pub enum Stroke {
    Seg {
        a: Vec2,
        b: Vec2,
    },
    Arc {
        c: Vec2,
        radius: f64,
        a0: f64,
        a1: f64,
    },
}

impl Stroke {
    /// Whether `p` lies within `half_t` of the stroke (round caps for walls,
    /// flat ends for doors).
    pub fn contains(&self, p: Vec2, half_t: f64, round_caps: bool) -> bool {
        match *self {
            Stroke::Seg { a, b } => {
                let d = b - a;
                let len2 = d.norm_squared();
                let t = (p - a).dot(&d) / len2;
                if round_caps {
                    let q = a + d * t.clamp(0.0, 1.0);
                    (p - q).norm() <= half_t
                } else {
                    (0.0..=1.0).contains(&t) && (p - (a + d * t)).norm() <= half_t
                }
            }
            Stroke::Arc { c, radius, a0, a1 } => {
                let v = p - c;
                let mut ang = v.y.atan2(v.x);
                while ang < a0 {
                    ang += std::f64::consts::TAU;
                }
                let on_arc = ang <= a1 && (v.norm() - radius).abs() <= half_t;
                if on_arc || !round_caps {
                    return on_arc;
                }
                let end = |a: f64| c + Vec2::new(a.cos(), a.sin()) * radius;
                (p - end(a0)).norm() <= half_t || (p - end(a1)).norm() <= half_t
            }
        }
    }
}

/// A straight stroke from (ax, ay) to (bx, by), metres.
pub fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Stroke {
    Stroke::Seg {
        a: Vec2::new(ax, ay),
        b: Vec2::new(bx, by),
    }
}

/// An axis-aligned filled rectangle [x0, x1] x [y0, y1], metres.
#[derive(Debug, Clone, Copy)]
pub struct Block {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Block {
    pub fn contains(&self, p: Vec2) -> bool {
        (self.x0..=self.x1).contains(&p.x) && (self.y0..=self.y1).contains(&p.y)
    }
}

/// What a plan is drawn from.
pub struct Drawing {
    /// Size of the plan, metres.
    pub width_m: f64,
    pub height_m: f64,
    /// Resolution, pixels per metre.
    pub pixels_per_meter: f64,
    /// Wall thickness, metres.
    pub wall_m: f64,
    pub walls: Vec<Stroke>,
    pub doors: Vec<Stroke>,
    /// Filled Wall areas.
    pub blocks: Vec<Block>,
    /// Walkable openings cut through blocks (walls and doors are drawn over them).
    pub openings: Vec<Block>,
}

impl Drawing {
    /// Renders the plan: a door pixel wins over everything, then walls, then
    /// openings, then blocks (pixel centres in the MCS, FP-BP eq. 23).
    pub fn render(&self, legend: &Legend) -> image::RgbImage {
        let r = self.pixels_per_meter;
        let (w, h) = (
            (self.width_m * r).round() as u32,
            (self.height_m * r).round() as u32,
        );
        let half_t = self.wall_m / 2.0;
        image::RgbImage::from_fn(w, h, |i, j| {
            let p = Vec2::new((i as f64 + 0.5) / r, (h as f64 - j as f64 - 0.5) / r);
            if self
                .doors
                .iter()
                .any(|d| d.contains(p, half_t + 1e-9, false))
            {
                image::Rgb(legend.door)
            } else if self.walls.iter().any(|s| s.contains(p, half_t, true)) {
                image::Rgb(legend.wall)
            } else if self.openings.iter().any(|o| o.contains(p)) {
                image::Rgb(legend.walkable)
            } else if self.blocks.iter().any(|b| b.contains(p)) {
                image::Rgb(legend.wall)
            } else {
                image::Rgb(legend.walkable)
            }
        })
    }
}

/// Whether MCS point (x, y) falls on a walkable pixel of `img` (r px/m).
pub fn is_walkable(img: &image::RgbImage, legend: &Legend, r: f64, x: f64, y: f64) -> bool {
    let (w, h) = img.dimensions();
    if !(x >= 0.0 && y >= 0.0) {
        return false;
    }
    let (i, j) = ((x * r).floor(), (h as f64 - y * r).floor());
    i >= 0.0
        && j >= 0.0
        && (i as u32) < w
        && (j as u32) < h
        && img.get_pixel(i as u32, j as u32).0 == legend.walkable
}
