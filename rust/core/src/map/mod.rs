//! The offline phase of FP-BP (Sec. IV-A): stylized plan -> masks, rooms,
//! ICS <-> MCS transform, map feature function M(x), raycast, normals, GML grid.
//!
//! Frames: ICS is image pixels (x right, y down, pixel (i, j) covers
//! [i, i+1) x [j, j+1)); MCS is metres (x right, y up, origin at the image's
//! bottom-left): x = x_I / r, y = (H - y_I) / r (eq. 23).

use crate::Vec2;

/// The map feature of a point (eq. 25).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Feature {
    Walkable = 0,
    Door = 1,
    Wall = 2,
}

impl Feature {
    /// M(x) of eq. 25: 0 Walkable, 0.5 Door, 1 Wall.
    pub fn m_value(self) -> f64 {
        match self {
            Feature::Walkable => 0.0,
            Feature::Door => 0.5,
            Feature::Wall => 1.0,
        }
    }

    /// Wall or Door.
    pub fn is_obstacle(self) -> bool {
        self != Feature::Walkable
    }
}

/// First obstacle met by [`FloorMap::raycast`] (Function 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    pub point: Vec2,
    pub feature: Feature,
}

/// A built floor map: one feature per pixel plus the frames.
#[derive(Debug, Clone)]
pub struct FloorMap {
    width_px: usize,
    height_px: usize,
    pixels_per_meter: f64,
    /// Row-major, row 0 at the top of the image.
    features: Vec<Feature>,
}

impl FloorMap {
    /// A map from per-pixel features (row-major, row 0 at the top).
    /// Panics if `features.len() != width_px * height_px` or r <= 0: callers
    /// (the plan loader, tests) validate first.
    pub fn from_features(
        width_px: usize,
        height_px: usize,
        pixels_per_meter: f64,
        features: Vec<Feature>,
    ) -> FloorMap {
        assert_eq!(features.len(), width_px * height_px, "feature grid size");
        assert!(pixels_per_meter > 0.0, "pixels_per_meter must be > 0");
        FloorMap {
            width_px,
            height_px,
            pixels_per_meter,
            features,
        }
    }

    pub fn width_px(&self) -> usize {
        self.width_px
    }
    pub fn height_px(&self) -> usize {
        self.height_px
    }
    /// Resolution factor r, pixels per metre.
    pub fn pixels_per_meter(&self) -> f64 {
        self.pixels_per_meter
    }
    pub fn width_m(&self) -> f64 {
        self.width_px as f64 / self.pixels_per_meter
    }
    pub fn height_m(&self) -> f64 {
        self.height_px as f64 / self.pixels_per_meter
    }

    /// MCS -> ICS (inverse of eq. 23), continuous pixel coordinates.
    pub fn mcs_to_ics(&self, p: Vec2) -> Vec2 {
        Vec2::new(
            p.x * self.pixels_per_meter,
            self.height_px as f64 - p.y * self.pixels_per_meter,
        )
    }

    /// ICS -> MCS (eq. 23).
    pub fn ics_to_mcs(&self, q: Vec2) -> Vec2 {
        Vec2::new(
            q.x / self.pixels_per_meter,
            (self.height_px as f64 - q.y) / self.pixels_per_meter,
        )
    }

    /// The pixel (column, row) containing MCS point `p`, if inside the image.
    pub fn pixel_of(&self, p: Vec2) -> Option<(usize, usize)> {
        let q = self.mcs_to_ics(p);
        if !(q.x >= 0.0 && q.y >= 0.0) {
            return None;
        }
        let (i, j) = (q.x.floor() as usize, q.y.floor() as usize);
        (i < self.width_px && j < self.height_px).then_some((i, j))
    }

    /// Feature of pixel (column, row); outside the image is Wall.
    pub fn feature_px(&self, i: isize, j: isize) -> Feature {
        if i < 0 || j < 0 || i as usize >= self.width_px || j as usize >= self.height_px {
            return Feature::Wall;
        }
        self.features[j as usize * self.width_px + i as usize]
    }

    /// The map feature function M(x) (eqs. 24-25) as a class; O(1); outside = Wall.
    pub fn feature(&self, p: Vec2) -> Feature {
        match self.pixel_of(p) {
            Some((i, j)) => self.features[j * self.width_px + i],
            None => Feature::Wall,
        }
    }

    /// M(x) in {0, 0.5, 1}.
    pub fn m_value(&self, p: Vec2) -> f64 {
        self.feature(p).m_value()
    }

    pub fn is_walkable(&self, p: Vec2) -> bool {
        self.feature(p) == Feature::Walkable
    }

    /// Raycast exactly as FP-BP Function 1: walk from `from` towards `to` in
    /// steps of `step_m` (k = 0..=Round(|to - from| / step_m)) and return the
    /// first sample whose M(x) > 0. A zero-length ray tests `from` alone.
    /// The returned point never lies beyond `to` by more than step_m / 2
    /// (the rounding of N); it is clamped to the segment.
    pub fn raycast(&self, from: Vec2, to: Vec2, step_m: f64) -> Option<RayHit> {
        let d = to - from;
        let len = d.norm();
        if len == 0.0 {
            let f = self.feature(from);
            return f.is_obstacle().then_some(RayHit {
                point: from,
                feature: f,
            });
        }
        let step = if step_m > 0.0 { step_m } else { 0.05 };
        let n = (len / step).round() as usize;
        let dir = d / len;
        for k in 0..=n {
            let s = (k as f64 * step).min(len);
            let x = from + dir * s;
            let f = self.feature(x);
            if f.is_obstacle() {
                return Some(RayHit {
                    point: x,
                    feature: f,
                });
            }
        }
        None
    }
}
