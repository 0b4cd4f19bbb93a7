//! Site loading and validation: every bad input gives one error naming the
//! file and the field.

use super::*;

/// A 40 x 20 px plan (r = 10 -> 4 m x 2 m): wall border, walkable inside,
/// a red door strip at columns 19-20.
fn plan_png() -> Vec<u8> {
    let img = image::RgbImage::from_fn(40, 20, |x, y| {
        if x == 0 || y == 0 || x == 39 || y == 19 {
            image::Rgb([0, 0, 0])
        } else if x == 19 || x == 20 {
            if (8..12).contains(&y) {
                image::Rgb([255, 0, 0])
            } else {
                image::Rgb([0, 0, 0])
            }
        } else {
            image::Rgb([255, 255, 255])
        }
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

const GOOD: &str = r#"{
  "format": "fpbp-site",
  "version": 1,
  "name": "tiny",
  "floors": [
    { "id": 0, "plan": "plan.png", "pixels_per_meter": 10.0 }
  ],
  "beacons": [
    { "id": "mac:AA:BB:CC:DD:EE:01", "floor": 0, "x_m": 1.0, "y_m": 1.0, "z_m": 2.5,
      "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0 }
  ]
}"#;

fn load(text: &str) -> Result<Site> {
    let spec = SiteSpec::from_json(text.as_bytes(), "site.json")?;
    Site::build(spec, "site.json", &mut |p: &str| {
        if p == "plan.png" {
            Ok(plan_png())
        } else if p == "junk.png" {
            Ok(b"this is not a png".to_vec())
        } else if p == "black.png" {
            let img = image::RgbImage::from_pixel(8, 8, image::Rgb([0, 0, 0]));
            let mut out = std::io::Cursor::new(Vec::new());
            img.write_to(&mut out, image::ImageFormat::Png).unwrap();
            Ok(out.into_inner())
        } else {
            Err(std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "No such file or directory",
            ))
        }
    })
}

fn err(text: &str) -> (String, String) {
    match load(text) {
        Ok(_) => panic!("expected an error for {text}"),
        Err(Error::Site { file, field, msg }) => {
            assert_eq!(file, "site.json");
            (field, msg)
        }
        Err(e) => panic!("expected Error::Site, got {e}"),
    }
}

#[test]
fn good_site_builds() {
    let site = load(GOOD).unwrap();
    let m = site.floor(0).unwrap();
    assert_eq!((m.width_px(), m.height_px()), (40, 20));
    assert_eq!(m.rooms().len(), 2);
    assert_eq!(m.door_pixel_count(), 8);
    assert_eq!(site.default_floor(), 0);
    // Round trip through JSON.
    let again = SiteSpec::from_json(site.spec.to_json_pretty().as_bytes(), "x").unwrap();
    assert_eq!(again, site.spec);
}

#[test]
fn open_floor_builds_without_a_plan() {
    let text = GOOD.replace(
        r#""plan": "plan.png", "pixels_per_meter": 10.0"#,
        r#""open_area_m": [20.0, 10.0]"#,
    );
    let site = load(&text).unwrap();
    let m = site.floor(0).unwrap();
    assert!((m.width_m() - 20.0).abs() < 1e-9);
    assert_eq!(m.rooms().len(), 1);
    assert!(m.grid().len() >= 18 * 8);
}

#[test]
fn missing_plan_file_names_the_field_and_path() {
    let (field, msg) = err(&GOOD.replace("plan.png", "nope.png"));
    assert_eq!(field, "floors[0].plan");
    assert!(
        msg.contains("nope.png") && msg.contains("No such file"),
        "{msg}"
    );
}

#[test]
fn non_png_plan() {
    let (field, msg) = err(&GOOD.replace("plan.png", "junk.png"));
    assert_eq!(field, "floors[0].plan");
    assert!(msg.contains("junk.png") && msg.contains("PNG"), "{msg}");
}

#[test]
fn zero_or_negative_resolution() {
    for r in ["0.0", "-10.0"] {
        let (field, msg) = err(&GOOD.replace("10.0 }", &format!("{r} }}")));
        assert_eq!(field, "floors[0].pixels_per_meter", "{msg}");
        let got = format!("got {}", r.parse::<f64>().unwrap());
        assert!(
            msg.contains("[0.01, 1000] px/m") && msg.contains(&got),
            "{msg}"
        );
    }
    let (field, _) = err(&GOOD.replace(r#", "pixels_per_meter": 10.0"#, ""));
    assert_eq!(field, "floors[0].pixels_per_meter");
}

#[test]
fn plan_without_walkable_pixels() {
    let (field, msg) = err(&GOOD
        .replace("plan.png", "black.png")
        .replace(r#""beacons": ["#, r#""beacons": [], "unused": ["#));
    // The unknown field is reported first (parse before build).
    assert_eq!(field, "unused", "{msg}");
    let text = r#"{"format":"fpbp-site","version":1,"name":"x",
        "floors":[{"id":0,"plan":"black.png","pixels_per_meter":10}]}"#;
    let (field, msg) = err(text);
    assert_eq!(field, "floors[0].plan");
    assert!(msg.contains("no Walkable pixels"), "{msg}");
}

#[test]
fn beacon_outside_the_plan_or_inside_a_wall() {
    let (field, msg) = err(&GOOD.replace(r#""x_m": 1.0"#, r#""x_m": 7.5"#));
    assert_eq!(field, "beacons[0]");
    assert!(msg.contains("outside"), "{msg}");
    // x = 1.95 m -> column 19.5: the divider wall (rows outside the door).
    let (field, msg) =
        err(&GOOD.replace(r#""x_m": 1.0, "y_m": 1.0"#, r#""x_m": 1.95, "y_m": 0.3"#));
    assert_eq!(field, "beacons[0]");
    assert!(msg.contains("inside a Wall"), "{msg}");
}

/// A key too long to keep is named by its first characters and its whole
/// length (the JNI layer's message keeps the length: NativeErrorsTest).
#[test]
fn a_long_unknown_key_is_named_by_its_start_and_length() {
    let key = "k".repeat(50_000);
    let (field, msg) = err(&GOOD.replace(r#""z_m": 2.5"#, &format!(r#""z_m": 2.5, "{key}": 3"#)));
    assert!(field.starts_with("beacons[0].kkk"), "{field}");
    assert!(field.ends_with("... (50000 chars)"), "{field}");
    assert!(field.len() < 200, "{} chars", field.len());
    assert!(msg.contains("unknown field"), "{msg}");
    // a key of exactly the kept length is not cut
    let key = "k".repeat(256);
    let (field, _) = err(&GOOD.replace(r#""z_m": 2.5"#, &format!(r#""z_m": 2.5, "{key}": 3"#)));
    assert_eq!(field, format!("beacons[0].{key}"));
}

#[test]
fn unknown_and_missing_fields_name_the_path() {
    let (field, msg) = err(&GOOD.replace(r#""z_m": 2.5"#, r#""z_m": 2.5, "colour": 3"#));
    assert_eq!(field, "beacons[0].colour", "{msg}");
    assert!(
        msg.contains("unknown field") && msg.contains("line"),
        "{msg}"
    );
    let (field, msg) = err(&GOOD.replace(r#""rssi_1m_dbm": -59.0,"#, ""));
    assert_eq!(field, "beacons[0].rssi_1m_dbm", "{msg}");
    assert!(msg.contains("missing field"), "{msg}");
    let (field, msg) = err(&GOOD.replace(r#""name": "tiny","#, ""));
    assert_eq!(field, "name", "{msg}");
    let (field, msg) = err(&GOOD.replace(r#""id": 0,"#, r#""id": "zero","#));
    assert_eq!(field, "floors[0].id", "{msg}");
    let (field, _) = err("{ not json");
    assert!(!field.is_empty());
    let (field, _) = err("");
    assert!(!field.is_empty());
}

#[test]
fn range_errors_name_the_field() {
    let cases = [
        (GOOD.replace("fpbp-site", "other"), "format"),
        (
            GOOD.replace(r#""version": 1"#, r#""version": 2"#),
            "version",
        ),
        (
            GOOD.replace(r#""floors": ["#, r#""grid_interval_m": 0, "floors": ["#),
            "grid_interval_m",
        ),
        (GOOD.replace("-59.0", "5.0"), "beacons[0].rssi_1m_dbm"),
        (
            GOOD.replace(r#""path_loss_exponent": 2.0"#, r#""path_loss_exponent": 0"#),
            "beacons[0].path_loss_exponent",
        ),
        (
            GOOD.replace(r#""floor": 0"#, r#""floor": 3"#),
            "beacons[0].floor",
        ),
    ];
    for (text, want) in cases {
        let (field, msg) = err(&text);
        assert_eq!(field, want, "{msg}");
    }
    // No floors.
    let text = r#"{"format":"fpbp-site","version":1,"name":"x","floors":[]}"#;
    assert_eq!(err(text).0, "floors");
    // Duplicate floor ids.
    let text = r#"{"format":"fpbp-site","version":1,"name":"x","floors":[
        {"id":0,"open_area_m":[5,5]},{"id":0,"open_area_m":[5,5]}]}"#;
    assert_eq!(err(text).0, "floors[1].id");
}

#[test]
fn target_resolution_downsamples_the_plan() {
    let text = GOOD.replace(
        r#""pixels_per_meter": 10.0"#,
        r#""pixels_per_meter": 10.0, "target_pixels_per_meter": 5.0"#,
    );
    let site = load(&text).unwrap();
    let m = site.floor(0).unwrap();
    assert_eq!((m.width_px(), m.height_px()), (20, 10));
    assert_eq!(m.pixels_per_meter(), 5.0);
    assert_eq!(m.build_report().downsample_factor, 2);
    assert!((m.width_m() - 4.0).abs() < 1e-9);
    // The divider (door + wall) still separates the two halves.
    assert_eq!(m.rooms().len(), 2);
}

proptest::proptest! {
    /// Any corruption of a good site file gives Ok or a typed error, never a panic.
    #[test]
    fn corrupted_site_json_never_panics(cut in 0usize..600, pos in 0usize..600, byte in 0u8..128) {
        let mut b = GOOD.as_bytes().to_vec();
        let pos = pos.min(b.len() - 1);
        b[pos] = byte;
        b.truncate(cut.max(1).min(b.len()));
        let text = String::from_utf8_lossy(&b).into_owned();
        match load(&text) {
            Ok(_) => {}
            Err(Error::Site { file, field, .. }) => {
                proptest::prop_assert_eq!(file, "site.json");
                proptest::prop_assert!(!field.is_empty());
            }
            Err(e) => proptest::prop_assert!(false, "unexpected error kind {e}"),
        }
    }
}

#[test]
fn heading_bias_is_read_checked_and_left_out_when_zero() {
    let with = GOOD.replace(
        r#""name": "tiny","#,
        r#""name": "tiny", "heading_bias_rad": 0.06,"#,
    );
    let site = load(&with).unwrap();
    assert_eq!(site.spec.heading_bias_rad, 0.06);
    assert!((site.spec.pdr_rotation_rad() - (site.spec.map_from_enu_rad + 0.06)).abs() < 1e-15);
    assert!(site.spec.to_json_pretty().contains("heading_bias_rad"));
    let zero = load(GOOD).unwrap();
    assert_eq!(zero.spec.heading_bias_rad, 0.0);
    assert!(!zero.spec.to_json_pretty().contains("heading_bias_rad"));
    let (field, msg) = err(&GOOD.replace(
        r#""name": "tiny","#,
        r#""name": "tiny", "heading_bias_rad": 4.0,"#,
    ));
    assert_eq!(field, "heading_bias_rad", "{msg}");
    assert!(msg.contains("got 4"), "{msg}");
}
