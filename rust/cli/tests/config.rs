//! `fpbp config`: an engine's settings as the JSON `--config` reads.

use std::process::Command;

fn fpbp(args: &[&str]) -> (bool, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .args(args)
        .output()
        .expect("fpbp runs");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn config_prints_what_config_reads_back() {
    let (ok, out, err) = fpbp(&["config", "--engine", "tcpf"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["tcpf"]["particle_count"], 1000);
    assert!(v.get("prox_pf").is_none(), "tcpf reads no prox_pf section");
    // the printed settings, changed and handed back, come out changed
    let changed = out.replace("\"particle_count\": 1000", "\"particle_count\": 321");
    assert_ne!(changed, out);
    let (ok, back, err) = fpbp(&["config", "--engine", "tcpf", "--config", &changed]);
    assert!(ok, "{err}");
    assert_eq!(back, changed);
    let (ok, _, err) = fpbp(&["config", "--engine", "nope"]);
    assert!(!ok);
    assert!(err.contains("nope") && err.contains("tcpf"), "{err}");
    let (ok, _, err) = fpbp(&["config", "--config", "{\"tcpf\": {\"no_such\": 1}}"]);
    assert!(!ok);
    assert!(err.contains("no_such"), "{err}");
}
