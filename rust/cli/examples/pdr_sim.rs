//! PDR against the simulator's truth, step by step: how many steps are found,
//! how long they are and which way they point, per carry profile.
//!
//! Usage: cargo run --release -p fpbp-cli --example pdr_sim -- [--site SITE]
//!        [--profiles default,swinging] [--seeds 1,2,3] [--seconds 120]
//!        [--config JSON] [--per-step]
//!
//! Each detected step is matched to the true step whose span holds its peak
//! time; its heading error is the step's yaw minus the route direction at the
//! middle of that true step. Figures per run: detected / true steps, matched
//! steps, walked-distance ratio (sum of detected lengths / true distance),
//! length ratio of matched steps (median), heading error (median and p80 of
//! |err|, and the circular mean of err), and the `pdr` position error at the
//! end of the walk (dead reckoning from the true start, no map).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use fpbp_core::events::LogEvent;
use fpbp_core::geometry::wrap_angle;
use fpbp_core::pdr::{Pdr, PdrConfig};
use fpbp_core::site::files::load_site;
use fpbp_sim::{SimProfile, SimRequest, simulate};

fn pct(v: &[f64], p: f64) -> f64 {
    fpbp_core::stats::quantile(v, p).unwrap_or(f64::NAN)
}

fn main() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut site_path = root.join("maps/demo/site.json");
    let mut profiles = vec!["default".to_string(), "swinging".to_string()];
    let mut seeds = vec![1u64, 2, 3];
    let mut seconds = 120.0;
    let mut cfg = PdrConfig::default();
    let mut per_step = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || args.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--site" => site_path = PathBuf::from(val()?),
            "--profiles" => profiles = val()?.split(',').map(str::to_string).collect(),
            "--seeds" => {
                seeds = val()?
                    .split(',')
                    .map(|s| s.parse().context("--seeds"))
                    .collect::<Result<_>>()?
            }
            "--seconds" => seconds = val()?.parse().context("--seconds")?,
            "--config" => {
                cfg = serde_json::from_str(&val()?).context("--config")?;
                cfg.validate()?;
            }
            "--per-step" => per_step = true,
            other => bail!("unknown option {other}"),
        }
    }
    let site = load_site(&site_path)?;
    println!("config: {}", serde_json::to_string(&cfg)?);
    println!(
        "{:9} {:>4} {:>5} {:>5} {:>5} {:>6} {:>6} {:>7} {:>7} {:>7} {:>7} {:>7}",
        "profile",
        "seed",
        "true",
        "found",
        "match",
        "dist",
        "len",
        "|h|p50",
        "|h|p80",
        "h_mean",
        "end_m",
        "upright"
    );
    for prof in &profiles {
        for &seed in &seeds {
            let mut req = SimRequest::new(seconds, seed);
            req.profile = SimProfile::named(prof)?;
            let log = simulate(&site, &req)?;
            let traj = &log.trajectory;
            let t0 = req.t0_ns;
            let mut pdr = Pdr::new(&cfg, site.spec.pdr_rotation_rad());
            let mut steps = Vec::new();
            for e in &log.events {
                if let LogEvent::Sensor(s) = e {
                    pdr.on_sensor(s);
                    steps.extend(pdr.take_steps());
                }
            }
            let true_steps: Vec<_> = traj.steps_in_log().collect();
            let true_dist: f64 = true_steps.iter().map(|s| s.length_m).sum();
            let mut matched = 0;
            let mut len_ratio = Vec::new();
            let mut herr = Vec::new();
            let (mut sx, mut sy) = (0.0, 0.0);
            let start = traj.position_at(0.0);
            let (mut px, mut py) = (start.x, start.y);
            let mut last_t = 0.0;
            for st in &steps {
                let t = (st.t_ns - t0) as f64 * 1e-9;
                px += st.length_m * st.yaw_rad.cos();
                py += st.length_m * st.yaw_rad.sin();
                last_t = t;
                let k = true_steps.partition_point(|s| s.t_end_s <= t);
                let Some(ts) = true_steps.get(k).filter(|s| s.t_start_s <= t) else {
                    if per_step {
                        println!("  t {t:7.2} unmatched len {:.2}", st.length_m);
                    }
                    continue;
                };
                matched += 1;
                len_ratio.push(st.length_m / ts.length_m);
                let mid = 0.5 * (ts.t_start_s + ts.t_end_s);
                let dir = traj.heading_at_arc(traj.arc_at(mid));
                let e = wrap_angle(st.yaw_rad - dir);
                sx += e.cos();
                sy += e.sin();
                herr.push(e.abs().to_degrees());
                if per_step {
                    println!(
                        "  t {t:7.2} step {:4} len {:.2}/{:.2} yaw {:7.1} true {:7.1} err {:7.1}",
                        ts.index,
                        st.length_m,
                        ts.length_m,
                        st.yaw_rad.to_degrees(),
                        dir.to_degrees(),
                        e.to_degrees()
                    );
                }
            }
            let walked: f64 = steps.iter().map(|s| s.length_m).sum();
            let end = traj.position_at(last_t);
            println!(
                "{:9} {:>4} {:>5} {:>5} {:>5} {:>6.3} {:>6.3} {:>7.1} {:>7.1} {:>7.1} {:>7.2} {:>7}",
                prof,
                seed,
                true_steps.len(),
                steps.len(),
                matched,
                walked / true_dist,
                pct(&len_ratio, 0.5),
                pct(&herr, 0.5),
                pct(&herr, 0.8),
                sy.atan2(sx).to_degrees(),
                (px - end.x).hypot(py - end.y),
                pdr.stats().upright_steps,
            );
        }
    }
    Ok(())
}
