//! `fpbp simulate` end to end: same seed, same bytes (plain and gzip), and
//! the shipped host-tests logs are exactly what their documented commands
//! produce.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn simulate(args: &[&str], out: &Path) {
    let st = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .current_dir(repo())
        .arg("simulate")
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .expect("run fpbp");
    assert!(
        st.status.success(),
        "fpbp simulate failed: {}",
        String::from_utf8_lossy(&st.stderr)
    );
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fpbp-sim-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

#[test]
fn same_seed_gives_the_same_file_byte_for_byte() {
    let base = ["--site", "maps/demo/site.json", "--seconds", "20"];
    for ext in ["log", "log.gz"] {
        let (a, b, c) = (
            tmp(&format!("a.{ext}")),
            tmp(&format!("b.{ext}")),
            tmp(&format!("c.{ext}")),
        );
        simulate(&[&base[..], &["--seed", "7"]].concat(), &a);
        simulate(&[&base[..], &["--seed", "7"]].concat(), &b);
        simulate(&[&base[..], &["--seed", "8"]].concat(), &c);
        let (ba, bb, bc) = (
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            std::fs::read(&c).unwrap(),
        );
        assert!(!ba.is_empty());
        assert_eq!(ba, bb, "{ext}: same seed, different bytes");
        assert_ne!(ba, bc, "{ext}: different seeds, same bytes");
    }
}

#[test]
fn bad_arguments_fail_with_a_message() {
    let out = tmp("bad.log");
    let st = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .current_dir(repo())
        .args([
            "simulate",
            "--site",
            "maps/demo/site.json",
            "--seconds",
            "10",
        ])
        .args(["--nlos-rate", "1.5", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!st.status.success());
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(err.contains("ble.nlos_rate"), "{err}");
    let st = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .current_dir(repo())
        .args([
            "simulate",
            "--site",
            "maps/demo/site.json",
            "--profile",
            "jogging",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("jogging"));
}

#[test]
fn shipped_logs_match_their_commands() {
    // One log here (keeps the debug test suite quick); host-tests/logs/generate.sh
    // --check compares all of them.
    let (file, seed, profile) = ("demo-walk-1.log.gz", "1", "default");
    let out = tmp(file);
    simulate(
        &[
            "--site",
            "maps/demo/site.json",
            "--seconds",
            "120",
            "--seed",
            seed,
            "--profile",
            profile,
        ],
        &out,
    );
    let shipped = std::fs::read(repo().join("host-tests/logs").join(file)).unwrap();
    assert!(
        std::fs::read(&out).unwrap() == shipped,
        "{file} differs from its command: run host-tests/logs/generate.sh and commit"
    );
}
