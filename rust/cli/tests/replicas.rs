//! Issue 18: the replica testbeds are pinned. The committed
//! maps/replica-*/ files must be exactly what the generator draws, and the
//! generator's output is pinned by a hash, so a change to a replica (plan,
//! beacons, heights, path-loss models) fails here. A tiny `fpbp reproduce
//! all` runs every paper end to end (the CI check of the command).

use std::path::{Path, PathBuf};
use std::process::Command;

use fpbp_eval::reproduce::write_replica as write;
use fpbp_sim::replica_sites::{REPLICAS, build};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
    })
}

#[test]
fn committed_replicas_are_the_generators_and_pinned() {
    let tmp = std::env::temp_dir().join(format!("fpbp-replicas-{}", std::process::id()));
    let mut pins = Vec::new();
    for name in REPLICAS {
        let r = build(name).unwrap();
        write(&r, &tmp).unwrap();
        for file in ["plan.png", "site.json"] {
            let fresh = std::fs::read(tmp.join(&r.dir).join(file)).unwrap();
            let committed = std::fs::read(repo().join("maps").join(&r.dir).join(file))
                .unwrap_or_else(|e| panic!("maps/{}/{file}: {e}", r.dir));
            assert!(
                fresh == committed,
                "maps/{}/{file} differs from the generator: run \
                 `cargo run -p fpbp-cli --example make_replica_sites -- maps`",
                r.dir
            );
        }
        // the site's content (beacons, models, floors) and the plan's pixels
        let raw: Vec<u8> = r.plan.as_raw().clone();
        pins.push(format!(
            "{} {} beacons {:016x} {:016x}",
            r.dir,
            r.spec.beacons.len(),
            fnv(r.spec.to_json_pretty().as_bytes()),
            fnv(&raw)
        ));
    }
    std::fs::remove_dir_all(&tmp).ok();
    let got = pins.join("\n");
    let want = "\
replica-fpbp 200 beacons 4c871bbc907eb3c8 28255a92bd69b80d
replica-prox-pf 9 beacons 6a2b1fb8cb08fe7b 061a64a8003ac0b3
replica-ppsa 32 beacons 365a5fb02648d205 4365e9cbffa86f73
replica-bmw 11 beacons c55e7ff40b624ce2 3ffbecb0bf932c93
replica-tc 22 beacons f1b7e078eff0d727 9d4e37f3a3c853a5";
    assert_eq!(got, want, "a replica site changed:\n{got}");
}

/// Every replica is a valid site whose beacons the paper's figures need:
/// PPSA's 32 at Table 1's coordinates, the proximity PF's 9, BMW's 11 on two
/// floors.
#[test]
fn replicas_follow_their_papers() {
    let ppsa = build("ppsa").unwrap();
    assert_eq!(ppsa.spec.beacons.len(), 32);
    for (b, p) in ppsa
        .spec
        .beacons
        .iter()
        .zip(fpbp_sim::replica_sites::PPSA_TABLE_1)
    {
        assert_eq!((b.x_m, b.y_m), (p[0], p[1]));
        assert_eq!((b.rssi_1m_dbm, b.path_loss_exponent), (-55.0, 2.7));
    }
    assert_eq!(build("prox-pf").unwrap().spec.beacons.len(), 9);
    let bmw = build("bmw").unwrap();
    assert_eq!(bmw.spec.beacons.len(), 11);
    assert_eq!(bmw.spec.floors.len(), 2);
    for name in REPLICAS {
        let site = fpbp_core::site::files::load_site(
            &repo()
                .join("maps")
                .join(format!("replica-{name}"))
                .join("site.json"),
        );
        assert!(site.is_ok(), "replica-{name}: {:?}", site.err());
    }
}

#[test]
fn tiny_reproduce_all_runs_every_paper() {
    let out = std::env::temp_dir().join(format!("fpbp-reproduce-{}", std::process::id()));
    let o = Command::new(env!("CARGO_BIN_EXE_fpbp"))
        .args([
            "reproduce",
            "all",
            "--seeds",
            "1",
            "--duration-scale",
            "0.2",
        ])
        .arg("--maps")
        .arg(repo().join("maps"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for (paper, source) in [
        ("fpbp", "Table II, trajectory 1"),
        ("prox-pf", "Table I, Ours"),
        ("ppsa", "Table 4, PPSA"),
        ("bmw", "Table 3, fusion"),
        ("tc", "Table III"),
    ] {
        assert!(text.contains(source), "no `{source}` row:\n{text}");
        assert!(
            out.join(paper).join("cdf.png").is_file(),
            "{paper}: no cdf.png"
        );
        let json = std::fs::read_to_string(out.join(paper).join("results.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        // every variant has a coverage and, with poses, a finite mean
        for var in v["variants"].as_array().unwrap() {
            let cov = var["coverage"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&cov), "{paper}: {var}");
            if cov > 0.0 {
                assert!(
                    var["mean_m"].as_f64().unwrap().is_finite(),
                    "{paper}: {var}"
                );
            }
        }
    }
    std::fs::remove_dir_all(&out).ok();
}

/// The BMW replica's walked survey (fpbp_sim::replica::survey_walks): four
/// rings 0.6 m apart on each floor, known points only at the survey lines'
/// ends, reference points in the corridor band on both floors.
#[test]
fn bmw_walked_survey_covers_the_corridor_on_both_floors() {
    use fpbp_core::engines::EngineConfig;
    use fpbp_eval::json_patch::merge;
    use fpbp_sim::replica::SurveyPattern;
    use fpbp_sim::replica_survey::{BMW_SURVEY_CONFIG, survey_db};
    let site =
        fpbp_core::site::files::load_site(&repo().join("maps/replica-bmw/site.json")).unwrap();
    let mut value = serde_json::to_value(EngineConfig::default()).unwrap();
    merge(
        &mut value,
        &serde_json::from_str(BMW_SURVEY_CONFIG).unwrap(),
    );
    let cfg = EngineConfig::from_json(&value.to_string()).unwrap();
    let (set, known, samples) = survey_db("bmw", &site, &cfg, 1, SurveyPattern::Alternate)
        .unwrap()
        .unwrap();
    // 20 lines and 3 ring changes per floor: a few dozen known points, not 10 Hz truth
    assert!((40..=80).contains(&known), "{known} known points");
    assert!(samples > 900, "{samples} samples");
    assert_eq!(set.floors.keys().copied().collect::<Vec<_>>(), vec![0, 1]);
    for (floor, f) in &set.floors {
        let n = f.db.points.len();
        assert!((300..=520).contains(&n), "floor {floor}: {n} points");
        for p in &f.db.points {
            let (x, y) = (p.pos.x, p.pos.y);
            let in_band = (1.3..=32.7).contains(&x)
                && (1.3..=14.7).contains(&y)
                && !((4.7..=29.3).contains(&x) && (4.7..=11.3).contains(&y));
            assert!(
                in_band,
                "floor {floor}: point ({x:.2}, {y:.2}) off the corridor"
            );
        }
    }
    assert!(
        survey_db("tc", &site, &cfg, 1, SurveyPattern::Alternate)
            .unwrap()
            .is_none()
    );
}

/// `walk.waypoints_m`: the simulated walker follows the course, corner
/// after corner, within half a metre (the proximity-PF course).
#[test]
fn replica_walk_follows_its_waypoints_in_order() {
    let site =
        fpbp_core::site::files::load_site(&repo().join("maps/replica-prox-pf/site.json")).unwrap();
    let profile = fpbp_sim::SimProfile::named("replica-prox-pf-1").unwrap();
    let wps = profile.walk.waypoints_m.clone();
    let req = fpbp_sim::SimRequest {
        profile,
        ..fpbp_sim::SimRequest::new(70.0, 3)
    };
    let log = fpbp_sim::simulate(&site, &req).unwrap();
    let traj = &log.trajectory;
    let mut t = 0.0;
    for w in &wps {
        let target = fpbp_core::Vec2::new(w[0], w[1]);
        let mut hit = None;
        let mut s = t;
        while s <= 70.0 {
            if (traj.position_at(s) - target).norm() < 0.5 {
                hit = Some(s);
                break;
            }
            s += 0.05;
        }
        let Some(s) = hit else {
            panic!("waypoint {w:?} not reached after t = {t:.1} s");
        };
        t = s;
    }
    assert!(log.header.distance_m > 60.0, "{}", log.header.distance_m);
}
