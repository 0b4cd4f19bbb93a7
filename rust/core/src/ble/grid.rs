//! A rectangular grid array for GML tests and benches (FP-BP Sec. IV-A4 on an
//! open rectangle). Engines use the map's own `FloorMap::grid()`.

use crate::Vec2;

/// Grid points ((i + 0.5) I, (j + 0.5) I) covering [0, w] x [0, h], row by row.
/// I is raised where needed so that the grid has at most
/// [`crate::bounds::MAX_GRID_CELLS`] points (an input-sized buffer).
pub fn rect_grid(width_m: f64, height_m: f64, interval_m: f64) -> Vec<Vec2> {
    if !(interval_m > 0.0 && width_m.is_finite() && height_m.is_finite()) {
        return Vec::new();
    }
    let mut interval_m = interval_m;
    while crate::bounds::grid_cells(width_m, height_m, interval_m)
        > crate::bounds::MAX_GRID_CELLS as f64
    {
        interval_m *= 1.25;
    }
    let nx = (width_m / interval_m).floor().max(0.0) as usize;
    let ny = (height_m / interval_m).floor().max(0.0) as usize;
    let mut g = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            g.push(Vec2::new(
                (i as f64 + 0.5) * interval_m,
                (j as f64 + 0.5) * interval_m,
            ));
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rect_grid_counts() {
        assert_eq!(rect_grid(60.0, 40.0, 1.0).len(), 2400);
        assert!(rect_grid(60.0, 40.0, 0.0).is_empty());
        assert!(rect_grid(f64::NAN, 40.0, 1.0).is_empty());
        // a tiny interval is coarsened to the cell bound instead of
        // allocating 20 x 12 / 1e-300^2 points
        let g = rect_grid(20.0, 12.0, 1e-300);
        assert!(!g.is_empty() && g.len() <= crate::bounds::MAX_GRID_CELLS);
    }
}
