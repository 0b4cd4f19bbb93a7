//! Building reference scans from survey logs with truth.

use std::collections::BTreeMap;

use super::{
    MAX_REFERENCE_ENTRIES, MAX_REFERENCE_IDS, MAX_REFERENCE_SCANS, MAX_SCAN_TRANSMITTERS,
    ReferenceScan, ReferenceScanConfig, ReferenceScans,
};
use crate::Result;
use crate::events::LogEvent;
use crate::radio::model::TxKind;
use crate::radio::survey::{RadioSample, SurveyCounts, SurveyOptions, survey_samples};

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

    /// The walk (log, counted from 0) of each scan so far.
    pub fn walk_of(&self) -> &[usize] {
        &self.walk_of
    }

    /// The set.
    pub fn finish(self) -> Result<ReferenceScans> {
        ReferenceScans::new(self.cfg, self.ids, self.scans)
    }

    /// The set with `offset_db(walk, kind)` (walks counted from 0 in the
    /// order their logs were added) subtracted from every reading of that
    /// walk's scans: the survey walks' own offsets
    /// ([`crate::radio::walk_offsets`]), as the radio map removed them.
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
