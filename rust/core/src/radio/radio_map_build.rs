//! Building a [`RadioMap`] from survey walks ([`RadioMapBuilder`]): the
//! readings of each walked log with truth ([`super::survey`]) are binned per transmitter and floor in `bin_m`
//! squares (count, sum, sum of squares, mean position, per-walk sums).
//! Transmitters heard in fewer than `min_samples` readings or on fewer than
//! `min_walks` walks are left out, and so are moving ones: where two walks
//! passed the same bin their means (after each walk's own median offset)
//! must agree within `moving_max_db` RMS. Each kept (transmitter, floor)
//! gets a grid of `cell_m` cells over the box of its bins grown by
//! `max_distance_m` (coarsened until at most `max_cells_per_grid`). A cell
//! holds, with Gaussian kernel weights (bandwidth `bandwidth_m`) over the
//! bins within 3 bandwidths of its centre:
//!
//! - mean = (sum w r + w0 mu_fb) / (sum w + w0): the kernel mean pulled
//!   towards the fallback mean `mu_fb` with `prior_weight` pseudo-samples
//!   (so cells with few samples near them lean on the fallback);
//! - sd = sqrt(lambda v + (1 - lambda) sd_fb^2 + (g d)^2), lambda = sum w /
//!   (sum w + w0), v the kernel-weighted local variance (at least
//!   `min_sd_db`^2), d the distance to the nearest bin and g
//!   `sd_growth_db_per_m`, clamped to [`min_sd_db`, `max_sd_db`];
//! - nothing (the fallback) beyond `max_distance_m` from every bin.
//!
//! With `wall_prior.enabled` ([`super::wall_prior`]) the fallback mean of
//! a transmitter the site places is the multi-wall prior fitted on the
//! survey: the bins are smoothed as residuals from it (`mu_fb` = 0 above,
//! the prior added back), and the cells beyond `max_distance_m` hold the
//! prior with the fallback's spread.
//!
//! Pure: logs in as events, the map out as a struct.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::magnetic_map::MagneticMapBuilder;
use super::model::{PathLossModel, PathLossParams, RadioModel, Transmitter, TxKind};
use super::radio_map::{FallbackParams, Grid, MapEntry, NO_VALUE, RadioMap, fallback_at};
pub use super::radio_map_config::RadioMapConfig;
use super::radio_map_spread::{SpreadCurve, SpreadFit, WalkFootprint};
use super::reference_scans::{ReferenceScanBuilder, ReferenceScanConfig};
use super::survey::{RadioSample, SurveyCounts, survey_samples};
use super::wall_prior::{PriorBin, WallFit, WallLoss, WallPriorConfig};
use crate::Vec2;
use crate::ble::pathloss::{PathLoss, range_m};
use crate::bounds::{MAX_RADIO_MAP_CELLS, MAX_RADIO_MAP_TRANSMITTERS};
use crate::events::LogEvent;
use crate::map::FloorMap;
use crate::site::Site;
use crate::{Error, Result};

/// Readings of one transmitter in one bin.
#[derive(Debug, Clone, Default)]
pub(super) struct Bin {
    pub(super) n: f64,
    sum: f64,
    sum2: f64,
    pub(super) pos_sum: Vec2,
    /// walk -> (count, sum, sum of squares)
    pub(super) walks: BTreeMap<usize, (f64, f64, f64)>,
}

/// Everything learned of one transmitter.
#[derive(Debug, Clone, Default)]
pub(super) struct TxAcc {
    pub(super) samples: usize,
    pub(super) walks: BTreeSet<usize>,
    /// floor -> bin index -> bin
    pub(super) bins: BTreeMap<i32, BTreeMap<(i64, i64), Bin>>,
}

/// Why a surveyed transmitter is not in the map (or how it entered it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TxReport {
    pub id: String,
    pub kind: String,
    pub samples: usize,
    pub walks: usize,
    /// RMS disagreement of walks in shared bins, dB, when tested.
    pub disagreement_db: Option<f64>,
    /// Grid floors built.
    pub floors: Vec<i32>,
    /// `None` when kept, else why it was left out.
    pub rejected: Option<String>,
}

/// Counters of a build.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BuildSummary {
    pub logs: usize,
    pub readings: usize,
    pub placed: usize,
    pub without_truth: usize,
    pub invalid: usize,
    /// Readings dropped: too many transmitters or off the floor's plan.
    pub dropped: usize,
    /// Transmitters surveyed, kept with grids, and site-only (fallback only).
    pub surveyed: usize,
    pub kept: usize,
    pub site_only: usize,
    pub cells: usize,
    /// Magnetometer samples seen and placed, and the magnetic grids'
    /// cells with a value.
    pub magnetic_samples: usize,
    pub magnetic_placed: usize,
    pub magnetic_cells: usize,
    /// With reference scans: windows left out (too few transmitters, a
    /// floor change, the size bounds).
    pub reference_scans_skipped: usize,
    /// With `walk_offsets`: each walk's offset per kind, dB, by walk (logs
    /// in the order added, from 0; walks without one are absent).
    pub ble_walk_offsets_db: BTreeMap<usize, f64>,
    pub wifi_walk_offsets_db: BTreeMap<usize, f64>,
    /// With `spread_calibration`: what leaving one walk out found per kind.
    pub ble_spread: Option<SpreadFit>,
    pub wifi_spread: Option<SpreadFit>,
    /// With `wall_prior.enabled`: the wall prior's fit per kind.
    pub ble_wall_prior: Option<WallFit>,
    pub wifi_wall_prior: Option<WallFit>,
    /// With reference scans: the walk (log added, counted from 0) of each
    /// scan, for
    /// [`super::reference_scans::ReferenceScans::left_out_distances`].
    #[serde(skip)]
    pub reference_scan_walks: Vec<usize>,
}

impl BuildSummary {
    /// The offsets of one radio kind.
    pub fn walk_offsets_db(&self, kind: TxKind) -> &BTreeMap<usize, f64> {
        match kind {
            TxKind::Ble => &self.ble_walk_offsets_db,
            TxKind::Wifi => &self.wifi_walk_offsets_db,
        }
    }

    /// The offset removed from `walk`'s readings of `kind`, dB (0: none).
    pub fn walk_offset_db(&self, walk: usize, kind: TxKind) -> f64 {
        self.walk_offsets_db(kind)
            .get(&walk)
            .copied()
            .unwrap_or(0.0)
    }

    /// (walk, kind) pairs given an offset.
    pub fn walks_with_offset(&self) -> usize {
        self.ble_walk_offsets_db.len() + self.wifi_walk_offsets_db.len()
    }
}

/// Builds a [`RadioMap`] log by log.
pub struct RadioMapBuilder<'a> {
    site: &'a Site,
    cfg: RadioMapConfig,
    site_model: PathLossModel,
    ids: BTreeMap<(TxKind, String), usize>,
    acc: Vec<TxAcc>,
    summary: BuildSummary,
    magnetic: Option<MagneticMapBuilder>,
    scans: Option<ReferenceScanBuilder>,
    /// The phone model of each walk added (`None`: not known).
    devices: Vec<Option<String>>,
}

impl<'a> RadioMapBuilder<'a> {
    /// A builder on `site` (its beacons and access points are the fallback).
    pub fn new(site: &'a Site, cfg: &RadioMapConfig) -> Result<Self> {
        cfg.validate()?;
        let fb = &cfg.fallback;
        let site_model = PathLossModel::for_site(
            site,
            PathLossParams {
                ble_sd_db: fb.ble_sd_db,
                wifi_sd_db: fb.wifi_sd_db,
                floor_loss_db: fb.floor_loss_db,
                other_floor_sd_db: fb.other_floor_sd_db,
                min_range_m: fb.min_range_m,
                phone_height_m: cfg.phone_height_m,
            },
        );
        Ok(RadioMapBuilder {
            site,
            cfg: cfg.clone(),
            site_model,
            ids: BTreeMap::new(),
            acc: Vec::new(),
            summary: BuildSummary::default(),
            magnetic: if cfg.magnetic.enabled {
                Some(MagneticMapBuilder::new(&cfg.magnetic)?)
            } else {
                None
            },
            scans: None,
            devices: Vec::new(),
        })
    }

    /// Also cut the walks into reference scans (`scans`' settings), carried
    /// by the finished map, with the walks' offsets removed as from the
    /// grids when `walk_offsets` and `walk_offsets_in_scans` are set.
    pub fn with_reference_scans(mut self, scans: &ReferenceScanConfig) -> Result<Self> {
        let single = (self.site.spec.floors.len() == 1).then(|| self.site.default_floor());
        self.scans = Some(ReferenceScanBuilder::new(scans, single)?);
        Ok(self)
    }

    /// Adds one walked log (time-ordered events with truth points),
    /// recorded by phone model `device` when known: the models' offsets
    /// per radio come from their walks' ([`super::device_offsets`]).
    pub fn add_log_of(&mut self, events: &[LogEvent], device: Option<&str>) -> SurveyCounts {
        self.devices.push(device.map(str::to_string));
        let walk = self.summary.logs;
        self.summary.logs += 1;
        let single = (self.site.spec.floors.len() == 1).then(|| self.site.default_floor());
        let opts = self.cfg.survey_options(single);
        if let Some(m) = self.magnetic.as_mut() {
            let (seen, placed) = m.add_log(events, &opts);
            self.summary.magnetic_samples += seen;
            self.summary.magnetic_placed += placed;
        }
        if let Some(s) = self.scans.as_mut() {
            s.add_log(events);
        }
        let mut dropped = 0usize;
        let counts = survey_samples(events, &opts, |s| {
            if !self.add_sample(walk, s) {
                dropped += 1;
            }
        });
        let sm = &mut self.summary;
        sm.readings += counts.readings;
        sm.placed += counts.placed;
        sm.without_truth += counts.without_truth;
        sm.invalid += counts.invalid;
        sm.dropped += dropped;
        counts
    }

    /// Adds one walked log (time-ordered events with truth points) whose
    /// phone model is not known.
    pub fn add_log(&mut self, events: &[LogEvent]) -> SurveyCounts {
        self.add_log_of(events, None)
    }

    fn add_sample(&mut self, walk: usize, s: RadioSample) -> bool {
        // on the floor's plan (with a margin): bounds the bins and grids
        let Some(map) = self.site.floor(s.floor) else {
            return false;
        };
        let m = self.cfg.max_distance_m;
        if !(s.pos.x >= -m
            && s.pos.y >= -m
            && s.pos.x <= map.width_m() + m
            && s.pos.y <= map.height_m() + m)
        {
            return false;
        }
        let next = self.acc.len();
        let key = (s.kind, s.id);
        let i = match self.ids.get(&key) {
            Some(i) => *i,
            None if next < MAX_RADIO_MAP_TRANSMITTERS => {
                self.ids.insert(key, next);
                self.acc.push(TxAcc::default());
                next
            }
            None => return false,
        };
        let a = &mut self.acc[i];
        a.samples += 1;
        a.walks.insert(walk);
        let b = self.cfg.bin_m;
        let k = ((s.pos.x / b).floor() as i64, (s.pos.y / b).floor() as i64);
        let bin = a.bins.entry(s.floor).or_default().entry(k).or_default();
        bin.n += 1.0;
        bin.sum += s.rssi_dbm;
        bin.sum2 += s.rssi_dbm * s.rssi_dbm;
        bin.pos_sum += s.pos;
        let w = bin.walks.entry(walk).or_insert((0.0, 0.0, 0.0));
        w.0 += 1.0;
        w.1 += s.rssi_dbm;
        w.2 += s.rssi_dbm * s.rssi_dbm;
        true
    }

    /// The map: every kept surveyed transmitter with its grids, then every
    /// site transmitter not kept (path-loss fallback only); a report per
    /// surveyed transmitter (sorted by kind and id) and the counters.
    pub fn finish(self) -> Result<(RadioMap, Vec<TxReport>, BuildSummary)> {
        let RadioMapBuilder {
            site,
            cfg,
            site_model,
            ids,
            mut acc,
            mut summary,
            magnetic,
            scans,
            devices,
        } = self;
        summary.surveyed = ids.len();
        if cfg.walk_offsets {
            for kind in [TxKind::Ble, TxKind::Wifi] {
                let of_kind: Vec<usize> = ids
                    .iter()
                    .filter(|((k, _), _)| *k == kind)
                    .map(|(_, i)| *i)
                    .collect();
                let off = remove_walk_offsets(
                    &mut acc,
                    &of_kind,
                    cfg.walk_offset_min_bins,
                    cfg.walk_offsets_converged,
                );
                match kind {
                    TxKind::Ble => summary.ble_walk_offsets_db = off,
                    TxKind::Wifi => summary.wifi_walk_offsets_db = off,
                }
            }
        }
        let mut fallback = cfg.fallback;
        let mut curves = [None, None];
        let footprint = cfg
            .spread_calibration
            .then(|| WalkFootprint::of(&acc, cfg.bin_m, cfg.max_distance_m));
        if cfg.spread_calibration {
            let fits = super::radio_map_spread::calibrate(&ids, &acc, &cfg, &site_model);
            for (k, (kind, fit)) in [TxKind::Ble, TxKind::Wifi]
                .into_iter()
                .zip(fits)
                .enumerate()
            {
                curves[k] = fit.curve;
                if let Some(sd) = fit.fallback_sd_db {
                    match kind {
                        TxKind::Ble => fallback.ble_sd_db = sd,
                        TxKind::Wifi => fallback.wifi_sd_db = sd,
                    }
                }
                match kind {
                    TxKind::Ble => summary.ble_spread = Some(fit),
                    TxKind::Wifi => summary.wifi_spread = Some(fit),
                }
            }
        }
        let priors = if cfg.wall_prior.enabled {
            fit_wall_priors(site, &ids, &acc, &site_model, &cfg, &mut summary)
        } else {
            BTreeMap::new()
        };
        let mut tx = Vec::new();
        let mut entries = Vec::new();
        let mut reports = Vec::new();
        let mut kept = BTreeSet::new();
        for ((kind, id), i) in &ids {
            let a = &acc[*i];
            let mut rep = TxReport {
                id: id.clone(),
                kind: kind_name(*kind).to_string(),
                samples: a.samples,
                walks: a.walks.len(),
                disagreement_db: None,
                floors: Vec::new(),
                rejected: None,
            };
            let in_site = site_model.lookup(*kind, id).is_some();
            if cfg.site_transmitters_only && !in_site {
                rep.rejected = Some("not in the site (site_transmitters_only)".into());
            } else if a.samples < cfg.min_samples {
                rep.rejected = Some(format!(
                    "{} readings < min_samples {}",
                    a.samples, cfg.min_samples
                ));
            } else if a.walks.len() < cfg.min_walks {
                rep.rejected = Some(format!(
                    "heard on {} walks < min_walks {}",
                    a.walks.len(),
                    cfg.min_walks
                ));
            } else {
                rep.disagreement_db = disagreement(a, cfg.moving_min_bins);
                if let Some(d) = rep.disagreement_db.filter(|d| *d > cfg.moving_max_db) {
                    rep.rejected = Some(format!(
                        "walks disagree at the same place (RMS {d:.1} dB > {}): moving or carried",
                        cfg.moving_max_db
                    ));
                }
            }
            if rep.rejected.is_none() {
                let (fb_t, site_t) = fallback_tx(*kind, id, a, &site_model, &cfg);
                let fb = Fallback {
                    t: &fb_t,
                    has_pathloss: site_t.is_some(),
                    params: &fallback,
                    floor_rank: &site_model,
                };
                let curve = match kind {
                    TxKind::Ble => curves[0],
                    TxKind::Wifi => curves[1],
                }
                .zip(footprint.as_ref());
                let prior = priors.get(i).and_then(|(model, loss)| {
                    Some(TxPrior {
                        t: &fb_t,
                        map: site.floor(fb_t.floor)?,
                        model: *model,
                        loss: *loss,
                        cfg: &cfg.wall_prior,
                        min_range_m: cfg.fallback.min_range_m,
                    })
                });
                let mut grids = Vec::new();
                for (floor, bins) in &a.bins {
                    let prior = prior.as_ref().filter(|p| p.t.floor == *floor);
                    if let Some(g) = build_grid(*floor, bins, &cfg, &fb, curve, prior)? {
                        summary.cells += g.nx * g.ny;
                        if summary.cells > MAX_RADIO_MAP_CELLS {
                            return Err(Error::Input(format!(
                                "radio map: more than {MAX_RADIO_MAP_CELLS} cells in all; \
                                 raise radio_map.cell_m or lower max_cells_per_grid"
                            )));
                        }
                        grids.push(g);
                    }
                }
                rep.floors = grids.iter().map(|g| g.floor).collect();
                if grids.is_empty() {
                    rep.rejected = Some("no grid cell near its readings".into());
                } else {
                    let mut t = fb_t;
                    if site_t.is_none() {
                        // where it is strongest: the engine's floor vote and
                        // missed-transmitter test use the position
                        if let Some(p) = peak(&grids, t.floor) {
                            t.pos = p;
                        }
                    }
                    kept.insert((*kind, id.clone()));
                    tx.push(t);
                    entries.push(MapEntry {
                        has_pathloss: site_t.is_some(),
                        samples: a.samples,
                        walks: a.walks.len(),
                        grids,
                    });
                }
            }
            reports.push(rep);
        }
        summary.kept = tx.len();
        for t in site_model.transmitters() {
            if !kept.contains(&(t.kind, t.id.clone())) {
                summary.site_only += 1;
                tx.push(t.clone());
                entries.push(MapEntry {
                    has_pathloss: true,
                    samples: 0,
                    walks: 0,
                    grids: Vec::new(),
                });
            }
        }
        let mut map = RadioMap::assemble(site, tx, entries, fallback)?;
        if let Some(m) = magnetic {
            let (mag, _) = m.finish()?;
            summary.magnetic_cells = mag.as_ref().map_or(0, |m| {
                m.grids()
                    .iter()
                    .map(super::magnetic_map::valued_cells)
                    .sum()
            });
            map.set_magnetic(mag);
        }
        if let Some(b) = scans {
            summary.reference_scans_skipped = b.skipped;
            summary.reference_scan_walks = b.walk_of().to_vec();
            let set = if cfg.walk_offsets && cfg.walk_offsets_in_scans {
                b.finish_with_walk_offsets(|walk, kind| summary.walk_offset_db(walk, kind))?
            } else {
                b.finish()?
            };
            map.set_reference_scans(set);
        }
        if cfg.walk_offsets {
            map.set_device_offsets(super::device_offsets::from_walks(
                &devices,
                &summary.ble_walk_offsets_db,
                &summary.wifi_walk_offsets_db,
            ));
        }
        Ok((map, reports, summary))
    }
}

/// `ble` / `wifi`.
pub fn kind_name(k: TxKind) -> &'static str {
    match k {
        TxKind::Ble => "ble",
        TxKind::Wifi => "wifi",
    }
}

/// The floor with the most readings.
fn busiest_floor(a: &TxAcc) -> i32 {
    a.bins
        .iter()
        .map(|(f, b)| (b.values().map(|x| x.n).sum::<f64>(), *f))
        .max_by(|x, y| x.0.total_cmp(&y.0).then(y.1.cmp(&x.1)))
        .map_or(0, |(_, f)| f)
}

/// The transmitter whose fallback a surveyed (`kind`, `id`) gets: the
/// site's (also returned, when the site has it), else a prior-only entry on
/// its busiest floor.
pub(super) fn fallback_tx(
    kind: TxKind,
    id: &str,
    a: &TxAcc,
    site_model: &PathLossModel,
    cfg: &RadioMapConfig,
) -> (Transmitter, Option<Transmitter>) {
    let site_t = site_model
        .lookup(kind, id)
        .and_then(|j| site_model.transmitters().get(j))
        .cloned();
    let fb_t = site_t.clone().unwrap_or_else(|| Transmitter {
        id: id.to_string(),
        kind,
        floor: busiest_floor(a),
        pos: Vec2::zeros(),
        dz_m: 0.0,
        model: PathLoss {
            rssi_1m_dbm: cfg.fallback.prior_dbm,
            exponent: 2.0,
        },
    });
    (fb_t, site_t)
}

/// Centre of the strongest cell of the grid on `floor`.
fn peak(grids: &[Grid], floor: i32) -> Option<Vec2> {
    let g = grids.iter().find(|g| g.floor == floor).or(grids.first())?;
    let (k, _) = g
        .mean_dbm_x10
        .iter()
        .enumerate()
        .filter(|(_, m)| **m != NO_VALUE)
        .max_by_key(|(k, m)| (**m, std::cmp::Reverse(*k)))?;
    let (i, j) = (k % g.nx, k / g.nx);
    Some(Vec2::new(
        g.x0_m + (i as f64 + 0.5) * g.cell_m,
        g.y0_m + (j as f64 + 0.5) * g.cell_m,
    ))
}

/// Learns the walks' offsets from the bins of the transmitters `txs`
/// ([`super::walk_offsets::estimate`]) and removes them from those bins'
/// sums; returns the offsets.
fn remove_walk_offsets(
    acc: &mut [TxAcc],
    txs: &[usize],
    min_bins: usize,
    converged: bool,
) -> BTreeMap<usize, f64> {
    use super::walk_offsets::{BinLevel, OTHER_WALKS_ROUNDS, ROUNDS, SharedBin, estimate};
    let shared: Vec<SharedBin> = txs
        .iter()
        .flat_map(|i| acc[*i].bins.values().flat_map(|f| f.values()))
        .filter(|b| b.walks.len() >= 2)
        .map(|b| SharedBin {
            walks: b
                .walks
                .iter()
                .map(|(w, (n, s, _))| (*w, *n, s / n))
                .collect(),
        })
        .collect();
    let off = if converged {
        estimate(&shared, min_bins, ROUNDS, BinLevel::AllWalks)
    } else {
        estimate(&shared, min_bins, OTHER_WALKS_ROUNDS, BinLevel::OtherWalks)
    };
    for i in txs {
        for b in acc[*i].bins.values_mut().flat_map(|f| f.values_mut()) {
            let (mut sum, mut sum2) = (0.0, 0.0);
            for (w, (n, s, s2)) in b.walks.iter_mut() {
                if let Some(o) = off.get(w) {
                    // sum (r - o)^2 = s2 - 2 o s + n o^2
                    *s2 += -2.0 * o * *s + *n * o * o;
                    *s -= *n * o;
                }
                sum += *s;
                sum2 += *s2;
            }
            b.sum = sum;
            b.sum2 = sum2;
        }
    }
    off
}

/// RMS disagreement of walks in bins two or more walks share, after each
/// walk's median offset from the shared bins' means; `None` with fewer than
/// `min_bins` shared bins.
pub(super) fn disagreement(a: &TxAcc, min_bins: usize) -> Option<f64> {
    // (walk, residual) per shared bin
    let mut res: Vec<(usize, f64)> = Vec::new();
    let mut shared = 0usize;
    for bins in a.bins.values() {
        for b in bins.values().filter(|b| b.walks.len() >= 2) {
            shared += 1;
            let means: Vec<(usize, f64)> =
                b.walks.iter().map(|(w, (n, s, _))| (*w, s / n)).collect();
            let c = means.iter().map(|m| m.1).sum::<f64>() / means.len() as f64;
            res.extend(means.iter().map(|(w, m)| (*w, m - c)));
        }
    }
    if shared < min_bins {
        return None;
    }
    let mut by_walk: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for (w, r) in &res {
        by_walk.entry(*w).or_default().push(*r);
    }
    let offsets: BTreeMap<usize, f64> = by_walk
        .into_iter()
        .map(|(w, mut v)| {
            v.sort_by(f64::total_cmp);
            (w, v[v.len() / 2])
        })
        .collect();
    let ss: f64 = res
        .iter()
        .map(|(w, r)| (r - offsets.get(w).copied().unwrap_or(0.0)).powi(2))
        .sum();
    Some((ss / res.len() as f64).sqrt())
}

/// The fallback of one transmitter while building its grids.
pub(super) struct Fallback<'a> {
    pub(super) t: &'a Transmitter,
    pub(super) has_pathloss: bool,
    pub(super) params: &'a FallbackParams,
    pub(super) floor_rank: &'a PathLossModel,
}

impl Fallback<'_> {
    pub(super) fn at(&self, floor: i32, p: Vec2) -> (f64, f64) {
        let apart = self.floor_rank.floors_apart(floor, self.t.floor);
        fallback_at(self.t, self.has_pathloss, self.params, apart, p)
    }
}

/// The wall prior of one transmitter on its own floor.
pub(super) struct TxPrior<'a> {
    t: &'a Transmitter,
    map: &'a FloorMap,
    model: PathLoss,
    loss: WallLoss,
    cfg: &'a WallPriorConfig,
    min_range_m: f64,
}

impl TxPrior<'_> {
    /// The prior's mean at `p`, dBm.
    fn at(&self, p: Vec2) -> f64 {
        let d = range_m(p, self.t.pos, self.t.dz_m, self.min_range_m);
        let c = self.cfg.counted(self.map.crossings(self.t.pos, p));
        super::wall_prior::mean(&self.model, &self.loss, 10.0 * d.log10(), c)
    }
}

/// Fits the wall prior of each radio kind on the survey's bins of every
/// transmitter the site has a position for (its own floor); the refitted
/// model and the kind's losses by transmitter (index into `acc`).
fn fit_wall_priors(
    site: &Site,
    ids: &BTreeMap<(TxKind, String), usize>,
    acc: &[TxAcc],
    site_model: &PathLossModel,
    cfg: &RadioMapConfig,
    summary: &mut BuildSummary,
) -> BTreeMap<usize, (PathLoss, WallLoss)> {
    let wp = &cfg.wall_prior;
    let mut out = BTreeMap::new();
    for kind in [TxKind::Ble, TxKind::Wifi] {
        let mut which = Vec::new();
        let mut txs = Vec::new();
        for ((k, id), i) in ids {
            let t = site_model
                .lookup(*k, id)
                .and_then(|j| site_model.transmitters().get(j));
            let (Some(t), true) = (t, *k == kind) else {
                continue;
            };
            let (Some(map), Some(bins)) = (site.floor(t.floor), acc[*i].bins.get(&t.floor)) else {
                continue;
            };
            let bins: Vec<PriorBin> = bins
                .values()
                .filter(|b| b.n > 0.0)
                .map(|b| {
                    let pos = b.pos_sum / b.n;
                    let d = range_m(pos, t.pos, t.dz_m, cfg.fallback.min_range_m);
                    PriorBin::new(b.sum / b.n, b.n, d, wp.counted(map.crossings(t.pos, pos)))
                })
                .collect();
            which.push(*i);
            txs.push((t.model, bins));
        }
        if txs.is_empty() {
            continue;
        }
        let (models, fit) = super::wall_prior::fit(&txs, wp);
        for (i, m) in which.into_iter().zip(models) {
            out.insert(i, (m, fit.loss));
        }
        match kind {
            TxKind::Ble => summary.ble_wall_prior = Some(fit),
            TxKind::Wifi => summary.wifi_wall_prior = Some(fit),
        }
    }
    out
}

/// A bin reduced to what smoothing needs.
pub(super) struct BinStat {
    pub pos: Vec2,
    pub n: f64,
    pub sum: f64,
    pub sum2: f64,
}

impl BinStat {
    /// The stat of a bin's sample count, sums of values and squares, and
    /// sum of positions (`n` > 0).
    pub fn of(n: f64, sum: f64, sum2: f64, pos_sum: Vec2) -> Self {
        BinStat {
            pos: pos_sum / n,
            n,
            sum,
            sum2,
        }
    }
}

/// How [`smooth_grid`] turns bins into cells (the units are the values':
/// dB for the radio map, uT for the magnetic one).
pub(super) struct SmoothParams<'a> {
    pub cell_m: f64,
    pub bandwidth_m: f64,
    pub max_distance_m: f64,
    pub prior_weight: f64,
    pub min_sd: f64,
    pub max_sd: f64,
    pub sd_growth_per_m: f64,
    pub max_cells_per_grid: usize,
    /// The calibrated spread at a cell centre, replacing the smoothed one
    /// (`RadioMapConfig::spread_calibration`).
    pub sd_at: Option<&'a dyn Fn(Vec2) -> f64>,
    /// A prior mean under the values (the wall prior): the bins' sums
    /// are residuals from it, it is added back to every cell, and the
    /// cells beyond `max_distance_m` of every bin hold it (with the
    /// fallback's spread) instead of nothing.
    pub base_at: Option<&'a dyn Fn(Vec2) -> f64>,
}

/// The grid of one transmitter on `floor` from its bins; `None` when no
/// cell is within `max_distance_m` of a bin.
fn build_grid(
    floor: i32,
    bins: &BTreeMap<(i64, i64), Bin>,
    cfg: &RadioMapConfig,
    fb: &Fallback<'_>,
    sd_curve: Option<(SpreadCurve, &WalkFootprint)>,
    prior: Option<&TxPrior<'_>>,
) -> Result<Option<Grid>> {
    let stats: Vec<BinStat> = bins
        .values()
        .filter(|b| b.n > 0.0)
        .map(|b| {
            let s = BinStat::of(b.n, b.sum, b.sum2, b.pos_sum);
            match prior {
                // residuals r - pi: sum - n pi, sum2 - 2 pi sum + n pi^2
                Some(pr) => {
                    let pi = pr.at(s.pos);
                    BinStat {
                        sum: s.sum - s.n * pi,
                        sum2: s.sum2 - 2.0 * pi * s.sum + s.n * pi * pi,
                        ..s
                    }
                }
                None => s,
            }
        })
        .collect();
    let p = SmoothParams {
        cell_m: cfg.cell_m,
        bandwidth_m: cfg.bandwidth_m,
        max_distance_m: cfg.max_distance_m,
        prior_weight: cfg.prior_weight,
        min_sd: cfg.min_sd_db,
        max_sd: cfg.max_sd_db,
        sd_growth_per_m: cfg.sd_growth_db_per_m,
        max_cells_per_grid: cfg.max_cells_per_grid,
        sd_at: None,
        base_at: None,
    };
    let base_at = |c: Vec2| prior.map_or(0.0, |pr| pr.at(c));
    let sd_at = |c: Vec2| match sd_curve {
        Some((curve, fp)) => curve.at(fp.distance(floor, c, None).min(cfg.max_distance_m)),
        None => 0.0,
    };
    let p = SmoothParams {
        sd_at: sd_curve.is_some().then_some(&sd_at as &dyn Fn(Vec2) -> f64),
        base_at: prior.is_some().then_some(&base_at as &dyn Fn(Vec2) -> f64),
        ..p
    };
    smooth_grid(floor, &stats, &p, &|c| fb.at(floor, c))
}

/// A grid over the box of `stats` grown by `max_distance_m` (cells
/// coarsened until at most `max_cells_per_grid`); each cell within
/// `max_distance_m` of a bin holds the kernel mean and spread of the
/// module docs, pulled towards `fallback(cell)` (mean, sd) by
/// `prior_weight` pseudo-samples. `None` when no cell has a value.
pub(super) fn smooth_grid(
    floor: i32,
    stats: &[BinStat],
    p: &SmoothParams,
    fallback: &dyn Fn(Vec2) -> (f64, f64),
) -> Result<Option<Grid>> {
    let Some(first) = stats.first() else {
        return Ok(None);
    };
    let (mut lo, mut hi) = (first.pos, first.pos);
    for s in stats {
        lo = lo.inf(&s.pos);
        hi = hi.sup(&s.pos);
    }
    let margin = p.max_distance_m;
    let (w, h) = (hi.x - lo.x + 2.0 * margin, hi.y - lo.y + 2.0 * margin);
    let mut cell = p.cell_m;
    let cells = |c: f64| ((w / c).ceil().max(1.0), (h / c).ceil().max(1.0));
    while {
        let (a, b) = cells(cell);
        a * b > p.max_cells_per_grid as f64
    } {
        cell *= 1.25;
    }
    let (nxf, nyf) = cells(cell);
    let (nx, ny) = (nxf as usize, nyf as usize);
    let (x0, y0) = (lo.x - margin, lo.y - margin);
    // bins bucketed by the search radius
    let h_m = p.bandwidth_m;
    let radius = (3.0 * h_m).max(margin).max(1e-3);
    let mut buckets: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    let key = |p: Vec2| ((p.x / radius).floor() as i64, (p.y / radius).floor() as i64);
    for (k, s) in stats.iter().enumerate() {
        buckets.entry(key(s.pos)).or_default().push(k);
    }
    let n = nx * ny;
    let mut mean = crate::bounds::try_filled(n, NO_VALUE, "radio map grid")?;
    let mut sd = crate::bounds::try_filled(n, NO_VALUE, "radio map grid")?;
    let w0 = p.prior_weight;
    let mut any = false;
    for j in 0..ny {
        for i in 0..nx {
            let c = Vec2::new(x0 + (i as f64 + 0.5) * cell, y0 + (j as f64 + 0.5) * cell);
            let (bx, by) = key(c);
            let (mut sw, mut s1, mut s2) = (0.0, 0.0, 0.0);
            let mut dmin = f64::INFINITY;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for &k in buckets.get(&(bx + dx, by + dy)).into_iter().flatten() {
                        let s = &stats[k];
                        let d2 = (s.pos - c).norm_squared();
                        dmin = dmin.min(d2);
                        if d2 <= 9.0 * h_m * h_m {
                            let kw = (-0.5 * d2 / (h_m * h_m)).exp();
                            sw += kw * s.n;
                            s1 += kw * s.sum;
                            s2 += kw * s.sum2;
                        }
                    }
                }
            }
            let dmin = dmin.sqrt();
            let base = p.base_at.map_or(0.0, |f| f(c));
            if dmin > margin {
                if p.base_at.is_some() {
                    let k = j * nx + i;
                    mean[k] = x10(base);
                    sd[k] = x10(fallback(c).1).max(1);
                }
                continue;
            }
            let (mu_fb, sd_fb) = fallback(c);
            let mu_fb = if p.base_at.is_some() { 0.0 } else { mu_fb };
            let (m, v) = if sw > 1e-12 {
                let m = s1 / sw;
                (m, (s2 / sw - m * m).max(p.min_sd * p.min_sd))
            } else {
                (mu_fb, sd_fb * sd_fb)
            };
            let lambda = if sw + w0 > 0.0 { sw / (sw + w0) } else { 1.0 };
            let mu = lambda * m + (1.0 - lambda) * mu_fb + base;
            let s = match p.sd_at {
                Some(f) => f(c),
                None => {
                    let g = p.sd_growth_per_m * dmin;
                    let var = lambda * v + (1.0 - lambda) * sd_fb * sd_fb + g * g;
                    var.sqrt().clamp(p.min_sd, p.max_sd)
                }
            };
            let k = j * nx + i;
            mean[k] = x10(mu);
            sd[k] = x10(s).max(1);
            any = true;
        }
    }
    Ok(any.then_some(Grid {
        floor,
        x0_m: x0,
        y0_m: y0,
        cell_m: cell,
        nx,
        ny,
        mean_dbm_x10: mean,
        sd_dbm_x10: sd,
    }))
}

/// dB to 0.1 dB units, clamped off [`NO_VALUE`].
fn x10(v: f64) -> i16 {
    (v * 10.0)
        .round()
        .clamp(f64::from(i16::MIN) + 1.0, f64::from(i16::MAX)) as i16
}
