//! Site bundles: round trip, and every malformed bundle refused with the
//! field or entry at fault, without a panic or an allocation sized by the
//! input.

use super::*;

/// A 40 x 20 px plan (r = 10 -> 4 m x 2 m): wall border, walkable inside.
fn plan_png() -> Vec<u8> {
    let img = image::RgbImage::from_fn(40, 20, |x, y| {
        if x == 0 || y == 0 || x == 39 || y == 19 {
            image::Rgb([0, 0, 0])
        } else {
            image::Rgb([255, 255, 255])
        }
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

const SITE: &str = r#"{"format": "fpbp-site", "version": 1, "name": "tiny",
  "floors": [{"id": 0, "plan": "plans/plan.png", "pixels_per_meter": 10.0}],
  "beacons": [{"id": "mac:AA:BB:CC:DD:EE:01", "floor": 0, "x_m": 1.0, "y_m": 1.0,
               "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0}]}"#;

const MAP: &str = r#"{"format": "fpbp-radio-map", "version": 1, "site": "tiny",
  "transmitters": [{"id": "mac:AA:BB:CC:DD:EE:01", "kind": "ble", "floor": 0,
    "x_m": 1.0, "y_m": 1.0, "samples": 12, "walks": 2,
    "pathloss": {"dz_m": 0.0, "rssi_1m_dbm": -58.1, "exponent": 2.3},
    "grids": [{"floor": 0, "x0_m": 0.5, "y0_m": 0.25, "cell_m": 1.0, "nx": 3, "ny": 1,
               "mean_dbm_x10": [-601, -32768, -655], "sd_dbm_x10": [41, -32768, 52]}]}]}"#;

fn bundle_of(map: Option<&str>) -> Vec<u8> {
    let png = plan_png();
    let plans = [("plans/plan.png", png.as_slice())];
    write(&BundleInput {
        site_json: SITE.as_bytes(),
        plans: &plans,
        radio_map_json: map.map(str::as_bytes),
        writer: "test",
    })
    .unwrap()
}

fn err(bytes: &[u8]) -> String {
    match Bundle::parse(bytes) {
        Ok(_) => panic!("parsed"),
        Err(e) => e.to_string(),
    }
}

/// The manifest's bytes and the entries' start in a bundle.
fn split(b: &[u8]) -> (Manifest, usize) {
    let m = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    (serde_json::from_slice(&b[16..16 + m]).unwrap(), 16 + m)
}

/// A bundle with `manifest` (as given) over the entries' bytes `data`.
fn assemble(manifest: &[u8], data: &[u8]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(manifest.len() as u32).to_le_bytes());
    out.extend_from_slice(manifest);
    out.extend_from_slice(data);
    out
}

#[test]
fn round_trip_gives_the_site_and_map_the_files_give() {
    let b = bundle_of(Some(MAP));
    assert_eq!(sniff(&b), Some(VERSION));
    let bundle = Bundle::parse(&b).unwrap();
    let names: Vec<&str> = bundle
        .manifest()
        .entries
        .iter()
        .map(|e| e.name.as_str())
        .collect();
    assert_eq!(names, [SITE_ENTRY, "plans/plan.png", RADIO_MAP_ENTRY]);
    assert_eq!(bundle.manifest().site, "tiny");
    assert_eq!(bundle.site_json(), SITE.as_bytes());
    assert_eq!(bundle.entry("plans/plan.png"), Some(plan_png().as_slice()));
    let site = bundle.build_site().unwrap();
    let direct = Site::build(
        SiteSpec::from_json(SITE.as_bytes(), "site.json").unwrap(),
        "site.json",
        &mut |_| Ok(plan_png()),
    )
    .unwrap();
    assert_eq!(site.spec, direct.spec);
    assert_eq!(site.floors.len(), 1);
    let map = bundle.radio_map(&site).unwrap().expect("a map");
    let want = RadioMap::from_json(MAP, &direct).unwrap();
    assert_eq!(map.to_json().unwrap(), want.to_json().unwrap());
    // the manifest's hashes are those of the stored bytes
    let e = &bundle.manifest().entries[1];
    assert_eq!(e.sha256, sha256_hex(&plan_png()));
    assert_eq!(e.size, plan_png().len() as u64);
}

#[test]
fn a_bundle_without_a_radio_map_is_allowed() {
    let b = bundle_of(None);
    let bundle = Bundle::parse(&b).unwrap();
    assert!(!bundle.has_radio_map());
    let site = bundle.build_site().unwrap();
    assert!(bundle.radio_map(&site).unwrap().is_none());
}

#[test]
fn sha256_is_the_standard_one() {
    // FIPS 180-2 example
    assert_eq!(
        sha256_hex(b"abc"),
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    );
}

#[test]
fn header_errors_name_the_field() {
    let b = bundle_of(None);
    assert!(err(&b[..10]).contains("header"), "{}", err(&b[..10]));
    let mut x = b.clone();
    x[0] = b'X';
    assert!(err(&x).contains("header.magic"));
    let mut x = b.clone();
    x[8..12].copy_from_slice(&2u32.to_le_bytes());
    let e = err(&x);
    assert!(e.contains("header.version") && e.contains("is 2"), "{e}");
    // an absurd manifest length is refused before anything is allocated
    let mut x = b.clone();
    x[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(err(&x).contains("header.manifest_length"));
    let mut x = b.clone();
    x[12..16].copy_from_slice(&(MAX_MANIFEST_BYTES - 1).to_le_bytes());
    let e = err(&x);
    assert!(e.contains("past the end"), "{e}");
}

#[test]
fn damaged_or_cut_files_are_refused() {
    let b = bundle_of(Some(MAP));
    // one byte of the plan changed: its hash names it
    let (m, start) = split(&b);
    let plan_at = start + m.entries[0].size as usize + 10;
    let mut x = b.clone();
    x[plan_at] ^= 1;
    let e = err(&x);
    assert!(
        e.contains("entry plans/plan.png") && e.contains("SHA-256"),
        "{e}"
    );
    // cut short: the last entry does not fit
    let e = err(&b[..b.len() - 1]);
    assert!(e.contains("entries[2].size"), "{e}");
    // trailing bytes
    let mut x = b.clone();
    x.push(0);
    assert!(err(&x).contains("after the last entry"));
}

#[test]
fn manifest_errors_name_the_field() {
    let b = bundle_of(None);
    let (m, start) = split(&b);
    let data = &b[start..];
    let with = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut v = serde_json::to_value(&m).unwrap();
        f(&mut v);
        assemble(&serde_json::to_vec(&v).unwrap(), data)
    };
    let e = err(&with(&|v| v["format"] = "zip".into()));
    assert!(e.contains("manifest.format"), "{e}");
    let e = err(&with(&|v| v["version"] = 7.into()));
    assert!(e.contains("manifest.version"), "{e}");
    let e = err(&with(&|v| v["extra"] = 1.into()));
    assert!(e.contains("extra"), "{e}");
    let e = err(&with(&|v| v["entries"][1]["kind"] = "font".into()));
    assert!(e.contains("entries[1].kind"), "{e}");
    let e = err(&with(&|v| v["entries"][1]["name"] = SITE_ENTRY.into()));
    assert!(e.contains("entries[1].name") && e.contains("twice"), "{e}");
    let e = err(&with(&|v| v["entries"][0]["encoding"] = "gzip".into()));
    assert!(e.contains("entries[0].encoding"), "{e}");
    let e = err(&with(&|v| v["entries"][1]["sha256"] = "ABC".into()));
    assert!(e.contains("entries[1].sha256"), "{e}");
    let e = err(&with(&|v| v["entries"][0]["size"] = u64::MAX.into()));
    assert!(e.contains("entries[0].size"), "{e}");
    let e = err(&with(&|v| {
        let site = v["entries"][0].clone();
        v["entries"] = serde_json::json!([site.clone(), site]);
    }));
    assert!(e.contains("twice"), "{e}");
    // a plan the site names but the bundle lacks
    let no_plan = with(&|v| {
        let site = v["entries"][0].clone();
        v["entries"] = serde_json::json!([site]);
    });
    let site_only = assemble(
        &serde_json::to_vec(&Manifest {
            entries: vec![m.entries[0].clone()],
            ..m.clone()
        })
        .unwrap(),
        SITE.as_bytes(),
    );
    assert!(err(&no_plan).contains("after the last entry"));
    let e = Bundle::parse(&site_only)
        .unwrap()
        .build_site()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("floors[0].plan") && e.contains("plans/plan.png"),
        "{e}"
    );
}

/// A bundle whose radio map entry is `gz` with `raw_size`.
fn with_map_entry(gz: &[u8], raw_size: u64) -> Vec<u8> {
    let b = bundle_of(None);
    let (mut m, start) = split(&b);
    m.entries.push(EntryInfo {
        name: RADIO_MAP_ENTRY.into(),
        kind: EntryKind::RadioMap,
        encoding: Encoding::Gzip,
        size: gz.len() as u64,
        raw_size: Some(raw_size),
        sha256: sha256_hex(gz),
    });
    let mut data = b[start..].to_vec();
    data.extend_from_slice(gz);
    assemble(&serde_json::to_vec(&m).unwrap(), &data)
}

fn gzip(b: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(b).unwrap();
    e.finish().unwrap()
}

fn map_err(bytes: &[u8]) -> String {
    let b = Bundle::parse(bytes).unwrap();
    let site = b.build_site().unwrap();
    b.radio_map(&site).unwrap_err().to_string()
}

#[test]
fn radio_map_errors_name_the_entry_and_field() {
    // wrong raw_size, both ways
    let gz = gzip(MAP.as_bytes());
    let n = MAP.len() as u64;
    assert!(map_err(&with_map_entry(&gz, n + 5)).contains("raw_size"));
    let e = map_err(&with_map_entry(&gz, n - 5));
    assert!(e.contains(RADIO_MAP_ENTRY), "{e}");
    // over the limit: refused by the manifest check, nothing decoded
    let e = err(&with_map_entry(&gz, MAX_RADIO_MAP_RAW_BYTES + 1));
    assert!(e.contains("entries[2].raw_size"), "{e}");
    // not gzip
    let e = map_err(&with_map_entry(MAP.as_bytes(), n));
    assert!(e.contains("gzip"), "{e}");
    // bad JSON: the field is named
    let bad = MAP.replace(r#""nx": 3"#, r#""nx": "three""#);
    let e = map_err(&with_map_entry(&gzip(bad.as_bytes()), bad.len() as u64));
    assert!(
        e.contains(RADIO_MAP_ENTRY) && e.contains("transmitters[0].grids[0].nx"),
        "{e}"
    );
    // valid JSON, invalid against the site
    let bad = MAP.replace(r#""floor": 0, "x0_m""#, r#""floor": 9, "x0_m""#);
    let e = map_err(&with_map_entry(&gzip(bad.as_bytes()), bad.len() as u64));
    assert!(e.contains("floor"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
    /// Any byte of a valid bundle changed, or the bundle cut anywhere:
    /// an error or a bundle, never a panic.
    #[test]
    fn damaged_bundles_never_panic(at in 0usize..100_000, v in 0u8..=255, cut in proptest::bool::ANY) {
        let mut b = bundle_of(Some(MAP));
        let at = at % b.len();
        if cut {
            b.truncate(at);
        } else {
            b[at] = v;
        }
        if let Ok(bundle) = Bundle::parse(&b)
            && let Ok(site) = bundle.build_site()
        {
            let _ = bundle.radio_map(&site);
        }
    }
}
