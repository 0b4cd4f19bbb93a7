//! PDR against the simulator's truth on the demo site: the phone in a
//! swinging hand (profile `swinging`) must give steps pointing along the walk
//! with the default (tilt-aware) forward axis; the paper's top-of-screen axis
//! flips with the swing. Figures at the time of writing
//! (`cargo run --release -p fpbp-cli --example pdr_sim`, 120 s walks): heading
//! |err| median 7-13 deg with `tilt_aware`, 84-142 deg with `top`.

mod common;

use common::demo_site;
use fpbp_core::events::LogEvent;
use fpbp_core::geometry::wrap_angle;
use fpbp_core::pdr::{ForwardAxis, Pdr, PdrConfig};
use fpbp_core::site::Site;
use fpbp_sim::{SimProfile, SimRequest, simulate};

/// (median |heading error| deg, walked-distance ratio) of one simulated walk.
fn run(site: &Site, profile: &str, seed: u64, cfg: &PdrConfig) -> (f64, f64) {
    let mut req = SimRequest::new(60.0, seed);
    req.profile = SimProfile::named(profile).unwrap();
    // The PDR's own errors only: a walker with the PDR's step-length model
    // and a small phone-to-walking-direction offset (the defaults add the
    // real walkers' 12 % / 10 deg spread: docs/sim.md "PDR drift").
    req.profile.imu.walker_step_length_sd_rel = 0.0;
    req.profile.imu.yaw_offset_rad = 0.05;
    let log = simulate(site, &req).unwrap();
    let traj = &log.trajectory;
    let mut pdr = Pdr::new(cfg, site.spec.map_from_enu_rad);
    let mut steps = Vec::new();
    for e in &log.events {
        if let LogEvent::Sensor(s) = e {
            pdr.on_sensor(s);
            steps.extend(pdr.take_steps());
        }
    }
    let truth: Vec<_> = traj.steps_in_log().collect();
    let mut err = Vec::new();
    for st in &steps {
        let t = (st.t_ns - req.t0_ns) as f64 * 1e-9;
        let k = truth.partition_point(|s| s.t_end_s <= t);
        if let Some(ts) = truth.get(k).filter(|s| s.t_start_s <= t) {
            let dir = traj.heading_at_arc(traj.arc_at(0.5 * (ts.t_start_s + ts.t_end_s)));
            err.push(wrap_angle(st.yaw_rad - dir).abs().to_degrees());
        }
    }
    assert!(
        err.len() * 10 >= truth.len() * 9,
        "{} of {}",
        err.len(),
        truth.len()
    );
    err.sort_by(f64::total_cmp);
    let walked: f64 = steps.iter().map(|s| s.length_m).sum();
    let true_m: f64 = truth.iter().map(|s| s.length_m).sum();
    (err[err.len() / 2], walked / true_m)
}

#[test]
fn swinging_hand_steps_point_along_the_walk() {
    let site = demo_site();
    let tilt = PdrConfig::default();
    assert_eq!(tilt.forward_axis, ForwardAxis::TiltAware);
    let top = PdrConfig {
        forward_axis: ForwardAxis::Top,
        ..PdrConfig::default()
    };
    for seed in [1, 2, 3] {
        let (med, ratio) = run(&site, "swinging", seed, &tilt);
        eprintln!("swinging seed {seed}: tilt_aware |err| median {med:.1} deg, ratio {ratio:.3}");
        assert!(med < 20.0, "seed {seed}: median |err| {med} deg");
        assert!((ratio - 1.0).abs() < 0.06, "seed {seed}: ratio {ratio}");
        let (med_top, _) = run(&site, "swinging", seed, &top);
        assert!(
            med_top > 60.0,
            "seed {seed}: top axis median |err| {med_top} deg"
        );
        // Phone in front: both axes agree (it never counts as upright).
        let (a, _) = run(&site, "default", seed, &tilt);
        let (b, _) = run(&site, "default", seed, &top);
        assert!((a - b).abs() < 1e-9 && a < 20.0, "seed {seed}: {a} vs {b}");
    }
}
