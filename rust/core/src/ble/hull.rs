//! Convex hull of the selected beacons (C_N of eq. 20) and the strict
//! interior test.

use crate::Vec2;

fn cross(o: Vec2, a: Vec2, b: Vec2) -> f64 {
    (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
}

/// Convex hull, counter-clockwise, without collinear points (Andrew's monotone
/// chain). Fewer than 3 vertices means the hull has no interior.
pub fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut p: Vec<Vec2> = points
        .iter()
        .copied()
        .filter(|q| q.x.is_finite() && q.y.is_finite())
        .collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// Whether `q` lies strictly inside the counter-clockwise hull `h` (false for
/// hulls with no interior).
pub fn strictly_inside(h: &[Vec2], q: Vec2) -> bool {
    if h.len() < 3 {
        return false;
    }
    (0..h.len()).all(|i| cross(h[i], h[(i + 1) % h.len()], q) > 1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_hull_and_interior() {
        let pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(4.0, 0.0),
            Vec2::new(4.0, 4.0),
            Vec2::new(0.0, 4.0),
            Vec2::new(2.0, 2.0),
            Vec2::new(2.0, 0.0),
        ];
        let h = convex_hull(&pts);
        assert_eq!(h.len(), 4);
        assert!(strictly_inside(&h, Vec2::new(1.0, 1.0)));
        assert!(!strictly_inside(&h, Vec2::new(0.0, 1.0)));
        assert!(!strictly_inside(&h, Vec2::new(5.0, 1.0)));
    }

    #[test]
    fn collinear_points_have_no_interior() {
        let pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(2.0, 2.0),
        ];
        let h = convex_hull(&pts);
        assert!(h.len() < 3);
        assert!(!strictly_inside(&h, Vec2::new(1.0, 1.0)));
    }
}
