//! A radio map learned from survey walks: per transmitter and floor, a grid
//! of the kernel-smoothed mean RSSI and its spread, implementing
//! [`RadioModel`] (model (b) of the tcpf issue; docs/tcpf.md, "Radio map").
//! Built by [`RadioMapBuilder`] ([`super::radio_map_build`]); its file form
//! is in [`super::radio_map_file`].
//!
//! Query ([`RadioModel::expected`]): bilinear between cell centres on the
//! phone's floor; where the grid has no value (outside it, far from the
//! walks, another floor never walked) the transmitter's fallback: the
//! site's path-loss model when the site had one (same formula as
//! [`super::PathLossModel`], wider `fallback` spreads), else a constant
//! weak prior (`prior_dbm`, `prior_sd_db`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::fast_ln::ln_normal;
use super::model::{RadioModel, Transmitter, TxKind};
pub use super::radio_map_build::{
    BuildSummary, RadioMapBuilder, RadioMapConfig, TxReport, kind_name,
};
use crate::Vec2;
use crate::site::Site;
use crate::{Error, Result};

/// Value of a grid cell with no estimate (the fallback applies), in the
/// x10 dB integer arrays.
pub const NO_VALUE: i16 = i16::MIN;

/// How the map answers where its grids do not.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FallbackParams {
    /// Spread around a site path-loss model, BLE / WiFi, dB. Default 8
    /// (wider than tcpf's 6: the map is used where it is better).
    pub ble_sd_db: f64,
    pub wifi_sd_db: f64,
    /// Extra loss per floor between phone and transmitter, dB. Default 15.
    pub floor_loss_db: f64,
    /// Extra spread on another floor, dB. Default 4.
    pub other_floor_sd_db: f64,
    /// Path-loss ranges are floored at this, metres. Default 0.5.
    pub min_range_m: f64,
    /// Mean and spread of a transmitter without a path-loss model away
    /// from its grids, dBm / dB. Defaults -92 / 10.
    pub prior_dbm: f64,
    pub prior_sd_db: f64,
}

impl Default for FallbackParams {
    fn default() -> Self {
        FallbackParams {
            ble_sd_db: 8.0,
            wifi_sd_db: 8.0,
            floor_loss_db: 15.0,
            other_floor_sd_db: 4.0,
            min_range_m: 0.5,
            prior_dbm: -92.0,
            prior_sd_db: 10.0,
        }
    }
}

impl FallbackParams {
    /// Checks every field, naming the bad one under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        use crate::bounds::check_range;
        for (f, v, lo, hi) in [
            ("ble_sd_db", self.ble_sd_db, 0.1, 50.0),
            ("wifi_sd_db", self.wifi_sd_db, 0.1, 50.0),
            ("floor_loss_db", self.floor_loss_db, 0.0, 100.0),
            ("other_floor_sd_db", self.other_floor_sd_db, 0.0, 50.0),
            ("min_range_m", self.min_range_m, 0.01, 100.0),
            ("prior_dbm", self.prior_dbm, -200.0, 0.0),
            ("prior_sd_db", self.prior_sd_db, 0.1, 50.0),
        ] {
            check_range(&format!("{prefix}.{f}"), v, lo, hi)?;
        }
        Ok(())
    }
}
/// One grid of a transmitter on one floor: `nx` x `ny` cells of `cell_m`
/// from (`x0_m`, `y0_m`) (row-major, x fastest), values in 0.1 dB,
/// [`NO_VALUE`] where the fallback applies. It is also the file's grid
/// (`radio_map_file`, which checks it on reading).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    pub floor: i32,
    pub x0_m: f64,
    pub y0_m: f64,
    pub cell_m: f64,
    pub nx: usize,
    pub ny: usize,
    /// Row-major (x fastest), 0.1 dB, -32768 ([`NO_VALUE`]) = no value.
    /// At most [`crate::bounds::MAX_RADIO_MAP_GRID_CELLS`] values each
    /// (counted while parsing).
    #[serde(deserialize_with = "grid_values")]
    pub mean_dbm_x10: Vec<i16>,
    #[serde(deserialize_with = "grid_values")]
    pub sd_dbm_x10: Vec<i16>,
}

fn grid_values<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Vec<i16>, D::Error> {
    crate::bounds::json::vec(d, crate::bounds::MAX_RADIO_MAP_GRID_CELLS)
}

/// Grid values (0.1 dB) below this are looked up in [`TENTHS`].
const TENTHS_LO: i32 = -2048;
/// x / 10 for every x in [`TENTHS_LO`], [`TENTHS_LO`] + 4096): the
/// grids' means and spreads (computed at compile time, the same
/// correctly rounded division as at run time; unit test).
static TENTHS: [f64; 4096] = {
    let mut t = [0.0; 4096];
    let mut i = 0;
    while i < 4096 {
        t[i] = (i as i32 + TENTHS_LO) as f64 / 10.0;
        i += 1;
    }
    t
};

/// `f64::from(x) / 10.0`, from [`TENTHS`] where it holds x.
#[inline(always)]
pub(crate) fn tenths(x: i16) -> f64 {
    let i = (i32::from(x) - TENTHS_LO) as usize;
    match TENTHS.get(i) {
        Some(v) => *v,
        None => f64::from(x) / 10.0,
    }
}

/// A grid's geometry prepared for many [`Grid::sample`]s: the same
/// values, with the division by the cell size a multiplication where
/// that is exact (a power of two) and the tenths from [`TENTHS`].
struct GridSampler<'a> {
    g: &'a Grid,
    /// 1 / cell_m when cell_m is a power of two (x / c == x * (1 / c)
    /// exactly), else 0 (divide).
    inv_cell: f64,
    nx: f64,
    ny: f64,
}

impl<'a> GridSampler<'a> {
    fn new(g: &'a Grid) -> Self {
        let c = g.cell_m;
        let pow2 = c.is_normal() && c > 0.0 && (c.to_bits() & 0x000f_ffff_ffff_ffff) == 0;
        let inv = 1.0 / c;
        GridSampler {
            g,
            inv_cell: if pow2 && inv.is_normal() { inv } else { 0.0 },
            nx: g.nx as f64,
            ny: g.ny as f64,
        }
    }

    /// [`Grid::sample`]`(ps[i])`, else `fast.at(ps[i])`, into `mean[i]`, `sd[i]`
    /// for every i, bit for bit (unit test): the same arithmetic in two
    /// passes, the cell coordinates and weights of every point first
    /// (vectorises), then per point the corners and the blend, the
    /// corners' tenths read without a branch when all eight are in
    /// [`TENTHS`] (the rare point off the grid or next to a hole settled
    /// as `sample` does).
    fn sample_many(&self, ps: &[Vec2], fast: &FastFallback, mean: &mut [f64], sd: &mut [f64]) {
        self.sample_many_as(ps, fast, mean, sd, None);
    }

    /// [`GridSampler::sample_many`]; `table`: `Some(on)` forces the
    /// corner table on or off (tests), `None` takes it when the points'
    /// cells are few against the points (a particle cloud: [`CornerTable`]).
    fn sample_many_as(
        &self,
        ps: &[Vec2],
        fast: &FastFallback,
        mean: &mut [f64],
        sd: &mut [f64],
        table: Option<bool>,
    ) {
        let g = self.g;
        let n = ps.len().min(mean.len()).min(sd.len());
        let mut at = Vec::with_capacity(n);
        self.locate(&ps[..n], &mut at);
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let mut off = Vec::new();
        let corners = CornerTable::of(g, &at, table);
        for (i, a) in at.iter().enumerate() {
            if !a.inside {
                off.push(i);
                continue;
            }
            // inside: i0 < nx and j0 < ny, so no index saturates
            let (i0, j0) = (a.i0 as usize, a.j0 as usize);
            let c = match &corners {
                Some(t) => t.get(i0, j0),
                None => corner_tenths(g, i0, j0),
            };
            let Some(c) = c else {
                (mean[i], sd[i]) = g
                    .at(a.u as usize, a.v as usize)
                    .unwrap_or_else(|| fast.at(ps[i]));
                continue;
            };
            mean[i] = lerp(lerp(c[0], c[1], a.tx), lerp(c[2], c[3], a.tx), a.ty);
            sd[i] = lerp(lerp(c[4], c[5], a.tx), lerp(c[6], c[7], a.tx), a.ty);
        }
        fast.at_some(ps, &off, mean, sd);
    }

    /// The cell coordinates of every point of `ps` appended to `at` (as
    /// [`Grid::sample`] computes them).
    fn locate(&self, ps: &[Vec2], at: &mut Vec<CellAt>) {
        let g = self.g;
        let (nx, ny) = (self.nx, self.ny);
        let one = |u: f64, v: f64| {
            let inside = u >= 0.0 && v >= 0.0 && u < nx && v < ny;
            let (fu, fv) = (u - 0.5, v - 0.5);
            let (i0, j0) = (fu.max(0.0) as i64, fv.max(0.0) as i64);
            CellAt {
                u,
                v,
                tx: (fu - i0 as f64).max(0.0),
                ty: (fv - j0 as f64).max(0.0),
                i0,
                j0,
                inside,
            }
        };
        if self.inv_cell != 0.0 {
            let inv = self.inv_cell;
            at.extend(
                ps.iter()
                    .map(|p| one((p.x - g.x0_m) * inv, (p.y - g.y0_m) * inv)),
            );
        } else {
            let c = g.cell_m;
            at.extend(
                ps.iter()
                    .map(|p| one((p.x - g.x0_m) / c, (p.y - g.y0_m) / c)),
            );
        }
    }
}

/// The tenths of the four corners' means, then of their spreads, of the
/// cell (`i0`, `j0`) of `g` (inside the grid) as [`Grid::sample`] blends
/// them (`i0 + 1`, `j0 + 1` clamped to the grid); `None` when one of them
/// has no value.
#[inline(always)]
fn corner_tenths(g: &Grid, i0: usize, j0: usize) -> Option<[f64; 8]> {
    let (i1, j1) = ((i0 + 1).min(g.nx - 1), (j0 + 1).min(g.ny - 1));
    let (r0, r1) = (j0 * g.nx, j1 * g.nx);
    let ks = [r0 + i0, r0 + i1, r1 + i0, r1 + i1];
    let mut x = [NO_VALUE; 8];
    for (q, k) in ks.iter().enumerate() {
        x[q] = g.mean_dbm_x10.get(*k).copied().unwrap_or(NO_VALUE);
        x[4 + q] = g.sd_dbm_x10.get(*k).copied().unwrap_or(NO_VALUE);
    }
    (!x.contains(&NO_VALUE)).then(|| tenths_8(x))
}

/// [`corner_tenths`] of every cell in the bounding box of the points'
/// cells, computed once per call of [`GridSampler::sample_many`] when the
/// box holds at most a quarter as many cells as there are points on the
/// grid (a particle cloud spans a few cells: each cell's eight corners
/// are read and converted once instead of once per particle). The same
/// values as [`corner_tenths`] per point (unit test).
struct CornerTable {
    i_lo: usize,
    j_lo: usize,
    w: usize,
    /// Row-major over the box; `None` where a corner has no value.
    c: Vec<Option<[f64; 8]>>,
}

impl CornerTable {
    fn of(g: &Grid, at: &[CellAt], force: Option<bool>) -> Option<Self> {
        if force == Some(false) {
            return None;
        }
        let (mut i_lo, mut i_hi, mut j_lo, mut j_hi) = (i64::MAX, i64::MIN, i64::MAX, i64::MIN);
        let mut inside = 0usize;
        for a in at.iter().filter(|a| a.inside) {
            i_lo = i_lo.min(a.i0);
            i_hi = i_hi.max(a.i0);
            j_lo = j_lo.min(a.j0);
            j_hi = j_hi.max(a.j0);
            inside += 1;
        }
        if inside == 0 {
            return None;
        }
        // inside points have 0 <= i0 < nx, 0 <= j0 < ny
        let (i_lo, j_lo) = (i_lo as usize, j_lo as usize);
        let (w, h) = (i_hi as usize - i_lo + 1, j_hi as usize - j_lo + 1);
        let cells = w.saturating_mul(h);
        if force.is_none() && cells.saturating_mul(4) > inside {
            return None;
        }
        let mut c = Vec::with_capacity(cells);
        for j in j_lo..j_lo + h {
            for i in i_lo..i_lo + w {
                c.push(corner_tenths(g, i, j));
            }
        }
        Some(CornerTable { i_lo, j_lo, w, c })
    }

    /// The corners of cell (`i0`, `j0`), one of the box's.
    #[inline(always)]
    fn get(&self, i0: usize, j0: usize) -> Option<[f64; 8]> {
        self.c
            .get((j0 - self.j_lo) * self.w + (i0 - self.i_lo))
            .copied()
            .flatten()
    }
}

/// [`tenths`] of eight values: from [`TENTHS`] without a branch per value
/// when all are in it, else one by one.
#[inline(always)]
fn tenths_8(x: [i16; 8]) -> [f64; 8] {
    let idx = x.map(|v| (i32::from(v) - TENTHS_LO) as u32);
    if idx.iter().all(|i| (*i as usize) < TENTHS.len()) {
        idx.map(|i| TENTHS[i as usize % TENTHS.len()])
    } else {
        x.map(tenths)
    }
}

/// Where a point falls on a grid ([`GridSampler::locate`]): its cell
/// coordinates (u, v), the blend weights, the lower corner, whether it
/// is on the grid.
#[derive(Debug, Clone, Copy)]
struct CellAt {
    u: f64,
    v: f64,
    tx: f64,
    ty: f64,
    i0: i64,
    j0: i64,
    inside: bool,
}

impl Grid {
    fn at(&self, i: usize, j: usize) -> Option<(f64, f64)> {
        let k = j.checked_mul(self.nx)?.checked_add(i)?;
        let m = *self.mean_dbm_x10.get(k)?;
        let s = *self.sd_dbm_x10.get(k)?;
        (m != NO_VALUE && s != NO_VALUE).then(|| (f64::from(m) / 10.0, f64::from(s) / 10.0))
    }

    /// (mean, sd) at `p`: bilinear between the four cell centres around
    /// it, the nearest cell's value where one of them has none, `None`
    /// outside the grid or where the nearest cell has no value.
    pub fn sample(&self, p: Vec2) -> Option<(f64, f64)> {
        let u = (p.x - self.x0_m) / self.cell_m;
        let v = (p.y - self.y0_m) / self.cell_m;
        if !(u >= 0.0 && v >= 0.0 && u < self.nx as f64 && v < self.ny as f64) {
            return None;
        }
        let (fu, fv) = (u - 0.5, v - 0.5);
        // fu, fv >= -0.5: the saturating cast is floor clamped at 0 (and
        // needs no libm call)
        let (i0, j0) = (fu as usize, fv as usize);
        let (i1, j1) = ((i0 + 1).min(self.nx - 1), (j0 + 1).min(self.ny - 1));
        let (tx, ty) = (
            (fu - i0 as f64).clamp(0.0, 1.0),
            (fv - j0 as f64).clamp(0.0, 1.0),
        );
        // the four corners' raw values (a missing index counts as no value)
        let (r0, r1) = (j0.saturating_mul(self.nx), j1.saturating_mul(self.nx));
        let raw = |k: usize| {
            (
                self.mean_dbm_x10.get(k).copied().unwrap_or(NO_VALUE),
                self.sd_dbm_x10.get(k).copied().unwrap_or(NO_VALUE),
            )
        };
        let c = [
            raw(r0.saturating_add(i0)),
            raw(r0.saturating_add(i1)),
            raw(r1.saturating_add(i0)),
            raw(r1.saturating_add(i1)),
        ];
        if c.iter().any(|(m, s)| *m == NO_VALUE || *s == NO_VALUE) {
            // the nearest cell is one of the four corners
            return self.at(u as usize, v as usize);
        }
        let f = |x: i16| f64::from(x) / 10.0;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let mean = lerp(
            lerp(f(c[0].0), f(c[1].0), tx),
            lerp(f(c[2].0), f(c[3].0), tx),
            ty,
        );
        let sd = lerp(
            lerp(f(c[0].1), f(c[1].1), tx),
            lerp(f(c[2].1), f(c[3].1), tx),
            ty,
        );
        Some((mean, sd))
    }
}

/// What the map knows of one transmitter besides its [`Transmitter`] entry.
#[derive(Debug, Clone, PartialEq)]
pub struct MapEntry {
    /// Whether the site had a path-loss model for it (else the prior).
    pub has_pathloss: bool,
    /// Readings and walks it was learned from (0 for site-only entries).
    pub samples: usize,
    pub walks: usize,
    /// Its grids, at most one per floor.
    pub grids: Vec<Grid>,
}

/// The learned radio map of a site.
#[derive(Debug, Clone)]
pub struct RadioMap {
    pub(crate) site_name: String,
    pub(crate) tx: Vec<Transmitter>,
    pub(crate) entries: Vec<MapEntry>,
    pub(crate) by_id: super::model::IdIndex,
    pub(crate) floor_rank: BTreeMap<i32, i32>,
    pub(crate) fallback: FallbackParams,
    /// The survey's scan vectors, when the map was built with them.
    pub(crate) scans: Option<super::reference_scans::ReferenceScans>,
    /// The survey's magnetic field, when the map was built with it.
    pub(crate) magnetic: Option<super::magnetic_map::MagneticMap>,
    /// The survey's phone models' offsets per radio.
    pub(crate) devices: super::device_offsets::DeviceOffsets,
    /// Values the engines derive from the map (emptied by every setter).
    pub(crate) derived: super::derived::DerivedCache,
}

impl RadioMap {
    /// Attaches the survey's reference scans (carried in the map's file).
    pub fn set_reference_scans(&mut self, scans: super::reference_scans::ReferenceScans) {
        self.scans = Some(scans);
        self.derived = Default::default();
    }

    /// Attaches the survey's phone models' offsets (carried in the map's
    /// file).
    pub fn set_device_offsets(&mut self, devices: super::device_offsets::DeviceOffsets) {
        self.devices = devices;
        self.derived = Default::default();
    }

    /// The survey's phone models' offsets per radio.
    pub fn device_offsets(&self) -> &super::device_offsets::DeviceOffsets {
        &self.devices
    }

    /// Attaches the survey's magnetic map (carried in the map's file).
    pub fn set_magnetic(&mut self, magnetic: Option<super::magnetic_map::MagneticMap>) {
        self.magnetic = magnetic;
        self.derived = Default::default();
    }

    /// A map of `tx` / `entries` (same order) on `site`'s floors; ids must
    /// be unique per kind.
    pub(crate) fn assemble(
        site: &Site,
        tx: Vec<Transmitter>,
        entries: Vec<MapEntry>,
        fallback: FallbackParams,
    ) -> Result<Self> {
        let mut by_id = super::model::IdIndex::default();
        for (i, t) in tx.iter().enumerate() {
            if !by_id.insert(t.kind, t.id.clone(), i) {
                return Err(Error::Input(format!(
                    "radio map: transmitter `{}` appears twice",
                    crate::bounds::echo(&t.id)
                )));
            }
        }
        Ok(RadioMap {
            site_name: site.spec.name.clone(),
            tx,
            entries,
            by_id,
            floor_rank: site
                .spec
                .floors
                .iter()
                .enumerate()
                .map(|(i, f)| (f.id, i as i32))
                .collect(),
            fallback,
            scans: None,
            magnetic: None,
            devices: Default::default(),
            derived: Default::default(),
        })
    }

    /// Per-transmitter entries, indexed like [`RadioModel::transmitters`].
    pub fn entries(&self) -> &[MapEntry] {
        &self.entries
    }

    /// The fallback settings.
    pub fn fallback(&self) -> &FallbackParams {
        &self.fallback
    }

    /// Name of the site the map was built on.
    pub fn site_name(&self) -> &str {
        &self.site_name
    }

    fn floors_apart(&self, a: i32, b: i32) -> i32 {
        match (self.floor_rank.get(&a), self.floor_rank.get(&b)) {
            (Some(x), Some(y)) => (x - y).abs(),
            _ => i32::from(a != b),
        }
    }

    /// The fallback (mean, sd) of transmitter `tx` at `p` on `floor`.
    pub fn fallback_expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        let t = self.tx.get(tx)?;
        let e = self.entries.get(tx)?;
        let apart = self.floors_apart(floor, t.floor);
        Some(fallback_at(t, e.has_pathloss, &self.fallback, apart, p))
    }
}

/// The fallback (mean, sd) of `t` at `p`, `apart` floors away: its
/// path-loss model (when `has_pathloss`) with the fallback spreads, or the
/// prior; the per-floor loss and spread on other floors.
pub(super) fn fallback_at(
    t: &Transmitter,
    has_pathloss: bool,
    fb: &FallbackParams,
    apart: i32,
    p: Vec2,
) -> (f64, f64) {
    let here = if has_pathloss {
        let sd = match t.kind {
            TxKind::Ble => fb.ble_sd_db,
            TxKind::Wifi => fb.wifi_sd_db,
        };
        (super::model::pathloss_mean(t, p, fb.min_range_m), sd)
    } else {
        (fb.prior_dbm, fb.prior_sd_db)
    };
    super::model::across_floors(here, apart, fb.floor_loss_db, fb.other_floor_sd_db)
}

/// [`fallback_at`] of one transmitter with its per-point work reduced to
/// a squared range and [`ln_normal`] (as [`super::model::pathloss_many`]):
/// within 1e-8 dB of it.
struct FastFallback {
    /// The prior (or, with a path-loss model, the spread) after floors.
    here: (f64, f64),
    pathloss: bool,
    /// R0 less the floors' loss, 5 n / ln 10, dz^2, the floored range^2.
    r0: f64,
    k: f64,
    dz2: f64,
    lo2: f64,
    pos: Vec2,
}

impl FastFallback {
    fn new(t: &Transmitter, has_pathloss: bool, fb: &FallbackParams, apart: i32) -> Self {
        let sd = match t.kind {
            TxKind::Ble => fb.ble_sd_db,
            TxKind::Wifi => fb.wifi_sd_db,
        };
        let base = if has_pathloss {
            (0.0, sd)
        } else {
            (fb.prior_dbm, fb.prior_sd_db)
        };
        let here = super::model::across_floors(base, apart, fb.floor_loss_db, fb.other_floor_sd_db);
        let loss = if apart > 0 {
            fb.floor_loss_db * f64::from(apart)
        } else {
            0.0
        };
        FastFallback {
            here,
            pathloss: has_pathloss,
            r0: t.model.rssi_1m_dbm - loss,
            k: 5.0 * t.model.exponent / std::f64::consts::LN_10,
            dz2: t.dz_m * t.dz_m,
            lo2: (fb.min_range_m * fb.min_range_m).max(f64::MIN_POSITIVE),
            pos: t.pos,
        }
    }

    /// [`FastFallback::at`] of `ps[i]` into `mean[i]`, `sd[i]` for every
    /// i of `which`: the path-loss curve over the gathered points in one
    /// loop (`model::pathloss_loop`, the same arithmetic: vectorises).
    fn at_some(&self, ps: &[Vec2], which: &[usize], mean: &mut [f64], sd: &mut [f64]) {
        if !self.pathloss {
            for &i in which {
                (mean[i], sd[i]) = self.here;
            }
            return;
        }
        let pts: Vec<Vec2> = which.iter().map(|&i| ps[i]).collect();
        let mut m = vec![0.0; pts.len()];
        super::model::pathloss_loop(&pts, self.pos, self.dz2, self.lo2, self.r0, self.k, &mut m);
        for (&i, v) in which.iter().zip(&m) {
            (mean[i], sd[i]) = (*v, self.here.1);
        }
    }

    #[inline]
    fn at(&self, p: Vec2) -> (f64, f64) {
        if !self.pathloss {
            return self.here;
        }
        let (dx, dy) = (p.x - self.pos.x, p.y - self.pos.y);
        let d2 = (dx * dx + dy * dy + self.dz2).max(self.lo2).min(f64::MAX);
        (self.r0 - self.k * ln_normal(d2), self.here.1)
    }
}

impl RadioModel for RadioMap {
    fn learned_per_floor(&self) -> bool {
        true
    }

    fn magnetic(&self) -> Option<&super::magnetic_map::MagneticMap> {
        self.magnetic.as_ref()
    }

    fn reference_scans(&self) -> Option<&super::reference_scans::ReferenceScans> {
        self.scans.as_ref().filter(|s| !s.is_empty())
    }

    fn derived(&self) -> Option<&super::derived::DerivedCache> {
        Some(&self.derived)
    }

    fn device_offset_db(&self, device: &str, kind: TxKind) -> Option<f64> {
        super::device_offsets::lookup(&self.devices, device).and_then(|d| d.of(kind))
    }

    fn transmitters(&self) -> &[Transmitter] {
        &self.tx
    }

    fn lookup(&self, kind: TxKind, id: &str) -> Option<usize> {
        super::model::lookup_in(&self.by_id, kind, id)
    }

    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        let e = self.entries.get(tx)?;
        if let Some(v) = e
            .grids
            .iter()
            .find(|g| g.floor == floor)
            .and_then(|g| g.sample(p))
        {
            return Some(v);
        }
        self.fallback_expected(tx, floor, p)
    }

    fn expected_many(
        &self,
        tx: usize,
        floor: i32,
        ps: &[Vec2],
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> bool {
        let (Some(t), Some(e)) = (self.tx.get(tx), self.entries.get(tx)) else {
            return false;
        };
        let grid = e.grids.iter().find(|g| g.floor == floor);
        let apart = self.floors_apart(floor, t.floor);
        let fb = &self.fallback;
        let fast = FastFallback::new(t, e.has_pathloss, fb, apart);
        match grid {
            Some(g) => GridSampler::new(g).sample_many(ps, &fast, mean, sd),
            None => {
                for ((p, m), s) in ps.iter().zip(mean.iter_mut()).zip(sd.iter_mut()) {
                    (*m, *s) = fast.at(*p);
                }
            }
        }
        true
    }
}

#[cfg(test)]
#[path = "radio_map_tests.rs"]
mod tests;
