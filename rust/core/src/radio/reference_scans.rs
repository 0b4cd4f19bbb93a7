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
//!
//! Layout: this file holds the set, its configuration and its checks;
//! `query` (and `powed_walk`) the k-nearest-neighbour query,
//! `candidates` what a query gives, `builder` the set from survey logs,
//! `trail` the phone's own trailing window, `left_out` each survey scan
//! read against the other walks' scans.

use serde::{Deserialize, Serialize};

use super::model::TxKind;
use crate::bounds::check_count;
use crate::{Error, Result};

mod builder;
mod candidates;
mod left_out;
mod powed_walk;
mod query;
mod trail;

pub use builder::ReferenceScanBuilder;
pub use candidates::{Candidate, CandidateFix, WeightedCandidate, candidate_fix};
pub use left_out::{LeftOutScan, MAX_GAP_M};
pub use trail::ScanTrail;

/// Most reference scans one set holds (a survey of ~55 h at 1 per s).
pub const MAX_REFERENCE_SCANS: usize = 200_000;
/// Most distinct transmitters.
pub const MAX_REFERENCE_IDS: usize = 100_000;
/// Most transmitters in one reference scan.
pub const MAX_SCAN_TRANSMITTERS: usize = 1024;
/// Most (transmitter, RSSI) entries over all scans (8 bytes each, 6 more
/// in the query's index: ~56 MB; ILC F1's 53 survey walks hold ~180 000).
pub const MAX_REFERENCE_ENTRIES: usize = 4_000_000;

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

fn scan_entries<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<(u32, i16)>, D::Error> {
    crate::bounds::json::vec(d, MAX_SCAN_TRANSMITTERS)
}

/// One reference scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceScan {
    pub floor: i32,
    /// The walker's position at the window's end, MCS metres.
    pub x_m: f64,
    pub y_m: f64,
    /// (transmitter index into `ids`, mean RSSI x 10 dBm), by index; at
    /// most [`MAX_SCAN_TRANSMITTERS`] (counted while parsing).
    #[serde(deserialize_with = "scan_entries")]
    pub tx: Vec<(u32, i16)>,
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
    /// [`crate::radio_id::normalize_beacon_id`] gives them, BSSIDs
    /// lower-case).
    pub fn index_of(&self, kind: TxKind, canonical_id: &str) -> Option<u32> {
        self.index.get(kind, canonical_id).map(|j| j as u32)
    }

    /// Kind of transmitter `j`.
    pub fn kind(&self, j: u32) -> Option<TxKind> {
        self.ids.get(j as usize).map(|x| x.0)
    }
}

#[cfg(test)]
mod tests;
