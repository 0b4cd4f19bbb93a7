//! Reference scans: the query against its definition, the levels, the
//! trail, the builder.

use std::collections::BTreeMap;

use super::*;
use crate::events::LogEvent;

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

#[test]
fn a_left_out_scan_is_read_against_the_other_walks_only() {
    // walk 0 at x 0 and 1, walk 1 at x 2 (3 dB off walk 0's x-1 scan on one
    // radio: RMS sqrt(9 / 2)) and x 40 (alone: no other walk within
    // MAX_GAP_M)
    let s = set(
        vec![
            scan(0.0, &[(0, -50.0), (1, -70.0)]),
            scan(1.0, &[(0, -52.0), (1, -68.0)]),
            scan(2.0, &[(0, -55.0), (1, -68.0)]),
            scan(40.0, &[(0, -80.0), (1, -40.0)]),
        ],
        2,
    );
    let walk_of = [0, 0, 1, 1];
    let rms = ScanMetric::RmsDb;
    let lo = s.left_out_distances(&walk_of, rms, 1).unwrap();
    assert_eq!(lo.len(), 4);
    // its own walk's x-0 scan is closer (2 dB on each radio) but left out
    let d = (9.0f64 / 2.0).sqrt();
    assert!((lo[1].dist_db - d).abs() < 1e-9, "{lo:?}");
    assert!((lo[1].gap_m - 1.0).abs() < 1e-9);
    assert!((lo[0].gap_m - 2.0).abs() < 1e-9);
    // walk 1's x-2 scan: walk 0's x-1 scan is the closest
    assert!((lo[2].dist_db - d).abs() < 1e-9, "{lo:?}");
    // walk 0's x-0 scan: walk 1's x-2 scan, 5 and 2 dB off
    assert!(
        (lo[0].dist_db - (29.0f64 / 2.0).sqrt()).abs() < 1e-9,
        "{lo:?}"
    );
    assert!(lo[3].gap_m.is_infinite());
    assert!(lo[3].dist_db > 25.0);
    // ranked as the anchors rank by default: the same left-out scans
    let powed = s
        .left_out_distances(&walk_of, ScanMetric::BrayCurtisPowed, 1)
        .unwrap();
    assert!((powed[1].dist_db - d).abs() < 1e-9, "{powed:?}");
    assert!((powed[2].dist_db - d).abs() < 1e-9, "{powed:?}");
    // every second scan only
    assert_eq!(s.left_out_distances(&walk_of, rms, 2).unwrap().len(), 2);
    // the walks must cover the scans
    assert!(s.left_out_distances(&walk_of[..3], rms, 1).is_err());
}
