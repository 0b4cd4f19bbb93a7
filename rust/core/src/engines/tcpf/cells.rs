//! The start / re-seeding cells of each floor, and the model's expected
//! RSSI over them, computed once.

use std::collections::BTreeMap;

use crate::Vec2;
use crate::map::FloorMap;
use crate::radio::{Measurement, RadioModel, TxKind};
use crate::site::Site;

/// Start / re-seeding cells per floor and the model's values over them.
pub(super) struct Cells {
    /// The walkable cells of each floor, `cell_m` apart.
    pub(super) by_floor: BTreeMap<i32, Vec<Vec2>>,
    /// The model's expected RSSI over those cells, per heard transmitter.
    pub(super) expected: CellExpected,
}

impl Cells {
    /// The cells of every floor of `site`, `cell_m` apart; nothing
    /// expected yet.
    pub(super) fn of_site(site: &Site, cell_m: f64) -> Self {
        let by_floor = site
            .spec
            .floors
            .iter()
            .zip(&site.floors)
            .map(|(f, m)| (f.id, cells_of(m, cell_m)))
            .collect();
        Cells {
            by_floor,
            expected: CellExpected::default(),
        }
    }
}

/// At most this many (mean, sd) pairs in [`CellExpected`] (16 MB); past
/// it the surface samples the model as before.
const CELL_EXPECTED_MAX: usize = 1 << 20;

/// The model's expected RSSI (mean, sd) of transmitters over a floor's
/// start / re-seeding cells, computed once per (floor, transmitter): the
/// cells and the model never change, so the likelihood surface of every
/// recovery check reads the same values instead of sampling the model
/// again (two thirds of a surface's work with a radio map).
#[derive(Debug, Default)]
pub(super) struct CellExpected {
    pub(super) by: BTreeMap<(i32, usize), CellValues>,
    pub(super) pairs: usize,
}

impl CellExpected {
    /// Computes the transmitters of `meas` not yet held for `floor` over
    /// `cells` (those the model knows, while under [`CELL_EXPECTED_MAX`]).
    pub(super) fn fill(
        &mut self,
        model: &dyn RadioModel,
        floor: i32,
        cells: &[Vec2],
        meas: &[Measurement],
    ) {
        for m in meas {
            if self.by.contains_key(&(floor, m.tx)) || self.pairs + cells.len() > CELL_EXPECTED_MAX
            {
                continue;
            }
            let (mut mean, mut sd) = (vec![0.0; cells.len()], vec![0.0; cells.len()]);
            if model.expected_many(m.tx, floor, cells, &mut mean, &mut sd) {
                let min_sd = sd.iter().copied().fold(f64::INFINITY, f64::min);
                self.by
                    .insert((floor, m.tx), CellValues { mean, sd, min_sd });
                self.pairs += cells.len();
            }
        }
    }
}

/// One transmitter's expected RSSI over a floor's cells.
#[derive(Debug)]
pub(super) struct CellValues {
    mean: Vec<f64>,
    sd: Vec<f64>,
    /// The smallest of `sd` ([`super::TcpfEngine::surface_gap_bound`]).
    pub(super) min_sd: f64,
}

/// `model` with the expected RSSI over `cells` of `floor` read from
/// `cache` where it holds them (the same values; anything else asks
/// `model`). Forwards the trait by hand: [`profiled_many`] takes a
/// `&dyn RadioModel`, and the defaulted methods must reach `model` too
/// (`learned_per_floor`, `reference_scans`), not fall back to the defaults.
pub(super) struct WithCells<'a> {
    pub(super) model: &'a dyn RadioModel,
    pub(super) floor: i32,
    pub(super) cells: &'a [Vec2],
    pub(super) cache: &'a CellExpected,
}

impl RadioModel for WithCells<'_> {
    fn transmitters(&self) -> &[crate::radio::Transmitter] {
        self.model.transmitters()
    }

    fn lookup(&self, kind: TxKind, id: &str) -> Option<usize> {
        self.model.lookup(kind, id)
    }

    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        self.model.expected(tx, floor, p)
    }

    fn expected_many(
        &self,
        tx: usize,
        floor: i32,
        ps: &[Vec2],
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> bool {
        // the very cell list (not merely as many points)
        let cells = floor == self.floor && std::ptr::eq(ps, self.cells);
        if let (true, Some(v)) = (cells, self.cache.by.get(&(floor, tx))) {
            let n = ps.len();
            mean[..n].copy_from_slice(&v.mean);
            sd[..n].copy_from_slice(&v.sd);
            return true;
        }
        self.model.expected_many(tx, floor, ps, mean, sd)
    }

    fn learned_per_floor(&self) -> bool {
        self.model.learned_per_floor()
    }

    fn reference_scans(&self) -> Option<&crate::radio::reference_scans::ReferenceScans> {
        self.model.reference_scans()
    }

    fn magnetic(&self) -> Option<&crate::radio::magnetic_map::MagneticMap> {
        self.model.magnetic()
    }
}

/// The walkable cells of `map`, one per `cell_m` square that holds a grid
/// point (the first grid point in it).
fn cells_of(map: &FloorMap, cell_m: f64) -> Vec<Vec2> {
    let mut seen = std::collections::BTreeSet::new();
    let mut out = Vec::new();
    for p in map.grid() {
        let key = ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64);
        if seen.insert(key) {
            out.push(*p);
        }
    }
    out
}
