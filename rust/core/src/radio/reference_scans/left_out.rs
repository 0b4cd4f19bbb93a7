//! How far a survey window reads from the other walks' scans: every
//! reference scan queried as if a phone's window, against the scans of the
//! other walks only (leave one walk out). Where another walk passed close
//! by, that distance is what a phone on the survey's lines reads from the
//! survey (walk-to-walk variation, a different phone, people about); where
//! none did, what a phone off the lines reads. The engine's far test
//! (`tcpf.anchors.far_db`) asks the first question of a live window.

use std::collections::HashMap;

use super::{ReferenceScans, ScanMetric};
use crate::{Error, Result};

/// Spatial gaps beyond this are not searched: infinite.
pub const MAX_GAP_M: f64 = 20.0;

/// One survey scan queried against the other walks' scans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeftOutScan {
    /// RMS dB distance of the other walks' closest scan, ranked by the
    /// query's metric as the engine ranks it.
    pub dist_db: f64,
    /// Distance from the scan to the nearest scan of another walk on its
    /// floor, m (infinite: none within [`MAX_GAP_M`]).
    pub gap_m: f64,
}

impl ReferenceScans {
    /// Every `every`-th scan (from the first) queried with the radios it
    /// heard against the scans of the other walks (`walk_of`: the walk of
    /// each scan). Scans no other walk's scan shares a transmitter with are
    /// left out.
    pub fn left_out_distances(
        &self,
        walk_of: &[usize],
        metric: ScanMetric,
        every: usize,
    ) -> Result<Vec<LeftOutScan>> {
        if walk_of.len() != self.scans.len() {
            return Err(Error::Input(format!(
                "reference scans: {} walks given for {} scans",
                walk_of.len(),
                self.scans.len()
            )));
        }
        let grid = self.floor_grid();
        let mut out = Vec::new();
        for si in (0..self.scans.len()).step_by(every.max(1)) {
            let s = &self.scans[si];
            let q: Vec<(u32, f64)> =
                s.tx.iter()
                    .map(|&(j, r10)| (j, crate::radio::radio_map::tenths(r10)))
                    .collect();
            let (ble, wifi) = self.radios_in(&q);
            let w = walk_of[si];
            let best = self.query_among(&q, ble, wifi, 1, metric, |o| walk_of[o] != w);
            if let Some(c) = best.first() {
                out.push(LeftOutScan {
                    dist_db: c.dist_db,
                    gap_m: self.walk_gap(&grid, walk_of, si),
                });
            }
        }
        Ok(out)
    }

    /// The scans by floor and [`MAX_GAP_M`] square.
    fn floor_grid(&self) -> HashMap<(i32, i64, i64), Vec<usize>> {
        let mut grid: HashMap<(i32, i64, i64), Vec<usize>> = HashMap::new();
        for (i, s) in self.scans.iter().enumerate() {
            grid.entry(grid_key(s.floor, s.x_m, s.y_m))
                .or_default()
                .push(i);
        }
        grid
    }

    /// The distance from scan `si` to the nearest scan of another walk on
    /// its floor (infinite beyond [`MAX_GAP_M`]): the 3 x 3 squares of
    /// `grid` around it searched.
    fn walk_gap(
        &self,
        grid: &HashMap<(i32, i64, i64), Vec<usize>>,
        walk_of: &[usize],
        si: usize,
    ) -> f64 {
        let s = &self.scans[si];
        let (f, kx, ky) = grid_key(s.floor, s.x_m, s.y_m);
        let mut best = f64::INFINITY;
        for dx in -1..=1 {
            for dy in -1..=1 {
                let Some(cell) = grid.get(&(f, kx + dx, ky + dy)) else {
                    continue;
                };
                for &o in cell.iter().filter(|&&o| walk_of[o] != walk_of[si]) {
                    let t = &self.scans[o];
                    best = best.min((t.x_m - s.x_m).hypot(t.y_m - s.y_m));
                }
            }
        }
        if best <= MAX_GAP_M {
            best
        } else {
            f64::INFINITY
        }
    }
}

/// The [`MAX_GAP_M`] square of a place on a floor.
fn grid_key(floor: i32, x_m: f64, y_m: f64) -> (i32, i64, i64) {
    let b = MAX_GAP_M;
    (floor, (x_m / b).floor() as i64, (y_m / b).floor() as i64)
}
