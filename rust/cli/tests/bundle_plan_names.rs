//! Issue 60 item 10, "absolute path": `fpbp calibrate --out` in another
//! directory points the site at its plans by a relative path, and `fpbp
//! bundle` names plan entries relative to the bundle (a plan path that is
//! absolute or leaves the site's directory by its file name), so that no
//! bundle names a path of the machine that built it.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fpbp(args: &[&std::ffi::OsStr]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "fpbp {args:?} failed: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The bundle's manifest (`fpbp bundle` prints each entry: kind, name).
fn plan_entries(stdout: &str) -> Vec<String> {
    stdout
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("plan "))
        .filter_map(|l| l.split_whitespace().next().map(String::from))
        .collect()
}

#[test]
fn calibrated_sites_and_bundles_name_plans_relatively() {
    let dir = std::env::temp_dir().join(format!("fpbp-bundle-names-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let logs = ["demo-walk-1.log.gz"].map(|l| repo().join("host-tests/logs").join(l));
    common::calibrate_demo(&dir, &logs, "all");
    let site = dir.join("site.json");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&site).unwrap()).unwrap();
    let plan = json["floors"][0]["plan"].as_str().unwrap().to_string();
    assert!(
        Path::new(&plan).is_relative() && plan.ends_with("plan.png"),
        "{plan}"
    );
    assert!(dir.join(&plan).is_file(), "{plan} from {}", dir.display());
    // the bundle names it by its file name (the path leaves the directory)
    let out = dir.join("site.fpbp");
    let printed = fpbp(&[
        "bundle".as_ref(),
        site.as_os_str(),
        "--radio-map".as_ref(),
        dir.join("radio-map.json").as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(plan_entries(&printed), ["plan.png"], "{printed}");
    fpbp(&["bundle".as_ref(), out.as_os_str(), "--check".as_ref()]);
    // a site naming its plan by an absolute path: the same
    let abs = std::fs::canonicalize(repo().join("maps/demo/plan.png")).unwrap();
    let mut v = json.clone();
    v["floors"][0]["plan"] = serde_json::json!(abs.display().to_string());
    let abs_site = dir.join("site-abs.json");
    std::fs::write(&abs_site, serde_json::to_string(&v).unwrap()).unwrap();
    let printed = fpbp(&[
        "bundle".as_ref(),
        abs_site.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(plan_entries(&printed), ["plan.png"], "{printed}");
    fpbp(&["bundle".as_ref(), out.as_os_str(), "--check".as_ref()]);
    std::fs::remove_dir_all(&dir).ok();
}
