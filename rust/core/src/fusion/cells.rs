//! Drawing particles from a likelihood surface over cells (a global start
//! or augmented-MCL re-seeding): the cells' cumulative distribution and
//! one jittered draw from it.

use rand::RngExt;
use rand_pcg::Pcg64;

use crate::Vec2;

/// Cumulative distribution of `weights` (non-negative; uniform when
/// they sum to 0 or are not finite).
pub fn cumulative(weights: &[f64]) -> Vec<f64> {
    let total: f64 = weights.iter().sum();
    let ok = total.is_finite() && total > 0.0;
    let n = weights.len().max(1) as f64;
    let mut acc = 0.0;
    weights
        .iter()
        .map(|w| {
            acc += if ok { w / total } else { 1.0 / n };
            acc
        })
        .collect()
}

/// Draws a cell of `cells` (non-empty) by its cumulative probability
/// `cdf` (last = 1), then a point jittered uniformly within +-`jitter_m` / 2
/// per axis of its centre while `accept` takes it (up to 8 tries, else the
/// cell centre). Returns the point and the cell's index.
pub fn draw_cell(
    rng: &mut Pcg64,
    cells: &[Vec2],
    cdf: &[f64],
    jitter_m: f64,
    accept: &impl Fn(Vec2) -> bool,
) -> (Vec2, usize) {
    let u: f64 = rng.random::<f64>();
    let k = cdf.partition_point(|&c| c < u).min(cells.len() - 1);
    let c = cells[k];
    for _ in 0..8 {
        let q = c + Vec2::new(
            jitter_m * (rng.random::<f64>() - 0.5),
            jitter_m * (rng.random::<f64>() - 0.5),
        );
        if accept(q) {
            return (q, k);
        }
    }
    (c, k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn cumulative_ends_at_one_and_falls_back_to_uniform() {
        assert_eq!(cumulative(&[1.0, 3.0]), vec![0.25, 1.0]);
        assert_eq!(cumulative(&[0.0, 0.0]), vec![0.5, 1.0]);
        assert_eq!(cumulative(&[f64::NAN, 1.0]), vec![0.5, 1.0]);
    }

    #[test]
    fn draws_stay_in_their_cell_or_at_its_centre() {
        let mut rng = Pcg64::seed_from_u64(2);
        let cells = [Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)];
        let cdf = cumulative(&[0.0, 1.0]);
        for _ in 0..100 {
            let (q, k) = draw_cell(&mut rng, &cells, &cdf, 1.0, &|_| true);
            assert_eq!(k, 1);
            assert!((q - cells[1]).norm() < 0.75);
        }
        let (q, _) = draw_cell(&mut rng, &cells, &cdf, 1.0, &|_| false);
        assert_eq!(q, cells[1]);
    }
}
