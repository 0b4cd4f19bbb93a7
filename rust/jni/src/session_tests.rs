//! Tests of the bridge session (`super::session`).

use super::*;
use fpbp_core::engine::EngineStats;

/// A test double that records what reaches the engine.
#[derive(Default)]
struct Recorder {
    sensors: Vec<SensorEvent>,
    ble: Vec<BleObservation>,
    gnss: Vec<GnssFix>,
    wifi: Vec<WifiScan>,
    tasks: Vec<(Task, i64)>,
}

impl Engine for Recorder {
    fn name(&self) -> &'static str {
        "recorder"
    }
    fn on_sensor(&mut self, e: &SensorEvent) {
        self.sensors.push(*e);
    }
    fn on_ble(&mut self, o: &BleObservation) {
        self.ble.push(o.clone());
    }
    fn on_gnss(&mut self, f: &GnssFix) {
        self.gnss.push(*f);
    }
    fn run_task(&mut self, task: Task, t_ns: i64) {
        self.tasks.push((task, t_ns));
    }
    fn task_period_ns(&self, task: Task) -> Option<i64> {
        (task == Task::Fusion).then_some(200_000_000)
    }
    fn pose(&self) -> Option<Pose> {
        self.tasks.last().map(|(_, t)| Pose {
            t_ns: *t,
            x_m: 1.0,
            y_m: 2.0,
            floor: -1,
            heading_rad: 0.5,
            accuracy_m: 3.0,
            floor_prob: 1.0,
            source: fpbp_core::engine::PoseSource::Fused,
        })
    }
    fn stats(&self) -> EngineStats {
        EngineStats {
            sensor_events: self.sensors.len() as u64,
            ble_observations: self.ble.len() as u64,
            ..Default::default()
        }
    }
}

#[test]
fn bad_samples_are_counted_and_never_reach_the_engine() {
    let mut s = Session::from_engine(Box::new(Recorder::default()));
    s.on_sensor(1, 10, Some(&[0.0, 0.0, 9.8]));
    s.on_sensor(1, 11, Some(&[0.0, 9.8]));
    s.on_sensor(99, 12, Some(&[0.0, 0.0, 9.8]));
    s.on_sensor(4, 13, Some(&[f64::NAN, 0.0, 0.0]));
    s.on_sensor(4, 14, None);
    s.on_ble(15, None, -70.0, f64::NAN);
    s.on_ble(16, Some("mac:00:00:00:00:00:01".into()), -70.0, f64::NAN);
    s.on_gnss(17, f64::NAN, 11.0, [f64::NAN; 4]);
    s.on_gnss(18, 49.0, 11.0, [300.0, f64::NAN, f64::NAN, f64::NAN]);
    let stats: serde_json::Value =
        serde_json::from_str(&s.snapshot().stats_json()).expect("stats JSON");
    assert_eq!(stats["sensor_events"], 1);
    assert_eq!(stats["ble_observations"], 1);
    assert_eq!(stats["bridge_rejected"], 6);
    assert_eq!(stats["rejected_inputs"], 6);
    assert_eq!(stats["engine"], "recorder");
}

/// Passes BLE and GNSS through to a shared log the test can read.
struct Spy(std::sync::Arc<std::sync::Mutex<Recorder>>);

impl Engine for Spy {
    fn name(&self) -> &'static str {
        "spy"
    }
    fn on_sensor(&mut self, e: &SensorEvent) {
        self.0.lock().expect("spy").on_sensor(e);
    }
    fn on_ble(&mut self, o: &BleObservation) {
        self.0.lock().expect("spy").on_ble(o);
    }
    fn on_gnss(&mut self, f: &GnssFix) {
        self.0.lock().expect("spy").on_gnss(f);
    }
    fn on_wifi(&mut self, w: &WifiScan) {
        self.0.lock().expect("spy").wifi.push(w.clone());
    }
    fn run_task(&mut self, _: Task, _: i64) {}
    fn task_period_ns(&self, _: Task) -> Option<i64> {
        None
    }
    fn pose(&self) -> Option<Pose> {
        None
    }
    fn stats(&self) -> EngineStats {
        EngineStats::default()
    }
}

#[test]
fn optional_values_map_nan_to_none_and_values_pass_unchanged() {
    let shared = std::sync::Arc::new(std::sync::Mutex::new(Recorder::default()));
    let mut s = Session::from_engine(Box::new(Spy(shared.clone())));
    s.on_ble(1, Some("mac:00:00:00:00:00:01".into()), -70.0, -59.0);
    s.on_ble(2, Some("mac:00:00:00:00:00:01".into()), -71.5, f64::NAN);
    s.on_gnss(3, 49.0, 11.0, [300.0, f64::NAN, 1.5, f64::INFINITY]);
    s.on_sensor(11, 4, Some(&[0.1, 0.2, 0.3, 0.9, 2.0]));
    assert_eq!(s.task_period_ns(Task::Radio), 0);
    let r = shared.lock().expect("spy");
    assert_eq!(r.ble[0].tx_power_dbm, Some(-59.0));
    assert_eq!(r.ble[1].tx_power_dbm, None);
    assert_eq!(r.ble[1].rssi_dbm, -71.5);
    let g = r.gnss[0];
    assert_eq!(
        (g.alt_m, g.accuracy_m, g.speed_mps, g.bearing_deg),
        (Some(300.0), None, Some(1.5), None)
    );
    assert_eq!(
        r.sensors[0].data,
        SensorData::RotationVector([0.1, 0.2, 0.3, 0.9])
    );
}

#[test]
fn task_codes_periods_and_pose_layout() {
    assert_eq!(task_from_code(TASK_RADIO).expect("gml"), Task::Radio);
    assert_eq!(task_from_code(TASK_FUSION).expect("fusion"), Task::Fusion);
    assert!(matches!(
        task_from_code(2),
        Err(BridgeError::IllegalArgument(_))
    ));
    let mut s = Session::from_engine(Box::new(Recorder::default()));
    assert_eq!(s.task_period_ns(Task::Radio), 0);
    assert_eq!(s.task_period_ns(Task::Fusion), 200_000_000);
    assert!(s.pose().is_none());
    s.run_task(Task::Fusion, 42);
    let p = s.pose().expect("pose after a task");
    assert_eq!(p.t_ns, 42);
    let a = pose_to_array(&p, &MapFrame::default());
    assert_eq!(a[..7], [1.0, 2.0, -1.0, 0.5, 3.0, 1.0, 2.0]);
    assert!(a[pose_index::LAT_DEG].is_nan() && a[pose_index::LON_DEG].is_nan());
    // heading 0.5 rad from the MCS x axis (east here): bearing 90 - 28.6 deg
    assert!((a[pose_index::BEARING_DEG] - (90.0 - 0.5f64.to_degrees())).abs() < 1e-12);
    assert_eq!(s.snapshot().pose, Some(p));
}

#[test]
fn lat_lon_and_bearing_follow_the_site_frame() {
    let g = GeoRef {
        lat_deg: 48.0,
        lon_deg: 11.0,
        x_m: 10.0,
        y_m: 20.0,
    };
    let frame = MapFrame {
        georef: Some(g),
        map_from_enu_rad: 0.3,
    };
    let pose = Pose {
        t_ns: 1,
        x_m: 35.0,
        y_m: -4.0,
        floor: 0,
        heading_rad: 0.3 + std::f64::consts::FRAC_PI_2,
        accuracy_m: 1.0,
        floor_prob: 0.75,
        source: fpbp_core::engine::PoseSource::DeadReckoning,
    };
    let a = pose_to_array(&pose, &frame);
    let (lat, lon) = fpbp_core::geo::wgs84_from_mcs(&g, 0.3, Vec2::new(35.0, -4.0));
    assert_eq!((a[pose_index::LAT_DEG], a[pose_index::LON_DEG]), (lat, lon));
    let back = fpbp_core::geo::mcs_from_wgs84(&g, 0.3, lat, lon);
    assert!((back - Vec2::new(35.0, -4.0)).norm() < 1e-6);
    // MCS heading = ENU north rotated into the MCS: bearing 0
    assert!(a[pose_index::BEARING_DEG].abs() < 1e-9 || a[pose_index::BEARING_DEG] > 359.999);
    assert_eq!(
        (a[pose_index::FLOOR_PROB], a[pose_index::SOURCE]),
        (0.75, 1.0)
    );
}

#[test]
fn wifi_entries_are_normalized_and_bad_ones_counted() {
    let bssids = [
        Some("AA:BB:CC:DD:EE:01".to_string()),
        Some("aa-bb-cc-dd-ee-02".to_string()),
        None,
        Some("not a bssid".to_string()),
        Some("aa:bb:cc:dd:ee:05".to_string()),
        Some("aa:bb:cc:dd:ee:06".to_string()),
        Some("aa:bb:cc:dd:ee:07".to_string()),
    ];
    let rssi = [-60.0, -70.5, -50.0, -50.0, f64::NAN, -80.0, -81.0];
    let freq = [2412, 5180, 2412, 2412, 2412, 0, 2437];
    let seen = [90, 100, 100, 100, 100, 100, 101];
    let e = WifiEntries {
        bssids: &bssids,
        rssi_dbm: &rssi,
        freq_mhz: &freq,
        seen_t_ns: &seen,
    };
    let (r, bad) = wifi_results(100, &e);
    assert_eq!(bad, 5);
    assert_eq!(r.len(), 2);
    assert_eq!(
        (
            r[0].bssid.as_str(),
            r[0].rssi_dbm,
            r[0].freq_mhz,
            r[0].seen_t_ns
        ),
        ("aa:bb:cc:dd:ee:01", -60.0, 2412, 90)
    );
    assert_eq!(r[1].bssid, "aa:bb:cc:dd:ee:02");
    let shared = std::sync::Arc::new(std::sync::Mutex::new(Recorder::default()));
    let mut s = Session::from_engine(Box::new(Spy(shared.clone())));
    s.on_wifi(100, &e);
    let none: [Option<String>; 1] = [None];
    let all_bad = WifiEntries {
        bssids: &none,
        rssi_dbm: &rssi[..1],
        freq_mhz: &freq[..1],
        seen_t_ns: &seen[..1],
    };
    s.on_wifi(200, &all_bad);
    let empty = WifiEntries {
        bssids: &[],
        rssi_dbm: &[],
        freq_mhz: &[],
        seen_t_ns: &[],
    };
    s.on_wifi(300, &empty);
    s.reject_wifi_scan("lengths differ");
    let r = shared.lock().expect("spy");
    assert_eq!(
        r.wifi
            .iter()
            .map(|w| (w.t_ns, w.results.len()))
            .collect::<Vec<_>>(),
        [(100, 2), (300, 0)]
    );
    let stats: serde_json::Value =
        serde_json::from_str(&s.snapshot().stats_json()).expect("stats JSON");
    assert_eq!(stats["wifi_scans"], 2);
    assert_eq!(stats["wifi_results"], 2);
    assert_eq!(stats["bridge_rejected"], 5 + 1 + 1);
}

#[test]
fn set_position_refused_by_an_engine_is_unsupported() {
    let mut s = Session::from_engine(Box::new(Recorder::default()));
    let at = InitialPosition {
        x_m: 1.0,
        y_m: 2.0,
        floor: 0,
        heading_rad: None,
    };
    match s.set_position(5, at) {
        Err(BridgeError::Unsupported(m)) => assert!(m.contains("recorder"), "{m}"),
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn initial_position_array() {
    let p = init_from_array(&[1.5, 2.5, -1.0, f64::NAN]).expect("init");
    assert_eq!((p.x_m, p.y_m, p.floor, p.heading_rad), (1.5, 2.5, -1, None));
    let p = init_from_array(&[1.5, 2.5, 0.0, 0.25]).expect("init");
    assert_eq!(p.heading_rad, Some(0.25));
    for bad in [
        &[1.0, 2.0][..],
        &[1.0, 2.0, 0.5, 0.0],
        &[f64::NAN, 2.0, 0.0, 0.0],
        &[1.0, 2.0, 1e12, 0.0],
    ] {
        assert!(
            matches!(init_from_array(bad), Err(BridgeError::IllegalArgument(_))),
            "{bad:?}"
        );
    }
}

#[test]
fn unknown_engine_is_rejected_before_the_site_is_read() {
    let r = Session::start(
        "not json",
        Path::new("/nonexistent"),
        "",
        "no-such-engine",
        None,
        None,
    );
    match r {
        Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("no-such-engine"), "{m}"),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("started an unknown engine"),
    }
}

#[test]
fn bad_config_names_the_field() {
    let engine = fpbp_core::engines::ENGINE_NAMES
        .first()
        .copied()
        .unwrap_or("fpbp");
    let r = Session::start(
        "{}",
        Path::new("."),
        r#"{"tasks": {"fusion_period_ms": 0}}"#,
        engine,
        None,
        None,
    );
    match r {
        Err(BridgeError::IllegalArgument(m)) => {
            assert!(
                m.contains("tasks.fusion_period_ms") || m.contains("unknown engine"),
                "{m}"
            )
        }
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("started with a bad config"),
    }
}

/// The stats JSON carries the engine's online phone RSSI offset and
/// step scale (issue 16: "reported in stats"): the same values as the
/// engine's own `stats` for the same input; null for an engine that
/// estimates none.
#[test]
fn stats_report_the_phone_offset_the_engine_estimates() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let site_json = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
    let site = Arc::new(site_loader::load_site(&site_json, &dir).expect("site"));
    let at = InitialPosition {
        x_m: 12.0,
        y_m: 8.0,
        floor: 0,
        heading_rad: None,
    };
    let cfg = EngineConfig::default();
    let mut e =
        fpbp_core::engines::tcpf::TcpfEngine::new(site.clone(), &cfg, Some(at)).expect("tcpf");
    let mut s = Session::start(&site_json, &dir, "", "tcpf", Some(at), None).expect("session");
    // every beacon heard 9 dB weaker than the site's model says at `at`
    let p = Vec2::new(at.x_m, at.y_m);
    let heard: Vec<(String, f64)> = (e.model().transmitters().iter().enumerate())
        .filter_map(|(k, t)| Some((t.id.clone(), e.model().expected(k, 0, p)?.0 - 9.0)))
        .collect();
    assert!(heard.len() >= 4, "demo beacons: {}", heard.len());
    for second in 1..=30i64 {
        let t_ns = second * 1_000_000_000;
        for (id, rssi) in &heard {
            e.on_ble(&BleObservation {
                t_ns,
                beacon_id: id.clone(),
                rssi_dbm: *rssi,
                tx_power_dbm: None,
            });
            s.on_ble(t_ns, Some(id.clone()), *rssi, f64::NAN);
        }
        for task in [Task::Radio, Task::Fusion] {
            e.run_task(task, t_ns);
            s.run_task(task, t_ns);
        }
    }
    let stats: serde_json::Value =
        serde_json::from_str(&s.snapshot().stats_json()).expect("stats JSON");
    let core = e.stats();
    let offset = stats["rssi_offset_db"].as_f64().expect("an offset");
    assert_eq!(Some(offset), core.rssi_offset_db);
    assert!(offset < -4.0, "9 dB weaker, estimated {offset} dB");
    assert_eq!(stats["step_scale"].as_f64(), core.step_scale);
    // the radio's trust as the engine reports it (1: no told start, so
    // the fit check does not run, and the pull check is off)
    assert_eq!(stats["radio_trust"].as_f64(), core.radio_trust);
    assert_eq!(core.radio_trust, Some(1.0));
    // no radio map, so no phone model's offsets
    assert!(stats["device_ble_offset_db"].is_null() && stats["device_wifi_offset_db"].is_null());
    let other = Session::from_engine(Box::new(Recorder::default()));
    let stats: serde_json::Value =
        serde_json::from_str(&other.snapshot().stats_json()).expect("stats JSON");
    assert!(stats["rssi_offset_db"].is_null() && stats["step_scale"].is_null());
    assert!(stats["radio_trust"].is_null());
}

/// `start`'s data JSON is told apart by its `format`: a radio map goes
/// to `tcpf`, and its errors name the field.
#[test]
fn start_takes_a_radio_map_in_the_data_json() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let site = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
    let map = r#"{"format": "fpbp-radio-map", "version": 1, "transmitters": [
        {"id": "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:1", "kind": "ble",
         "floor": 0, "x_m": 3.5, "y_m": 3.5,
         "grids": [{"floor": 0, "x0_m": 0.0, "y0_m": 0.0, "cell_m": 2.0, "nx": 2, "ny": 1,
                    "mean_dbm_x10": [-600, -650], "sd_dbm_x10": [40, 45]}]}]}"#;
    let s = Session::start(&site, &dir, "", "tcpf", None, Some(map));
    assert!(s.is_ok(), "{:?}", s.err().map(|e| e.to_string()));
    let bad = map.replace("\"nx\": 2", "\"nx\": 3");
    match Session::start(&site, &dir, "", "tcpf", None, Some(&bad)) {
        Err(BridgeError::IllegalArgument(m)) => {
            assert!(m.contains("transmitters[0].grids[0].mean_dbm_x10"), "{m}")
        }
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("started with a bad radio map"),
    }
    // a fingerprint file still goes to the fingerprint parser
    let fp = r#"{"format": "fpbp-fingerprints", "version": 9}"#;
    match Session::start(&site, &dir, "", "robust-ekf", None, Some(fp)) {
        Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("fingerprint"), "{m}"),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("started with a bad fingerprint file"),
    }
}

/// A bundle of the demo site and a radio map starts the engine the
/// site and map texts start: the same poses on the same inputs; a
/// damaged bundle is an IllegalArgument naming the entry.
#[test]
fn start_bundle_equals_start_with_the_same_files() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let site = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
    let plan = std::fs::read(dir.join("plan.png")).expect("demo plan");
    let map = r#"{"format": "fpbp-radio-map", "version": 1, "transmitters": [
        {"id": "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:1", "kind": "ble",
         "floor": 0, "x_m": 3.5, "y_m": 3.5,
         "grids": [{"floor": 0, "x0_m": 0.0, "y0_m": 0.0, "cell_m": 2.0, "nx": 2, "ny": 1,
                    "mean_dbm_x10": [-600, -650], "sd_dbm_x10": [40, 45]}]}]}"#;
    let spec =
        fpbp_core::site::SiteSpec::from_json(site.as_bytes(), "site.json").expect("demo spec");
    let plan_name = spec.floors[0].plan.clone().expect("a plan");
    let plans = [(plan_name.as_str(), plan.as_slice())];
    let bytes = fpbp_core::bundle::write(&fpbp_core::bundle::BundleInput {
        site_json: site.as_bytes(),
        plans: &plans,
        radio_map_json: Some(map.as_bytes()),
        writer: "test",
    })
    .expect("bundle");
    assert_eq!(Session::bundle_site_json(&bytes).expect("site text"), site);
    let init = Some(InitialPosition {
        x_m: 5.0,
        y_m: 5.0,
        floor: 0,
        heading_rad: Some(0.0),
    });
    let mut a = Session::start(&site, &dir, "", "tcpf", init, Some(map)).expect("start");
    let mut b = Session::start_bundle(&bytes, "", "tcpf", init).expect("start bundle");
    for k in 0..40i64 {
        let t = k * 100_000_000;
        for s in [&mut a, &mut b] {
            s.on_sensor(1, t, Some(&[0.1, 0.2, 9.8]));
            s.on_ble(
                t,
                Some("ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:1".into()),
                -65.0 - (k % 5) as f64,
                f64::NAN,
            );
            s.run_task(Task::Fusion, t);
        }
        assert_eq!(a.snapshot(), b.snapshot(), "at {t}");
    }
    assert!(a.snapshot().pose.is_some());
    // a changed byte in the map entry: refused, naming it
    let mut bad = bytes.clone();
    let n = bad.len();
    bad[n - 20] ^= 0x55;
    match Session::start_bundle(&bad, "", "tcpf", None) {
        Err(BridgeError::IllegalArgument(m)) => {
            assert!(
                m.contains("bundle") && m.contains("radio-map.json.gz"),
                "{m}"
            )
        }
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("started from a damaged bundle"),
    }
    // the engine name is checked before the bundle is read
    match Session::start_bundle(&[], "", "nope", None) {
        Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("unknown engine"), "{m}"),
        _ => panic!("expected an unknown engine error"),
    }
}

/// Issue 60 item 10: a bundle over the core's limits (here a radio map of
/// 20 001 transmitters, refused while it streams) is an
/// IllegalArgumentException naming the entry and field, not an abort.
#[test]
fn start_bundle_over_the_limits_is_an_illegal_argument() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let site = std::fs::read_to_string(dir.join("site.json")).expect("demo site");
    let plan = std::fs::read(dir.join("plan.png")).expect("demo plan");
    let spec =
        fpbp_core::site::SiteSpec::from_json(site.as_bytes(), "site.json").expect("demo spec");
    let plan_name = spec.floors[0].plan.clone().expect("a plan");
    let plans = [(plan_name.as_str(), plan.as_slice())];
    let tx = r#"{"id": "mac:AA:BB:CC:DD:EE:01", "kind": "ble", "floor": 0, "x_m": 1, "y_m": 1},"#;
    let map = format!(
        r#"{{"format": "fpbp-radio-map", "version": 1, "transmitters": [{}{{}}]}}"#,
        tx.repeat(fpbp_core::bounds::MAX_RADIO_MAP_TRANSMITTERS + 1)
    );
    let bytes = fpbp_core::bundle::write(&fpbp_core::bundle::BundleInput {
        site_json: site.as_bytes(),
        plans: &plans,
        radio_map_json: Some(map.as_bytes()),
        writer: "test",
    })
    .expect("bundle");
    match Session::start_bundle(&bytes, "", "tcpf", None) {
        Err(e @ BridgeError::IllegalArgument(_)) => {
            assert_eq!(e.java_class(), "java/lang/IllegalArgumentException");
            let m = e.to_string();
            assert!(
                m.contains("radio-map.json.gz") && m.contains("more than 20000 elements"),
                "{m}"
            );
        }
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("started from a bundle over the limits"),
    }
}
