//! GML, the grid-based maximum-likelihood estimator of FP-BP Sec. III.
//!
//! 1. B_N: the N >= 3 strongest filtered beacons (eq. 9).
//! 2. For each, log10 of the range implied by the filtered RSSI (eq. 10b) and
//!    eta_i = sigma_i / (10 n_i) (eq. 12).
//! 3. y* = argmin over the candidate grid points G' of
//!    sum_i (log10 d_i - log10 ||y - b_i||)^2 / (2 eta_i^2) (eqs. 17-19), ranges
//!    in 3-D (phone height vs beacon height), first grid point on ties.
//! 4. G' (eqs. 20-21), chosen per call:
//!    - previous position unknown: the whole grid G;
//!    - otherwise G'2 = {y in G : |y - x_prev|_1 < d0}; the call is "dense" when
//!      x_prev lies strictly inside the hull C_N of B_N and at least
//!      `dense_min_inside_fraction` of G'2 lies strictly inside C_N; then
//!      G'1 = G'2 ∩ int C_N is used, else G'2;
//!    - when the chosen set is empty (x_prev far off the grid), the whole grid.
//! 5. The mean filter (eq. 22) is applied by the caller ([`super::task::BleTask`]),
//!    the same for every positioner.
//!
//! Speed: [`BlePositioner::locate`] evaluates the cost of every grid point in
//! f32 from precomputed log-ranges ([`super::gml_tables`]), then re-evaluates
//! in f64, exactly as the reference, every candidate whose f32 cost is
//! within a tolerance of the f32 minimum (a bound well above the f32 rounding
//! error, see [`f32_tolerance`]) and returns the f64 argmin among them (first
//! grid point on ties). So it returns the reference's grid point unless f32
//! rounding exceeds the tolerance. [`Gml::locate_reference`] is the
//! exhaustive f64 search, kept as the oracle (property test below).

use super::config::{BleConfig, GmlConfig};
use super::frontend::{BleFrontEnd, FilteredBeacon};
use super::gml_tables::{GmlTables, log_range};
use super::hull::{convex_hull, strictly_inside};
use super::positioner::{BlePositioner, finite};
use crate::Vec2;

/// Which candidate set the last call searched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CandidateSet {
    /// The whole grid G (no previous position, or G' empty).
    Whole,
    /// G'1 of eq. 20 (dense: inside the hull and near the previous position).
    G1,
    /// G'2 of eq. 21 (sparse: near the previous position).
    G2,
}

/// The GML estimator.
#[derive(Debug, Clone)]
pub struct Gml {
    cfg: GmlConfig,
    min_distance_m: f64,
    /// Candidate set searched by the last successful call.
    pub last_set: Option<CandidateSet>,
    /// Number of candidate points searched by the last call.
    pub last_candidates: usize,
    /// Candidates re-evaluated in f64 by the last fast call.
    pub last_rechecked: usize,
    tables: GmlTables,
    costs: Vec<f32>,
}

/// Tolerance of the f32 pre-selection: candidates with an f32 cost within
/// this of the f32 minimum are re-evaluated in f64. The f32 log-ranges carry
/// an absolute error below 1e-6 (`gml_tables::fast_log10` and f32 rounding)
/// and log d_hat below 5e-7 (|log10 d| < 8), so each term's error is below
/// ~2 w |r| 1.5e-6 + w r^2 1e-7; the bound used, 1e-4 (1 + |c_min|) +
/// 5e-4 sum w, is ~20x that for residuals |r| < 8 (and more for the small
/// residuals near the minimum).
pub fn f32_tolerance(c_min: f32, weight_sum: f64) -> f64 {
    1e-4 * (1.0 + c_min.abs() as f64) + 5e-4 * weight_sum
}

struct Term {
    index: usize,
    pos: Vec2,
    dz_m: f64,
    log_d_hat: f64,
    weight: f64,
}

impl Gml {
    pub fn new(cfg: &BleConfig) -> Self {
        Gml {
            cfg: cfg.gml.clone(),
            min_distance_m: cfg.min_distance_m,
            last_set: None,
            last_candidates: 0,
            last_rechecked: 0,
            tables: GmlTables::default(),
            costs: Vec::new(),
        }
    }

    /// Bytes held by the precomputed log-range tables.
    pub fn table_bytes(&self) -> usize {
        self.tables.bytes()
    }

    /// Beacon columns held by the tables (over all grids).
    pub fn table_columns(&self) -> usize {
        self.tables.column_count()
    }

    /// The exhaustive f64 search over the candidate set (the reference the
    /// fast [`BlePositioner::locate`] is tested against).
    pub fn locate_reference(
        &mut self,
        beacons: &[FilteredBeacon],
        grid: &[Vec2],
        prev: Option<Vec2>,
    ) -> Option<Vec2> {
        self.last_set = None;
        self.last_candidates = 0;
        self.last_rechecked = 0;
        let (terms, cand, set) = self.setup(beacons, grid, prev)?;
        let mut best: Option<(f64, usize)> = None;
        for &i in &cand {
            let c = self.cost(&terms, grid[i]);
            if c.is_finite() && best.is_none_or(|(b, _)| c < b) {
                best = Some((c, i));
            }
        }
        let (_, i) = best?;
        self.last_set = Some(set);
        self.last_candidates = cand.len();
        finite(grid[i])
    }

    /// Terms and candidate set of one call (None: no fix possible).
    fn setup(
        &self,
        beacons: &[FilteredBeacon],
        grid: &[Vec2],
        prev: Option<Vec2>,
    ) -> Option<(Vec<Term>, Vec<usize>, CandidateSet)> {
        if beacons.len() < 3 || grid.is_empty() {
            return None;
        }
        let terms = self.terms(beacons);
        if terms
            .iter()
            .any(|t| !(t.log_d_hat.is_finite() && t.weight.is_finite()))
        {
            return None;
        }
        let pos: Vec<Vec2> = terms.iter().map(|t| t.pos).collect();
        let (cand, set) = self.candidates(&pos, grid, prev);
        Some((terms, cand, set))
    }

    /// One GML estimate from the front end's current set at `t_ns`, restricted
    /// to the floor most of the strongest beacons are on (the caller's `grid`
    /// must be that floor's grid).
    pub fn estimate(
        &mut self,
        front: &BleFrontEnd,
        t_ns: i64,
        grid: &[Vec2],
        prev: Option<Vec2>,
    ) -> Option<Vec2> {
        let all = front.current(t_ns);
        let floor = BleFrontEnd::likely_floor(&all, self.cfg.top_n)?;
        let on_floor: Vec<FilteredBeacon> = all.into_iter().filter(|b| b.floor == floor).collect();
        self.locate(&on_floor, grid, prev)
    }

    fn terms(&self, beacons: &[FilteredBeacon]) -> Vec<Term> {
        beacons
            .iter()
            .take(self.cfg.top_n)
            .map(|b| {
                let var = self.cfg.rssi_sigma_dbm.powi(2)
                    + if self.cfg.use_kalman_variance {
                        b.var_dbm2
                    } else {
                        0.0
                    };
                let eta2 = var / (10.0 * b.model.exponent).powi(2);
                Term {
                    index: b.index,
                    pos: b.pos,
                    dz_m: b.dz_m,
                    log_d_hat: b.model.log10_distance(b.rssi_dbm),
                    weight: 1.0 / (2.0 * eta2),
                }
            })
            .collect()
    }

    fn cost(&self, terms: &[Term], y: Vec2) -> f64 {
        terms
            .iter()
            .map(|t| {
                let r = t.log_d_hat - log_range(y, t.pos, t.dz_m, self.min_distance_m);
                t.weight * r * r
            })
            .sum()
    }

    /// The candidate set for this call (indices into `grid`) and its kind.
    pub fn candidates(
        &self,
        beacon_pos: &[Vec2],
        grid: &[Vec2],
        prev: Option<Vec2>,
    ) -> (Vec<usize>, CandidateSet) {
        let whole = || ((0..grid.len()).collect::<Vec<usize>>(), CandidateSet::Whole);
        let Some(prev) = prev.and_then(finite) else {
            return whole();
        };
        let d0 = self.cfg.d0_m;
        let g2: Vec<usize> = (0..grid.len())
            .filter(|&i| (grid[i].x - prev.x).abs() + (grid[i].y - prev.y).abs() < d0)
            .collect();
        if g2.is_empty() {
            return whole();
        }
        let hull = convex_hull(beacon_pos);
        if strictly_inside(&hull, prev) {
            let g1: Vec<usize> = g2
                .iter()
                .copied()
                .filter(|&i| strictly_inside(&hull, grid[i]))
                .collect();
            if !g1.is_empty()
                && g1.len() as f64 >= self.cfg.dense_min_inside_fraction * g2.len() as f64
            {
                return (g1, CandidateSet::G1);
            }
        }
        (g2, CandidateSet::G2)
    }
}

impl BlePositioner for Gml {
    fn name(&self) -> &'static str {
        "gml"
    }

    fn locate(
        &mut self,
        beacons: &[FilteredBeacon],
        grid: &[Vec2],
        prev: Option<Vec2>,
    ) -> Option<Vec2> {
        self.last_set = None;
        self.last_candidates = 0;
        self.last_rechecked = 0;
        let (terms, cand, set) = self.setup(beacons, grid, prev)?;
        // f32 cost of every grid point from the tables
        let keys: Vec<(usize, Vec2, f64)> =
            terms.iter().map(|t| (t.index, t.pos, t.dz_m)).collect();
        let (g, slots) = self.tables.prepare(grid, &keys, self.min_distance_m);
        self.costs.clear();
        self.costs.resize(grid.len(), 0.0);
        for (t, &slot) in terms.iter().zip(&slots) {
            let col = self.tables.column(g, slot);
            let (l, w) = (t.log_d_hat as f32, t.weight as f32);
            for (c, &d) in self.costs.iter_mut().zip(col) {
                let r = l - d;
                *c += w * r * r;
            }
        }
        let c_min = min_over(&self.costs, &cand);
        if !c_min.is_finite() {
            // every f32 cost overflowed or is NaN: fall back to the reference
            return self.locate_reference(beacons, grid, prev);
        }
        let w_sum: f64 = terms.iter().map(|t| t.weight).sum();
        let limit = c_min as f64 + f32_tolerance(c_min, w_sum);
        // exact f64 argmin among the near-best (first grid point on ties)
        let mut best: Option<(f64, usize)> = None;
        let mut rechecked = 0;
        for block in cand.chunks(16) {
            // skip a block of candidates with one test when none is near-best
            if (min_over(&self.costs, block) as f64) > limit {
                continue;
            }
            for &i in block {
                if (self.costs[i] as f64) <= limit {
                    rechecked += 1;
                    let c = self.cost(&terms, grid[i]);
                    if c.is_finite() && best.is_none_or(|(b, _)| c < b) {
                        best = Some((c, i));
                    }
                }
            }
        }
        let (_, i) = best?;
        self.last_set = Some(set);
        self.last_candidates = cand.len();
        self.last_rechecked = rechecked;
        finite(grid[i])
    }
}

/// min of `costs[i]` over `idx` (NaN ignored; +inf when empty), with four
/// independent accumulators so the loop is not one long dependency chain.
fn min_over(costs: &[f32], idx: &[usize]) -> f32 {
    let mut m = [f32::INFINITY; 4];
    let mut chunks = idx.chunks_exact(4);
    for c in &mut chunks {
        for k in 0..4 {
            m[k] = m[k].min(costs[c[k]]);
        }
    }
    for &i in chunks.remainder() {
        m[0] = m[0].min(costs[i]);
    }
    m[0].min(m[1]).min(m[2].min(m[3]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::grid::rect_grid;
    use crate::ble::pathloss::range_m;
    use crate::ble::testutil::{lattice_24, noise_free};

    /// GML with d0 = 10 m (the tests' geometry is laid out for it).
    fn gml() -> Gml {
        let mut cfg = BleConfig::default();
        cfg.gml.d0_m = 10.0;
        Gml::new(&cfg)
    }

    #[test]
    fn noise_free_rssi_gives_the_true_grid_point() {
        let grid = rect_grid(60.0, 40.0, 1.0);
        let beacons = lattice_24();
        let mut g = gml();
        for (k, truth) in [
            Vec2::new(12.5, 17.5),
            Vec2::new(0.5, 0.5),
            Vec2::new(44.5, 31.5),
            Vec2::new(30.5, 20.5),
        ]
        .into_iter()
        .enumerate()
        {
            let fb = noise_free(&beacons, truth);
            // whole grid at start-up
            let y = g.locate(&fb, &grid, None).unwrap();
            assert!((y - truth).norm() < 1e-9, "case {k}: {y:?} vs {truth:?}");
            assert_eq!(g.last_set, Some(CandidateSet::Whole));
            assert_eq!(g.last_candidates, grid.len());
            // and around a previous position 3 m away
            let y = g
                .locate(&fb, &grid, Some(truth + Vec2::new(2.0, -1.0)))
                .unwrap();
            assert!((y - truth).norm() < 1e-9, "case {k} local: {y:?}");
            assert!(g.last_candidates < grid.len());
        }
    }

    #[test]
    fn candidate_set_follows_the_density_rule() {
        let grid = rect_grid(60.0, 40.0, 1.0);
        let g = gml();
        // a square of beacons around the previous position: dense -> G'1
        let square = [
            Vec2::new(10.0, 10.0),
            Vec2::new(30.0, 10.0),
            Vec2::new(30.0, 30.0),
            Vec2::new(10.0, 30.0),
        ];
        let (c1, s1) = g.candidates(&square, &grid, Some(Vec2::new(20.0, 20.0)));
        assert_eq!(s1, CandidateSet::G1);
        assert!(
            c1.iter()
                .all(|&i| strictly_inside(&convex_hull(&square), grid[i]))
        );
        assert!(
            c1.iter()
                .all(|&i| (grid[i].x - 20.0).abs() + (grid[i].y - 20.0).abs() < 10.0)
        );
        // previous position near the hull's corner: most of G'2 is outside -> G'2
        let (c2, s2) = g.candidates(&square, &grid, Some(Vec2::new(11.0, 11.0)));
        assert_eq!(s2, CandidateSet::G2);
        assert!(
            c2.iter()
                .any(|&i| !strictly_inside(&convex_hull(&square), grid[i]))
        );
        // previous position outside the hull: G'2
        let (_, s3) = g.candidates(&square, &grid, Some(Vec2::new(50.0, 20.0)));
        assert_eq!(s3, CandidateSet::G2);
        // collinear beacons have no interior: G'2
        let line = [
            Vec2::new(10.0, 10.0),
            Vec2::new(20.0, 10.0),
            Vec2::new(30.0, 10.0),
        ];
        let (_, s4) = g.candidates(&line, &grid, Some(Vec2::new(20.0, 12.0)));
        assert_eq!(s4, CandidateSet::G2);
        // unknown or far-off previous position: whole grid
        assert_eq!(g.candidates(&square, &grid, None).1, CandidateSet::Whole);
        assert_eq!(
            g.candidates(&square, &grid, Some(Vec2::new(500.0, 500.0)))
                .1,
            CandidateSet::Whole
        );
        assert_eq!(
            g.candidates(&square, &grid, Some(Vec2::new(f64::NAN, 1.0)))
                .1,
            CandidateSet::Whole
        );
    }

    #[test]
    fn too_few_beacons_or_no_grid_give_no_fix() {
        let grid = rect_grid(60.0, 40.0, 1.0);
        let fb = noise_free(&lattice_24()[..2], Vec2::new(10.0, 10.0));
        assert_eq!(gml().locate(&fb, &grid, None), None);
        let fb = noise_free(&lattice_24(), Vec2::new(10.0, 10.0));
        assert_eq!(gml().locate(&fb, &[], None), None);
    }

    #[test]
    fn collinear_beacons_give_a_finite_point() {
        let grid = rect_grid(60.0, 40.0, 1.0);
        let line = [
            Vec2::new(10.0, 10.0),
            Vec2::new(20.0, 10.0),
            Vec2::new(30.0, 10.0),
        ];
        let truth = Vec2::new(20.5, 15.5);
        let fb = noise_free(&line, truth);
        let y = gml().locate(&fb, &grid, Some(truth)).unwrap();
        // the mirror image (20.5, 4.5) is as likely; the previous position picks the side
        assert!((y - truth).norm() < 1e-9, "{y:?}");
    }

    /// Beacons of `lattice_24` at random heights, with RSSI noise.
    fn noisy_scan(
        truth: Vec2,
        noise: &[f64],
        heights: &[f64],
        exponent: f64,
    ) -> Vec<FilteredBeacon> {
        let mut fb = noise_free(&lattice_24(), truth);
        for (k, b) in fb.iter_mut().enumerate() {
            b.dz_m = heights[k % heights.len()];
            b.model.exponent = exponent;
            let d = range_m(truth, b.pos, b.dz_m, 0.5);
            b.rssi_dbm = b.model.rssi_at(d, 0.5) + noise[k % noise.len()];
        }
        fb.sort_by(|a, b| {
            b.rssi_dbm
                .total_cmp(&a.rssi_dbm)
                .then(a.index.cmp(&b.index))
        });
        fb
    }

    #[test]
    fn tables_are_reused_and_follow_grid_changes() {
        let grid = rect_grid(60.0, 40.0, 1.0);
        let mut g = gml();
        let fb = noise_free(&lattice_24(), Vec2::new(12.5, 17.5));
        g.locate(&fb, &grid, None).unwrap();
        assert_eq!(g.table_columns(), 6);
        assert_eq!(g.table_bytes(), grid.len() * (16 + 6 * 4));
        g.locate(&fb, &grid, Some(Vec2::new(12.0, 17.0))).unwrap();
        assert_eq!(
            g.table_columns(),
            6,
            "same beacons, same grid: no new column"
        );
        // same beacons on a different grid: new columns, right answer
        let coarse = rect_grid(60.0, 40.0, 2.0);
        let y = g.locate(&fb, &coarse, None).unwrap();
        assert_eq!(Some(y), g.locate_reference(&fb, &coarse, None));
        assert_eq!(g.table_columns(), 12);
        // a beacon moved under the same registry index: its column is rebuilt
        let mut moved = fb.clone();
        moved[0].pos += Vec2::new(3.0, 0.0);
        let y = g.locate(&moved, &grid, None).unwrap();
        assert_eq!(Some(y), g.locate_reference(&moved, &grid, None));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        /// The fast search returns the exhaustive f64 reference's grid point
        /// (same candidate set) on random noisy scans, beacon heights, models,
        /// top-N and previous positions.
        #[test]
        fn fast_search_matches_the_reference(
            tx in 0.0f64..60.0, ty in 0.0f64..40.0,
            noise in proptest::collection::vec(-12.0f64..12.0, 24),
            heights in proptest::collection::vec(-1.0f64..3.0, 1..4),
            exponent in 1.2f64..4.0,
            top_n in 3usize..10,
            prev in proptest::option::of((-5.0f64..65.0, -5.0f64..45.0)),
            sigma in 0.5f64..8.0,
            kalman in proptest::bool::ANY,
            interval in proptest::prop_oneof![proptest::strategy::Just(1.0f64), 0.3f64..3.0],
        ) {
            let grid = rect_grid(60.0, 40.0, interval);
            let mut cfg = BleConfig::default();
            cfg.gml.top_n = top_n;
            cfg.gml.rssi_sigma_dbm = sigma;
            cfg.gml.use_kalman_variance = kalman;
            let mut g = Gml::new(&cfg);
            let fb = noisy_scan(Vec2::new(tx, ty), &noise, &heights, exponent);
            let prev = prev.map(|(x, y)| Vec2::new(x, y));
            let fast = g.locate(&fb, &grid, prev);
            let (set, n) = (g.last_set, g.last_candidates);
            let reference = g.locate_reference(&fb, &grid, prev);
            proptest::prop_assert_eq!(fast, reference);
            proptest::prop_assert_eq!((set, n), (g.last_set, g.last_candidates));
        }
    }

    proptest::proptest! {
        #[test]
        fn gml_never_returns_nan(rssi in proptest::collection::vec(-120.0f64..-1.0, 3..8), px in -100.0f64..100.0) {
            let grid = rect_grid(60.0, 40.0, 2.0);
            let mut fb = noise_free(&lattice_24()[..rssi.len()], Vec2::new(1.0, 1.0));
            for (b, r) in fb.iter_mut().zip(&rssi) { b.rssi_dbm = *r; }
            let y = gml().locate(&fb, &grid, Some(Vec2::new(px, 3.0)));
            proptest::prop_assert!(y.is_some_and(|p| p.x.is_finite() && p.y.is_finite()));
        }
    }
}
