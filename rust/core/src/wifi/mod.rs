//! WiFi access points as one more kind of radio transmitter: BSSIDs and
//! bands, how the BSSIDs of one physical AP are grouped, which results of a
//! scan are new, calibration of APs from survey walks (the BLE calibration's
//! fit and acceptance tests, [`calibrate`]) and the config of all this.
//!
//! Site files list APs in `access_points` (one entry per BSSID, the fields
//! of a beacon; docs/formats.md). Android reports the BSSIDs of one AP as
//! separate results: one per SSID it serves (on the ILC mall APs the first
//! octet differs: `06:74:9c:2b:13:8f`, `0a:74:9c:2b:13:8f`, ...) and per
//! radio (2.4 / 5 GHz: the last nibble differs, `..:62:7a` at 2452 MHz,
//! `..:62:7b` at 5785 MHz). [`BssidGrouping`] says which of them share one
//! position and path-loss model.

pub mod calibrate;
pub mod config;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::events::{WifiResult, WifiScan};

pub use config::WifiConfig;

pub use crate::radio_id::{canonical_bssid, is_bssid, normalize_bssid};

/// A WiFi band from a channel centre frequency.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Band {
    /// 2400-2500 MHz.
    Ghz2_4,
    /// 4900-5900 MHz.
    Ghz5,
    /// 5925-7125 MHz.
    Ghz6,
    Other,
}

impl Band {
    pub fn of(freq_mhz: u32) -> Band {
        match freq_mhz {
            2400..=2500 => Band::Ghz2_4,
            4900..=5900 => Band::Ghz5,
            5925..=7125 => Band::Ghz6,
            _ => Band::Other,
        }
    }

    /// Short name (`2.4`, `5`, `6`, `other`).
    pub fn name(self) -> &'static str {
        match self {
            Band::Ghz2_4 => "2.4",
            Band::Ghz5 => "5",
            Band::Ghz6 => "6",
            Band::Other => "other",
        }
    }
}

/// Which BSSIDs share one position and path-loss model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BssidGrouping {
    /// Every BSSID on its own.
    #[default]
    Bssid,
    /// BSSIDs equal but for the first octet and the last nibble (the SSIDs
    /// and radios of one AP) and on the same band: one model per AP and band.
    ApBand,
    /// The same across bands: one position and one model per AP.
    Ap,
}

impl BssidGrouping {
    /// The transmitter a result belongs to: the BSSID itself, or
    /// `ap:<octets 2-5>:<high nibble of octet 6>x[/<band>]`.
    pub fn key(self, bssid: &str, freq_mhz: u32) -> String {
        match self {
            BssidGrouping::Bssid => bssid.to_string(),
            BssidGrouping::ApBand | BssidGrouping::Ap => {
                let core = bssid.get(3..16).unwrap_or(bssid);
                let mut k = format!("ap:{core}x");
                if self == BssidGrouping::ApBand {
                    k.push('/');
                    k.push_str(Band::of(freq_mhz).name());
                }
                k
            }
        }
    }
}

/// Picks the results of scans that are new measurements: Android (and ILC's
/// app) repeat a cached result in later scans with its old last-seen time,
/// so a result counts only when it was seen more than `repeat_tolerance_ns`
/// after the last counted result of its BSSID, and only when it is at most
/// `max_age_ns` older than its scan.
///
/// What it remembers is bounded: a BSSID whose last counted result is older
/// than the scan's `max_age_ns + REPEAT_TOLERANCE_NS` is forgotten (no
/// result fresh enough to count could be a repeat of it, so for scans in
/// time order this changes nothing), and beyond [`MAX_FRESH_BSSIDS`]
/// BSSIDs the oldest are dropped. Randomised hotspot MACs heard over a long
/// session would otherwise grow the map without end.
#[derive(Debug, Clone, Default)]
pub struct FreshResults {
    last_seen_ns: BTreeMap<String, i64>,
}

/// Last-seen times of one cached result differ by up to 1 ms between scans
/// on ILC (e.g. 1574559665384 and ...385).
pub const REPEAT_TOLERANCE_NS: i64 = 10_000_000;

/// Most BSSIDs [`FreshResults`] remembers; past it the oldest quarter is
/// dropped. A phone hears a few hundred in one scan (the JNI bridge takes at
/// most 512 per scan) and keeps only those of the last `max_age_ns`.
pub const MAX_FRESH_BSSIDS: usize = 4096;

impl FreshResults {
    /// The new results of `scan`, in scan order.
    pub fn of<'a>(&mut self, scan: &'a WifiScan, max_age_ns: i64) -> Vec<&'a WifiResult> {
        self.forget_older_than(
            scan.t_ns
                .saturating_sub(max_age_ns.max(0))
                .saturating_sub(REPEAT_TOLERANCE_NS),
        );
        let mut out = Vec::new();
        for r in &scan.results {
            if scan.t_ns.saturating_sub(r.seen_t_ns) > max_age_ns || !r.rssi_dbm.is_finite() {
                continue;
            }
            let last = self.last_seen_ns.get(&r.bssid).copied();
            if last.is_some_and(|l| r.seen_t_ns <= l.saturating_add(REPEAT_TOLERANCE_NS)) {
                continue;
            }
            match self.last_seen_ns.get_mut(&r.bssid) {
                Some(l) => *l = r.seen_t_ns,
                None => {
                    self.last_seen_ns.insert(r.bssid.clone(), r.seen_t_ns);
                }
            }
            out.push(r);
        }
        if self.last_seen_ns.len() > MAX_FRESH_BSSIDS {
            self.drop_oldest(MAX_FRESH_BSSIDS * 3 / 4);
        }
        out
    }

    /// BSSIDs remembered now.
    pub fn len(&self) -> usize {
        self.last_seen_ns.len()
    }

    /// Whether no BSSID is remembered.
    pub fn is_empty(&self) -> bool {
        self.last_seen_ns.is_empty()
    }

    /// Forgets every BSSID last counted before `cutoff_ns`. A result that
    /// passes the age test of a scan at `t` was seen at or after
    /// `t - max_age`, later than `cutoff + REPEAT_TOLERANCE_NS`: it counts
    /// whether or not the entry is still here.
    fn forget_older_than(&mut self, cutoff_ns: i64) {
        // cheap test first: most scans find nothing to forget
        if self.last_seen_ns.values().any(|&l| l < cutoff_ns) {
            self.last_seen_ns.retain(|_, l| *l >= cutoff_ns);
        }
    }

    /// Keeps at most `keep` BSSIDs, the most recently counted (ties at the
    /// cut are dropped together, so it may keep fewer).
    fn drop_oldest(&mut self, keep: usize) {
        let n = self.last_seen_ns.len();
        if n <= keep {
            return;
        }
        let mut times: Vec<i64> = self.last_seen_ns.values().copied().collect();
        let (_, &mut cut, _) = times.select_nth_unstable(n - keep - 1);
        self.last_seen_ns.retain(|_, l| *l > cut);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_bssid_lowers_only_what_needs_it() {
        use std::borrow::Cow;
        assert!(matches!(
            canonical_bssid("aa:bb:cc:dd:ee:0f"),
            Cow::Borrowed("aa:bb:cc:dd:ee:0f")
        ));
        assert_eq!(canonical_bssid("AA:bb:CC:dd:EE:0F"), "aa:bb:cc:dd:ee:0f");
        assert!(matches!(
            canonical_bssid("AA:BB:CC:DD:EE:0F"),
            Cow::Owned(_)
        ));
    }

    fn res(b: &str, seen: i64) -> WifiResult {
        WifiResult {
            bssid: b.into(),
            rssi_dbm: -60.0,
            freq_mhz: 2412,
            seen_t_ns: seen,
        }
    }

    #[test]
    fn bssids_bands_and_groups() {
        assert!(is_bssid("0a:74:9c:2b:62:7a"));
        assert!(!is_bssid("0A:74:9c:2b:62:7a") && !is_bssid("0a:74:9c:2b:62") && !is_bssid(""));
        assert_eq!(Band::of(2452), Band::Ghz2_4);
        assert_eq!(Band::of(5785), Band::Ghz5);
        assert_eq!(Band::of(900), Band::Other);
        let g = BssidGrouping::ApBand;
        assert_eq!(g.key("0a:74:9c:2b:62:7a", 2452), "ap:74:9c:2b:62:7x/2.4");
        assert_eq!(g.key("12:74:9c:2b:62:7b", 5785), "ap:74:9c:2b:62:7x/5");
        assert_eq!(
            BssidGrouping::Ap.key("12:74:9c:2b:62:7b", 5785),
            BssidGrouping::Ap.key("0a:74:9c:2b:62:7a", 2452)
        );
        assert_eq!(
            BssidGrouping::Bssid.key("0a:74:9c:2b:62:7a", 2452),
            "0a:74:9c:2b:62:7a"
        );
    }

    #[test]
    fn cached_and_old_results_are_not_new() {
        let mut f = FreshResults::default();
        let s1 = WifiScan {
            t_ns: 10_000_000_000,
            results: vec![
                res("00:00:00:00:00:01", 9_000_000_000),
                res("00:00:00:00:00:02", 1),
            ],
        };
        // max age 5 s: the second result is 10 s old
        assert_eq!(f.of(&s1, 5_000_000_000).len(), 1);
        // the same cached result again (1 ms later), and a new one
        let s2 = WifiScan {
            t_ns: 12_000_000_000,
            results: vec![
                res("00:00:00:00:00:01", 9_001_000_000),
                res("00:00:00:00:00:03", 11_000_000_000),
            ],
        };
        let got: Vec<&str> = f
            .of(&s2, 5_000_000_000)
            .iter()
            .map(|r| r.bssid.as_str())
            .collect();
        assert_eq!(got, vec!["00:00:00:00:00:03"]);
        let s3 = WifiScan {
            t_ns: 14_000_000_000,
            results: vec![res("00:00:00:00:00:01", 13_000_000_000)],
        };
        assert_eq!(f.of(&s3, 5_000_000_000).len(), 1);
    }

    /// The map stays bounded (issue 37: 10^6 randomised BSSIDs cost ~154 MB
    /// before): by age when scans move on, by the cap when they all arrive
    /// within the freshness window. Fails if either bound is removed.
    #[test]
    fn remembered_bssids_stay_bounded() {
        let bssid = |i: u64| {
            let b = i.to_be_bytes();
            format!(
                "{:02x}:{:02x}:{:02x}:{:02x}:{:02x}:{:02x}",
                b[2], b[3], b[4], b[5], b[6], b[7]
            )
        };
        let max_age = 5_000_000_000;
        // 120 000 distinct BSSIDs, 40 per scan, one scan a second: the age rule
        let mut f = FreshResults::default();
        let mut peak = 0;
        for k in 0..3000u64 {
            let t = 1_000_000_000 * (k as i64 + 1);
            let scan = WifiScan {
                t_ns: t,
                results: (0..40).map(|j| res(&bssid(k * 40 + j), t)).collect(),
            };
            assert_eq!(f.of(&scan, max_age).len(), 40, "every result is new");
            peak = peak.max(f.len());
        }
        // the scans of the last max_age + tolerance: 6 x 40
        assert!(peak <= 6 * 40, "remembered {peak} BSSIDs");
        // 120 000 distinct BSSIDs within one freshness window: the cap
        let mut f = FreshResults::default();
        for k in 0..3000u64 {
            let t = 1_000_000 * (k as i64 + 1);
            let scan = WifiScan {
                t_ns: t,
                results: (0..40).map(|j| res(&bssid(k * 40 + j), t)).collect(),
            };
            f.of(&scan, i64::MAX);
            assert!(f.len() <= MAX_FRESH_BSSIDS, "remembered {}", f.len());
        }
        assert!(f.len() >= MAX_FRESH_BSSIDS / 2, "kept too few: {}", f.len());
    }

    /// Forgetting by age never changes which results count, for scans in
    /// time order (what keeps tcpf's tracks as they were): the same seeded
    /// random scans through a bounded and an unbounded picker.
    #[test]
    fn forgetting_old_bssids_changes_no_result() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(37);
        let mut bounded = FreshResults::default();
        let mut plain: BTreeMap<String, i64> = BTreeMap::new();
        let max_age = 4_000_000_000;
        let mut t = 0i64;
        for _ in 0..3000 {
            t += rng.random_range(200_000_000..3_000_000_000i64);
            let results: Vec<WifiResult> = (0..rng.random_range(0..30))
                .map(|_| {
                    let ap = rng.random_range(0..60u32);
                    let age = rng.random_range(0..8_000_000_000i64);
                    res(&format!("00:00:00:00:00:{ap:02x}"), t - age)
                })
                .collect();
            let scan = WifiScan { t_ns: t, results };
            let got: Vec<(String, i64)> = bounded
                .of(&scan, max_age)
                .iter()
                .map(|r| (r.bssid.clone(), r.seen_t_ns))
                .collect();
            // the unbounded rule, as it was
            let mut want = Vec::new();
            for r in &scan.results {
                if scan.t_ns - r.seen_t_ns > max_age {
                    continue;
                }
                if plain
                    .get(&r.bssid)
                    .is_some_and(|&l| r.seen_t_ns <= l + REPEAT_TOLERANCE_NS)
                {
                    continue;
                }
                plain.insert(r.bssid.clone(), r.seen_t_ns);
                want.push((r.bssid.clone(), r.seen_t_ns));
            }
            assert_eq!(got, want, "at t = {t}");
        }
        assert!(bounded.len() < plain.len(), "nothing was ever forgotten");
    }
}
