//! Is a radio map's spread honest? Held-out walks with truth are read
//! against the map ([`check_calibration`]): every placed reading (the
//! walker's position interpolated in the truth, [`survey_samples`]) gives a
//! standardised residual z = (heard - mean) / sd from
//! [`RadioModel::expected`] at that position, binned by the distance from
//! the nearest survey sample ([`SurveyFootprint`]). A calibrated map has an
//! RMS z near 1 in every bin, near the survey and far from it.
//!
//! Two views: `raw` (the residual as heard) and `offset_removed` (each
//! held-out walk's median residual per radio kind taken out first, as the
//! engines' online phone offset does: [`super::offset`]).
//!
//! Pure: logs in as events, the figures out as a struct.

use std::collections::BTreeMap;

use serde::Serialize;

use super::model::{RadioModel, TxKind};
use super::survey::{SurveyOptions, survey_samples};
use crate::Vec2;
use crate::events::LogEvent;

/// Side of the cells survey positions are kept in (one per cell), m.
const FOOTPRINT_CELL_M: f64 = 0.5;
/// Side of the buckets the nearest-position search walks, m.
const BUCKET_M: f64 = 4.0;
/// Farthest the nearest-position search looks, m (farther: this).
const SEARCH_MAX_M: f64 = 200.0;

/// Where a survey walked: its readings' positions per floor (one per
/// 0.5 m cell), for the distance of a point from the survey.
#[derive(Debug, Clone, Default)]
pub struct SurveyFootprint {
    /// floor -> bucket -> positions
    buckets: BTreeMap<i32, BTreeMap<(i64, i64), Vec<Vec2>>>,
    cells: BTreeMap<i32, std::collections::BTreeSet<(i64, i64)>>,
}

impl SurveyFootprint {
    /// The footprint of survey `logs` (placed as `opts` places them).
    pub fn of_logs(logs: &[&[LogEvent]], opts: &SurveyOptions) -> Self {
        let mut f = SurveyFootprint::default();
        for l in logs {
            survey_samples(l, opts, |s| f.add(s.floor, s.pos));
        }
        f
    }

    /// Adds one surveyed position.
    pub fn add(&mut self, floor: i32, p: Vec2) {
        let cell = (
            (p.x / FOOTPRINT_CELL_M).floor() as i64,
            (p.y / FOOTPRINT_CELL_M).floor() as i64,
        );
        if self.cells.entry(floor).or_default().insert(cell) {
            self.buckets
                .entry(floor)
                .or_default()
                .entry(bucket(p))
                .or_default()
                .push(p);
        }
    }

    /// Positions kept.
    pub fn len(&self) -> usize {
        self.cells.values().map(|c| c.len()).sum()
    }

    /// Whether nothing was surveyed.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Distance from `p` on `floor` to the nearest surveyed position, m
    /// (at most 200 m; `None` when the floor was never surveyed).
    pub fn distance(&self, floor: i32, p: Vec2) -> Option<f64> {
        let b = self.buckets.get(&floor)?;
        let (bx, by) = bucket(p);
        let mut best = f64::INFINITY;
        let rings = (SEARCH_MAX_M / BUCKET_M).ceil() as i64;
        for r in 0..=rings {
            // every point of ring r is at least (r - 1) buckets away
            if best.is_finite() && ((r - 1) as f64) * BUCKET_M > best {
                break;
            }
            for dx in -r..=r {
                for dy in -r..=r {
                    if dx.abs() != r && dy.abs() != r {
                        continue;
                    }
                    for q in b.get(&(bx + dx, by + dy)).into_iter().flatten() {
                        best = best.min((q - p).norm());
                    }
                }
            }
        }
        Some(best.min(SEARCH_MAX_M))
    }
}

fn bucket(p: Vec2) -> (i64, i64) {
    (
        (p.x / BUCKET_M).floor() as i64,
        (p.y / BUCKET_M).floor() as i64,
    )
}

/// Standardised residuals of one distance bin.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ZBin {
    /// Distance from the survey, [lo, hi) m.
    pub lo_m: f64,
    pub hi_m: f64,
    /// Readings.
    pub n: usize,
    /// Mean, RMS and sd of z.
    pub mean_z: f64,
    pub rms_z: f64,
    pub sd_z: f64,
    /// RMS of the residual in dB and the mean model spread, dB.
    pub rms_db: f64,
    pub mean_sd_db: f64,
}

/// [`ZBin`]s of every distance bin, over all readings and per radio kind.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ZTable {
    pub all: Vec<ZBin>,
    pub ble: Vec<ZBin>,
    pub wifi: Vec<ZBin>,
}

/// What [`check_calibration`] found.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// Residuals as heard.
    pub raw: ZTable,
    /// Each held-out walk's median residual per kind removed.
    pub offset_removed: ZTable,
    /// Readings placed, of transmitters the map lacks, off every
    /// surveyed floor.
    pub placed: usize,
    pub unknown_tx: usize,
    pub unsurveyed_floor: usize,
}

/// One reading read against the map.
struct Residual {
    walk: usize,
    kind: TxKind,
    d_m: f64,
    r_db: f64,
    sd_db: f64,
}

/// Distance bins of the report: [0, 2), [2, 5), [5, 10), [10, inf) m.
pub const DEFAULT_EDGES_M: [f64; 3] = [2.0, 5.0, 10.0];

/// Reads every held-out log against `map` (see the module docs);
/// `edges_m` (ascending) cut the distances from `footprint` into bins
/// ([0, e0), [e0, e1), ..., [e_last, inf)).
pub fn check_calibration(
    map: &dyn RadioModel,
    footprint: &SurveyFootprint,
    held_out: &[&[LogEvent]],
    opts: &SurveyOptions,
    edges_m: &[f64],
) -> CalibrationReport {
    let mut rep = CalibrationReport::default();
    let mut res = Vec::new();
    for (walk, l) in held_out.iter().enumerate() {
        survey_samples(l, opts, |s| {
            rep.placed += 1;
            let Some(tx) = map.lookup(s.kind, &s.id) else {
                rep.unknown_tx += 1;
                return;
            };
            let Some(d_m) = footprint.distance(s.floor, s.pos) else {
                rep.unsurveyed_floor += 1;
                return;
            };
            let Some((mean, sd)) = map.expected(tx, s.floor, s.pos) else {
                rep.unknown_tx += 1;
                return;
            };
            if sd > 0.0 && mean.is_finite() {
                res.push(Residual {
                    walk,
                    kind: s.kind,
                    d_m,
                    r_db: s.rssi_dbm - mean,
                    sd_db: sd,
                });
            }
        });
    }
    rep.raw = table(&res, edges_m);
    // each walk's median residual per kind
    let mut by: BTreeMap<(usize, u8), Vec<f64>> = BTreeMap::new();
    for r in &res {
        by.entry((r.walk, kind_key(r.kind)))
            .or_default()
            .push(r.r_db);
    }
    let med: BTreeMap<(usize, u8), f64> = by
        .into_iter()
        .map(|(k, mut v)| {
            v.sort_by(f64::total_cmp);
            (k, v[v.len() / 2])
        })
        .collect();
    for r in &mut res {
        r.r_db -= med.get(&(r.walk, kind_key(r.kind))).copied().unwrap_or(0.0);
    }
    rep.offset_removed = table(&res, edges_m);
    rep
}

fn kind_key(k: TxKind) -> u8 {
    match k {
        TxKind::Ble => 0,
        TxKind::Wifi => 1,
    }
}

fn table(res: &[Residual], edges_m: &[f64]) -> ZTable {
    let of = |k: Option<TxKind>| {
        let rs: Vec<&Residual> = res
            .iter()
            .filter(|r| k.is_none_or(|k| r.kind == k))
            .collect();
        bins(&rs, edges_m)
    };
    ZTable {
        all: of(None),
        ble: of(Some(TxKind::Ble)),
        wifi: of(Some(TxKind::Wifi)),
    }
}

fn bins(res: &[&Residual], edges_m: &[f64]) -> Vec<ZBin> {
    let mut lo = 0.0;
    let mut out = Vec::new();
    for k in 0..=edges_m.len() {
        let hi = edges_m.get(k).copied().unwrap_or(f64::INFINITY);
        let (mut n, mut sz, mut sz2, mut sr2, mut ssd) = (0usize, 0.0, 0.0, 0.0, 0.0);
        for r in res.iter().filter(|r| r.d_m >= lo && r.d_m < hi) {
            let z = r.r_db / r.sd_db;
            n += 1;
            sz += z;
            sz2 += z * z;
            sr2 += r.r_db * r.r_db;
            ssd += r.sd_db;
        }
        let nf = n.max(1) as f64;
        let mean_z = sz / nf;
        out.push(ZBin {
            lo_m: lo,
            hi_m: hi,
            n,
            mean_z,
            rms_z: (sz2 / nf).sqrt(),
            sd_z: (sz2 / nf - mean_z * mean_z).max(0.0).sqrt(),
            rms_db: (sr2 / nf).sqrt(),
            mean_sd_db: ssd / nf,
        });
        lo = hi;
    }
    out
}

/// The table as text lines: `kind bin n rms_z sd_z mean_z rms_db sd_db`.
pub fn format_table(name: &str, t: &ZTable) -> String {
    let mut s = String::new();
    for (kind, bins) in [("all", &t.all), ("ble", &t.ble), ("wifi", &t.wifi)] {
        for b in bins.iter().filter(|b| b.n > 0) {
            s.push_str(&format!(
                "{name} {kind:4} [{:>4.0},{:>4.0}) m  n {:>7}  rms_z {:.2}  sd_z {:.2}  \
                 mean_z {:+.2}  rms {:.1} dB  model sd {:.1} dB\n",
                b.lo_m, b.hi_m, b.n, b.rms_z, b.sd_z, b.mean_z, b.rms_db, b.mean_sd_db
            ));
        }
    }
    s
}
