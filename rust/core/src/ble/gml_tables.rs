//! Precomputed log-ranges for the fast GML search ([`super::gml::Gml`]).
//!
//! For each grid the positioner is called with, and each beacon that has
//! appeared in a call on it, one column: log10 of the 3-D range (floored at
//! `min_distance_m`) from every grid point to the beacon, as f32 (struct of
//! arrays: one contiguous column per beacon). A call then costs N passes of
//! multiply-adds over contiguous f32 (vectorised by the compiler) instead of
//! N square roots and logarithms per grid point.
//!
//! Columns are built lazily, the first time a beacon is among a call's top N
//! on that grid, so memory is grid points x beacons actually heard x 4 bytes
//! (bounded by [`MAX_COLUMNS`] per grid, oldest evicted first) plus one copy
//! of the grid per cached grid (up to [`MAX_GRIDS`], oldest evicted first).
//! A grid is recognised by its contents (compared every call), so a caller
//! may pass any slice; a column by (registry index, position, dz).

use super::pathloss::range_m;
use crate::Vec2;

/// Grids cached at once (one per floor in practice).
pub const MAX_GRIDS: usize = 8;
/// Beacon columns kept per grid.
pub const MAX_COLUMNS: usize = 512;

#[derive(Debug, Clone)]
struct Column {
    index: usize,
    pos: Vec2,
    dz_m: f64,
    log_d: Vec<f32>,
}

#[derive(Debug, Clone)]
struct GridTable {
    grid: Vec<Vec2>,
    columns: Vec<Column>,
}

/// The per-grid, per-beacon log-range tables.
#[derive(Debug, Clone, Default)]
pub struct GmlTables {
    grids: Vec<GridTable>,
}

/// log10 of the floored 3-D range, the quantity the eq. 19 cost compares (f64).
pub(crate) fn log_range(y: Vec2, b: Vec2, dz_m: f64, min_distance_m: f64) -> f64 {
    range_m(y, b, dz_m, min_distance_m).log10()
}

/// Whether two grids hold the same points (NaN never matches). Compares in
/// blocks without an early exit inside a block, so the loop vectorises.
fn same_grid(a: &[Vec2], b: &[Vec2]) -> bool {
    a.len() == b.len()
        && a.chunks(64).zip(b.chunks(64)).all(|(ca, cb)| {
            ca.iter()
                .zip(cb)
                .fold(true, |ok, (p, q)| ok & (p.x == q.x) & (p.y == q.y))
        })
}

/// log10 of a positive f32 without libm (vectorisable): exponent from the
/// bits, ln of the mantissa m in [1, 2) by the atanh series
/// 2 (t + t^3/3 + ... + t^11/11), t = (m - 1) / (m + 1) <= 1/3. Absolute
/// error < 2e-6 on [1e-6, 1e9] (mostly the f32 rounding of the result; test
/// below); non-normal input falls back to `log10`.
pub(crate) fn fast_log10(x: f32) -> f32 {
    if !(x.is_normal() && x > 0.0) {
        return x.log10();
    }
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let t = (m - 1.0) / (m + 1.0);
    let t2 = t * t;
    let ln_m = 2.0
        * t
        * (1.0
            + t2 * (1.0 / 3.0
                + t2 * (1.0 / 5.0 + t2 * (1.0 / 7.0 + t2 * (1.0 / 9.0 + t2 * (1.0 / 11.0))))));
    e as f32 * std::f32::consts::LOG10_2 + ln_m * std::f32::consts::LOG10_E
}

/// One column: log10 of the floored 3-D range, computed as
/// 0.5 log10(max(d^2, min^2)) in f32 (no square root, [`fast_log10`]: error
/// < 1e-6, inside the f32 pre-selection's tolerance; the final choice is
/// re-evaluated in f64).
fn column(grid: &[Vec2], pos: Vec2, dz_m: f64, min_distance_m: f64) -> Vec<f32> {
    let dz2 = dz_m * dz_m;
    let min2 = (min_distance_m * min_distance_m) as f32;
    grid.iter()
        .map(|&y| {
            let d2 = ((y - pos).norm_squared() + dz2) as f32;
            0.5 * fast_log10(d2.max(min2))
        })
        .collect()
}

impl GmlTables {
    /// Index of the cached table for `grid`, building (and evicting) as needed.
    fn grid_slot(&mut self, grid: &[Vec2]) -> usize {
        if let Some(k) = self.grids.iter().position(|t| same_grid(&t.grid, grid)) {
            return k;
        }
        if self.grids.len() >= MAX_GRIDS {
            self.grids.remove(0);
        }
        self.grids.push(GridTable {
            grid: grid.to_vec(),
            columns: Vec::new(),
        });
        self.grids.len() - 1
    }

    /// For beacons (registry index, position, dz) on `grid`, the slot of the
    /// grid and of each beacon's column, building what is missing.
    pub fn prepare(
        &mut self,
        grid: &[Vec2],
        beacons: &[(usize, Vec2, f64)],
        min_distance_m: f64,
    ) -> (usize, Vec<usize>) {
        let g = self.grid_slot(grid);
        let table = &mut self.grids[g];
        let mut slots = Vec::with_capacity(beacons.len());
        for &(index, pos, dz_m) in beacons {
            let found = table.columns.iter().position(|c| {
                c.index == index && c.pos == pos && c.dz_m.to_bits() == dz_m.to_bits()
            });
            let slot = match found {
                Some(s) => s,
                None => {
                    if table.columns.len() >= MAX_COLUMNS {
                        // never evict a column this call already uses
                        let victim = (0..table.columns.len())
                            .find(|s| !slots.contains(s))
                            .unwrap_or(0);
                        table.columns.remove(victim);
                        for s in slots.iter_mut() {
                            if *s > victim {
                                *s -= 1;
                            }
                        }
                    }
                    table.columns.push(Column {
                        index,
                        pos,
                        dz_m,
                        log_d: column(&table.grid, pos, dz_m, min_distance_m),
                    });
                    table.columns.len() - 1
                }
            };
            slots.push(slot);
        }
        (g, slots)
    }

    /// Column `slot` of grid `g` (from [`GmlTables::prepare`]).
    pub fn column(&self, g: usize, slot: usize) -> &[f32] {
        &self.grids[g].columns[slot].log_d
    }

    /// Bytes held by the tables (columns and grid copies).
    pub fn bytes(&self) -> usize {
        self.grids
            .iter()
            .map(|t| {
                t.grid.len() * std::mem::size_of::<Vec2>()
                    + t.columns.iter().map(|c| c.log_d.len() * 4).sum::<usize>()
            })
            .sum()
    }

    /// Columns held over all grids.
    pub fn column_count(&self) -> usize {
        self.grids.iter().map(|t| t.columns.len()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_log10_is_accurate() {
        let mut worst = 0.0f64;
        let mut x = 1e-6f64;
        while x < 1e9 {
            let got = fast_log10(x as f32) as f64;
            let want = (x as f32 as f64).log10();
            worst = worst.max((got - want).abs());
            x *= 1.000_37;
        }
        assert!(worst < 2e-6, "worst {worst}");
        assert_eq!(fast_log10(0.0), f32::NEG_INFINITY);
        assert!(fast_log10(f32::NAN).is_nan());
    }
}
