//! The offline phase of FP-BP (Sec. IV-A): stylized plan -> masks, rooms,
//! ICS <-> MCS transform, map feature function M(x), raycast, normals, GML grid.
//!
//! Frames: ICS is image pixels (x right, y down, pixel (i, j) covers
//! [i, i+1) x [j, j+1)); MCS is metres (x right, y up, origin at the image's
//! bottom-left): x = x_I / r, y = (H - y_I) / r (eq. 23).

mod crossings;
pub mod distance_grid;
mod downsample;
mod grid;
mod normals;
pub mod plan;
mod raycast;
mod rooms;
pub mod survey_coverage;
mod walk;

pub use crossings::Crossings;
pub use plan::{ClassifiedPlan, Legend, classify_png, png_dimensions};
pub use raycast::crosses_wall_sampled;
pub use rooms::{Room, RoomId};
pub use walk::{TRACK_WALL_STEP_M, WALK_MAX_NODES, WalkStep};

use crate::Vec2;
use rooms::NO_ROOM;

/// Default GML grid interval I_M, metres (used by [`FloorMap::from_features`]).
pub const DEFAULT_GRID_INTERVAL_M: f64 = 1.0;

/// How a floor map was built from its plan (printed by `fpbp map check`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BuildReport {
    /// Plan size before downsampling, pixels.
    pub source_width_px: usize,
    pub source_height_px: usize,
    /// Plan pixels that matched no legend colour within the tolerance.
    pub unclassified_count: usize,
    /// unclassified_count over all plan pixels.
    pub unclassified_fraction: f64,
    /// Integer downsampling factor applied (1 = none).
    pub downsample_factor: usize,
}

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
    /// `width_px as f64`, `height_px as f64` (the conversion is not free).
    width_f: f64,
    height_f: f64,
    pixels_per_meter: f64,
    /// 1 / `pixels_per_meter`.
    meters_per_pixel: f64,
    /// Row-major, row 0 at the top of the image.
    features: Vec<Feature>,
    /// Row-major obstacle clearance per pixel (`raycast.rs`).
    clearance: Vec<u8>,
    /// Row-major Wall clearance per pixel (Doors count as free; `raycast.rs`).
    wall_clearance: Vec<u8>,
    /// Row-major room label per pixel ([`NO_ROOM`] on obstacles).
    room_labels: Vec<RoomId>,
    rooms: Vec<Room>,
    /// Per room, boundary pixel indices (for nearest-point queries).
    room_boundary: Vec<Vec<u32>>,
    grid: Vec<Vec2>,
    grid_interval_m: f64,
    walkable_pixels: usize,
    door_pixels: usize,
    report: BuildReport,
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
        Self::from_features_with_grid(
            width_px,
            height_px,
            pixels_per_meter,
            features,
            DEFAULT_GRID_INTERVAL_M,
        )
    }

    /// As [`FloorMap::from_features`] with GML grid interval `grid_interval_m`
    /// (I_M, metres; a value not > 0 gives an empty grid). Labels the rooms
    /// and builds the grid. Same panics as `from_features`.
    pub fn from_features_with_grid(
        width_px: usize,
        height_px: usize,
        pixels_per_meter: f64,
        features: Vec<Feature>,
        grid_interval_m: f64,
    ) -> FloorMap {
        assert_eq!(features.len(), width_px * height_px, "feature grid size");
        assert!(pixels_per_meter > 0.0, "pixels_per_meter must be > 0");
        let labels = rooms::label_rooms(width_px, height_px, pixels_per_meter, &features);
        let walkable_pixels = features.iter().filter(|f| **f == Feature::Walkable).count();
        let door_pixels = features.iter().filter(|f| **f == Feature::Door).count();
        let clearance = raycast::clearance_px(width_px, height_px, &features, Feature::is_obstacle);
        let wall_clearance =
            raycast::clearance_px(width_px, height_px, &features, |f| f == Feature::Wall);
        let mut map = FloorMap {
            width_px,
            height_px,
            width_f: width_px as f64,
            height_f: height_px as f64,
            pixels_per_meter,
            meters_per_pixel: 1.0 / pixels_per_meter,
            features,
            clearance,
            wall_clearance,
            room_labels: labels.labels,
            rooms: labels.rooms,
            room_boundary: labels.boundary,
            grid: Vec::new(),
            grid_interval_m,
            walkable_pixels,
            door_pixels,
            report: BuildReport {
                source_width_px: width_px,
                source_height_px: height_px,
                unclassified_count: 0,
                unclassified_fraction: 0.0,
                downsample_factor: 1,
            },
        };
        map.grid = grid::build_grid(&map, grid_interval_m);
        map
    }

    /// Builds a map from a classified plan, downsampled by `downsample_factor`
    /// (1 = none; see `downsample.rs`) with `pixels_per_meter` being the plan's r.
    pub fn from_classified_plan(
        plan: ClassifiedPlan,
        pixels_per_meter: f64,
        downsample_factor: usize,
        grid_interval_m: f64,
    ) -> FloorMap {
        let k = downsample_factor.max(1);
        let report = BuildReport {
            source_width_px: plan.width_px,
            source_height_px: plan.height_px,
            unclassified_count: plan.unclassified_count,
            unclassified_fraction: plan.unclassified_fraction(),
            downsample_factor: k,
        };
        let (w, h, f) = if k == 1 {
            (plan.width_px, plan.height_px, plan.features)
        } else {
            downsample::downsample(plan.width_px, plan.height_px, &plan.features, k)
        };
        let mut map =
            Self::from_features_with_grid(w, h, pixels_per_meter / k as f64, f, grid_interval_m);
        map.report = report;
        map
    }

    /// The integer downsampling factor taking resolution `r` to about `target` px/m.
    pub fn downsample_factor(r: f64, target: f64) -> usize {
        downsample::factor(r, target)
    }

    /// How this map was built (unclassified pixels, downsampling).
    pub fn build_report(&self) -> &BuildReport {
        &self.report
    }

    /// The room containing MCS point `p` (None on obstacles and outside); O(1).
    pub fn room_of(&self, p: Vec2) -> Option<RoomId> {
        let (i, j) = self.pixel_of(p)?;
        let id = self.room_labels[j * self.width_px + i];
        (id != NO_ROOM).then_some(id)
    }

    /// The room of pixel (column, row), if any.
    pub fn room_of_px(&self, i: usize, j: usize) -> Option<RoomId> {
        if i >= self.width_px || j >= self.height_px {
            return None;
        }
        let id = self.room_labels[j * self.width_px + i];
        (id != NO_ROOM).then_some(id)
    }

    /// All rooms, indexed by their id.
    pub fn rooms(&self) -> &[Room] {
        &self.rooms
    }

    /// Unit normal (MCS) of the obstacle mask at `p`, pointing out of the
    /// obstacle into walkable space (-grad I, eq. 37); None where the
    /// gradient vanishes.
    pub fn normal_at(&self, p: Vec2) -> Option<Vec2> {
        normals::normal_at(self, p)
    }

    /// The Walkable point of `room` nearest to `p` (FP-BP eq. 43's x_c): `p`
    /// itself when it lies in the room, otherwise the centre of the nearest
    /// boundary pixel of the room. None for an unknown room id. Cost: one
    /// pass over the room's boundary pixels.
    pub fn nearest_walkable_in_room(&self, room: RoomId, p: Vec2) -> Option<Vec2> {
        let boundary = self.room_boundary.get(room as usize)?;
        if self.room_of(p) == Some(room) {
            return Some(p);
        }
        let q = self.mcs_to_ics(p);
        let mut best: Option<(f64, u32)> = None;
        for &k in boundary {
            let (i, j) = (k as usize % self.width_px, k as usize / self.width_px);
            let dx = i as f64 + 0.5 - q.x;
            let dy = j as f64 + 0.5 - q.y;
            let d2 = dx * dx + dy * dy;
            if best.is_none_or(|(b, _)| d2 < b) {
                best = Some((d2, k));
            }
        }
        let (_, k) = best?;
        let (i, j) = (k as usize % self.width_px, k as usize / self.width_px);
        Some(self.ics_to_mcs(Vec2::new(i as f64 + 0.5, j as f64 + 0.5)))
    }

    /// The Walkable pixel centre nearest to `p` within `radius_m` (`p`
    /// itself when it is Walkable); None when there is none. Cost: the
    /// pixels of the square around `p` (radius capped at 50 m).
    pub fn nearest_walkable_within(&self, p: Vec2, radius_m: f64) -> Option<Vec2> {
        if self.is_walkable(p) {
            return Some(p);
        }
        if radius_m.is_nan() || radius_m <= 0.0 || !p.x.is_finite() || !p.y.is_finite() {
            return None;
        }
        let q = self.mcs_to_ics(p);
        let r_px = radius_m.min(50.0) * self.pixels_per_meter;
        let clamp = |v: f64, n: usize| v.floor().clamp(0.0, n as f64) as usize;
        let (i0, i1) = (
            clamp(q.x - r_px, self.width_px),
            clamp(q.x + r_px + 1.0, self.width_px),
        );
        let (j0, j1) = (
            clamp(q.y - r_px, self.height_px),
            clamp(q.y + r_px + 1.0, self.height_px),
        );
        let mut best: Option<(f64, usize, usize)> = None;
        for j in j0..j1 {
            for i in i0..i1 {
                if self.features[j * self.width_px + i] != Feature::Walkable {
                    continue;
                }
                let (dx, dy) = (i as f64 + 0.5 - q.x, j as f64 + 0.5 - q.y);
                let d2 = dx * dx + dy * dy;
                if d2 <= r_px * r_px && best.is_none_or(|(b, _, _)| d2 < b) {
                    best = Some((d2, i, j));
                }
            }
        }
        best.map(|(_, i, j)| self.ics_to_mcs(Vec2::new(i as f64 + 0.5, j as f64 + 0.5)))
    }

    /// The GML grid G (Sec. IV-A4): Walkable cell centres at interval I_M.
    pub fn grid(&self) -> &[Vec2] {
        &self.grid
    }

    /// The grid interval I_M, metres.
    pub fn grid_interval_m(&self) -> f64 {
        self.grid_interval_m
    }

    /// Walkable pixels.
    pub fn walkable_pixel_count(&self) -> usize {
        self.walkable_pixels
    }

    /// Walkable area, square metres.
    pub fn walkable_area_m2(&self) -> f64 {
        self.walkable_pixels as f64 / (self.pixels_per_meter * self.pixels_per_meter)
    }

    /// Door pixels.
    pub fn door_pixel_count(&self) -> usize {
        self.door_pixels
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
            self.height_f - p.y * self.pixels_per_meter,
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
        // 0 <= q < (W, H) (false for NaN): truncation is floor there (and
        // cheaper than a libm call), and q < W <=> floor(q) < W for integer W
        if q.x >= 0.0 && q.y >= 0.0 && q.x < self.width_f && q.y < self.height_f {
            Some((q.x as i64 as usize, q.y as i64 as usize))
        } else {
            None
        }
    }

    /// Row-major index of the pixel containing `p`, if inside the image.
    fn index_of(&self, p: Vec2) -> Option<usize> {
        self.pixel_of(p).map(|(i, j)| j * self.width_px + i)
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
        match self.index_of(p) {
            Some(k) => self.features[k],
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
}

#[cfg(test)]
mod tests;
