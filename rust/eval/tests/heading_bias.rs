//! The site heading bias end to end: a simulated walk on the demo site,
//! replayed by the `pdr` engine on a site whose `heading_bias_rad` is
//! wrong by a known angle, gives that angle back
//! (`fpbp_core::pdr::heading_bias`, what `fpbp calibrate` prints and
//! writes), and with the bias it reports the PDR meets the truth.

use std::path::Path;
use std::sync::Arc;

use fpbp_core::engine::InitialPosition;
use fpbp_core::engine::replay::replay;
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::site::{Site, SiteSpec};
use fpbp_eval::heading_bias::{HeadingSegment, heading_bias, segments};
use fpbp_sim::{SimRequest, simulate};

fn demo_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo")
}

fn demo_spec() -> SiteSpec {
    fpbp_core::site::files::load_site(&demo_dir().join("site.json"))
        .unwrap()
        .spec
        .clone()
}

/// The `pdr` engine's segments on three simulated walks, on the demo site
/// with `heading_bias_rad` set to `bias`.
fn pdr_segments(bias: f64) -> Vec<HeadingSegment> {
    let mut spec = demo_spec();
    spec.heading_bias_rad = bias;
    let dir = demo_dir();
    let site = Arc::new(
        Site::build(spec, "demo", &mut |plan: &str| {
            fpbp_core::site::files::read_plan_file(&dir.join(plan))
        })
        .unwrap(),
    );
    let mut out = Vec::new();
    for seed in 1..=3 {
        let mut req = SimRequest::new(90.0, seed);
        // the PDR's own heading, not a walker's phone held askew
        req.profile.imu.yaw_offset_rad = 0.0;
        let log = simulate(&site, &req).unwrap();
        let (k, first) = log
            .events
            .iter()
            .enumerate()
            .find_map(|(k, e)| Some((k, *e.as_truth()?)))
            .unwrap();
        let init = InitialPosition {
            x_m: first.x_m,
            y_m: first.y_m,
            floor: first.floor.unwrap_or(0),
            heading_rad: None,
        };
        let mut e =
            build_engine("pdr", site.clone(), &EngineConfig::default(), Some(init)).unwrap();
        let r = replay(e.as_mut(), log.events[k + 1..].iter().cloned());
        out.extend(segments(&r.scored));
    }
    out
}

#[test]
fn a_wrong_bias_is_measured_and_the_measured_one_fits() {
    let wrong = -0.15;
    let b = heading_bias(&pdr_segments(wrong)).expect("enough segments");
    assert!(b.segments >= 30, "{b:?}");
    // the demo site's own bias is 0: the PDR needs +0.15 rad back
    assert!((b.rad + wrong).abs() < 0.04, "{b:?}");
    let fixed = heading_bias(&pdr_segments(wrong + b.rad)).expect("enough segments");
    assert!(fixed.rad.abs() < 0.02, "{fixed:?}");
}
