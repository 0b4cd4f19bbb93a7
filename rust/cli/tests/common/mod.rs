//! Helpers shared by the CLI's end-to-end tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `fpbp calibrate` of the demo site on `logs` (`--split split`), writing
/// DIR/site.json and DIR/radio-map.json; panics with calibrate's stderr
/// when it fails.
pub fn calibrate_demo(dir: &Path, logs: &[PathBuf], split: &str) -> Output {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .arg("calibrate")
        .arg("--site")
        .arg(repo.join("maps/demo/site.json"))
        .arg("--logs")
        .args(logs)
        .args(["--split", split, "--out"])
        .arg(dir.join("site.json"))
        .arg("--radio-map")
        .arg(dir.join("radio-map.json"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "calibrate failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}
