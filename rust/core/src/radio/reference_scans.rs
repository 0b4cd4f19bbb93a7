//! Reference scans: the fingerprints of survey walks. Every `step_s` of a
//! walk with truth, the readings of the last `window_s` (each BLE advert
//! and each new WiFi result, [`super::survey`]) become one RSSI vector
//! (mean per transmitter) at the walker's position and floor. A phone's
//! own trailing window of the same length is compared with every
//! reference scan ([`ReferenceScans::query`]): the closest ones are the
//! candidate places of a weighted k-nearest-neighbour fix, which `tcpf`
//! uses as anchors (global start, re-seeding and a weak extra likelihood;
//! docs/tcpf.md, "Anchors").
//!
//! Why beside the radio map: a scan vector says as much by what it does
//! *not* hear as by what it hears (an AP heard at -50 dBm on the survey
//! and silent now rules a place out), and it keeps every transmitter of
//! the survey, not only those with a fitted model. The RSSI distance is
//! the RMS difference over the union of the two vectors' transmitters of
//! the radios in use, a transmitter missing on one side counting as
//! `missing_dbm`.
//!
//! Pure: built from events, queried with vectors; its file form lives in
//! [`super::radio_map_file`] (the `reference_scans` section).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::model::TxKind;
use super::survey::{RadioSample, SurveyCounts, SurveyOptions, survey_samples};
use crate::Vec2;
use crate::bounds::check_count;
use crate::events::LogEvent;
use crate::{Error, Result};

mod powed_walk;

/// Most reference scans one set holds (a survey of ~55 h at 1 per s).
pub const MAX_REFERENCE_SCANS: usize = 200_000;
/// Most distinct transmitters.
pub const MAX_REFERENCE_IDS: usize = 100_000;
/// Most transmitters in one reference scan.
pub const MAX_SCAN_TRANSMITTERS: usize = 1024;
/// Most (transmitter, RSSI) entries over all scans (~240 MB with the
/// query's index; ILC F1's 53 survey walks hold ~180 000).
pub const MAX_REFERENCE_ENTRIES: usize = 10_000_000;

/// How a query ranks and weighs the reference scans.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScanMetric {
    /// RMS dB difference over the union of the two vectors' transmitters,
    /// a transmitter missing on one side counting as `missing_dbm`.
    #[default]
    RmsDb,
    /// Bray-Curtis (Sorensen) dissimilarity of the "powed" levels
    /// [`powed_level`]: sum |a - b| / sum (a + b) over the union, in
    /// [0, 1]. Strong readings weigh more than weak ones (a weak reading
    /// differs little from a missing one), and a scan's score does not
    /// grow with its length. Torres-Sospedra et al., "Comprehensive
    /// analysis of distance and similarity measures for Wi-Fi
    /// fingerprinting indoor positioning systems", Expert Systems with
    /// Applications 42 (2015), found this pair the best of those compared.
    BrayCurtisPowed,
}

/// Exponent of the powed level (docs/parameters.md "tcpf anchors").
pub const POWED_BETA: f64 = 1.7;

/// The powed level of `rssi_dbm`: (-m) ((r - m) / -m)^beta with m =
/// `missing_dbm`, 0 for a missing transmitter, -m at 0 dBm.
pub fn powed_level(rssi_dbm: f64, missing_dbm: f64) -> f64 {
    let span = -missing_dbm;
    let x = ((rssi_dbm - missing_dbm) / span).clamp(0.0, 1.0);
    span * x.powf(POWED_BETA)
}

/// [`powed_level`] of a scan's RSSI `r` (floored at `missing_dbm`, in
/// 0.1 dB) from `table` (the levels from `missing_dbm` up in 0.1 dB).
fn tabled_level(table: &[f64], r: f64, missing_dbm: f64) -> f64 {
    table[(((r - missing_dbm) * 10.0).round() as usize).min(table.len() - 1)]
}

/// How reference scans are cut from survey walks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReferenceScanConfig {
    /// Length of the trailing window of one scan vector, s (the engine's
    /// query window is the same).
    pub window_s: f64,
    /// One reference scan every this many seconds of a walk.
    pub step_s: f64,
    /// A reference scan needs this many transmitters.
    pub min_transmitters: usize,
    /// RSSI of a transmitter one side did not hear, dBm.
    pub missing_dbm: f64,
    /// Readings weaker than this are left out, dBm.
    pub min_rssi_dbm: f64,
    /// WiFi results older than this against their scan are left out, s.
    pub wifi_max_age_s: f64,
    /// No position across truth points further apart than this, s.
    pub max_truth_gap_s: f64,
}

impl Default for ReferenceScanConfig {
    fn default() -> Self {
        ReferenceScanConfig {
            window_s: 4.0,
            step_s: 1.0,
            min_transmitters: 3,
            missing_dbm: -100.0,
            min_rssi_dbm: -100.0,
            wifi_max_age_s: 4.0,
            max_truth_gap_s: 30.0,
        }
    }
}

impl ReferenceScanConfig {
    /// Checks every field, naming the bad one under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        use crate::bounds::check_range;
        for (f, v, lo, hi) in [
            ("window_s", self.window_s, 0.1, 120.0),
            ("step_s", self.step_s, 0.1, 120.0),
            ("missing_dbm", self.missing_dbm, -200.0, 0.0),
            ("min_rssi_dbm", self.min_rssi_dbm, -200.0, 0.0),
            ("wifi_max_age_s", self.wifi_max_age_s, 0.0, 600.0),
            ("max_truth_gap_s", self.max_truth_gap_s, 0.1, 3600.0),
        ] {
            check_range(&format!("{prefix}.{f}"), v, lo, hi)?;
        }
        if !(1..=MAX_SCAN_TRANSMITTERS).contains(&self.min_transmitters) {
            return Err(Error::config(
                format!("{prefix}.min_transmitters"),
                format!("must be in 1..={MAX_SCAN_TRANSMITTERS}"),
            ));
        }
        Ok(())
    }
}

/// One reference scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceScan {
    pub floor: i32,
    /// The walker's position at the window's end, MCS metres.
    pub x_m: f64,
    pub y_m: f64,
    /// (transmitter index into `ids`, mean RSSI x 10 dBm), by index.
    pub tx: Vec<(u32, i16)>,
}

/// One candidate place of a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub floor: i32,
    pub pos: Vec2,
    /// RMS RSSI difference to the query, dB.
    pub dist_db: f64,
    /// The distance of the query's metric ([`ScanMetric`]): `dist_db`
    /// for [`ScanMetric::RmsDb`].
    pub score: f64,
}

/// A candidate weighted by its score: exp(-(s - s_best) / tau), the
/// weights of one query summing to 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightedCandidate {
    pub floor: i32,
    pub pos: Vec2,
    pub w: f64,
    /// The candidate's RSSI distance from the query, dB.
    pub dist_db: f64,
}

/// Where weighted candidates point: their heaviest floor (ties: the lower
/// id), its share of the weight, and the weighted mean and RMS spread of
/// the candidates on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateFix {
    pub floor: i32,
    pub share: f64,
    pub mean: Vec2,
    pub spread_m: f64,
}

/// The [`CandidateFix`] of `c`; `None` without weight.
pub fn candidate_fix(c: &[WeightedCandidate]) -> Option<CandidateFix> {
    let mut by_floor: BTreeMap<i32, f64> = BTreeMap::new();
    for a in c {
        *by_floor.entry(a.floor).or_insert(0.0) += a.w;
    }
    let (floor, share) = by_floor
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
    let (mut m, mut w) = (Vec2::zeros(), 0.0);
    for a in c.iter().filter(|a| a.floor == floor) {
        m += a.pos * a.w;
        w += a.w;
    }
    if w <= 0.0 {
        return None;
    }
    let mean = m / w;
    let spread_m = (c
        .iter()
        .filter(|a| a.floor == floor)
        .map(|a| a.w * (a.pos - mean).norm_squared())
        .sum::<f64>()
        / w)
        .sqrt();
    Some(CandidateFix {
        floor,
        share,
        mean,
        spread_m,
    })
}

/// The reference scans of a site.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReferenceScans {
    cfg: ReferenceScanConfig,
    /// Transmitter ids (canonical beacon id / lower-case BSSID) and kinds.
    ids: Vec<(TxKind, String)>,
    index: super::model::IdIndex,
    scans: Vec<ReferenceScan>,
    /// Per transmitter j, entries `post_start[j]..post_start[j + 1]` of
    /// `post_scan` / `post_r10`: (scan index, its RSSI x 10 dBm) of every
    /// scan that heard it (the query visits only these; 6 bytes an entry,
    /// the RSSI floored at `missing_dbm` as it is read).
    post_start: Vec<u32>,
    post_scan: Vec<u32>,
    post_r10: Vec<i16>,
    /// Per scan and radio (BLE, WiFi): sum of (r - missing)^2 and count,
    /// the scan's side of "heard on one side only".
    alone: Vec<[(f64, u32); 2]>,
    /// Per scan and radio: sum of the powed levels ([`powed_level`]).
    powed_alone: Vec<[f64; 2]>,
    /// [`powed_level`] of every RSSI from `missing_dbm` to 0 dBm in
    /// 0.1 dB (the scans' resolution).
    powed_table: Vec<f64>,
    /// What the query needs of a posting's RSSI, by `r10 - levels_lo`
    /// for every `r10` the postings hold ([`PostingLevel`]).
    levels: Vec<PostingLevel>,
    /// The `powed` of `levels` alone (the Bray-Curtis walk reads only it).
    level_powed: Vec<f64>,
    levels_lo: i16,
}

/// A scan's RSSI as the query reads it, computed once per value (the
/// postings hold few distinct ones): r = r10 / 10 floored at
/// `missing_dbm` (m), (r - m)^2, and its powed level from the table
/// (the query's own arithmetic on them, so the same sums).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct PostingLevel {
    r: f64,
    r_m2: f64,
    powed: f64,
}

impl PostingLevel {
    fn of(r10: i16, m: f64, powed_table: &[f64]) -> Self {
        let r = super::radio_map::tenths(r10).max(m);
        PostingLevel {
            r,
            r_m2: (r - m) * (r - m),
            powed: tabled_level(powed_table, r, m),
        }
    }
}

/// A query's running sums for one scan under [`ScanMetric::RmsDb`]: the
/// shared transmitters' correction of the RMS sum and their count (one
/// struct: one cache line per posting visited).
#[derive(Debug, Clone, Copy, Default)]
struct SharedSums {
    corr: f64,
    n: u32,
}

/// 0 for BLE, 1 for WiFi (index into [`ReferenceScans`]'s per-radio sums).
fn radio_slot(k: TxKind) -> usize {
    match k {
        TxKind::Ble => 0,
        TxKind::Wifi => 1,
    }
}

impl ReferenceScans {
    /// A set from its parts; checks sizes, indices and values (errors name
    /// the field, under `reference_scans.`).
    pub fn new(
        cfg: ReferenceScanConfig,
        ids: Vec<(TxKind, String)>,
        scans: Vec<ReferenceScan>,
    ) -> Result<Self> {
        cfg.validate("reference_scans.config")?;
        check_count("reference_scans.ids", ids.len(), 0, MAX_REFERENCE_IDS)?;
        check_count("reference_scans.scans", scans.len(), 0, MAX_REFERENCE_SCANS)?;
        let entries = scans
            .iter()
            .map(|s| s.tx.len())
            .fold(0usize, usize::saturating_add);
        check_count(
            "reference_scans.scans[].tx",
            entries,
            0,
            MAX_REFERENCE_ENTRIES,
        )?;
        for (i, s) in scans.iter().enumerate() {
            let bad = |f: &str, m: String| {
                Err(Error::Input(format!(
                    "radio map: field `reference_scans.scans[{i}].{f}`: {m}"
                )))
            };
            if !(s.x_m.is_finite() && s.y_m.is_finite()) {
                return bad("x_m", "position must be finite".into());
            }
            if s.tx.len() > MAX_SCAN_TRANSMITTERS {
                return bad("tx", format!("more than {MAX_SCAN_TRANSMITTERS} entries"));
            }
            for w in s.tx.windows(2) {
                if w[0].0 >= w[1].0 {
                    return bad("tx", "indices must be strictly increasing".into());
                }
            }
            if let Some(&(j, _)) = s.tx.iter().find(|(j, _)| *j as usize >= ids.len()) {
                return bad("tx", format!("index {j} is not below {} ids", ids.len()));
            }
        }
        let mut index = super::model::IdIndex::default();
        for (i, id) in ids.iter().enumerate() {
            if !index.insert(id.0, id.1.clone(), i) {
                return Err(Error::Input(format!(
                    "radio map: field `reference_scans.ids[{i}]`: `{}` is listed twice",
                    id.1
                )));
            }
        }
        let m = cfg.missing_dbm;
        let mut alone = Vec::with_capacity(scans.len());
        let powed_table: Vec<f64> = (0..=(-m * 10.0).round() as usize)
            .map(|i| powed_level(m + i as f64 / 10.0, m))
            .collect();
        let mut powed_alone = Vec::with_capacity(scans.len());
        // postings by counting: entries per transmitter, their starts,
        // then each scan's entries in scan order
        let mut post_start = vec![0u32; ids.len() + 1];
        for s in &scans {
            for &(j, _) in &s.tx {
                post_start[j as usize + 1] += 1;
            }
        }
        for j in 0..ids.len() {
            post_start[j + 1] += post_start[j];
        }
        let mut next: Vec<u32> = post_start[..ids.len()].to_vec();
        let (mut post_scan, mut post_r10) = (vec![0u32; entries], vec![0i16; entries]);
        for (si, s) in scans.iter().enumerate() {
            let mut a = [(0.0, 0u32); 2];
            let mut p = [0.0; 2];
            for &(j, r10) in &s.tx {
                let r = (f64::from(r10) / 10.0).max(m);
                let e = &mut next[j as usize];
                post_scan[*e as usize] = si as u32;
                post_r10[*e as usize] = r10;
                *e += 1;
                let k = radio_slot(ids[j as usize].0);
                let slot = &mut a[k];
                slot.0 += (r - m) * (r - m);
                slot.1 += 1;
                p[k] += tabled_level(&powed_table, r, m);
            }
            alone.push(a);
            powed_alone.push(p);
        }
        let levels_lo = post_r10.iter().copied().min().unwrap_or(0);
        let levels_hi = post_r10.iter().copied().max().unwrap_or(0);
        let levels: Vec<PostingLevel> = (levels_lo..=levels_hi)
            .map(|r10| PostingLevel::of(r10, m, &powed_table))
            .collect();
        let level_powed = levels.iter().map(|l| l.powed).collect();
        Ok(ReferenceScans {
            cfg,
            ids,
            index,
            scans,
            post_start,
            post_scan,
            post_r10,
            alone,
            powed_alone,
            powed_table,
            levels,
            level_powed,
            levels_lo,
        })
    }

    pub fn config(&self) -> &ReferenceScanConfig {
        &self.cfg
    }

    pub fn ids(&self) -> &[(TxKind, String)] {
        &self.ids
    }

    pub fn scans(&self) -> &[ReferenceScan] {
        &self.scans
    }

    pub fn is_empty(&self) -> bool {
        self.scans.is_empty()
    }

    /// Index of a transmitter by canonical id (beacon ids as
    /// [`crate::ble::beacon_id::normalize_beacon_id`] gives them, BSSIDs
    /// lower-case).
    pub fn index_of(&self, kind: TxKind, canonical_id: &str) -> Option<u32> {
        self.index.get(kind, canonical_id).map(|j| j as u32)
    }

    /// Kind of transmitter `j`.
    pub fn kind(&self, j: u32) -> Option<TxKind> {
        self.ids.get(j as usize).map(|x| x.0)
    }

    /// The `k` reference scans closest to `query` ((index, RSSI dBm),
    /// sorted by index, one entry per transmitter), comparing only the
    /// transmitters of the radios in `use_ble` / `use_wifi`; a scan
    /// counts only if it shares at least one heard transmitter. Sorted by
    /// distance (ties: scan order).
    pub fn query(
        &self,
        query: &[(u32, f64)],
        use_ble: bool,
        use_wifi: bool,
        k: usize,
    ) -> Vec<Candidate> {
        self.query_with(query, use_ble, use_wifi, k, ScanMetric::RmsDb)
    }

    /// [`ReferenceScans::query`] ranked by `metric` (each candidate still
    /// carries its RMS dB distance).
    pub fn query_with(
        &self,
        query: &[(u32, f64)],
        use_ble: bool,
        use_wifi: bool,
        k: usize,
        metric: ScanMetric,
    ) -> Vec<Candidate> {
        let used = |j: u32| match self.kind(j) {
            Some(TxKind::Ble) => use_ble,
            Some(TxKind::Wifi) => use_wifi,
            None => false,
        };
        let m = self.cfg.missing_dbm;
        let q: Vec<(u32, f64)> = query
            .iter()
            .filter(|(j, r)| used(*j) && r.is_finite())
            .map(|&(j, r)| (j, r.max(m)))
            .collect();
        if q.is_empty() || k == 0 {
            return Vec::new();
        }
        let q_only: f64 = q.iter().map(|(_, r)| (r - m) * (r - m)).sum();
        // powed: the query's levels, once (Bray-Curtis = 1 - 2 sum of the
        // shared transmitters' min(level_query, level_scan) / sum of all
        // levels)
        let powed = metric == ScanMetric::BrayCurtisPowed;
        let q_levels: Option<Vec<f64>> =
            powed.then(|| q.iter().map(|&(_, a)| powed_level(a, m)).collect());
        let q_powed: f64 = q_levels.as_ref().map_or(0.0, |l| l.iter().sum());
        let mut out: Vec<(f64, f64, usize)> = Vec::new();
        if let Some(levels) = &q_levels {
            // the scores from the min-level sums alone; the RMS distance
            // of the k winners only (the same bits, `powed_walk`)
            for (si, &min_powed) in self.powed_sums(&q, levels).iter().enumerate() {
                if min_powed.is_sign_negative() {
                    continue;
                }
                let score = self.powed_score(si, q_powed, min_powed, use_ble, use_wifi);
                out.push((score, f64::NAN, si));
            }
        } else {
            for (si, sh) in self.shared_sums(&q).iter().enumerate() {
                if sh.n > 0 {
                    let d = self.rms_db(q.len(), q_only, (sh.corr, sh.n), si, use_ble, use_wifi);
                    out.push((d, d, si));
                }
            }
        }
        let k = k.min(out.len());
        if k == 0 {
            return Vec::new();
        }
        let cmp =
            |a: &(f64, f64, usize), b: &(f64, f64, usize)| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2));
        if k < out.len() {
            out.select_nth_unstable_by(k - 1, cmp);
            out.truncate(k);
        }
        out.sort_by(cmp);
        if powed {
            for c in &mut out {
                let sh = self.shared_of(&q, c.2);
                c.1 = self.rms_db(q.len(), q_only, sh, c.2, use_ble, use_wifi);
            }
        }
        out.into_iter()
            .map(|(score, d, si)| {
                let s = &self.scans[si];
                Candidate {
                    floor: s.floor,
                    pos: Vec2::new(s.x_m, s.y_m),
                    dist_db: d,
                    score,
                }
            })
            .collect()
    }
}

impl ReferenceScans {
    /// The RMS dB distance of scan `si` from a query of `q_len`
    /// transmitters whose "heard on the query's side only" sum is
    /// `q_only`, given the shared transmitters' correction and count.
    fn rms_db(
        &self,
        q_len: usize,
        q_only: f64,
        (corr, n_shared): (f64, u32),
        si: usize,
        use_ble: bool,
        use_wifi: bool,
    ) -> f64 {
        let al = &self.alone[si];
        let (mut sum, mut n) = (q_only + corr, q_len as u32 - n_shared);
        for (slot, on) in [(0, use_ble), (1, use_wifi)] {
            if on {
                sum += al[slot].0;
                n += al[slot].1;
            }
        }
        (sum.max(0.0) / f64::from(n.max(1))).sqrt()
    }

    /// The postings walk of [`ReferenceScans::query_with`] under
    /// [`ScanMetric::RmsDb`]: per scan, the sums over the transmitters it
    /// shares with `q` (RSSIs floored at `missing_dbm`; only the scans
    /// that heard one of them are visited). Each shared transmitter turns
    /// two "heard on one side only" terms into one difference: (a - r)^2
    /// - (a - m)^2 - (r - m)^2.
    fn shared_sums(&self, q: &[(u32, f64)]) -> Vec<SharedSums> {
        let m = self.cfg.missing_dbm;
        let mut shared = vec![SharedSums::default(); self.scans.len()];
        for &(j, a) in q {
            let a_m2 = (a - m) * (a - m);
            let (lo, hi) = (
                self.post_start[j as usize] as usize,
                self.post_start[j as usize + 1] as usize,
            );
            for (&si, &r10) in self.post_scan[lo..hi].iter().zip(&self.post_r10[lo..hi]) {
                let l = &self.levels[(i32::from(r10) - i32::from(self.levels_lo)) as usize];
                let e = &mut shared[si as usize];
                e.corr += (a - l.r) * (a - l.r) - a_m2 - l.r_m2;
                e.n += 1;
            }
        }
        shared
    }

    /// Bray-Curtis dissimilarity of powed levels between a query (its
    /// powed sum `q_powed`) and scan `si` sharing `min_powed` with it: 1 -
    /// 2 shared / (both sums), the scan's sum over the kinds the query uses.
    fn powed_score(
        &self,
        si: usize,
        q_powed: f64,
        min_powed: f64,
        use_ble: bool,
        use_wifi: bool,
    ) -> f64 {
        let mut total = q_powed;
        for (slot, on) in [(0, use_ble), (1, use_wifi)] {
            if on {
                total += self.powed_alone[si][slot];
            }
        }
        if total > 0.0 {
            (1.0 - 2.0 * min_powed / total).max(0.0)
        } else {
            1.0
        }
    }

    /// [`ReferenceScans::query_with`] over the radios `query` holds, each
    /// of the `k` candidates weighted exp(-(s - s_best) / `tau`) of its
    /// `metric` score s (dB for [`ScanMetric::RmsDb`]), the weights
    /// summing to 1.
    pub fn weighted_query(
        &self,
        query: &[(u32, f64)],
        k: usize,
        tau: f64,
        metric: ScanMetric,
    ) -> Vec<WeightedCandidate> {
        let has = |kind: TxKind| query.iter().any(|(j, _)| self.kind(*j) == Some(kind));
        let c = self.query_with(query, has(TxKind::Ble), has(TxKind::Wifi), k, metric);
        let Some(d0) = c.first().map(|c| c.score) else {
            return Vec::new();
        };
        let mut out: Vec<WeightedCandidate> = c
            .iter()
            .map(|c| WeightedCandidate {
                floor: c.floor,
                pos: c.pos,
                w: (-(c.score - d0) / tau).exp(),
                dist_db: c.dist_db,
            })
            .collect();
        let total: f64 = out.iter().map(|a| a.w).sum();
        out.iter_mut().for_each(|a| a.w /= total);
        out
    }
}

/// Builds [`ReferenceScans`] from survey logs with truth, one log at a time.
#[derive(Debug, Clone)]
pub struct ReferenceScanBuilder {
    cfg: ReferenceScanConfig,
    default_floor: Option<i32>,
    ids: Vec<(TxKind, String)>,
    index: BTreeMap<(TxKind, String), u32>,
    scans: Vec<ReferenceScan>,
    /// The walk (log, counted from 0) of each scan.
    walk_of: Vec<usize>,
    /// Logs added so far.
    logs: usize,
    /// Entries over all scans so far.
    entries: usize,
    /// Scans left out: too few transmitters, a floor change inside the
    /// window, or over the size bounds.
    pub skipped: usize,
}

impl ReferenceScanBuilder {
    /// `default_floor`: the floor of truth points without one (single-floor
    /// sites).
    pub fn new(cfg: &ReferenceScanConfig, default_floor: Option<i32>) -> Result<Self> {
        cfg.validate("reference_scans")?;
        Ok(ReferenceScanBuilder {
            cfg: *cfg,
            default_floor,
            ids: Vec::new(),
            index: BTreeMap::new(),
            scans: Vec::new(),
            walk_of: Vec::new(),
            logs: 0,
            entries: 0,
            skipped: 0,
        })
    }

    /// Adds the reference scans of one log (time-ordered events).
    pub fn add_log(&mut self, events: &[LogEvent]) -> SurveyCounts {
        let opts = SurveyOptions {
            default_floor: self.default_floor,
            max_truth_gap_ns: (self.cfg.max_truth_gap_s * 1e9) as i64,
            wifi_max_age_ns: (self.cfg.wifi_max_age_s * 1e9) as i64,
            min_rssi_dbm: self.cfg.min_rssi_dbm,
        };
        let walk = self.logs;
        self.logs += 1;
        let mut samples: Vec<RadioSample> = Vec::new();
        let counts = survey_samples(events, &opts, |s| samples.push(s));
        samples.sort_by_key(|s| s.t_ns);
        let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
            return counts;
        };
        let (t0, t1) = (first.t_ns, last.t_ns);
        let win = (self.cfg.window_s * 1e9) as i64;
        let step = ((self.cfg.step_s * 1e9) as i64).max(1);
        let mut end = t0 + win.min(t1 - t0);
        let (mut lo, mut hi) = (0usize, 0usize);
        while end <= t1 {
            while hi < samples.len() && samples[hi].t_ns <= end {
                hi += 1;
            }
            while lo < hi && samples[lo].t_ns <= end - win {
                lo += 1;
            }
            self.push_window(&samples[lo..hi], walk);
            end += step;
        }
        counts
    }

    fn push_window(&mut self, w: &[RadioSample], walk: usize) {
        let Some(at) = w.last() else { return };
        if w.iter().any(|s| s.floor != at.floor)
            || self.scans.len() >= MAX_REFERENCE_SCANS
            || self.entries + w.len().min(MAX_SCAN_TRANSMITTERS) > MAX_REFERENCE_ENTRIES
        {
            self.skipped += 1;
            return;
        }
        let mut acc: BTreeMap<u32, (f64, usize)> = BTreeMap::new();
        for s in w {
            let key = (s.kind, s.id.clone());
            let j = match self.index.get(&key) {
                Some(j) => *j,
                None => {
                    if self.ids.len() >= MAX_REFERENCE_IDS {
                        continue;
                    }
                    let j = self.ids.len() as u32;
                    self.ids.push(key.clone());
                    self.index.insert(key, j);
                    j
                }
            };
            let e = acc.entry(j).or_insert((0.0, 0));
            e.0 += s.rssi_dbm;
            e.1 += 1;
        }
        if acc.len() < self.cfg.min_transmitters {
            self.skipped += 1;
            return;
        }
        let mut tx: Vec<(u32, i16)> = acc
            .into_iter()
            .map(|(j, (s, n))| (j, (s / n as f64 * 10.0).round().clamp(-2000.0, 0.0) as i16))
            .collect();
        if tx.len() > MAX_SCAN_TRANSMITTERS {
            // keep the strongest
            tx.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
            tx.truncate(MAX_SCAN_TRANSMITTERS);
            tx.sort_by_key(|x| x.0);
        }
        self.entries += tx.len();
        self.walk_of.push(walk);
        self.scans.push(ReferenceScan {
            floor: at.floor,
            x_m: (at.pos.x * 100.0).round() / 100.0,
            y_m: (at.pos.y * 100.0).round() / 100.0,
            tx,
        });
    }

    /// The set.
    pub fn finish(self) -> Result<ReferenceScans> {
        ReferenceScans::new(self.cfg, self.ids, self.scans)
    }

    /// The set with `offset_db(walk, kind)` (walks counted from 0 in the
    /// order their logs were added) subtracted from every reading of that
    /// walk's scans: the survey walks' own offsets
    /// ([`super::walk_offsets`]), as the radio map removed them.
    pub fn finish_with_walk_offsets(
        mut self,
        offset_db: impl Fn(usize, TxKind) -> f64,
    ) -> Result<ReferenceScans> {
        for (scan, walk) in self.scans.iter_mut().zip(&self.walk_of) {
            for (j, r) in scan.tx.iter_mut() {
                let kind = self.ids[*j as usize].0;
                let o = offset_db(*walk, kind);
                if o != 0.0 {
                    *r = (f64::from(*r) - o * 10.0).round().clamp(-2000.0, 0.0) as i16;
                }
            }
        }
        ReferenceScans::new(self.cfg, self.ids, self.scans)
    }
}

/// A phone's trailing window of readings, as the reference scans were cut:
/// readings of the last `window_s`, mean per transmitter.
#[derive(Debug, Clone, Default)]
pub struct ScanTrail {
    readings: std::collections::VecDeque<(i64, u32, f64)>,
    /// Reference-scan index of each beacon id as heard (cached).
    ble_ids: BTreeMap<String, Option<u32>>,
}

/// Most readings a trail keeps (a flood of adverts cannot grow it).
const MAX_TRAIL: usize = 20_000;
/// Most beacon ids whose index is cached.
const MAX_ID_CACHE: usize = 4096;

impl ScanTrail {
    /// A BLE advert of beacon `raw_id` (any spelling), if `scans` knows it.
    pub fn push_ble(&mut self, scans: &ReferenceScans, raw_id: &str, t_ns: i64, rssi_dbm: f64) {
        let j = match self.ble_ids.get(raw_id) {
            Some(j) => *j,
            None => {
                let j = crate::ble::beacon_id::normalize_beacon_id(raw_id)
                    .ok()
                    .and_then(|id| scans.index_of(TxKind::Ble, &id));
                if self.ble_ids.len() < MAX_ID_CACHE {
                    self.ble_ids.insert(raw_id.to_string(), j);
                }
                j
            }
        };
        if let Some(j) = j {
            self.push(t_ns, j, rssi_dbm);
        }
    }

    /// A WiFi result of `bssid` heard at `t_ns`, if `scans` knows it.
    pub fn push_wifi(&mut self, scans: &ReferenceScans, bssid: &str, t_ns: i64, rssi_dbm: f64) {
        if let Some(j) = scans.index_of(TxKind::Wifi, &crate::wifi::canonical_bssid(bssid)) {
            self.push(t_ns, j, rssi_dbm);
        }
    }

    /// One reading of transmitter `j` at `t_ns`.
    pub fn push(&mut self, t_ns: i64, j: u32, rssi_dbm: f64) {
        if !rssi_dbm.is_finite() {
            return;
        }
        if self.readings.len() >= MAX_TRAIL {
            self.readings.pop_front();
        }
        self.readings.push_back((t_ns, j, rssi_dbm));
    }

    /// The mean per transmitter of the readings in (now - window, now],
    /// minus `offset_db`, sorted by index; older readings are dropped.
    pub fn vector(&mut self, now_ns: i64, window_s: f64, offset_db: f64) -> Vec<(u32, f64)> {
        let from = now_ns - (window_s * 1e9) as i64;
        while self.readings.front().is_some_and(|r| r.0 <= from) {
            self.readings.pop_front();
        }
        // by transmitter, each one's readings in the trail's order (a
        // stable sort), summed in that order
        let mut rs: Vec<(u32, f64)> = self
            .readings
            .iter()
            .filter(|r| r.0 <= now_ns)
            .map(|&(_, j, r)| (j, r))
            .collect();
        rs.sort_by_key(|r| r.0);
        let mut out: Vec<(u32, f64)> = Vec::new();
        let mut k = 0;
        while k < rs.len() {
            let j = rs[k].0;
            let (mut s, mut n) = (0.0, 0usize);
            while k < rs.len() && rs[k].0 == j {
                s += rs[k].1;
                n += 1;
                k += 1;
            }
            out.push((j, s / n as f64 - offset_db));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trail_vector_is_the_per_transmitter_mean_bit_for_bit() {
        // the BTreeMap accumulation it replaced, on readings out of index
        // order, repeated, some after `now`
        let mut trail = ScanTrail::default();
        let mut reference = Vec::new();
        for k in 0..500u32 {
            let (t, j, r) = (
                i64::from(k) * 10_000_000,
                (k * 7919) % 37,
                -40.0 - f64::from((k * 131) % 613) / 9.7,
            );
            trail.push(t, j, r);
            reference.push((t, j, r));
        }
        let now = 4_000_000_000;
        let from = now - 3_000_000_000;
        let mut acc: BTreeMap<u32, (f64, usize)> = BTreeMap::new();
        for &(_, j, r) in reference.iter().filter(|r| r.0 > from && r.0 <= now) {
            let e = acc.entry(j).or_insert((0.0, 0));
            e.0 += r;
            e.1 += 1;
        }
        let want: Vec<(u32, u64)> = acc
            .into_iter()
            .map(|(j, (s, n))| (j, (s / n as f64 - 1.3).to_bits()))
            .collect();
        let got: Vec<(u32, u64)> = trail
            .vector(now, 3.0, 1.3)
            .into_iter()
            .map(|(j, v)| (j, v.to_bits()))
            .collect();
        assert_eq!(got, want);
    }
    use crate::events::{BleObservation, TruthPoint, WifiResult, WifiScan};

    fn set(scans: Vec<ReferenceScan>, n_ids: usize) -> ReferenceScans {
        let ids = (0..n_ids)
            .map(|i| (TxKind::Wifi, format!("0a:00:00:00:00:{i:02x}")))
            .collect();
        ReferenceScans::new(ReferenceScanConfig::default(), ids, scans).unwrap()
    }

    fn scan(x: f64, tx: &[(u32, f64)]) -> ReferenceScan {
        ReferenceScan {
            floor: 0,
            x_m: x,
            y_m: 0.0,
            tx: tx.iter().map(|&(j, r)| (j, (r * 10.0) as i16)).collect(),
        }
    }

    #[test]
    fn the_closest_scan_wins_and_silence_counts() {
        let s = set(
            vec![
                scan(0.0, &[(0, -50.0), (1, -80.0)]),
                scan(10.0, &[(0, -80.0), (1, -50.0)]),
                // hears 0 like the query but also 2 loudly, which the query does not
                scan(20.0, &[(0, -52.0), (1, -80.0), (2, -45.0)]),
            ],
            3,
        );
        let c = s.query(&[(0, -51.0), (1, -79.0)], false, true, 3);
        assert_eq!(c.len(), 3);
        assert_eq!(c[0].pos.x, 0.0);
        // x = 20 matches both heard APs within 2 dB but its loud third AP
        // is silent now: it ranks below x = 10, where both are 29 dB off
        assert_eq!(c[1].pos.x, 10.0, "{c:?}");
        assert_eq!(c[2].pos.x, 20.0, "{c:?}");
        assert!(c[2].dist_db > 30.0, "a loud AP not heard now is far: {c:?}");
        // distance by hand: RMS of (1, 1) dB
        assert!((c[0].dist_db - 1.0).abs() < 1e-9);
        // the radio not in use is ignored: no WiFi, no candidate
        assert!(s.query(&[(0, -51.0)], true, false, 3).is_empty());
        // nothing shared: no candidate
        assert!(s.query(&[(2, -51.0)], false, true, 3).len() == 1);
    }

    /// The distance by its definition: RMS over the union of the radios in
    /// use, one side missing = `missing_dbm`.
    fn brute(s: &ReferenceScans, q: &[(u32, f64)], ble: bool, wifi: bool) -> Vec<(f64, usize)> {
        let m = s.config().missing_dbm;
        let used = |j: u32| match s.kind(j) {
            Some(TxKind::Ble) => ble,
            Some(TxKind::Wifi) => wifi,
            None => false,
        };
        let mut out = Vec::new();
        for (si, sc) in s.scans().iter().enumerate() {
            let mut all: BTreeMap<u32, (f64, f64)> = BTreeMap::new();
            for &(j, a) in q.iter().filter(|(j, _)| used(*j)) {
                all.entry(j).or_insert((m, m)).0 = a.max(m);
            }
            for &(j, r) in sc.tx.iter().filter(|(j, _)| used(*j)) {
                all.entry(j).or_insert((m, m)).1 = (f64::from(r) / 10.0).max(m);
            }
            let shared = q
                .iter()
                .any(|(j, _)| used(*j) && sc.tx.iter().any(|(k, _)| k == j));
            if shared {
                let sum: f64 = all.values().map(|(a, r)| (a - r) * (a - r)).sum();
                out.push(((sum / all.len() as f64).sqrt(), si));
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out
    }

    /// (Bray-Curtis of the powed levels, RMS dB, scan) of every scan
    /// sharing a used transmitter with `q`, best first.
    fn brute_powed(
        s: &ReferenceScans,
        q: &[(u32, f64)],
        ble: bool,
        wifi: bool,
    ) -> Vec<(f64, f64, usize)> {
        let m = s.config().missing_dbm;
        let rms: BTreeMap<usize, f64> = brute(s, q, ble, wifi)
            .into_iter()
            .map(|(d, si)| (si, d))
            .collect();
        let used = |j: u32| match s.kind(j) {
            Some(TxKind::Ble) => ble,
            Some(TxKind::Wifi) => wifi,
            None => false,
        };
        let mut out = Vec::new();
        for (si, d) in rms {
            let mut all: BTreeMap<u32, (f64, f64)> = BTreeMap::new();
            for &(j, a) in q.iter().filter(|(j, _)| used(*j)) {
                all.entry(j).or_insert((0.0, 0.0)).0 = powed_level(a, m);
            }
            for &(j, r) in s.scans()[si].tx.iter().filter(|(j, _)| used(*j)) {
                all.entry(j).or_insert((0.0, 0.0)).1 = powed_level(f64::from(r) / 10.0, m);
            }
            let num: f64 = all.values().map(|(a, r)| (a - r).abs()).sum();
            let den: f64 = all.values().map(|(a, r)| a + r).sum();
            out.push((num / den, d, si));
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
        out
    }

    #[test]
    fn powed_levels_weigh_strong_readings_more() {
        assert_eq!(powed_level(-100.0, -100.0), 0.0);
        assert_eq!(powed_level(-120.0, -100.0), 0.0);
        assert!((powed_level(0.0, -100.0) - 100.0).abs() < 1e-12);
        // 10 dB near the floor moves the level less than 10 dB near the top
        let low = powed_level(-80.0, -100.0) - powed_level(-90.0, -100.0);
        let high = powed_level(-40.0, -100.0) - powed_level(-50.0, -100.0);
        assert!(high > 2.0 * low, "{low} {high}");
    }

    #[test]
    fn the_level_table_is_the_per_posting_arithmetic() {
        // RSSIs below the missing level (floored), at it, and up to 0 dBm
        let ids: Vec<(TxKind, String)> = (0..3).map(|i| (TxKind::Wifi, format!("id{i}"))).collect();
        let scans: Vec<ReferenceScan> = [-1500i16, -1000, -999, -655, -1, 0]
            .iter()
            .enumerate()
            .map(|(i, &r10)| ReferenceScan {
                floor: 0,
                x_m: i as f64,
                y_m: 0.0,
                tx: vec![(i as u32 % 3, r10)],
            })
            .collect();
        let set = ReferenceScans::new(ReferenceScanConfig::default(), ids, scans).unwrap();
        let m = set.cfg.missing_dbm;
        for &r10 in &set.post_r10 {
            let l = set.levels[(i32::from(r10) - i32::from(set.levels_lo)) as usize];
            // the query's arithmetic before the table, value by value
            let r = super::super::radio_map::tenths(r10).max(m);
            assert_eq!(l.r.to_bits(), r.to_bits());
            assert_eq!(l.r_m2.to_bits(), ((r - m) * (r - m)).to_bits());
            let want = tabled_level(&set.powed_table, r, m);
            assert_eq!(l.powed.to_bits(), want.to_bits());
        }
        assert_eq!(set.levels.len(), 1501);
    }

    #[test]
    fn the_query_matches_the_definition_on_random_scans() {
        let mut seed = 12345u64;
        let mut next = move |n: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % n
        };
        let ids: Vec<(TxKind, String)> = (0..30)
            .map(|i| {
                let k = if i % 3 == 0 {
                    TxKind::Ble
                } else {
                    TxKind::Wifi
                };
                (k, format!("id{i}"))
            })
            .collect();
        let scans: Vec<ReferenceScan> = (0..200)
            .map(|i| {
                let mut tx: Vec<(u32, i16)> = Vec::new();
                for j in 0..30u32 {
                    if next(3) == 0 {
                        tx.push((j, -(300 + next(700) as i16)));
                    }
                }
                ReferenceScan {
                    floor: 0,
                    x_m: i as f64,
                    y_m: 0.0,
                    tx,
                }
            })
            .collect();
        let set = ReferenceScans::new(ReferenceScanConfig::default(), ids, scans).unwrap();
        for _ in 0..50 {
            let mut q: Vec<(u32, f64)> = Vec::new();
            for j in 0..30u32 {
                if next(4) == 0 {
                    q.push((j, -30.0 - next(75) as f64));
                }
            }
            for (ble, wifi) in [(true, true), (true, false), (false, true)] {
                let want = brute(&set, &q, ble, wifi);
                let got = set.query(&q, ble, wifi, 7);
                assert_eq!(got.len(), want.len().min(7));
                for (g, w) in got.iter().zip(&want) {
                    assert!((g.dist_db - w.0).abs() < 1e-9, "{g:?} vs {w:?}");
                    assert_eq!(g.score, g.dist_db);
                }
                let want = brute_powed(&set, &q, ble, wifi);
                let got = set.query_with(&q, ble, wifi, 7, ScanMetric::BrayCurtisPowed);
                assert_eq!(got.len(), want.len().min(7));
                for (g, w) in got.iter().zip(&want) {
                    assert!((g.score - w.0).abs() < 1e-9, "{g:?} vs {w:?}");
                    assert!((g.dist_db - w.1).abs() < 1e-9, "{g:?} vs {w:?}");
                    assert_eq!(g.pos.x, w.2 as f64);
                }
            }
        }
    }

    #[test]
    fn bad_sets_are_refused_with_the_field() {
        let ids = vec![(TxKind::Ble, "a".to_string())];
        let bad = ReferenceScans::new(
            ReferenceScanConfig::default(),
            ids.clone(),
            vec![scan(0.0, &[(3, -60.0)])],
        )
        .unwrap_err()
        .to_string();
        assert!(bad.contains("reference_scans.scans[0].tx"), "{bad}");
        let bad = ReferenceScans::new(
            ReferenceScanConfig::default(),
            ids,
            vec![ReferenceScan {
                floor: 0,
                x_m: f64::NAN,
                y_m: 0.0,
                tx: vec![],
            }],
        )
        .unwrap_err()
        .to_string();
        assert!(bad.contains("scans[0].x_m"), "{bad}");
    }

    #[test]
    fn survey_walk_gives_one_scan_per_step_at_the_window_end() {
        let mut ev = vec![
            LogEvent::Truth(TruthPoint {
                t_ns: 0,
                x_m: 0.0,
                y_m: 0.0,
                floor: None,
            }),
            LogEvent::Truth(TruthPoint {
                t_ns: 20_000_000_000,
                x_m: 20.0,
                y_m: 0.0,
                floor: None,
            }),
        ];
        for i in 0..20 {
            let t = i * 1_000_000_000 + 500_000_000;
            ev.push(LogEvent::Ble(BleObservation {
                t_ns: t,
                beacon_id: "MAC:AA:BB:CC:DD:EE:01".into(),
                rssi_dbm: -60.0 - i as f64,
                tx_power_dbm: None,
            }));
            ev.push(LogEvent::Wifi(WifiScan {
                t_ns: t,
                results: vec![
                    WifiResult {
                        bssid: "0A:00:00:00:00:01".into(),
                        rssi_dbm: -70.0,
                        freq_mhz: 2412,
                        seen_t_ns: t,
                    },
                    WifiResult {
                        bssid: "0A:00:00:00:00:02".into(),
                        rssi_dbm: -75.0,
                        freq_mhz: 2412,
                        seen_t_ns: t,
                    },
                ],
            }));
        }
        ev.sort_by_key(|e| e.t_ns());
        let cfg = ReferenceScanConfig {
            window_s: 2.0,
            ..Default::default()
        };
        let mut b = ReferenceScanBuilder::new(&cfg, Some(0)).unwrap();
        b.add_log(&ev);
        let s = b.finish().unwrap();
        assert_eq!(s.ids().len(), 3);
        assert!(s.scans().len() >= 15, "{}", s.scans().len());
        // the first scan ends 2 s after the first reading, at x = 2.5
        let f = &s.scans()[0];
        assert!((f.x_m - 2.5).abs() < 1e-6, "{f:?}");
        // mean of the adverts at 1.5 s (-61) and 2.5 s (-62): the window
        // is (end - 2 s, end]
        let ble = s.ids().iter().position(|(k, _)| *k == TxKind::Ble).unwrap() as u32;
        let r = f.tx.iter().find(|(j, _)| *j == ble).unwrap().1;
        assert_eq!(r, -615, "{f:?}");
        // querying with the trail of a walker at x = 10.5 finds x = 10.5
        let mut trail = ScanTrail::default();
        for i in 8..=10 {
            let t = i * 1_000_000_000 + 500_000_000;
            trail.push(t, ble, -60.0 - i as f64);
            for (bssid, r) in [("0a:00:00:00:00:01", -70.0), ("0a:00:00:00:00:02", -75.0)] {
                trail.push(t, s.index_of(TxKind::Wifi, bssid).unwrap(), r);
            }
        }
        let q = trail.vector(10_500_000_000, 2.0, 0.0);
        assert_eq!(q.len(), 3);
        let c = s.query(&q, true, true, 1);
        assert!((c[0].pos.x - 10.5).abs() < 1.01, "{c:?}");
    }
}
