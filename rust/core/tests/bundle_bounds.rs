//! Issue 60 item 10's reproducers: bundles of bad bytes that used to
//! allocate gigabytes or take seconds (a gzip bomb of small transmitters, a
//! huge string, the error path of a large map, a huge grid, a plan image
//! decoded before its size was checked, a plan named by an absolute path)
//! are refused with an error naming the entry and field, within a small
//! allocation budget.
//!
//! Each malicious bundle is generated here (a repeated pattern streamed
//! through a `GzEncoder`: cheap to make, large once decompressed). Memory is
//! the peak of extra live bytes while the bundle is read, measured with a
//! counting global allocator (as in `input_bounds.rs`); the tests take one
//! lock so that their peaks do not mix. Time is not asserted (CI machines
//! vary); `fpbp bundle --check` gives the figures (docs/formats.md).

use std::io::Write;

use fpbp_core::bundle::{self, Bundle, BundleInput};
use fpbp_core::radio::RadioMap;

mod counting_alloc;
use counting_alloc::SERIAL;

/// Extra memory reading a malicious bundle may take, bytes.
const BUDGET: usize = 32 << 20;

/// `f`'s result and the peak of extra live bytes while it ran.
fn measured<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = counting_alloc::start();
    let out = f();
    (out, counting_alloc::extra_peak(base))
}

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

fn site_json(plan: &str, ppm: f64) -> String {
    site_json_to(plan, ppm, ppm)
}

/// The tiny site with its plan downsampled to `target` px/m.
fn site_json_to(plan: &str, ppm: f64, target: f64) -> String {
    format!(
        r#"{{"format": "fpbp-site", "version": 1, "name": "tiny",
  "floors": [{{"id": 0, "plan": "{plan}", "pixels_per_meter": {ppm},
               "target_pixels_per_meter": {target}}}]}}"#
    )
}

/// gzip (fast) of `head`, `n` copies of `unit`, then `tail`, streamed: the
/// text is never held. Returns the gzip and the text's length.
fn gzip_pattern(head: &str, unit: &str, n: usize, tail: &str) -> (Vec<u8>, u64) {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(head.as_bytes()).unwrap();
    // write the repeated unit in 1 MB blocks
    let per = (1 << 20) / unit.len().max(1) + 1;
    let block = unit.repeat(per.min(n.max(1)));
    let mut left = n;
    while left > 0 {
        let k = left.min(per);
        enc.write_all(&block.as_bytes()[..k * unit.len()]).unwrap();
        left -= k;
    }
    enc.write_all(tail.as_bytes()).unwrap();
    let len = head.len() as u64 + (n * unit.len()) as u64 + tail.len() as u64;
    (enc.finish().unwrap(), len)
}

/// A bundle of the tiny site and plan with a radio map entry of stored
/// bytes `gz` declaring `raw_size` (the manifest written by hand, as an
/// attacker would).
fn bundle_with_map(gz: &[u8], raw_size: u64) -> Vec<u8> {
    let site = site_json("plan.png", 10.0);
    let png = plan_png();
    let entry = |name: &str, kind: &str, enc: &str, d: &[u8], raw: Option<u64>| {
        format!(
            r#"{{"name": "{name}", "kind": "{kind}", "encoding": "{enc}", "size": {}{}, "sha256": "{}"}}"#,
            d.len(),
            raw.map_or(String::new(), |r| format!(r#", "raw_size": {r}"#)),
            bundle::sha256_hex(d)
        )
    };
    let manifest = format!(
        r#"{{"format": "fpbp-bundle", "version": 1, "site": "tiny", "entries": [{}, {}, {}]}}"#,
        entry("site.json", "site", "identity", site.as_bytes(), None),
        entry("plan.png", "plan", "identity", &png, None),
        entry(
            bundle::RADIO_MAP_ENTRY,
            "radio_map",
            "gzip",
            gz,
            Some(raw_size)
        ),
    );
    let mut out = bundle::MAGIC.to_vec();
    out.extend_from_slice(&bundle::VERSION.to_le_bytes());
    out.extend_from_slice(&(manifest.len() as u32).to_le_bytes());
    out.extend_from_slice(manifest.as_bytes());
    out.extend_from_slice(site.as_bytes());
    out.extend_from_slice(&png);
    out.extend_from_slice(gz);
    out
}

/// Reads `bytes` as `startBundle` does (parse, site, radio map); the error
/// must hold every needle, within [`BUDGET`].
fn refused(bytes: &[u8], needles: &[&str]) -> String {
    let (r, peak) = measured(|| {
        let b = Bundle::parse(bytes)?;
        let site = b.build_site()?;
        b.radio_map(&site).map(|_| ())
    });
    let e = r.expect_err("the bundle must be refused").to_string();
    for n in needles {
        assert!(e.contains(n), "`{n}` not in: {e}");
    }
    assert!(peak < BUDGET, "{peak} bytes for: {e}");
    e
}

const MAP_HEAD: &str = r#"{"format": "fpbp-radio-map", "version": 1, "site": "tiny", "#;
const TX: &str =
    r#"{"id": "mac:AA:BB:CC:DD:EE:01", "kind": "ble", "floor": 0, "x_m": 1, "y_m": 1},"#;

#[test]
fn bundle_gzip_bomb_of_transmitters_is_refused_at_the_limit() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // 64 MiB of small transmitters (0.8 M of them) in ~0.3 MB of gzip
    let n = (bundle::MAX_RADIO_MAP_RAW_BYTES as usize - 200) / TX.len();
    let (gz, raw) = gzip_pattern(&format!(r#"{MAP_HEAD}"transmitters": ["#), TX, n, "{}]}");
    assert!(gz.len() < raw as usize / 50, "{} of {raw}", gz.len());
    let e = refused(
        &bundle_with_map(&gz, raw),
        &[
            "entry radio-map.json.gz",
            "field `transmitters[",
            "more than 20000 elements",
        ],
    );
    println!("{e}");
    // the same text declared past the limit is refused by the manifest
    let e = refused(
        &bundle_with_map(&gz, bundle::MAX_RADIO_MAP_RAW_BYTES + 1),
        &["manifest.entries[2].raw_size", "over the limit"],
    );
    println!("{e}");
    // and a raw_size that lies stops the stream where it says
    let e = refused(
        &bundle_with_map(&gz, 4096),
        &["more than the manifest's raw_size of 4096 bytes"],
    );
    println!("{e}");
}

#[test]
fn bundle_huge_string_is_refused_while_streaming() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let head = r#"{"format": "fpbp-radio-map", "version": 1, "site": ""#;
    let (gz, raw) = gzip_pattern(head, "x", 60 << 20, r#"", "transmitters": []}"#);
    let e = refused(
        &bundle_with_map(&gz, raw),
        &[
            "entry radio-map.json.gz",
            "field `site`",
            "string over 1024 bytes",
        ],
    );
    println!("{e}");
    // a number token too
    let head = r#"{"format": "fpbp-radio-map", "version": 1, "transmitters": [], "fallback": 1"#;
    let (gz, raw) = gzip_pattern(head, "0", 60 << 20, "}");
    refused(
        &bundle_with_map(&gz, raw),
        &["field `fallback`", "number over 100 characters"],
    );
}

#[test]
fn bundle_error_path_does_not_hold_the_text() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // 60 MiB of whitespace, then a type error: the message names the field
    // without the text of the map being built
    let (gz, raw) = gzip_pattern(
        "",
        " ",
        60 << 20,
        r#"{"format": "fpbp-radio-map", "version": 1, "transmitters": [{"id": 5}]}"#,
    );
    let e = refused(
        &bundle_with_map(&gz, raw),
        &["entry radio-map.json.gz", "field `transmitters[0].id`"],
    );
    println!("{e}");
}

#[test]
fn bundle_huge_grid_is_refused_at_the_cell_limit() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let head = format!(
        r#"{MAP_HEAD}"transmitters": [{{"id": "mac:AA:BB:CC:DD:EE:01", "kind": "ble",
        "floor": 0, "x_m": 1, "y_m": 1, "grids": [{{"floor": 0, "x0_m": 0, "y0_m": 0,
        "cell_m": 1, "nx": 23170, "ny": 23170, "mean_dbm_x10": ["#
    );
    let (gz, raw) = gzip_pattern(&head, "0,", 30 << 20, "0]}]}]}");
    let e = refused(
        &bundle_with_map(&gz, raw),
        &[
            "transmitters[0].grids[0].mean_dbm_x10",
            "more than 1048576 elements",
        ],
    );
    println!("{e}");
}

#[test]
fn radio_map_text_with_a_huge_grid_is_refused_while_parsing() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // the JSON form (`start()`, `fpbp eval`) parses the same bounded types
    let text = format!(
        r#"{MAP_HEAD}"transmitters": [{{"id": "mac:AA:BB:CC:DD:EE:01", "kind": "ble",
        "floor": 0, "x_m": 1, "y_m": 1, "grids": [{{"floor": 0, "x0_m": 0, "y0_m": 0,
        "cell_m": 1, "nx": 2, "ny": 2, "mean_dbm_x10": [{}0]}}]}}]}}"#,
        "0,".repeat(2 << 20)
    );
    let site = tiny_site();
    let (r, peak) = measured(|| RadioMap::from_json(&text, &site).map(|_| ()));
    let e = r.unwrap_err().to_string();
    assert!(
        e.contains("transmitters[0].grids[0].mean_dbm_x10") && e.contains("more than 1048576"),
        "{e}"
    );
    assert!(peak < BUDGET, "{peak}");
}

fn tiny_site() -> fpbp_core::site::Site {
    let json = site_json("plan.png", 10.0);
    let spec = fpbp_core::site::SiteSpec::from_json(json.as_bytes(), "site.json").unwrap();
    let png = plan_png();
    fpbp_core::site::Site::build(spec, "site.json", &mut |_| Ok(png.clone())).unwrap()
}

/// A PNG of `w` x `h` px of colour type `color` (2 RGB, 6 RGBA), bit
/// depth `depth`, whose image data is one row of zeros (enough for a
/// decoder to read the header; a full image would be hundreds of MB).
fn png_header_only(w: u32, h: u32, depth: u8, color: u8) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[depth, color, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    let row = vec![0u8; 1 + w as usize * 8];
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(&row).unwrap();
    chunk(&mut out, b"IDAT", &z.finish().unwrap());
    chunk(&mut out, b"IEND", &[]);
    out
}

fn bundle_with_plan(png: &[u8], ppm: f64, target: f64) -> Vec<u8> {
    let site = site_json_to("plan.png", ppm, target);
    let plans = [("plan.png", png)];
    bundle::write(&BundleInput {
        site_json: site.as_bytes(),
        plans: &plans,
        radio_map_json: None,
        writer: "test",
    })
    .unwrap()
}

#[test]
fn bundle_plan_image_is_checked_from_its_header_before_decoding() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // 8000 x 8000 px of 16-bit RGBA at 40 px/m downsampled to 10 (a 200 m
    // floor of 2000 x 2000 px, within the map limits): 512 MB decoded (844
    // MB with the old RGB copy), refused from the header
    let png = png_header_only(8000, 8000, 16, 6);
    let e = refused(
        &bundle_with_plan(&png, 40.0, 10.0),
        &["floors[0].plan", "bytes decoded", "over the limit"],
    );
    println!("{e}");
    // 8-bit RGB within the decoded-size limit, but a floor of 800 km at
    // 0.01 px/m: refused from the header too, before decoding
    let png = png_header_only(8000, 8000, 8, 2);
    let e = refused(
        &bundle_with_plan(&png, 0.01, 0.01),
        &["floors[0].plan", "over the limit of 10000 m a side"],
    );
    println!("{e}");
}

#[test]
fn bundle_plan_names_are_relative_and_old_absolute_names_still_read() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let png = plan_png();
    for name in [
        "/home/someone/site/plan.png",
        "../plan.png",
        "C:\\site\\plan.png",
    ] {
        let site = site_json(&name.replace('\\', "\\\\"), 10.0);
        let plans = [(name, png.as_slice())];
        let e = bundle::write(&BundleInput {
            site_json: site.as_bytes(),
            plans: &plans,
            radio_map_json: None,
            writer: "test",
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("relative to the bundle"), "{e}");
    }
    assert!(bundle::is_bundle_relative("plans/plan.png"));
    assert!(bundle::is_bundle_relative("plan..v2.png"));
    // a bundle written before the check, naming its plan by an absolute
    // path (as its site.json does), still reads
    let abs = "/home/someone/site/plan.png";
    let site = site_json(abs, 10.0);
    let entry = |name: &str, kind: &str, d: &[u8]| {
        format!(
            r#"{{"name": "{name}", "kind": "{kind}", "size": {}, "sha256": "{}"}}"#,
            d.len(),
            bundle::sha256_hex(d)
        )
    };
    let manifest = format!(
        r#"{{"format": "fpbp-bundle", "version": 1, "site": "tiny", "entries": [{}, {}]}}"#,
        entry("site.json", "site", site.as_bytes()),
        entry(abs, "plan", &png),
    );
    let mut old = bundle::MAGIC.to_vec();
    old.extend_from_slice(&bundle::VERSION.to_le_bytes());
    old.extend_from_slice(&(manifest.len() as u32).to_le_bytes());
    old.extend_from_slice(manifest.as_bytes());
    old.extend_from_slice(site.as_bytes());
    old.extend_from_slice(&png);
    let b = Bundle::parse(&old).unwrap();
    assert_eq!(b.build_site().unwrap().floors.len(), 1);
}

#[test]
fn bundle_site_json_collections_are_bounded_while_parsing() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // 200 000 beacons (their duplicate check was quadratic): refused at
    // the limit
    let beacon = r#"{"id": "b", "floor": 0, "x_m": 1, "y_m": 1, "rssi_1m_dbm": -59, "path_loss_exponent": 2},"#;
    let json = format!(
        r#"{{"format": "fpbp-site", "version": 1, "name": "t",
  "floors": [{{"id": 0, "open_area_m": [10, 10]}}], "beacons": [{}{}]}}"#,
        beacon.repeat(200_000),
        &beacon[..beacon.len() - 1]
    );
    let (r, peak) = measured(|| fpbp_core::site::SiteSpec::from_json(json.as_bytes(), "s"));
    let e = r.unwrap_err().to_string();
    assert!(
        e.contains("beacons[") && e.contains("more than 20000"),
        "{e}"
    );
    assert!(peak < BUDGET, "{peak}");
    let json = format!(
        r#"{{"format": "fpbp-site", "version": 1, "name": "t", "floors": [{}{{"id": 0}}]}}"#,
        r#"{"id": 0},"#.repeat(300)
    );
    let e = fpbp_core::site::SiteSpec::from_json(json.as_bytes(), "s")
        .unwrap_err()
        .to_string();
    assert!(e.contains("floors[") && e.contains("more than 256"), "{e}");
}

#[test]
fn bundle_floors_cannot_multiply_the_map_memory() {
    let _g = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // each floor within the map limit (the second 4096 x 4096 px = 16 Mi
    // px), together over it: refused from the second plan's header before
    // that floor is built (256 floors on one such plan entry would have
    // built 256 maps)
    let small = plan_png();
    let big = png_header_only(4096, 4096, 8, 0);
    let site = r#"{"format": "fpbp-site", "version": 1, "name": "tall",
  "floors": [{"id": 0, "plan": "plan.png", "pixels_per_meter": 10},
             {"id": 1, "plan": "big.png", "pixels_per_meter": 20}]}"#;
    let plans = [("plan.png", small.as_slice()), ("big.png", big.as_slice())];
    let bytes = bundle::write(&BundleInput {
        site_json: site.as_bytes(),
        plans: &plans,
        radio_map_json: None,
        writer: "test",
    })
    .unwrap();
    let e = refused(&bytes, &["floors[1].plan", "for a site"]);
    println!("{e}");
}
