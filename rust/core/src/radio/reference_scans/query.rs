//! The k-nearest-neighbour query of the reference scans: the postings
//! walk of each metric, the RMS distance, the Bray-Curtis score and the
//! weighted candidates.

use super::{Candidate, ReferenceScans, ScanMetric, WeightedCandidate, powed_level};
use crate::Vec2;
use crate::radio::model::TxKind;

/// A query's running sums for one scan under [`ScanMetric::RmsDb`]: the
/// shared transmitters' correction of the RMS sum and their count (one
/// struct: one cache line per posting visited).
#[derive(Debug, Clone, Copy, Default)]
struct SharedSums {
    corr: f64,
    n: u32,
}

impl ReferenceScans {
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
        self.query_among(query, use_ble, use_wifi, k, metric, |_| true)
    }

    /// [`ReferenceScans::query_with`] over the scans `keep` accepts (by
    /// index).
    pub(super) fn query_among(
        &self,
        query: &[(u32, f64)],
        use_ble: bool,
        use_wifi: bool,
        k: usize,
        metric: ScanMetric,
        keep: impl Fn(usize) -> bool,
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
                if min_powed.is_sign_negative() || !keep(si) {
                    continue;
                }
                let score = self.powed_score(si, q_powed, min_powed, use_ble, use_wifi);
                out.push((score, f64::NAN, si));
            }
        } else {
            for (si, sh) in self.shared_sums(&q).iter().enumerate() {
                if sh.n > 0 && keep(si) {
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

    /// The RMS dB distance of scan `si` from a query of `q_len`
    /// transmitters whose "heard on the query's side only" sum is
    /// `q_only`, given the shared transmitters' correction and count.
    pub(super) fn rms_db(
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
    pub(super) fn powed_score(
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

    /// Whether `query` holds a BLE and a WiFi transmitter: the radios a
    /// query over what it holds uses.
    pub(super) fn radios_in(&self, query: &[(u32, f64)]) -> (bool, bool) {
        let has = |kind: TxKind| query.iter().any(|(j, _)| self.kind(*j) == Some(kind));
        (has(TxKind::Ble), has(TxKind::Wifi))
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
        let (ble, wifi) = self.radios_in(query);
        let c = self.query_with(query, ble, wifi, k, metric);
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
