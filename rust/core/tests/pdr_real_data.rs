//! PDR regression on real logs: ILC site2/F4 (26 paths) with the default
//! PdrConfig. Skipped, with a message, when ../shared/datasets is missing.
//! Figures at the time of writing (examples/pdr_stats): ratio median 1.001,
//! 1.86 steps/s, straight-leg heading error median 5.1 deg after a per-path offset.

use std::path::Path;

use fpbp_core::events::LogEvent;
use fpbp_core::geometry::wrap_angle;
use fpbp_core::pdr::{Pdr, PdrConfig};
use fpbp_logs::{ReadOptions, read_all};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn ilc_site2_f4_walked_distance_cadence_and_heading() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ilc/site2/F4/path_data_files");
    if !dir.is_dir() {
        println!("skipped: ../shared/datasets not found");
        return;
    }
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    files.sort();
    let cfg = PdrConfig::default();
    let (mut ratios, mut rates, mut leg_err) = (Vec::new(), Vec::new(), Vec::new());
    for f in files {
        let opts = ReadOptions {
            default_floor: Some(0),
            ..ReadOptions::default()
        };
        let (events, _) = read_all(&f, &opts).unwrap();
        let truth: Vec<_> = events
            .iter()
            .filter_map(LogEvent::as_truth)
            .copied()
            .collect();
        let len: f64 = truth
            .windows(2)
            .map(|w| (w[1].x_m - w[0].x_m).hypot(w[1].y_m - w[0].y_m))
            .sum();
        if truth.len() < 2 || len <= 0.0 {
            continue;
        }
        let (t0, t1) = (truth[0].t_ns, truth[truth.len() - 1].t_ns);
        let mut pdr = Pdr::new(&cfg, 0.0);
        let mut steps = Vec::new();
        for e in &events {
            if let LogEvent::Sensor(s) = e {
                pdr.on_sensor(s);
                steps.extend(
                    pdr.take_steps()
                        .into_iter()
                        .filter(|s| s.t_ns >= t0 && s.t_ns <= t1),
                );
            }
        }
        ratios.push(steps.iter().map(|s| s.length_m).sum::<f64>() / len);
        rates.push(steps.len() as f64 / ((t1 - t0) as f64 * 1e-9));
        let mut errs = Vec::new();
        for w in truth.windows(2) {
            let (dx, dy) = (w[1].x_m - w[0].x_m, w[1].y_m - w[0].y_m);
            let on_leg: Vec<f64> = steps
                .iter()
                .filter(|s| s.t_ns >= w[0].t_ns && s.t_ns <= w[1].t_ns)
                .map(|s| s.yaw_rad)
                .collect();
            if dx.hypot(dy) >= 5.0 && on_leg.len() >= 3 {
                let (s, c) = on_leg
                    .iter()
                    .fold((0.0, 0.0), |(s, c), y| (s + y.sin(), c + y.cos()));
                errs.push(wrap_angle(s.atan2(c) - dy.atan2(dx)));
            }
        }
        if !errs.is_empty() {
            let (s, c) = errs
                .iter()
                .fold((0.0, 0.0), |(s, c), y: &f64| (s + y.sin(), c + y.cos()));
            let off = s.atan2(c);
            leg_err.extend(errs.iter().map(|e| wrap_angle(e - off).abs().to_degrees()));
        }
    }
    assert_eq!(
        ratios.len(),
        26,
        "all 26 site2/F4 paths have >= 2 waypoints"
    );
    let ratio = median(ratios);
    let rate = median(rates);
    let heading = median(leg_err);
    println!(
        "site2/F4: ratio median {ratio:.3}, steps/s median {rate:.2}, leg heading median {heading:.1} deg"
    );
    assert!(
        (0.9..=1.1).contains(&ratio),
        "walked-distance ratio median {ratio}"
    );
    assert!((1.5..=2.2).contains(&rate), "cadence median {rate} steps/s");
    assert!(
        heading < 10.0,
        "straight-leg heading error median {heading} deg"
    );
}
