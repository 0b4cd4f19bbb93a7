//! Reader tests on small excerpts generated here.

use std::io::Write;

use fpbp_core::events::{
    BleObservation, GnssFix, LogEvent, SensorData, SensorEvent, TruthPoint, WifiResult, WifiScan,
};
use proptest::prelude::*;

use super::*;

fn read_str(text: &str, opts: &ReadOptions) -> Result<(Vec<LogEvent>, ReadReport), LogError> {
    let mut r = LogReader::from_reader(
        "mem.txt",
        std::io::Cursor::new(text.as_bytes().to_vec()),
        opts,
    )?;
    let mut v = Vec::new();
    while let Some(e) = r.try_next()? {
        v.push(e);
    }
    Ok((v, r.report()))
}

fn gz(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn sample_events() -> Vec<LogEvent> {
    vec![
        LogEvent::Sensor(SensorEvent {
            t_ns: 10,
            data: SensorData::Accelerometer([0.1, -0.2, 9.81]),
        }),
        LogEvent::Sensor(SensorEvent {
            t_ns: 10,
            data: SensorData::Gyroscope([1e-9, 0.0, -3.5]),
        }),
        LogEvent::Sensor(SensorEvent {
            t_ns: 11,
            data: SensorData::Magnetometer([20.0, -5.5, -40.25]),
        }),
        LogEvent::Sensor(SensorEvent {
            t_ns: 12,
            data: SensorData::RotationVector([0.1, 0.2, 0.3, 0.9273618495495703]),
        }),
        LogEvent::Sensor(SensorEvent {
            t_ns: 12,
            data: SensorData::GameRotationVector([0.0, 0.0, 0.6, 0.8]),
        }),
        LogEvent::Sensor(SensorEvent {
            t_ns: 13,
            data: SensorData::Pressure(1013.25),
        }),
        LogEvent::Ble(BleObservation {
            t_ns: 14,
            beacon_id: "ibeacon:ABC:1:2".into(),
            rssi_dbm: -71.0,
            tx_power_dbm: Some(-59.0),
        }),
        LogEvent::Ble(BleObservation {
            t_ns: 15,
            beacon_id: "mac:AA:BB:CC:DD:EE:FF".into(),
            rssi_dbm: -90.0,
            tx_power_dbm: None,
        }),
        LogEvent::Gnss(GnssFix {
            t_ns: 16,
            lat_deg: 49.5,
            lon_deg: 11.1,
            alt_m: None,
            accuracy_m: Some(8.0),
            speed_mps: None,
            bearing_deg: Some(270.0),
        }),
        LogEvent::Wifi(WifiScan {
            t_ns: 16,
            results: vec![
                WifiResult {
                    bssid: "a8:0c:ca:03:9d:d7".into(),
                    rssi_dbm: -49.0,
                    freq_mhz: 2422,
                    seen_t_ns: -3_000_000_000,
                },
                WifiResult {
                    bssid: "a8:0c:ca:83:9d:d7".into(),
                    rssi_dbm: -59.5,
                    freq_mhz: 5785,
                    seen_t_ns: 16,
                },
            ],
        }),
        // a scan that heard nothing
        LogEvent::Wifi(WifiScan {
            t_ns: 17,
            results: vec![],
        }),
        LogEvent::Truth(TruthPoint {
            t_ns: 17,
            x_m: 12.5,
            y_m: 3.25,
            floor: Some(-2),
        }),
        LogEvent::Truth(TruthPoint {
            t_ns: 18,
            x_m: 1.0,
            y_m: 2.0,
            floor: None,
        }),
    ]
}

fn write_native(events: &[LogEvent], header: &NativeHeader) -> Vec<u8> {
    let mut w = NativeWriter::new(Vec::new(), header).unwrap();
    for e in events {
        w.write(e).unwrap();
    }
    w.finish().unwrap()
}

#[test]
fn native_round_trip_of_every_kind_plain_and_gzip() {
    let events = sample_events();
    let header = NativeHeader::new()
        .with("device", "Pixel 7 (test)")
        .with("seed", "42");
    let bytes = write_native(&events, &header);
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert!(
        text.starts_with("#fpbp-log 2\n#meta device=Pixel 7 (test)\n#meta seed=42\n"),
        "{text}"
    );
    for data in [bytes.clone(), gz(&bytes)] {
        let mut r =
            LogReader::from_reader("x", std::io::Cursor::new(data), &ReadOptions::default())
                .unwrap();
        assert_eq!(r.format(), LogFormat::Native);
        let got: Vec<_> = r.by_ref().collect();
        assert_eq!(got, events);
        assert_eq!(r.native_header(), Some(&header));
        let rep = r.report();
        assert_eq!(rep.events.total(), events.len() as u64);
        assert_eq!(rep.header_lines, 3);
        assert_eq!(rep.malformed_skipped, 0);
    }
}

#[test]
fn native_v1_files_still_read_and_v1_has_no_wifi() {
    // A v1 file as the v1 writer wrote it (every v1 kind).
    let v1: Vec<LogEvent> = sample_events()
        .into_iter()
        .filter(|e| !matches!(e, LogEvent::Wifi(_)))
        .collect();
    let mut w = NativeWriter::with_version(Vec::new(), &NativeHeader::new(), 1).unwrap();
    for e in &v1 {
        w.write(e).unwrap();
    }
    let text = String::from_utf8(w.finish().unwrap()).unwrap();
    assert!(text.starts_with("#fpbp-log 1\n"), "{text}");
    assert!(text.contains("\n10 ACC 0.1 -0.2 9.81\n"), "{text}");
    let mut r = LogReader::from_reader(
        "v1.log",
        std::io::Cursor::new(text.clone().into_bytes()),
        &ReadOptions::default(),
    )
    .unwrap();
    let got: Vec<_> = r.by_ref().collect();
    assert_eq!(got, v1);
    assert_eq!(r.native_version(), Some(1));
    // The v1 writer refuses WiFi; a WIFI line in a v1 file is a malformed WiFi row.
    let mut w = NativeWriter::with_version(Vec::new(), &NativeHeader::new(), 1).unwrap();
    let scan = sample_events()
        .into_iter()
        .find(|e| matches!(e, LogEvent::Wifi(_)))
        .unwrap();
    assert!(w.write(&scan).is_err());
    assert!(NativeWriter::with_version(Vec::new(), &NativeHeader::new(), 3).is_err());
    let bad = format!("{text}20 WIFI 1 a8:0c:ca:03:9d:d7 -49 2422 20\n");
    let (ev, rep) = read_str(&bad, &ReadOptions::default()).unwrap();
    assert_eq!(ev, v1);
    assert_eq!(rep.malformed_wifi_rows, 1);
    let named = rep.first_malformed_wifi.unwrap();
    assert!(named.contains("need native log version 2"), "{named}");
}

#[test]
fn native_wifi_lines_are_checked_before_allocating() {
    let cases = [
        ("1 WIFI 2 a8:0c:ca:03:9d:d7 -49 2422 1", "needs 9 values"),
        (
            "1 WIFI 99999999999 a8:0c:ca:03:9d:d7 -49 2422 1",
            "n_results",
        ),
        ("1 WIFI 1 A8:0C:CA:03:9D:D7x -49 2422 1", "bssid"),
        ("1 WIFI 1 a8:0c:ca:03:9d:d7 -49 2422 2", "after the scan"),
        ("1 WIFI 1 a8:0c:ca:03:9d:d7 -49 -5 1", "freq_mhz"),
    ];
    for (line, what) in cases {
        let text = format!("#fpbp-log 2\n0 ACC 0 0 9.8\n{line}\n");
        let (ev, rep) = read_str(&text, &ReadOptions::default()).unwrap();
        assert_eq!(ev.len(), 1, "{line}");
        assert_eq!((rep.malformed_wifi_rows, rep.malformed_skipped), (1, 1));
        let named = rep.first_malformed_wifi.unwrap();
        assert!(
            named.starts_with("mem.txt:3:") && named.contains(what),
            "{named}"
        );
        let strict = ReadOptions {
            strict: true,
            ..Default::default()
        };
        let e = read_str(&text, &strict).unwrap_err().to_string();
        assert!(e.starts_with("mem.txt:3:"), "{e}");
    }
    // Upper-case BSSIDs are read (normalised) but the writer wants them canonical.
    let (ev, _) = read_str(
        "#fpbp-log 2\n5 WIFI 1 A8:0C:CA:03:9D:D7 -49 2422 1\n",
        &ReadOptions::default(),
    )
    .unwrap();
    match &ev[0] {
        LogEvent::Wifi(w) => assert_eq!(w.results[0].bssid, "a8:0c:ca:03:9d:d7"),
        e => panic!("{e:?}"),
    }
    let mut w = NativeWriter::new(Vec::new(), &NativeHeader::new()).unwrap();
    let upper = LogEvent::Wifi(WifiScan {
        t_ns: 5,
        results: vec![WifiResult {
            bssid: "A8:0C:CA:03:9D:D7".into(),
            rssi_dbm: -49.0,
            freq_mhz: 2422,
            seen_t_ns: 1,
        }],
    });
    assert!(w.write(&upper).is_err());
}

fn wifi_scans(ev: &[LogEvent]) -> Vec<&WifiScan> {
    ev.iter()
        .filter_map(|e| match e {
            LogEvent::Wifi(w) => Some(w),
            _ => None,
        })
        .collect()
}

#[test]
fn ilc_wifi_rows_become_scans_with_their_ages() {
    // Generated in the ILC layout: two scans, the second with a result 20 s
    // old, a malformed row inside the first, sensor rows around them.
    let text = "#\tstartTime:1600000000000\n\
        1600000000500\tTYPE_ACCELEROMETER\t0.1\t0.2\t9.8\t3\n\
        1600000002000\tTYPE_WIFI\tFMI\ta8:0c:ca:03:9d:d7\t-49\t2422\t1600000001500\n\
        1600000002000\tTYPE_WIFI\t\tA8:0C:CA:83:9D:D7\t-59\t5785\t1600000001900\n\
        1600000002000\tTYPE_WIFI\tx\tnot-a-bssid\t-59\t5785\t1600000001900\n\
        1600000002000\tTYPE_WIFI\tFMI\t04:33:89:79:fc:7c\t-70\t2412\t1600000001000\n\
        1600000002010\tTYPE_ACCELEROMETER\t0.1\t0.2\t9.8\t3\n\
        1600000004100\tTYPE_WIFI\tFMI\ta8:0c:ca:03:9d:d7\t-51\t2422\t1600000004000\n\
        1600000004100\tTYPE_WIFI\told\t12:74:9c:2b:13:8f\t-80\t5180\t1599999984100\n\
        #\tendTime:1600000004200\n";
    let (ev, rep) = read_str(text, &ReadOptions::default()).unwrap();
    let scans = wifi_scans(&ev);
    assert_eq!(ev.len(), 4);
    assert_eq!(scans.len(), 2);
    assert_eq!(scans[0].t_ns, 2_000_000_000);
    let got: Vec<(&str, i64)> = scans[0]
        .results
        .iter()
        .map(|r| (r.bssid.as_str(), r.seen_t_ns))
        .collect();
    assert_eq!(
        got,
        vec![
            ("a8:0c:ca:03:9d:d7", 1_500_000_000),
            ("a8:0c:ca:83:9d:d7", 1_900_000_000),
            ("04:33:89:79:fc:7c", 1_000_000_000)
        ]
    );
    assert_eq!(scans[1].t_ns, 4_100_000_000);
    assert_eq!(scans[1].results[1].seen_t_ns, -15_900_000_000);
    assert_eq!((rep.events.wifi, rep.wifi_rows), (2, 5));
    assert_eq!((rep.malformed_wifi_rows, rep.malformed_skipped), (1, 1));
    assert!(
        rep.first_malformed_wifi
            .unwrap()
            .starts_with("mem.txt:5: field 4 (bssid)")
    );
    assert_eq!(rep.ignored_records, 0);
    let strict = ReadOptions {
        strict: true,
        ..Default::default()
    };
    let e = read_str(text, &strict).unwrap_err().to_string();
    assert!(e.starts_with("mem.txt:5:"), "{e}");
}

#[test]
fn ipin_wifi_rows_are_grouped_by_app_timestamp() {
    let text = "% GetSensorData-like header (generated)\n\
        ACCE;0.010;100.0;0.1;0.2;9.8;3\n\
        WIFI;0.651;65094.18;SSID2023_0001;20:23:00:00:00:01;2437;-60\n\
        WIFI;0.651;65094.1801;SSID2023_0025;20:23:00:00:00:80;5200;-70\n\
        ACCE;0.700;100.7;0.1;0.2;9.8;3\n\
        WIFI;4.6;65098.1;SSID2023_0001;20:23:00:00:00:01;2437;NaN\n\
        WIFI;4.6;65098.1;SSID2023_0001;20:23:00:00:00:01;2437;-62\n";
    let (ev, rep) = read_str(text, &ReadOptions::default()).unwrap();
    let scans = wifi_scans(&ev);
    assert_eq!(scans.len(), 2);
    assert_eq!(scans[0].t_ns, 651_000_000);
    assert_eq!(scans[0].results.len(), 2);
    assert_eq!(scans[0].results[1].freq_mhz, 5200);
    assert!(scans[0].results.iter().all(|r| r.seen_t_ns == 651_000_000));
    assert_eq!(scans[1].t_ns, 4_600_000_000);
    assert_eq!(scans[1].results.len(), 1);
    assert_eq!(rep.non_finite_dropped, 1);
    assert_eq!(rep.wifi_rows, 4);
}

#[test]
fn the_recording_phone_model_is_reported() {
    let ipin = "% Phone used for this logfile:\n\
        % Manufacturer:            \tsamsung\n\
        % Model:                   \tSM-G930F\n\
        ACCE;0.010;100.0;0.1;0.2;9.8;3\n";
    let (_, rep) = read_str(ipin, &ReadOptions::default()).unwrap();
    assert_eq!(rep.device.as_deref(), Some("SM-G930F"));
    let header = NativeHeader::new().with("device", "Pixel 7");
    let data = write_native(&sample_events(), &header);
    let mut r =
        LogReader::from_reader("n", std::io::Cursor::new(data), &ReadOptions::default()).unwrap();
    while r.try_next().unwrap().is_some() {}
    assert_eq!(r.report().device.as_deref(), Some("Pixel 7"));
    // no model line, an empty one: none
    let (_, rep) = read_str(
        "% Model:   \nACCE;0.010;100.0;0.1;0.2;9.8;3\n",
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(rep.device, None);
}

#[test]
fn writer_rejects_ids_with_spaces_and_bad_keys() {
    let mut w = NativeWriter::new(Vec::new(), &NativeHeader::new()).unwrap();
    let e = LogEvent::Ble(BleObservation {
        t_ns: 1,
        beacon_id: "a b".into(),
        rssi_dbm: -1.0,
        tx_power_dbm: None,
    });
    assert!(w.write(&e).is_err());
    assert!(NativeWriter::new(Vec::new(), &NativeHeader::new().with("a b", "x")).is_err());
}

#[test]
fn strict_mode_names_file_and_line_lenient_counts() {
    let text = "#fpbp-log 1\n1 ACC 0 0 9.8\n2 ACC 0 0\n3 FOO 1\n4 GYR 0 0 1\n";
    let err = read_str(
        text,
        &ReadOptions {
            strict: true,
            ..Default::default()
        },
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(msg.starts_with("mem.txt:3: ACC needs 3 values"), "{msg}");
    let (ev, rep) = read_str(text, &ReadOptions::default()).unwrap();
    assert_eq!(ev.len(), 2);
    assert_eq!(rep.malformed_skipped, 2);
    assert!(
        rep.first_malformed
            .as_deref()
            .unwrap()
            .starts_with("mem.txt:3:")
    );
    assert_eq!(rep.lines, 5);
}

#[test]
fn unknown_version_and_unknown_format_are_errors() {
    let e = read_str("#fpbp-log 7\n1 ACC 0 0 1\n", &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(e, LogError::UnsupportedVersion { line: 1, .. }),
        "{e}"
    );
    let e = read_str("hello\nworld\n", &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, LogError::UnknownFormat { .. }));
    let e = read_str("", &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, LogError::UnknownFormat { .. }));
}

#[test]
fn nan_backwards_duplicates_and_gaps_are_counted() {
    let text = "#fpbp-log 1\n\
        0 ACC 0 0 9.8\n\
        100000000 ACC NaN 0 9.8\n\
        200000000 ACC 0 0 9.7\n\
        150000000 BLE mac:AA:BB:CC:DD:EE:FF -80 -\n\
        200000000 ACC 0 0 9.7\n\
        5000000000 ACC 0 0 9.6\n\
        1000000 GYR 0 0 1\n\
        5000000000 PRS inf\n";
    let (ev, rep) = read_str(
        text,
        &ReadOptions {
            reorder_window_s: 3.0,
            ..Default::default()
        },
    )
    .unwrap();
    let ts: Vec<i64> = ev.iter().map(|e| e.t_ns()).collect();
    assert_eq!(ts, vec![0, 150_000_000, 200_000_000, 5_000_000_000]);
    assert_eq!(rep.non_finite_dropped, 2);
    assert_eq!(rep.duplicates_dropped, 1);
    assert_eq!(rep.late_dropped, 1);
    assert_eq!(rep.backwards_timestamps, 2);
    assert_eq!(rep.gaps_over_threshold, 1);
    assert!((rep.max_gap_s - 4.8).abs() < 1e-9);
    assert_eq!(rep.events.acc, 3);
    assert_eq!(rep.events.ble, 1);
}

#[test]
fn ilc_excerpt_is_sorted_and_deduplicated() {
    // Generated in the ILC layout: a BLE row and a waypoint step back in time,
    // the last waypoint is written again at the end.
    let text = "#\tstartTime:1600000000000\n\
        #\tSiteID:s\tSiteName:n\tFloorId:f\tFloorName:F2\n\
        1600000000010\tTYPE_WAYPOINT\t10.0\t20.0\n\
        1600000000020\tTYPE_ACCELEROMETER\t0.1\t0.2\t9.8\t3\n\
        1600000000020\tTYPE_ACCELEROMETER_UNCALIBRATED\t0.1\t0.2\t9.8\t0\t0\t0\t3\n\
        1600000000040\tTYPE_ACCELEROMETER\t0.1\t0.2\t9.9\t3\n\
        1600000000030\tTYPE_BLUE\t\t01:02:03:04:05:06\t-70\n\
        1600000000060\tTYPE_WAYPOINT\t11.0\t20.0\n\
        1600000000080\tTYPE_ACCELEROMETER\t0.1\t0.2\t9.7\t3\n\
        1600000000060\tTYPE_WAYPOINT\t11.0\t20.0\n\
        #\tendTime:1600000000090\n";
    let (ev, rep) = read_str(
        text,
        &ReadOptions {
            default_floor: Some(2),
            ..Default::default()
        },
    )
    .unwrap();
    let ts: Vec<i64> = ev.iter().map(|e| e.t_ns()).collect();
    assert_eq!(
        ts,
        vec![
            10_000_000, 20_000_000, 30_000_000, 40_000_000, 60_000_000, 80_000_000
        ]
    );
    assert_eq!(rep.format, Some(LogFormat::Ilc));
    assert_eq!(rep.events.truth, 2);
    assert_eq!(rep.duplicates_dropped, 1);
    assert_eq!(rep.backwards_timestamps, 1);
    assert_eq!(rep.ignored_records, 1);
    assert_eq!(rep.header_lines, 3);
    assert!(matches!(
        ev[0],
        LogEvent::Truth(TruthPoint { floor: Some(2), .. })
    ));
}

#[test]
fn ipin_excerpt_with_and_without_georef() {
    let text = "% GetSensorData-like header (generated)\n\
        ACCE;0.010;100.0;0.1;0.2;9.8;3\n\
        POSI;0.020;1;49.0;11.0;0;100\n\
        BLE4;0.030;iBeacon;AA:00:00:00:00:01;-80;0;1;2;abcd\n";
    let (ev, rep) = read_str(text, &ReadOptions::default()).unwrap();
    assert_eq!(ev.len(), 2);
    assert_eq!(rep.truth_without_georef, 1);
    assert_eq!(rep.format, Some(LogFormat::Ipin));
    let g = fpbp_core::site::GeoRef {
        lat_deg: 49.0,
        lon_deg: 11.0,
        x_m: 5.0,
        y_m: 6.0,
    };
    let (ev, rep) = read_str(
        text,
        &ReadOptions {
            site_georef: Some((g, 0.3)),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(ev.len(), 3);
    assert_eq!(rep.truth_without_georef, 0);
    assert_eq!(
        ev[1],
        LogEvent::Truth(TruthPoint {
            t_ns: 20_000_000,
            x_m: 5.0,
            y_m: 6.0,
            floor: Some(0)
        })
    );
}

#[test]
fn open_log_reads_gzip_files_and_names_missing_files() {
    let dir = std::env::temp_dir().join(format!("fpbp-logs-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("a.log.gz");
    std::fs::write(
        &p,
        gz(&write_native(&sample_events(), &NativeHeader::new())),
    )
    .unwrap();
    let (ev, _) = read_all(&p, &ReadOptions::default()).unwrap();
    assert_eq!(ev, sample_events());
    let missing = dir.join("nope.log");
    let e = open_log(&missing, &ReadOptions::default()).err().unwrap();
    assert!(e.to_string().contains("nope.log"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn truncated_gzip_ends_with_io_error() {
    let bytes = gz(&write_native(
        &(0..50).flat_map(|_| sample_events()).collect::<Vec<_>>(),
        &NativeHeader::new(),
    ));
    let cut = bytes[..bytes.len() / 2].to_vec();
    let mut r =
        LogReader::from_reader("cut.gz", std::io::Cursor::new(cut), &ReadOptions::default())
            .unwrap();
    let n = r.by_ref().count();
    assert!(n < 550);
    assert!(r.error().is_some());
    assert!(r.report().io_error.unwrap().starts_with("cut.gz:"));
}

fn finite() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        any::<f64>().prop_filter("finite", |x| x.is_finite()),
        -1e3f64..1e3
    ]
}

fn event() -> impl Strategy<Value = LogEvent> {
    let t = -1_000_000_000i64..i64::MAX / 4;
    let opt = || proptest::option::of(finite());
    prop_oneof![
        (t.clone(), finite(), finite(), finite(), 0usize..3).prop_map(|(t_ns, a, b, c, k)| {
            let v = [a, b, c];
            let data = match k {
                0 => SensorData::Accelerometer(v),
                1 => SensorData::Gyroscope(v),
                _ => SensorData::Magnetometer(v),
            };
            LogEvent::Sensor(SensorEvent { t_ns, data })
        }),
        (
            t.clone(),
            finite(),
            finite(),
            finite(),
            finite(),
            any::<bool>()
        )
            .prop_map(|(t_ns, a, b, c, d, g)| {
                let q = [a, b, c, d];
                let data = if g {
                    SensorData::GameRotationVector(q)
                } else {
                    SensorData::RotationVector(q)
                };
                LogEvent::Sensor(SensorEvent { t_ns, data })
            }),
        (t.clone(), finite()).prop_map(|(t_ns, p)| LogEvent::Sensor(SensorEvent {
            t_ns,
            data: SensorData::Pressure(p)
        })),
        (t.clone(), "[a-zA-Z0-9:_.-]{1,40}", finite(), opt()).prop_map(
            |(t_ns, beacon_id, rssi_dbm, tx_power_dbm)| LogEvent::Ble(BleObservation {
                t_ns,
                beacon_id,
                rssi_dbm,
                tx_power_dbm
            })
        ),
        (t.clone(), finite(), finite(), opt(), opt(), opt(), opt()).prop_map(
            |(t_ns, lat_deg, lon_deg, alt_m, accuracy_m, speed_mps, bearing_deg)| {
                LogEvent::Gnss(GnssFix {
                    t_ns,
                    lat_deg,
                    lon_deg,
                    alt_m,
                    accuracy_m,
                    speed_mps,
                    bearing_deg,
                })
            }
        ),
        (
            t.clone(),
            proptest::collection::vec(
                (
                    any::<[u8; 6]>(),
                    finite(),
                    1u32..100_000,
                    0i64..1_000_000_000_000
                ),
                0..5
            )
        )
            .prop_map(|(t_ns, rs)| LogEvent::Wifi(WifiScan {
                t_ns,
                results: rs
                    .into_iter()
                    .map(|(b, rssi_dbm, freq_mhz, age)| WifiResult {
                        bssid: b
                            .iter()
                            .map(|x| format!("{x:02x}"))
                            .collect::<Vec<_>>()
                            .join(":"),
                        rssi_dbm,
                        freq_mhz,
                        seen_t_ns: t_ns - age,
                    })
                    .collect()
            })),
        (t, finite(), finite(), proptest::option::of(any::<i32>())).prop_map(
            |(t_ns, x_m, y_m, floor)| LogEvent::Truth(TruthPoint {
                t_ns,
                x_m,
                y_m,
                floor
            })
        ),
    ]
}

proptest! {
    #[test]
    fn native_write_read_round_trip_is_exact(mut events in proptest::collection::vec(event(), 0..40)) {
        events.sort_by_key(|e| e.t_ns());
        let mut unique: Vec<LogEvent> = Vec::new();
        for e in events {
            if !unique.contains(&e) {
                unique.push(e);
            }
        }
        let events = unique;
        let bytes = write_native(&events, &NativeHeader::new().with("seed", "1"));
        let (got, rep) = read_str(&String::from_utf8(bytes).unwrap(), &ReadOptions::default()).unwrap();
        prop_assert_eq!(rep.malformed_skipped, 0);
        // Same-time events keep their order; exact duplicates are dropped by design.
        prop_assert_eq!(got, events);
    }

    #[test]
    fn arbitrary_lines_never_panic(lines in proptest::collection::vec("[ -~\t]{0,60}", 0..30), fmt in 0usize..4) {
        let head = ["#fpbp-log 1", "#\tstartTime:1000", "% ipin", "#fpbp-log 2"][fmt];
        let text = format!("{head}\n{}\n", lines.join("\n"));
        let r = read_str(&text, &ReadOptions::default());
        prop_assert!(r.is_ok());
    }
}
