//! WiFi rows of the real logs in ../shared/datasets (when present): every
//! scan the readers deliver is checked against the raw rows read here
//! independently (arrival time, BSSIDs, last-seen times), and the scan
//! rates, result ages and bands are printed (docs/wifi.md quotes them).

use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::Path;

use fpbp_core::events::{LogEvent, WifiScan};
use fpbp_logs::{ReadOptions, decompressing, open_log};

mod common;
use common::{datasets, gz_files};

fn raw_lines(path: &Path) -> Vec<String> {
    let f = std::fs::File::open(path).unwrap();
    decompressing(f)
        .unwrap()
        .lines()
        .map(|l| l.unwrap())
        .collect()
}

/// What the reader delivered: scans and the ILC origin.
fn scans(path: &Path) -> (Vec<WifiScan>, Option<i64>, u64) {
    let mut r = open_log(path, &ReadOptions::default()).unwrap();
    let mut v = Vec::new();
    while let Some(e) = r.try_next().unwrap() {
        if let LogEvent::Wifi(w) = e {
            v.push(w);
        }
    }
    let rep = r.report();
    assert_eq!(rep.malformed_wifi_rows, 0, "{:?}", rep.first_malformed_wifi);
    (v, r.ilc_origin_ms(), rep.wifi_rows)
}

fn pct(v: &[f64], p: f64) -> f64 {
    fpbp_core::stats::quantile(v, p).unwrap_or(f64::NAN)
}

#[derive(Default)]
struct Stats {
    scans: usize,
    results: usize,
    intervals_s: Vec<f64>,
    ages_s: Vec<f64>,
    band5: usize,
    bssids: std::collections::BTreeSet<String>,
}

impl Stats {
    fn add(&mut self, s: &[WifiScan]) {
        self.scans += s.len();
        for w in s.windows(2) {
            self.intervals_s.push((w[1].t_ns - w[0].t_ns) as f64 * 1e-9);
        }
        for w in s {
            self.results += w.results.len();
            for r in &w.results {
                self.ages_s.push((w.t_ns - r.seen_t_ns) as f64 * 1e-9);
                self.band5 += usize::from(r.freq_mhz >= 4900);
                self.bssids.insert(r.bssid.clone());
            }
        }
    }

    fn print(&mut self, name: &str) {
        let n = self.results.max(1) as f64;
        let old = self.ages_s.iter().filter(|a| **a > 5.0).count() as f64 / n;
        println!(
            "{name}: {} scans, {:.0} results/scan, interval p10/p50/p90 {:.2}/{:.2}/{:.2} s, age p50/p90/max {:.2}/{:.2}/{:.1} s, {:.1} % older than 5 s, 5 GHz {:.1} % of results, {} BSSIDs",
            self.scans,
            self.results as f64 / self.scans.max(1) as f64,
            pct(&self.intervals_s, 0.1),
            pct(&self.intervals_s, 0.5),
            pct(&self.intervals_s, 0.9),
            pct(&self.ages_s, 0.5),
            pct(&self.ages_s, 0.9),
            pct(&self.ages_s, 1.0),
            100.0 * old,
            100.0 * self.band5 as f64 / n,
            self.bssids.len()
        );
    }
}

#[test]
fn ilc_wifi_scans_match_the_raw_rows_with_their_times() {
    let Some(d) = datasets() else { return };
    for (floor, n_files) in [("ilc/site2/F4", 26), ("ilc/site1/F1", 106)] {
        let files = gz_files(&d.join(floor).join("path_data_files"));
        assert_eq!(files.len(), n_files);
        let mut st = Stats::default();
        for f in &files {
            // raw: arrival ms -> [(bssid, last-seen ms)]
            let mut raw: BTreeMap<i64, Vec<(String, i64)>> = BTreeMap::new();
            for l in raw_lines(f) {
                let c: Vec<&str> = l.split('\t').collect();
                if c.get(1) == Some(&"TYPE_WIFI") {
                    raw.entry(c[0].parse().unwrap())
                        .or_default()
                        .push((c[3].to_lowercase(), c[6].parse().unwrap()));
                }
            }
            let (got, origin, rows) = scans(f);
            let origin = origin.unwrap();
            assert_eq!(got.len(), raw.len(), "{}", f.display());
            assert_eq!(rows as usize, raw.values().map(Vec::len).sum::<usize>());
            for (w, (t_ms, rs)) in got.iter().zip(&raw) {
                assert_eq!(w.t_ns, (t_ms - origin) * 1_000_000, "{}", f.display());
                let back: Vec<(String, i64)> = w
                    .results
                    .iter()
                    .map(|r| (r.bssid.clone(), r.seen_t_ns / 1_000_000 + origin))
                    .collect();
                assert_eq!(&back, rs, "{} at {t_ms}", f.display());
                assert!(w.results.iter().all(|r| r.seen_t_ns <= w.t_ns));
            }
            st.add(&got);
        }
        st.print(floor);
        // Last-seen times are not the arrival times: some results are seconds old.
        assert!(st.ages_s.iter().any(|a| *a > 5.0), "{floor}");
    }
}

#[test]
fn ipin_wifi_scans_match_the_raw_rows_with_their_times() {
    let Some(d) = datasets() else { return };
    let files = gz_files(&d.join("ipin2023/logs"));
    let mut st = [Stats::default(), Stats::default()];
    for f in &files {
        let mut raw: BTreeMap<i64, Vec<String>> = BTreeMap::new();
        let mut model = String::new();
        for l in raw_lines(f) {
            if l.starts_with("% Model:") {
                model = l.split_whitespace().last().unwrap_or("").to_string();
            }
            let c: Vec<&str> = l.split(';').collect();
            if c[0] == "WIFI" {
                let t_ns = (c[1].parse::<f64>().unwrap() * 1e9).round() as i64;
                raw.entry(t_ns).or_default().push(c[4].to_lowercase());
            }
        }
        let (got, _, _) = scans(f);
        assert_eq!(got.len(), raw.len(), "{}", f.display());
        for (w, (t_ns, rs)) in got.iter().zip(&raw) {
            assert_eq!(w.t_ns, *t_ns);
            let back: Vec<&String> = w.results.iter().map(|r| &r.bssid).collect();
            assert_eq!(back, rs.iter().collect::<Vec<_>>());
            assert!(w.results.iter().all(|r| r.seen_t_ns == w.t_ns));
        }
        st[usize::from(model == "SM-G930F")].add(&got);
    }
    st[0].print("ipin SM-A520F");
    st[1].print("ipin SM-G930F");
    assert!(st.iter().all(|s| s.scans > 0));
}
