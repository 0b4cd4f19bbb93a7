//! Rooms (FP-BP Sec. IV-A2): the regions bounded by the obstacle mask
//! I_obs = I_Wall + I_Door. We label the 4-connected components of Walkable
//! pixels instead of tracing inner contours: every query the engines make
//! (`room_of`, "same room?", nearest point of a room) becomes an O(1) array
//! lookup or a scan of one room's boundary pixels, and nested obstacles
//! (a pillar inside a room) need no contour hierarchy. 4-connectivity keeps an
//! 8-connected (one pixel thick) diagonal wall closed.

use crate::Vec2;

use super::Feature;

/// Room identifier: index into [`super::FloorMap::rooms`].
pub type RoomId = u32;

/// Label of pixels that belong to no room (obstacles).
pub(crate) const NO_ROOM: RoomId = RoomId::MAX;

/// One room: a 4-connected component of Walkable pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Room {
    pub id: RoomId,
    /// Area, square metres (pixel_count / r^2).
    pub area_m2: f64,
    pub pixel_count: usize,
    /// Mean of the pixel centres, MCS metres (may lie outside a non-convex room).
    pub centroid_m: Vec2,
}

/// Per-pixel room labels plus per-room data.
#[derive(Debug, Clone)]
pub(crate) struct RoomLabels {
    /// Row-major, one label per pixel; [`NO_ROOM`] on obstacles.
    pub labels: Vec<RoomId>,
    pub rooms: Vec<Room>,
    /// Per room, the pixel indices (j * width + i) of its boundary pixels:
    /// room pixels with a 4-neighbour outside the room.
    pub boundary: Vec<Vec<u32>>,
}

/// Labels the Walkable components of a row-major feature grid, in scan order.
pub(crate) fn label_rooms(
    width: usize,
    height: usize,
    pixels_per_meter: f64,
    features: &[Feature],
) -> RoomLabels {
    let mut labels = vec![NO_ROOM; width * height];
    let mut rooms = Vec::new();
    let mut boundary = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    for start in 0..width * height {
        if features[start] != Feature::Walkable || labels[start] != NO_ROOM {
            continue;
        }
        let id = rooms.len() as RoomId;
        labels[start] = id;
        stack.push(start);
        let (mut n, mut sx, mut sy) = (0usize, 0.0f64, 0.0f64);
        let mut edge = Vec::new();
        while let Some(k) = stack.pop() {
            let (i, j) = (k % width, k / width);
            n += 1;
            sx += i as f64 + 0.5;
            sy += j as f64 + 0.5;
            let mut on_edge = false;
            let nbrs = [
                (i > 0).then(|| k - 1),
                (i + 1 < width).then(|| k + 1),
                (j > 0).then(|| k - width),
                (j + 1 < height).then(|| k + width),
            ];
            for nb in nbrs {
                match nb {
                    Some(m) if features[m] == Feature::Walkable => {
                        if labels[m] == NO_ROOM {
                            labels[m] = id;
                            stack.push(m);
                        }
                    }
                    _ => on_edge = true,
                }
            }
            if on_edge {
                edge.push(k as u32);
            }
        }
        edge.sort_unstable();
        let r = pixels_per_meter;
        rooms.push(Room {
            id,
            area_m2: n as f64 / (r * r),
            pixel_count: n,
            centroid_m: Vec2::new(sx / n as f64 / r, (height as f64 - sy / n as f64) / r),
        });
        boundary.push(edge);
    }
    RoomLabels {
        labels,
        rooms,
        boundary,
    }
}
