//! Normals of the obstacle mask (FP-BP eq. 37): n_h from the image gradient
//! of I_obs (1 on Wall/Door, 0 on Walkable; outside the image counts as
//! obstacle), taken with a 3x3 Sobel kernel at the pixel and, where that
//! vanishes (inside a thick wall, or on a one-pixel symmetric feature), with
//! a 5x5 kernel. The normal is -grad I (pointing out of the obstacle into
//! walkable space), converted ICS -> MCS by flipping y, unit length.

use crate::Vec2;

use super::FloorMap;

fn obs(map: &FloorMap, i: isize, j: isize) -> f64 {
    if map.feature_px(i, j).is_obstacle() {
        1.0
    } else {
        0.0
    }
}

/// Gradient of I_obs at pixel (i, j) in ICS (x right, y down) over a square
/// window of radius `rad` (1 = Sobel 3x3; 2 = the 5x5 kernel
/// w(dx, dy) = dx / (dx^2 + dy^2), a smoothed central difference).
pub(crate) fn gradient_ics(map: &FloorMap, i: isize, j: isize, rad: isize) -> (f64, f64) {
    let (mut gx, mut gy) = (0.0, 0.0);
    for dy in -rad..=rad {
        for dx in -rad..=rad {
            if dx == 0 && dy == 0 {
                continue;
            }
            let v = obs(map, i + dx, j + dy);
            if v == 0.0 {
                continue;
            }
            let (wx, wy) = if rad == 1 {
                // Sobel: [1 2 1]^T [-1 0 1]
                let s = |a: isize| if a == 0 { 2.0 } else { 1.0 };
                (dx as f64 * s(dy), dy as f64 * s(dx))
            } else {
                let d2 = (dx * dx + dy * dy) as f64;
                (dx as f64 / d2, dy as f64 / d2)
            };
            gx += wx * v;
            gy += wy * v;
        }
    }
    (gx, gy)
}

/// Unit normal in the MCS at MCS point `p`, pointing out of the obstacle, or
/// None where the gradient vanishes (open floor, wall interiors thicker than 5 px).
pub(crate) fn normal_at(map: &FloorMap, p: Vec2) -> Option<Vec2> {
    let q = map.mcs_to_ics(p);
    if !(q.x.is_finite() && q.y.is_finite()) {
        return None;
    }
    let (i, j) = (q.x.floor() as isize, q.y.floor() as isize);
    for rad in [1, 2] {
        let (gx, gy) = gradient_ics(map, i, j, rad);
        // -grad in ICS = (-gx, -gy); ICS -> MCS flips y: (-gx, gy).
        let n = Vec2::new(-gx, gy);
        let len = n.norm();
        if len > 1e-9 {
            return Some(n / len);
        }
    }
    None
}
