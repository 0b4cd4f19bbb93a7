//! `fpbp map check` end to end: the demo site, and bad sites giving one
//! clear error (file + field) and no panic.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fpbp-map-check-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn check(site: &Path, out: &Path) -> (bool, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .args(["map", "check"])
        .arg(site)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn demo_site_checks_and_writes_an_overlay() {
    let out = scratch("demo");
    let (ok, stdout, stderr) = check(&repo().join("maps/demo/site.json"), &out);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("64.00 m x 44.00 m"), "{stdout}");
    let rooms: usize = stdout
        .lines()
        .find_map(|l| l.trim().strip_prefix("rooms"))
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("rooms line");
    assert!(
        rooms >= 9,
        "8+ rooms off the corridors plus the corridor: {stdout}"
    );
    assert!(stdout.contains("beacons           54"), "{stdout}");
    let img = image::open(out.join("overlay-raw.png")).unwrap();
    assert_eq!((img.width(), img.height()), (640, 440));
    // the figure: wider than the plan (axes, legend strip)
    let fig = image::open(out.join("overlay.png")).unwrap();
    assert!(fig.width() > 1000 && fig.height() > 440);
}

#[test]
fn truth_points_are_drawn() {
    let out = scratch("truth");
    let log = out.join("walk.txt");
    // A native log with three truth points along the corridor, one in a wall.
    std::fs::write(
        &log,
        "#fpbp-log 1\n1000000 TRUTH 5.0 20.5 0\n2000000 TRUTH 10.0 20.5 -\n3000000 TRUTH 0.05 20.5 0\n",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .args(["map", "check"])
        .arg(repo().join("maps/demo/site.json"))
        .arg("--out")
        .arg(&out)
        .arg("--truth")
        .arg(&log)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("truth points      3 (1 off Walkable)"),
        "{stdout}"
    );
    let img = image::open(out.join("overlay-raw.png")).unwrap().to_rgba8();
    // MCS (5.0, 20.5) -> ICS (50, 235): magenta.
    assert_eq!(img.get_pixel(50, 235).0, [220, 0, 220, 255]);
}

/// Writes a one-floor site (plan.png 20 x 10 px at r = 10) with `edit`
/// applied to the JSON text, runs map check, and returns stderr.
fn bad_site(name: &str, plan: Option<&[u8]>, edit: impl Fn(String) -> String) -> String {
    let dir = scratch(name);
    if let Some(bytes) = plan {
        std::fs::write(dir.join("plan.png"), bytes).unwrap();
    }
    let json = r#"{"format": "fpbp-site", "version": 1, "name": "t",
 "floors": [{"id": 0, "plan": "plan.png", "pixels_per_meter": 10.0}],
 "beacons": [{"id": "mac:00:00:00:00:00:01", "floor": 0, "x_m": 1.0, "y_m": 0.5,
   "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0}]}"#;
    std::fs::write(dir.join("site.json"), edit(json.to_string())).unwrap();
    let (ok, _, stderr) = check(&dir.join("site.json"), &dir.join("out"));
    assert!(!ok, "{name}: expected failure");
    assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    assert_eq!(
        stderr.trim().lines().count(),
        1,
        "{name}: one line: {stderr}"
    );
    stderr
}

fn good_png() -> Vec<u8> {
    let img = image::RgbImage::from_fn(20, 10, |x, y| {
        if x == 0 || y == 0 || x == 19 || y == 9 {
            image::Rgb([0, 0, 0])
        } else {
            image::Rgb([255, 255, 255])
        }
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

#[test]
fn bad_sites_fail_with_file_and_field() {
    let png = good_png();
    let same = |s: String| s;
    let e = bad_site("top-unknown", Some(&png), |s| {
        s.replace("\"t\"", "\"t\", \"extra\": 1")
    });
    assert!(e.contains("site.json") && e.contains("`extra`"), "{e}");
    let e = bad_site("missing-plan", None, same);
    assert!(
        e.contains("site.json") && e.contains("floors[0].plan") && e.contains("plan.png"),
        "{e}"
    );
    let e = bad_site("not-png", Some(b"hello"), same);
    assert!(e.contains("floors[0].plan") && e.contains("PNG"), "{e}");
    let e = bad_site("zero-r", Some(&png), |s| s.replace("10.0}", "0}"));
    assert!(e.contains("floors[0].pixels_per_meter"), "{e}");
    let e = bad_site("neg-r", Some(&png), |s| s.replace("10.0}", "-3}"));
    assert!(e.contains("floors[0].pixels_per_meter"), "{e}");
    let e = bad_site("outside", Some(&png), |s| {
        s.replace("\"x_m\": 1.0", "\"x_m\": 9.0")
    });
    assert!(e.contains("beacons[0]") && e.contains("outside"), "{e}");
    let e = bad_site("in-wall", Some(&png), |s| {
        s.replace("\"y_m\": 0.5", "\"y_m\": 0.05")
    });
    assert!(e.contains("beacons[0]") && e.contains("Wall"), "{e}");
    let e = bad_site("missing-field", Some(&png), |s| {
        s.replace("\"name\": \"t\",", "")
    });
    assert!(e.contains("site.json") && e.contains("`name`"), "{e}");
    let e = bad_site("unknown-field", Some(&png), |s| {
        s.replace("\"floor\": 0,", "\"floor\": 0, \"flor\": 1,")
    });
    assert!(e.contains("beacons[0].flor"), "{e}");
    let black = {
        let img = image::RgbImage::from_pixel(20, 10, image::Rgb([0, 0, 0]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    };
    let e = bad_site("no-walkable", Some(&black), |s| {
        s.replace("\"beacons\": [{", "\"beacons\": [], \"x\": [{")
    });
    assert!(e.contains("`x`"), "{e}");
    let dir = scratch("missing-site");
    let (ok, _, stderr) = check(&dir.join("nope.json"), &dir);
    assert!(!ok && stderr.contains("nope.json"), "{stderr}");
}

#[test]
fn plan_without_walkable_pixels_fails() {
    let black = {
        let img = image::RgbImage::from_pixel(20, 10, image::Rgb([0, 0, 0]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    };
    let e = bad_site("no-walkable2", Some(&black), |s| {
        let cut = s.find(",\n \"beacons\"").unwrap();
        format!("{}}}", &s[..cut])
    });
    assert!(
        e.contains("floors[0].plan") && e.contains("no Walkable"),
        "{e}"
    );
}

/// `--radio-map`: the share of the walkable area by distance to the
/// survey's reference scans, per floor, and coverage.png; a missing map
/// file is one clear error naming it.
#[test]
fn a_radio_map_gives_the_survey_coverage() {
    let out = scratch("coverage");
    let (site, map) = (out.join("site.json"), out.join("radio-map.json"));
    let logs = ["demo-walk-1.log.gz", "demo-walk-2.log.gz"]
        .map(|l| repo().join("host-tests/logs").join(l));
    let cal = common::calibrate_demo(&out, &logs, "all");
    let run = |map: &Path| {
        Command::new(env!("CARGO_BIN_EXE_fpbp"))
            .args(["map", "check"])
            .arg(&site)
            .arg("--out")
            .arg(out.join("check"))
            .arg("--radio-map")
            .arg(map)
            .output()
            .unwrap()
    };
    let o = run(&map);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let line = stdout
        .lines()
        .find_map(|l| l.trim().strip_prefix("survey coverage"))
        .unwrap_or_else(|| panic!("no survey coverage line: {stdout}"));
    // the figures before each "%"
    let words: Vec<&str> = line.split_whitespace().collect();
    let shares: Vec<f64> = words
        .windows(2)
        .filter(|w| w[1] == "%")
        .filter_map(|w| w[0].parse::<f64>().ok())
        .collect();
    assert_eq!(shares.len(), 4, "{line}");
    assert!((shares.iter().sum::<f64>() - 100.0).abs() < 0.5, "{line}");
    // two walks of four minutes pass along the corridors: some of the
    // floor is near them, and the rooms they never entered are not
    assert!(shares[0] > 5.0 && shares[0] < 80.0, "{line}");
    assert!(shares[0] + shares[1] < 100.0, "{line}");
    assert!(out.join("check/coverage.png").is_file());
    // calibrate prints the same shares when it writes the map
    let cal_out = String::from_utf8_lossy(&cal.stdout);
    let cal_line = cal_out
        .lines()
        .find_map(|l| l.strip_prefix("survey coverage, floor 0:"))
        .unwrap_or_else(|| panic!("calibrate printed no survey coverage: {cal_out}"));
    let head = |l: &str| {
        l.split(" of the walkable")
            .next()
            .unwrap()
            .trim()
            .to_string()
    };
    assert_eq!(head(cal_line), head(line), "{cal_line} / {line}");
    let o = run(&out.join("nope.json"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("nope.json"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}
