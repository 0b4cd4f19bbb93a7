//! Optional downsampling (end of FP-BP Sec. IV-A): integer block reduction by
//! k = round(r / r_target) (k >= 1). A block is Wall if any of its pixels is
//! Wall, else Door if any is Door, else Walkable: obstacles never vanish, so
//! a thin wall stays closed at the coarser resolution (it may thicken by up to
//! one block).

use super::Feature;

/// Reduces a row-major grid by factor `k`; returns (width, height, features).
/// Partial blocks at the right/bottom edge are kept.
pub(crate) fn downsample(
    width: usize,
    height: usize,
    features: &[Feature],
    k: usize,
) -> (usize, usize, Vec<Feature>) {
    let k = k.max(1);
    if k == 1 {
        return (width, height, features.to_vec());
    }
    let (w2, h2) = (width.div_ceil(k), height.div_ceil(k));
    let mut out = vec![Feature::Walkable; w2 * h2];
    for j in 0..height {
        for i in 0..width {
            let f = features[j * width + i];
            let o = &mut out[(j / k) * w2 + i / k];
            if (f as u8) > (*o as u8) {
                *o = f;
            }
        }
    }
    (w2, h2, out)
}

/// The integer factor for going from `r` to about `target` pixels per metre.
pub(crate) fn factor(r: f64, target: f64) -> usize {
    if target.is_nan() || target <= 0.0 || target >= r {
        return 1;
    }
    ((r / target).round() as usize).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thin_wall_survives_downsampling() {
        // 4x4 with a one-pixel vertical wall at column 1.
        let mut f = vec![Feature::Walkable; 16];
        for j in 0..4 {
            f[j * 4 + 1] = Feature::Wall;
        }
        f[3 * 4 + 2] = Feature::Door;
        let (w, h, g) = downsample(4, 4, &f, 2);
        assert_eq!((w, h), (2, 2));
        assert_eq!(
            g,
            vec![
                Feature::Wall,
                Feature::Walkable,
                Feature::Wall,
                Feature::Door
            ]
        );
        assert_eq!(factor(10.0, 5.0), 2);
        assert_eq!(factor(10.0, 20.0), 1);
    }
}
