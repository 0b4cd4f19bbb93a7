//! Raycast (FP-BP Function 1) and the obstacle clearance table that lets it
//! skip samples which cannot be on an obstacle.
//!
//! The clearance of pixel P is D(P) = the chessboard distance (in pixels,
//! centre to centre) from P to the nearest obstacle pixel, counting the
//! pixels just outside the image as obstacles (outside is Wall), saturated at
//! 255. Any point of P is at least (D - 1) px (Euclidean) from any point of
//! any obstacle pixel: the chessboard distance never exceeds the Euclidean
//! one, and two unit squares whose centres are D apart along the larger axis
//! have a gap of D - 1 along it. So a raycast sample x in P proves that every
//! later sample closer than (D - 1) / r metres to x is not on an obstacle, and
//! the walk may jump over them. The samples the walk does evaluate are the
//! very points of Function 1 (same arithmetic), so the result is identical to
//! [`FloorMap::raycast_reference`], the literal sample-by-sample loop kept as
//! the oracle (property test in `map/tests.rs`).
//!
//! The Wall clearance table is the same transform of the Wall mask alone
//! (Doors count as free, the outside of the image as Wall), and lets
//! [`FloorMap::crosses_wall`] (the particle wall check, where particles may
//! pass doors) skip samples by the same argument; it equals
//! [`FloorMap::crosses_wall_reference`], the literal loop (property tests
//! below and in `fusion/ppc.rs`).
//!
//! Memory: one byte per pixel for each table, two in all (demo plan 640 x
//! 440 px: 2 x 282 KB).

use super::{Feature, FloorMap, RayHit};
use crate::Vec2;

/// Margin (metres) subtracted from a clearance before skipping samples, so
/// floating-point rounding of sample positions can never step into a pixel
/// the bound did not cover.
const SKIP_MARGIN_M: f64 = 1e-6;

/// `x.round() as usize` for x >= 0 (NaN -> 0, saturating) without the libm
/// call: x - trunc(x) is exact below 2^52, and above it x is an integer.
fn round_half_away(x: f64) -> usize {
    let t = x as usize;
    if x - t as f64 >= 0.5 {
        t.saturating_add(1)
    } else {
        t
    }
}

/// Outcome of the midpoint test of [`FloorMap::crosses_wall`].
#[derive(Debug, Clone, Copy, Default)]
struct WallMidTest {
    /// No sample is on a Wall.
    settled: bool,
    /// Rounding margin of the move, metres.
    margin_m: f64,
    /// Radius about the midpoint free of Walls, metres (0: none known).
    free_m: f64,
}

/// `x.ceil() as usize` for x >= 0 (NaN -> 0, saturating) without the libm
/// call: below 2^53 the truncation is exact, above it x is an integer.
fn ceil_nonneg(x: f64) -> usize {
    let t = x as usize;
    if (t as f64) < x {
        t.saturating_add(1)
    } else {
        t
    }
}

/// The largest whole m >= 0 with m * spacing < free_m (0 when free_m <= 0),
/// as f64; `inv_spacing` is 1 / spacing (maybe rounded). The quotient may
/// saturate (a smaller m, which only skips less).
fn skip_count(free_m: f64, spacing: f64, inv_spacing: f64) -> f64 {
    // (false for NaN)
    if free_m > 0.0 {
        // positive: truncation is floor; step back if rounding overshot
        let m = ((free_m * inv_spacing) as i64) as f64;
        if m > 0.0 && m * spacing >= free_m {
            m - 1.0
        } else {
            m
        }
    } else {
        0.0
    }
}

/// The literal particle wall check over any feature function M(x): whether
/// one of the samples x_k = from + d (k / n), k = 0..=n, d = to - from,
/// n = ceil(|d| / step_m) (0.05 m when `step_m` is not > 0) is a Wall.
/// [`FloorMap::crosses_wall`] gives the same answer by skipping samples.
pub fn crosses_wall_sampled(
    feature_at: impl Fn(Vec2) -> Feature,
    from: Vec2,
    to: Vec2,
    step_m: f64,
) -> bool {
    let d = to - from;
    let len = d.norm();
    let step = if step_m > 0.0 { step_m } else { 0.05 };
    let n = (len / step).ceil() as usize;
    (0..=n).any(|k| {
        let t = if n == 0 { 0.0 } else { k as f64 / n as f64 };
        feature_at(from + d * t) == Feature::Wall
    })
}

/// Chessboard distance transform (two passes, 8-neighbourhood) of the mask
/// of the pixels whose feature is `blocked` (obstacles for [`FloorMap::raycast`],
/// Walls for [`FloorMap::crosses_wall`]), with the outside of the image as
/// blocked; saturated at 255. Row-major like `features`.
pub(crate) fn clearance_px(
    width: usize,
    height: usize,
    features: &[Feature],
    blocked: impl Fn(Feature) -> bool,
) -> Vec<u8> {
    let mut d: Vec<u16> = Vec::with_capacity(width * height);
    for j in 0..height {
        for i in 0..width {
            let f = features[j * width + i];
            d.push(if blocked(f) {
                0
            } else {
                // distance to the ring of (blocked) pixels outside the image
                let edge = (i + 1).min(j + 1).min(width - i).min(height - j);
                edge.min(255) as u16
            });
        }
    }
    // forward pass: neighbours above and to the left
    for j in 0..height {
        for i in 0..width {
            let k = j * width + i;
            let mut v = d[k];
            if v == 0 {
                continue;
            }
            if i > 0 {
                v = v.min(d[k - 1] + 1);
            }
            if j > 0 {
                let up = k - width;
                v = v.min(d[up] + 1);
                if i > 0 {
                    v = v.min(d[up - 1] + 1);
                }
                if i + 1 < width {
                    v = v.min(d[up + 1] + 1);
                }
            }
            d[k] = v;
        }
    }
    // backward pass: neighbours below and to the right
    for j in (0..height).rev() {
        for i in (0..width).rev() {
            let k = j * width + i;
            let mut v = d[k];
            if v == 0 {
                continue;
            }
            if i + 1 < width {
                v = v.min(d[k + 1] + 1);
            }
            if j + 1 < height {
                let down = k + width;
                v = v.min(d[down] + 1);
                if i + 1 < width {
                    v = v.min(d[down + 1] + 1);
                }
                if i > 0 {
                    v = v.min(d[down - 1] + 1);
                }
            }
            d[k] = v;
        }
    }
    d.into_iter().map(|v| v.min(255) as u8).collect()
}

impl FloorMap {
    /// Raycast exactly as FP-BP Function 1: walk from `from` towards `to` in
    /// steps of `step_m` (k = 0..=Round(|to - from| / step_m)) and return the
    /// first sample whose M(x) > 0. A zero-length ray tests `from` alone.
    /// The returned point never lies beyond `to` by more than step_m / 2
    /// (the rounding of N); it is clamped to the segment.
    ///
    /// Same result as [`FloorMap::raycast_reference`]; samples within a
    /// pixel's obstacle clearance of an evaluated sample are skipped (module
    /// doc), so a ray through open space costs a few lookups.
    pub fn raycast(&self, from: Vec2, to: Vec2, step_m: f64) -> Option<RayHit> {
        let d = to - from;
        // every sample lies within |d| of `from`: one lookup settles a ray
        // shorter than the clearance there
        if self.obstacle_free_within(from, d.norm()) {
            return None;
        }
        let inv_r = 1.0 / self.pixels_per_meter;
        let len = d.norm();
        if len == 0.0 {
            let f = self.feature(from);
            return f.is_obstacle().then_some(RayHit {
                point: from,
                feature: f,
            });
        }
        let step = if step_m > 0.0 { step_m } else { 0.05 };
        let n = round_half_away(len / step);
        let dir = d / len;
        let inv_step = 1.0 / step;
        let mut k = 0usize;
        while k <= n {
            let s = (k as f64 * step).min(len);
            let x = from + dir * s;
            let Some((i, j)) = self.pixel_of(x) else {
                return Some(RayHit {
                    point: x,
                    feature: Feature::Wall,
                });
            };
            let idx = j * self.width_px + i;
            // one load per sample: the feature is read only on obstacles
            let c = self.clearance[idx];
            if c == 0 {
                return Some(RayHit {
                    point: x,
                    feature: self.features[idx],
                });
            }
            let mut next = k + 1;
            if c >= 2 {
                // samples k + m with m step < clearance are free
                let free_m = (c - 1) as f64 * inv_r - SKIP_MARGIN_M;
                // positive: truncation is floor; the reciprocal may round up
                // by an ulp, so check m step < free_m and step back if not
                let mut m = (free_m * inv_step) as usize;
                if m > 0 && m as f64 * step >= free_m {
                    m -= 1;
                }
                next = k.saturating_add(m).saturating_add(1);
            }
            k = next;
        }
        None
    }

    /// The literal Function 1 loop (every sample evaluated): the oracle for
    /// [`FloorMap::raycast`].
    pub fn raycast_reference(&self, from: Vec2, to: Vec2, step_m: f64) -> Option<RayHit> {
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

    /// Whether the straight move `from` -> `to` meets a Wall pixel (Doors do
    /// not count; outside the image is Wall), sampled at
    /// x_k = from + d (k / n), k = 0..=n, d = to - from, n = ceil(|d| /
    /// step_m) (0.05 m when `step_m` is not > 0), both ends included: the
    /// particle wall check with `particles_pass_doors`.
    ///
    /// Same answer as [`FloorMap::crosses_wall_reference`] for every input:
    /// the samples it evaluates are the very points of the literal loop (same
    /// arithmetic), and it skips only samples that the Wall clearance of an
    /// evaluated point (or of the midpoint, which settles a move in open space
    /// with one lookup) proves off every Wall (module doc).
    pub fn crosses_wall(&self, from: Vec2, to: Vec2, step_m: f64) -> bool {
        let d = to - from;
        let mid = self.wall_mid_test(from, d);
        if mid.settled {
            return false;
        }
        self.crosses_wall_walk(from, to, step_m, mid)
    }

    /// [`FloorMap::crosses_wall`] of every move `from[i]` -> `to[i]`, into
    /// `out[i]` (`out` is resized to the shorter of the two slices): the
    /// same answers, faster over many moves. The midpoint test, which settles
    /// most moves, runs over a block of moves without a branch on its outcome
    /// (which mispredicts on nearly every move it does not settle) and lists
    /// those; they then take the rest of `crosses_wall`.
    pub fn crosses_wall_each(&self, from: &[Vec2], to: &[Vec2], step_m: f64, out: &mut Vec<bool>) {
        const BLOCK: usize = 64;
        let n = from.len().min(to.len());
        out.clear();
        out.resize(n, false);
        let mut rest = [(0usize, WallMidTest::default()); BLOCK];
        for ((from, to), out) in from[..n]
            .chunks(BLOCK)
            .zip(to[..n].chunks(BLOCK))
            .zip(out.chunks_mut(BLOCK))
        {
            let mut n_rest = 0;
            for (k, (&a, &b)) in from.iter().zip(to).enumerate() {
                let mid = self.wall_mid_test(a, b - a);
                // written always, kept (n_rest advanced) when not settled
                rest[n_rest] = (k, mid);
                n_rest += usize::from(!mid.settled);
            }
            for &(k, mid) in &rest[..n_rest] {
                out[k] = self.crosses_wall_walk(from[k], to[k], step_m, mid);
            }
        }
    }

    /// The first step of [`FloorMap::crosses_wall`], branch-free: every
    /// sample lies within |d| / 2 of the midpoint from + d / 2, so its Wall
    /// clearance alone settles a move in open space (compared squared,
    /// without the square root; its relative rounding, ~1e-16, is far
    /// inside the margin).
    #[inline(always)]
    fn wall_mid_test(&self, from: Vec2, d: Vec2) -> WallMidTest {
        let inv_r = self.meters_per_pixel;
        // Rounding of a sample position and of its ICS image is a few ulps
        // of the largest magnitude involved: negligible against 1e-6 m on any
        // plan, and covered by the relative term for absurd coordinates
        // (sums of |.|: at least the largest, and cheaper than max).
        let margin_m = SKIP_MARGIN_M
            + 1e-12 * (from.x.abs() + from.y.abs() + d.x.abs() + d.y.abs() + self.height_f * inv_r);
        // pixel_of(from + d / 2), with `&` for `&&` and selects for branches
        let q = self.mcs_to_ics(from + d * 0.5);
        let inside = (q.x >= 0.0) & (q.y >= 0.0) & (q.x < self.width_f) & (q.y < self.height_f);
        let k = (q.y as i64 as usize)
            .wrapping_mul(self.width_px)
            .wrapping_add(q.x as i64 as usize);
        let c = self.wall_clearance.get(k).copied().unwrap_or(0);
        let c = if inside { c } else { 0 };
        let free_m = f64::from(c) * inv_r - inv_r - margin_m;
        // (NaN fails both tests)
        let free_m = if free_m > 0.0 { free_m } else { 0.0 };
        WallMidTest {
            settled: d.norm_squared() * 0.25 < free_m * free_m,
            margin_m,
            free_m,
        }
    }

    /// [`FloorMap::crosses_wall`] past the midpoint test.
    fn crosses_wall_walk(&self, from: Vec2, to: Vec2, step_m: f64, mid: WallMidTest) -> bool {
        let d = to - from;
        let inv_r = self.meters_per_pixel;
        let (margin_m, mid_free_m) = (mid.margin_m, mid.free_m);
        // Sample 0 is from + d (0 / n) = from + d 0 whatever n (n = 0
        // included), and sample n is from + d (n / n) = from + d 1 for n >= 1:
        // their lookups need not wait for n (a square root and a division).
        let c_first = self.wall_clearance_or_0(from + d * 0.0);
        let c_last = self.wall_clearance_or_0(from + d * 1.0);
        if c_first == 0 {
            return true;
        }
        let len = d.norm();
        let step = if step_m > 0.0 { step_m } else { 0.05 };
        let n = ceil_nonneg(len / step);
        if n == 0 {
            // sample 0 alone, and it is off every Wall
            return false;
        }
        if c_last == 0 {
            return true;
        }
        if n as u64 > 1u64 << 50 {
            // (the sample counters in f64 below, up to 3 n, would not all be
            // exact)
            return self.crosses_wall_reference(from, to, step_m);
        }
        // Sample indices as f64 (exact: integers below 2^53), so k / n is the
        // very quotient of the literal loop. Consecutive samples are
        // spacing = |d| / n apart, and sample k lies |k - n/2| spacing from
        // the midpoint: those with |k - n/2| < h are off every Wall. Two
        // walks, from either end, cover the rest, each skipping what the
        // clearance of its samples proves free; they are independent chains
        // of dependent loads, which the processor runs side by side.
        // (Evaluating a sample that was proved free anyway is harmless: only
        // skipping needs the proof.)
        let nf = n as f64;
        let spacing = len / nf;
        let inv_spacing = nf / len;
        let skip = |c: u8| {
            skip_count(
                f64::from(c) * inv_r - inv_r - margin_m,
                spacing,
                inv_spacing,
            )
        };
        let h = skip_count(mid_free_m, spacing, inv_spacing).min(nf);
        // forward: samples k with 2k <= n - 2h; backward: 2k >= n + 2h
        let (lim_fwd, lim_back) = (nf - 2.0 * h, nf + 2.0 * h);
        let (mut kf, mut kb) = (skip(c_first) + 1.0, nf - skip(c_last) - 1.0);
        loop {
            let fwd = 2.0 * kf <= lim_fwd && kf <= kb;
            let back = 2.0 * kb >= lim_back && kb >= kf;
            if !(fwd || back) {
                // every sample in [kf, kb] (if any) is within h of n/2
                return false;
            }
            if fwd {
                let c = self.wall_clearance_or_0(from + d * (kf / nf));
                if c == 0 {
                    return true;
                }
                kf += skip(c) + 1.0;
            }
            if back {
                let c = self.wall_clearance_or_0(from + d * (kb / nf));
                if c == 0 {
                    return true;
                }
                kb -= skip(c) + 1.0;
            }
        }
    }

    /// The Wall clearance of the pixel containing `p`; 0 outside the image.
    fn wall_clearance_or_0(&self, p: Vec2) -> u8 {
        self.index_of(p).map_or(0, |k| self.wall_clearance[k])
    }

    /// The literal sample-by-sample loop of [`FloorMap::crosses_wall`]
    /// (every sample evaluated, no early exit): its oracle, and the
    /// particle wall check before the Wall clearance table.
    pub fn crosses_wall_reference(&self, from: Vec2, to: Vec2, step_m: f64) -> bool {
        crosses_wall_sampled(|p| self.feature(p), from, to, step_m)
    }

    /// Chessboard clearance (pixels, saturated at 255) of pixel (column,
    /// row) to the nearest Wall pixel or the image border (Doors count as
    /// free); 0 on Walls and outside the image.
    pub fn wall_clearance_px(&self, i: usize, j: usize) -> u8 {
        self.table_px(&self.wall_clearance, i, j)
    }

    /// Pixel (column, row) of a row-major clearance table; 0 outside.
    fn table_px(&self, table: &[u8], i: usize, j: usize) -> u8 {
        if i >= self.width_px || j >= self.height_px {
            return 0;
        }
        table[j * self.width_px + i]
    }

    /// Chessboard clearance (pixels, saturated at 255) of pixel (column,
    /// row) to the nearest obstacle or the image border; 0 on obstacles and
    /// outside the image.
    pub fn clearance_px(&self, i: usize, j: usize) -> u8 {
        self.table_px(&self.clearance, i, j)
    }

    /// Whether no obstacle (Wall or Door) lies within `radius_m` of `p`,
    /// from the clearance table (one lookup; conservative: `false` when the
    /// clearance there is too small to tell).
    pub fn obstacle_free_within(&self, p: Vec2, radius_m: f64) -> bool {
        let Some((i, j)) = self.pixel_of(p) else {
            return false;
        };
        // clearance 0 <=> obstacle (a free pixel is >= 1 from the border)
        let c = self.clearance[j * self.width_px + i];
        if c < 2 {
            return false;
        }
        let free_m = (c - 1) as f64 / self.pixels_per_meter - SKIP_MARGIN_M;
        free_m > 0.0 && radius_m < free_m
    }

    /// Bytes held by the clearance tables (obstacle and Wall: one byte per
    /// pixel each).
    pub fn clearance_bytes(&self) -> usize {
        self.clearance.len() + self.wall_clearance.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn demo() -> &'static FloorMap {
        use std::sync::OnceLock;
        static MAP: OnceLock<FloorMap> = OnceLock::new();
        MAP.get_or_init(|| {
            let png = include_bytes!("../../../../maps/demo/plan.png");
            let plan = super::super::classify_png(png, &crate::map::Legend::default(), "plan.png")
                .unwrap();
            FloorMap::from_classified_plan(plan, 10.0, 1, 1.0)
        })
    }

    /// A w x h map with pseudo-random obstacles (density ~ `density`).
    fn random_map(w: usize, h: usize, r: f64, seed: u64, density: f64) -> FloorMap {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let f = (0..w * h)
            .map(|_| {
                let u: f64 = rng.random();
                if u < density {
                    Feature::Wall
                } else if u < density * 1.2 {
                    Feature::Door
                } else {
                    Feature::Walkable
                }
            })
            .collect();
        FloorMap::from_features(w, h, r, f)
    }

    /// A w x h map with pseudo-random Walls (share `walls`) and Doors (share
    /// `doors`), dropped as squares of up to `blob` px so that open areas,
    /// thick walls and door strips all occur.
    fn blob_map(
        w: usize,
        h: usize,
        r: f64,
        seed: u64,
        walls: f64,
        doors: f64,
        blob: usize,
    ) -> FloorMap {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut f = vec![Feature::Walkable; w * h];
        let n = w * h / (blob * blob).max(1);
        for _ in 0..n {
            let u: f64 = rng.random();
            let feature = if u < walls {
                Feature::Wall
            } else if u < walls + doors {
                Feature::Door
            } else {
                continue;
            };
            let (i0, j0) = (rng.random_range(0..w), rng.random_range(0..h));
            let (bw, bh) = (rng.random_range(1..=blob), rng.random_range(1..=blob));
            for j in j0..(j0 + bh).min(h) {
                for i in i0..(i0 + bw).min(w) {
                    f[j * w + i] = feature;
                }
            }
        }
        FloorMap::from_features(w, h, r, f)
    }

    fn brute_clearance(m: &FloorMap, i: usize, j: usize) -> u8 {
        brute_clearance_of(m, i, j, Feature::is_obstacle)
    }

    fn brute_clearance_of(
        m: &FloorMap,
        i: usize,
        j: usize,
        blocked: impl Fn(Feature) -> bool,
    ) -> u8 {
        let (w, h) = (m.width_px() as isize, m.height_px() as isize);
        let (i, j) = (i as isize, j as isize);
        let mut best = i + 1;
        best = best.min(j + 1).min(w - i).min(h - j);
        for jj in 0..h {
            for ii in 0..w {
                if blocked(m.feature_px(ii, jj)) {
                    best = best.min((ii - i).abs().max((jj - j).abs()));
                }
            }
        }
        best.min(255) as u8
    }

    #[test]
    fn round_half_away_is_round() {
        for x in [
            0.0,
            0.49999999999999994,
            0.5,
            1.5,
            2.5,
            13.999999,
            14.0,
            14.5000001,
            1e15 + 0.5,
            4.5e15,
        ] {
            assert_eq!(round_half_away(x), x.round() as usize, "{x}");
        }
        assert_eq!(round_half_away(f64::NAN), 0);
        assert_eq!(round_half_away(f64::INFINITY), usize::MAX);
    }

    #[test]
    fn clearance_is_the_chessboard_distance_to_obstacles_or_border() {
        for (seed, density) in [(1, 0.02), (2, 0.1), (3, 0.0)] {
            let m = random_map(37, 23, 2.0, seed, density);
            for j in 0..23 {
                for i in 0..37 {
                    assert_eq!(
                        m.clearance_px(i, j),
                        brute_clearance(&m, i, j),
                        "seed {seed} pixel ({i}, {j})"
                    );
                }
            }
        }
        assert_eq!(demo().clearance_bytes(), 2 * 640 * 440);
        // 0 exactly on obstacles
        let m = random_map(37, 23, 2.0, 4, 0.1);
        for j in 0..23 {
            for i in 0..37 {
                let obstacle = m.feature_px(i as isize, j as isize).is_obstacle();
                assert_eq!(m.clearance_px(i, j) == 0, obstacle, "({i}, {j})");
            }
        }
    }

    #[test]
    fn wall_clearance_is_the_chessboard_distance_to_walls_or_border() {
        let maps = [
            random_map(37, 23, 2.0, 1, 0.02),
            random_map(37, 23, 2.0, 2, 0.1),
            random_map(37, 23, 2.0, 3, 0.0),
            blob_map(41, 29, 1.0, 4, 0.3, 0.5, 6),
        ];
        for (k, m) in maps.iter().enumerate() {
            for j in 0..m.height_px() {
                for i in 0..m.width_px() {
                    let want = brute_clearance_of(m, i, j, |f| f == Feature::Wall);
                    assert_eq!(m.wall_clearance_px(i, j), want, "map {k} pixel ({i}, {j})");
                    let wall = m.feature_px(i as isize, j as isize) == Feature::Wall;
                    assert_eq!(want == 0, wall);
                    // Doors are free: never below the obstacle clearance
                    assert!(want >= m.clearance_px(i, j));
                }
            }
        }
        assert_eq!(maps[0].wall_clearance_px(37, 0), 0);
    }

    /// Moves the literal loop and the skipping walk must agree on: zero
    /// length, NaN and infinite ends, huge coordinates, odd steps.
    #[test]
    fn crosses_wall_equals_reference_on_special_inputs() {
        let m = demo();
        let v = Vec2::new;
        let (nan, inf) = (f64::NAN, f64::INFINITY);
        let pts = [
            v(3.0, 20.5),
            v(3.7, 20.5),
            v(30.0, 20.0),
            v(0.05, 0.05),
            v(63.99, 43.99),
            v(64.0, 44.0),
            v(-0.0, 0.0),
            v(-1e-300, 10.0),
            v(1e15, 20.0),
            v(-1e15, 20.0),
            v(1e300, -1e300),
            v(nan, 1.0),
            v(inf, 20.0),
            v(-inf, 20.0),
        ];
        for a in pts {
            for b in pts {
                for step in [0.05, 0.0, -1.0, 0.3, 1e-3, nan, inf] {
                    let len = (b - a).norm();
                    let s = if step > 0.0 { step } else { 0.05 };
                    // the reference visits every sample: keep it bounded
                    if len.is_finite() && len / s > 1e6 {
                        continue;
                    }
                    assert_eq!(
                        m.crosses_wall(a, b, step),
                        m.crosses_wall_reference(a, b, step),
                        "{a:?} -> {b:?} step {step}"
                    );
                }
            }
        }
        for (a, b) in [(v(3.0, 20.5), v(3.0, 20.5)), (v(0.0, 0.0), v(0.0, 0.0))] {
            assert_eq!(
                m.crosses_wall(a, b, 0.05),
                m.crosses_wall_reference(a, b, 0.05)
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// The particle wall check: the skipping walk answers exactly as the
        /// literal loop on the demo plan, for particle-sized moves and long
        /// segments (also leaving the image) and any step.
        #[test]
        fn crosses_wall_equals_reference_on_demo(
            x1 in -2.0f64..66.0, y1 in -2.0f64..46.0,
            dx in -1.5f64..1.5, dy in -1.5f64..1.5, long in 0.0f64..10.0,
            step in prop_oneof![Just(0.05f64), 0.005f64..1.5, Just(0.0)],
        ) {
            let m = demo();
            let a = Vec2::new(x1, y1);
            for b in [a + Vec2::new(dx, dy), a + Vec2::new(dx, dy) * long] {
                prop_assert_eq!(m.crosses_wall(a, b, step), m.crosses_wall_reference(a, b, step));
            }
        }

        /// Same on random maps of any resolution, Wall and Door density.
        #[test]
        fn crosses_wall_equals_reference_on_random_maps(
            seed in 0u64..1000, walls in 0.0f64..0.3, doors in 0.0f64..0.5,
            blob in 1usize..12, r in 0.5f64..20.0,
            fx in -0.1f64..1.1, fy in -0.1f64..1.1, tx in -0.2f64..1.2, ty in -0.2f64..1.2,
            step in 0.01f64..0.5,
        ) {
            let m = blob_map(60, 40, r, seed, walls, doors, blob);
            let (w, h) = (m.width_m(), m.height_m());
            let (a, b) = (Vec2::new(fx * w, fy * h), Vec2::new(tx * w, ty * h));
            prop_assert_eq!(m.crosses_wall(a, b, step), m.crosses_wall_reference(a, b, step));
            // a particle-sized move from the same start
            let c = a + (b - a) * (0.7 / (b - a).norm().max(0.7));
            prop_assert_eq!(m.crosses_wall(a, c, step), m.crosses_wall_reference(a, c, step));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// The block version answers every move as the literal loop, for
        /// clouds of particle moves (some leaving the image, odd counts
        /// across the blocks), on the demo plan and on random maps.
        #[test]
        fn crosses_wall_each_equals_reference(
            seed in 0u64..1000, count in 0usize..300, spread in 0.0f64..6.0,
            cx in -2.0f64..66.0, cy in -2.0f64..46.0, len in 0.0f64..2.0,
            random_map in any::<bool>(), step in prop_oneof![Just(0.05f64), 0.01f64..0.5],
        ) {
            use rand::{RngExt, SeedableRng};
            let m = if random_map {
                &blob_map(80, 50, 10.0, seed, 0.2, 0.3, 8)
            } else {
                demo()
            };
            let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
            let mut from = Vec::new();
            let mut to = Vec::new();
            for _ in 0..count {
                let a = Vec2::new(cx, cy)
                    + Vec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5) * spread;
                let t = rng.random::<f64>() * std::f64::consts::TAU;
                from.push(a);
                to.push(a + Vec2::new(t.cos(), t.sin()) * (len * rng.random::<f64>()));
            }
            // a longer `to` is cut to `from`'s length
            to.push(Vec2::new(cx, cy));
            let mut out = vec![true; 7];
            m.crosses_wall_each(&from, &to, step, &mut out);
            prop_assert_eq!(out.len(), count);
            for i in 0..count {
                prop_assert_eq!(out[i], m.crosses_wall_reference(from[i], to[i], step), "move {}", i);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// The skipping raycast returns exactly the reference's hit (or none)
        /// on the demo plan, for any segment (also leaving the image) and step.
        #[test]
        fn raycast_equals_reference_on_demo(
            x1 in -2.0f64..66.0, y1 in -2.0f64..46.0,
            dx in -12.0f64..12.0, dy in -12.0f64..12.0,
            step in prop_oneof![Just(0.05f64), 0.005f64..1.5, Just(0.0)],
        ) {
            let m = demo();
            let (a, b) = (Vec2::new(x1, y1), Vec2::new(x1 + dx, y1 + dy));
            prop_assert_eq!(m.raycast(a, b, step), m.raycast_reference(a, b, step));
        }

        /// Same on random maps of any resolution and obstacle density.
        #[test]
        fn raycast_equals_reference_on_random_maps(
            seed in 0u64..1000, density in 0.0f64..0.05, r in 0.5f64..20.0,
            fx in 0.0f64..1.0, fy in 0.0f64..1.0, tx in -0.2f64..1.2, ty in -0.2f64..1.2,
            step in 0.01f64..0.5,
        ) {
            let m = random_map(60, 40, r, seed, density);
            let (w, h) = (m.width_m(), m.height_m());
            let (a, b) = (Vec2::new(fx * w, fy * h), Vec2::new(tx * w, ty * h));
            prop_assert_eq!(m.raycast(a, b, step), m.raycast_reference(a, b, step));
        }
    }
}
