//! The GML grid array G (FP-BP Sec. IV-A4). The paper prints
//! g_ij = [(i + 0.5) X / I_M, (j + 0.5) Y / I_M], which is dimensionally off
//! (X / I_M is a count, not a length); we use the cell centres
//! g_ij = [(i + 0.5) I_M, (j + 0.5) I_M] for i in 0..floor(X / I_M),
//! j in 0..floor(Y / I_M) and keep only the Walkable ones (M(g) = 0). The
//! paper's 1 <= i drops the first row and column; we keep them, since
//! filtering by M already removes points on a bordering wall and an open
//! floor has walkable space there.

use crate::Vec2;

use super::FloorMap;

/// Walkable cell centres at interval `interval_m`, in row-major order from
/// the MCS origin (j outer, i inner). Empty when `interval_m` is not > 0.
pub(crate) fn build_grid(map: &FloorMap, interval_m: f64) -> Vec<Vec2> {
    if !(interval_m > 0.0 && interval_m.is_finite()) {
        return Vec::new();
    }
    let ni = (map.width_m() / interval_m).floor() as usize;
    let nj = (map.height_m() / interval_m).floor() as usize;
    let mut g = Vec::new();
    for j in 0..nj {
        for i in 0..ni {
            let p = Vec2::new((i as f64 + 0.5) * interval_m, (j as f64 + 0.5) * interval_m);
            if map.is_walkable(p) {
                g.push(p);
            }
        }
    }
    g
}
