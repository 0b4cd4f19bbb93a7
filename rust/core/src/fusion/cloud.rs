//! The particle set of the particle filters: positions and weights in
//! structure-of-arrays form, plus per-particle state columns (scalars a
//! motion model or the filter's owner keeps per particle, e.g. FP-BP's
//! heading offsets and step scales, tcpf's RSSI offset).
//!
//! Operations that do not depend on a model: weight normalisation, the
//! effective sample size, resampling (systematic or stratified; copies
//! take their columns along), estimates (weighted mean,
//! spread), shifting, replacing invalid particles, Gaussian injection and
//! log-likelihood weighting. Random draws come from the caller's RNG in a
//! fixed order.

use rand::RngExt;
use rand_pcg::Pcg64;

use super::config::Resampling;
use super::random::{gaussian_2d, in_disc, uniform_index};
use crate::Vec2;

/// One per-particle state column.
#[derive(Debug, Clone, Default)]
struct Column {
    /// One value per particle, or empty (= none).
    values: Vec<f64>,
    /// Whether resampling and [`Cloud::replace_invalid`] copy the values
    /// along with their particles (a column whose values are all equal
    /// need not be).
    carried: bool,
}

/// Read access to a cloud's columns ([`Cloud::parts_for_weighting`]).
#[derive(Debug, Clone, Copy)]
pub struct Columns<'a>(&'a [Column]);

impl<'a> Columns<'a> {
    /// The values of column `c` (empty = none).
    pub fn get(&self, c: usize) -> &'a [f64] {
        &self.0[c].values
    }
}

/// Particles (positions in the MCS, weights, state columns) and reused
/// scratch buffers.
#[derive(Debug, Clone, Default)]
pub struct Cloud {
    positions: Vec<Vec2>,
    weights: Vec<f64>,
    columns: Vec<Column>,
    scratch_positions: Vec<Vec2>,
    scratch_values: Vec<f64>,
    index: Vec<usize>,
    /// Exponents and their exp in [`Cloud::weight_log`], reused.
    exp_in: Vec<f64>,
    exp_out: Vec<f64>,
}

/// Normalises `weights` to sum 1 (uniform when they are all zero or not finite).
pub fn normalize_weights(weights: &mut [f64]) {
    let sum: f64 = weights.iter().sum();
    if sum.is_finite() && sum > 0.0 {
        for w in weights.iter_mut() {
            *w /= sum;
        }
    } else {
        let u = 1.0 / weights.len().max(1) as f64;
        weights.iter_mut().for_each(|w| *w = u);
    }
}

/// Multiplies by `factor` every weight whose flag is set, then
/// renormalises when any was; returns how many were.
pub fn scale_flagged(weights: &mut [f64], flags: impl Iterator<Item = bool>, factor: f64) -> usize {
    let mut n = 0;
    for (w, flag) in weights.iter_mut().zip(flags) {
        if flag {
            *w *= factor;
            n += 1;
        }
    }
    if n > 0 {
        normalize_weights(weights);
    }
    n
}

/// The source particle of every new particle of one resampling: target
/// `target(i)` (i = 0, 1, ... counted in f64, exact below 2^53) on the
/// cumulative `weights`, walked once.
#[inline]
fn select_sources(
    weights: &[f64],
    index: &mut Vec<usize>,
    n: usize,
    mut target: impl FnMut(f64) -> f64,
) {
    let m = weights.len();
    index.resize(n, 0);
    let mut cum = weights[0];
    let mut j = 0usize;
    let mut fi = 0.0f64;
    for slot in index.iter_mut() {
        let u = target(fi);
        fi += 1.0;
        while u > cum && j + 1 < m {
            j += 1;
            cum += weights[j];
        }
        *slot = j;
    }
}

impl Cloud {
    /// An empty cloud with room for `capacity` particles and `columns`
    /// state columns (all empty, all carried).
    pub fn new(capacity: usize, columns: usize) -> Self {
        Cloud {
            positions: Vec::with_capacity(capacity),
            weights: Vec::with_capacity(capacity),
            columns: vec![
                Column {
                    values: Vec::new(),
                    carried: true,
                };
                columns
            ],
            scratch_positions: Vec::with_capacity(capacity),
            index: Vec::with_capacity(capacity),
            ..Cloud::default()
        }
    }

    /// Sets whether column `c` travels with its particles when they are
    /// copied (resampling, [`Cloud::replace_invalid`]).
    pub fn set_carried(&mut self, c: usize, carried: bool) {
        self.columns[c].carried = carried;
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the cloud has no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Removes every particle and empties every column.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.weights.clear();
        for c in &mut self.columns {
            c.values.clear();
        }
    }

    /// Adds a particle at `position` with weight `weight` (columns untouched).
    pub fn push(&mut self, position: Vec2, weight: f64) {
        self.positions.push(position);
        self.weights.push(weight);
    }

    /// Replaces the particles by `count` ones at `start` with weight
    /// 1/`count` (columns emptied), or uniform in the disc of radius
    /// `spread_m` around it when `spread_m > 0`: up to 8 draws
    /// ([`in_disc`]) until `accept` takes one, else `start`.
    pub fn fill_disc(
        &mut self,
        rng: &mut Pcg64,
        count: usize,
        start: Vec2,
        spread_m: f64,
        accept: impl Fn(Vec2) -> bool,
    ) {
        self.clear();
        let w = 1.0 / count as f64;
        for _ in 0..count {
            let mut p = start;
            if spread_m > 0.0 {
                for _ in 0..8 {
                    let q = in_disc(rng, start, spread_m);
                    if accept(q) {
                        p = q;
                        break;
                    }
                }
            }
            self.push(p, w);
        }
    }

    /// Particle positions.
    pub fn positions(&self) -> &[Vec2] {
        &self.positions
    }

    /// Mutable particle positions.
    pub fn positions_mut(&mut self) -> &mut [Vec2] {
        &mut self.positions
    }

    /// Weights (same order as the positions).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Mutable weights.
    pub fn weights_mut(&mut self) -> &mut [f64] {
        &mut self.weights
    }

    /// Positions and weights, mutably at once.
    pub fn positions_and_weights_mut(&mut self) -> (&mut [Vec2], &mut [f64]) {
        (&mut self.positions, &mut self.weights)
    }

    /// The values of column `c` (empty = none).
    pub fn column(&self, c: usize) -> &[f64] {
        &self.columns[c].values
    }

    /// Mutable values of column `c`.
    pub fn column_mut(&mut self, c: usize) -> &mut [f64] {
        &mut self.columns[c].values
    }

    /// Column `c` as a vector (to fill it particle by particle).
    pub fn column_vec_mut(&mut self, c: usize) -> &mut Vec<f64> {
        &mut self.columns[c].values
    }

    /// Sets column `c` to `values` when they are one per particle;
    /// otherwise empties it.
    pub fn set_column(&mut self, c: usize, values: Vec<f64>) {
        self.columns[c].values = if values.len() == self.positions.len() {
            values
        } else {
            Vec::new()
        };
    }

    /// Positions and the columns `ids` (strictly increasing), mutably at once.
    pub fn positions_and_columns_mut<const K: usize>(
        &mut self,
        ids: [usize; K],
    ) -> (&mut [Vec2], [&mut [f64]; K]) {
        let mut rest = &mut self.columns[..];
        let mut base = 0;
        let cols = std::array::from_fn(|k| {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(ids[k] + 1 - base);
            base = ids[k] + 1;
            rest = tail;
            &mut head[head.len() - 1].values[..]
        });
        (&mut self.positions, cols)
    }

    /// Positions and columns to read, and the weights to write, at once
    /// (a measurement update that uses per-particle state).
    pub fn parts_for_weighting(&mut self) -> (&[Vec2], Columns<'_>, &mut [f64]) {
        (&self.positions, Columns(&self.columns), &mut self.weights)
    }

    /// Normalises the weights to sum 1 (uniform when they are all zero or not finite).
    pub fn normalize(&mut self) {
        normalize_weights(&mut self.weights);
    }

    /// Effective sample size 1 / sum w_i^2 of the normalised weights.
    pub fn effective_sample_size(&self) -> f64 {
        let s: f64 = self.weights.iter().map(|w| w * w).sum();
        if s > 0.0 { 1.0 / s } else { 0.0 }
    }

    /// [`scale_flagged`] on the weights.
    pub fn scale_flagged(&mut self, flags: impl Iterator<Item = bool>, factor: f64) -> usize {
        scale_flagged(&mut self.weights, flags, factor)
    }

    /// Resamples the particles on their normalised weights by `scheme`;
    /// weights become 1/m. One uniform u0 is drawn first (systematic:
    /// targets (i + u0) / m); stratified then draws one more per particle
    /// (targets (i + u_i) / m).
    pub fn resample(&mut self, rng: &mut Pcg64, scheme: Resampling) {
        self.resample_to(rng, scheme, self.positions.len());
    }

    /// As [`Cloud::resample`], but draws `n` particles from the m there are
    /// (targets (i + u) / n): the cloud grows or shrinks to `n`, weights
    /// 1/n. Nothing happens without particles or with `n` 0.
    pub fn resample_to(&mut self, rng: &mut Pcg64, scheme: Resampling, n: usize) {
        if self.positions.is_empty() || n == 0 {
            return;
        }
        let inv_n = 1.0 / n as f64;
        let u0: f64 = rng.random::<f64>();
        match scheme {
            Resampling::Systematic => {
                select_sources(&self.weights, &mut self.index, n, |fi| (fi + u0) * inv_n)
            }
            Resampling::Stratified => select_sources(&self.weights, &mut self.index, n, |fi| {
                (fi + rng.random::<f64>()) * inv_n
            }),
        }
        self.copy_sources();
        self.weights.clear();
        self.weights.resize(n, inv_n);
    }

    /// Stratified resampling (Kitagawa) on unnormalised weights: one
    /// uniform in each of m equal strata of the cumulative weight W,
    /// targets (i + u_i) / m * W. Copies keep their source's weight.
    /// Leaves the cloud unchanged when the weights sum to 0 or are not finite.
    pub fn resample_stratified_keeping_weights(&mut self, rng: &mut Pcg64) {
        let m = self.positions.len();
        let total: f64 = self.weights.iter().sum();
        if m == 0 || !(total.is_finite() && total > 0.0) {
            return;
        }
        let n = m as f64;
        select_sources(&self.weights, &mut self.index, m, |fi| {
            (fi + rng.random::<f64>()) / n * total
        });
        self.copy_sources();
        self.scratch_values.clear();
        let (src, w) = (&self.index, &self.weights);
        self.scratch_values.extend(src.iter().map(|&j| w[j]));
        std::mem::swap(&mut self.weights, &mut self.scratch_values);
    }

    /// Every particle i := particle `index[i]`: positions and the carried
    /// columns with one value per particle.
    /// When the count changes, every full column comes along (one not
    /// carried holds one value for all: it must keep one per particle).
    fn copy_sources(&mut self) {
        let m = self.positions.len();
        let src = &self.index;
        let resized = src.len() != m;
        self.scratch_positions.clear();
        self.scratch_positions
            .extend(src.iter().map(|&j| self.positions[j]));
        std::mem::swap(&mut self.positions, &mut self.scratch_positions);
        for c in &mut self.columns {
            if (c.carried || resized) && c.values.len() == m {
                self.scratch_values.clear();
                self.scratch_values.extend(src.iter().map(|&j| c.values[j]));
                std::mem::swap(&mut c.values, &mut self.scratch_values);
            }
        }
    }

    /// The weighted mean of the particles (`None` without particles;
    /// the weights should be normalised).
    pub fn mean(&self) -> Option<Vec2> {
        if self.positions.is_empty() {
            return None;
        }
        let mut s = Vec2::zeros();
        for (p, w) in self.positions.iter().zip(&self.weights) {
            s += p * *w;
        }
        Some(s)
    }

    /// Root-mean-square distance of the particles from their weighted mean, metres.
    pub fn spread_m(&self) -> f64 {
        let Some(m) = self.mean() else { return 0.0 };
        self.positions
            .iter()
            .zip(&self.weights)
            .map(|(p, w)| w * (p - m).norm_squared())
            .sum::<f64>()
            .sqrt()
    }

    /// Shifts every particle by `delta`.
    pub fn shift(&mut self, delta: Vec2) {
        for p in &mut self.positions {
            *p += delta;
        }
    }

    /// Puts every particle back at `positions` (same length; otherwise
    /// nothing happens). Weights and columns are kept.
    pub fn restore_positions(&mut self, positions: &[Vec2]) {
        if positions.len() == self.positions.len() {
            self.positions.copy_from_slice(positions);
        }
    }

    /// Replaces every particle for which `bad` holds by a copy of a random
    /// particle for which it does not (one [`uniform_index`] draw per bad
    /// particle, in index order; carried columns come along, and the weight
    /// too when `keep_weights`, then renormalised), or by `fallback` when
    /// every particle is bad. Returns how many were replaced.
    pub fn replace_invalid(
        &mut self,
        rng: &mut Pcg64,
        bad: impl Fn(Vec2) -> bool,
        fallback: Vec2,
        keep_weights: bool,
    ) -> usize {
        // good indices first, bad ones from the back of one reused buffer
        let m = self.positions.len();
        self.index.clear();
        self.index.resize(m, 0);
        let (mut n_good, mut n_bad) = (0usize, 0usize);
        for (i, p) in self.positions.iter().enumerate() {
            if bad(*p) {
                n_bad += 1;
                self.index[m - n_bad] = i;
            } else {
                self.index[n_good] = i;
                n_good += 1;
            }
        }
        // bad indices in increasing order, as drawn before
        self.index[n_good..].reverse();
        for b in n_good..m {
            let i = self.index[b];
            if n_good == 0 {
                self.positions[i] = fallback;
            } else {
                let src = self.index[uniform_index(rng, n_good)];
                self.positions[i] = self.positions[src];
                for c in &mut self.columns {
                    if c.carried && c.values.len() == m {
                        c.values[i] = c.values[src];
                    }
                }
                if keep_weights {
                    self.weights[i] = self.weights[src];
                }
            }
        }
        if keep_weights && n_bad > 0 {
            self.normalize();
        }
        n_bad
    }

    /// Replaces `round(fraction * m)` particles, chosen at random
    /// ([`uniform_index`]), by draws of [`gaussian_2d`] around `center`
    /// with standard deviation `sigma_m` that `accept` takes (up to 16
    /// tries each; a particle whose draws are all rejected stays). Weights
    /// and columns are left as they are. Returns how many were replaced.
    pub fn inject(
        &mut self,
        rng: &mut Pcg64,
        fraction: f64,
        center: Vec2,
        sigma_m: f64,
        accept: impl Fn(Vec2) -> bool,
    ) -> usize {
        let m = self.positions.len();
        if m == 0 || fraction.is_nan() || fraction <= 0.0 {
            return 0;
        }
        let k = ((fraction.min(1.0) * m as f64).round() as usize).min(m);
        let mut n = 0;
        for _ in 0..k {
            let i = uniform_index(rng, m);
            for _ in 0..16 {
                let q = gaussian_2d(rng, center, sigma_m);
                if accept(q) {
                    self.positions[i] = q;
                    n += 1;
                    break;
                }
            }
        }
        n
    }

    /// Multiplies every weight by exp(`log_l[i]` - max) and renormalises
    /// (a measurement update given as log-likelihoods; non-finite entries
    /// count as -inf). Nothing happens when `log_l` is not one per particle
    /// or has no finite entry.
    pub fn weight_log(&mut self, log_l: &[f64]) {
        if self.positions.is_empty() || log_l.len() != self.positions.len() {
            return;
        }
        let max =
            crate::fast_math::max_many(
                log_l,
                |v| {
                    if v.is_finite() { v } else { f64::NEG_INFINITY }
                },
            );
        if !max.is_finite() {
            return;
        }
        // exp(l - max) of every particle in one pass (non-finite: 0)
        let (xs, e) = (&mut self.exp_in, &mut self.exp_out);
        xs.clear();
        xs.extend(log_l.iter().map(|l| {
            if l.is_finite() {
                l - max
            } else {
                f64::NEG_INFINITY
            }
        }));
        e.resize(xs.len(), 0.0);
        crate::fast_math::exp_many(xs, e);
        for (w, f) in self.weights.iter_mut().zip(e.iter()) {
            *w *= f;
        }
        self.normalize();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn line(weights: &[f64]) -> Cloud {
        let mut c = Cloud::new(weights.len(), 1);
        for (i, w) in weights.iter().enumerate() {
            c.push(Vec2::new(i as f64, 0.0), *w);
        }
        c
    }

    #[test]
    fn stratified_resampling_keeping_weights_copies_in_proportion() {
        let mut rng = Pcg64::seed_from_u64(3);
        let w: Vec<f64> = (0..100)
            .map(|i| match i {
                10 => 3.0,
                20 => 1.0,
                _ => 0.0,
            })
            .collect();
        let mut c = line(&w);
        c.set_column(0, (0..100).map(f64::from).collect());
        c.resample_stratified_keeping_weights(&mut rng);
        assert_eq!(c.len(), 100);
        let n10 = c.positions().iter().filter(|p| p.x == 10.0).count();
        let n20 = c.positions().iter().filter(|p| p.x == 20.0).count();
        assert_eq!(n10 + n20, 100);
        assert_eq!(n10, 75, "stratified: exactly n w_i / W copies here");
        for ((p, w), s) in c.positions().iter().zip(c.weights()).zip(c.column(0)) {
            assert_eq!(*w, if p.x == 10.0 { 3.0 } else { 1.0 });
            assert_eq!(*s, p.x, "the column travels with its particle");
        }
        // all-zero weights: unchanged, no draw
        let mut zero = line(&[0.0; 5]);
        let before = rng.clone();
        zero.resample_stratified_keeping_weights(&mut rng);
        assert_eq!(zero.positions()[4], Vec2::new(4.0, 0.0));
        assert_eq!(rng, before);
    }

    #[test]
    fn columns_not_carried_or_not_full_stay_put() {
        let mut rng = Pcg64::seed_from_u64(1);
        let mut c = Cloud::new(4, 3);
        for i in 0..4 {
            c.push(Vec2::new(f64::from(i), 0.0), if i == 3 { 1.0 } else { 0.0 });
        }
        c.set_column(0, vec![0.0, 1.0, 2.0, 3.0]);
        c.set_column(1, vec![0.0, 1.0, 2.0, 3.0]);
        c.set_carried(1, false);
        c.set_column(2, vec![1.0; 3]);
        assert!(c.column(2).is_empty(), "a short column is refused");
        c.resample(&mut rng, Resampling::Systematic);
        assert!(c.positions().iter().all(|p| p.x == 3.0));
        assert_eq!(c.column(0), &[3.0; 4]);
        assert_eq!(c.column(1), &[0.0, 1.0, 2.0, 3.0]);
        assert!(c.weights().iter().all(|w| *w == 0.25));
        let (pos, [a, b]) = c.positions_and_columns_mut([0, 2]);
        assert_eq!((pos.len(), a.len(), b.len()), (4, 4, 0));
    }

    #[test]
    fn resample_to_grows_and_shrinks_the_cloud_with_every_column() {
        let mut rng = Pcg64::seed_from_u64(1);
        let mut c = Cloud::new(4, 2);
        for i in 0..4 {
            c.push(
                Vec2::new(f64::from(i), 0.0),
                [0.1, 0.2, 0.3, 0.4][i as usize],
            );
        }
        c.set_column(0, vec![0.0, 10.0, 20.0, 30.0]);
        c.set_column(1, vec![7.0; 4]);
        c.set_carried(1, false);
        c.resample_to(&mut rng, Resampling::Systematic, 10);
        assert_eq!(c.len(), 10);
        assert!(c.weights().iter().all(|w| *w == 0.1));
        // systematic: 1, 2, 3, 4 copies of the particles of weight 0.1..0.4
        let xs: Vec<f64> = c.positions().iter().map(|p| p.x).collect();
        for (i, n) in [1, 2, 3, 4].into_iter().enumerate() {
            assert_eq!(xs.iter().filter(|x| **x == i as f64).count(), n, "{xs:?}");
        }
        // the carried column follows its particle, the other keeps one
        // value per particle
        for (p, v) in c.positions().iter().zip(c.column(0)) {
            assert_eq!(*v, 10.0 * p.x);
        }
        assert_eq!(c.column(1), &[7.0; 10]);
        c.resample_to(&mut rng, Resampling::Stratified, 3);
        assert_eq!((c.len(), c.column(0).len(), c.column(1).len()), (3, 3, 3));
        assert!(c.weights().iter().all(|w| (*w - 1.0 / 3.0).abs() < 1e-15));
        // nothing to draw to
        c.resample_to(&mut rng, Resampling::Systematic, 0);
        assert_eq!(c.len(), 3);
    }

    #[test]
    fn weight_log_multiplies_by_the_likelihoods() {
        let mut c = line(&[0.5, 0.5, 0.0]);
        c.weight_log(&[0.0, 2f64.ln(), f64::NAN]);
        let w = c.weights();
        assert!((w[0] - 1.0 / 3.0).abs() < 1e-12 && (w[1] - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(w[2], 0.0);
        // wrong length or nothing finite: unchanged
        let before = c.weights().to_vec();
        c.weight_log(&[0.0]);
        c.weight_log(&[f64::NAN; 3]);
        assert_eq!(c.weights(), &before[..]);
    }
}
