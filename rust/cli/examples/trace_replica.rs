//! Traces one engine on one replica walk (docs/reproduction.md): after every
//! task run, the engine's pose and its BLE-only position (x_B, when it has
//! one) beside the truth at that time, and the pose's accuracy (for `fpbp`
//! and `bp` the particle cloud's spread, at least 0.5 m), as CSV on stdout;
//! a summary on stderr.
//! For finding where and why an engine leaves the walker.
//!
//! Usage: cargo run --release -p fpbp-cli --example trace_replica --
//!        PAPER WALK SEED ENGINE [CONFIG_JSON] [--truth-start]
//!
//! WALK is the 0-based index of the paper's replica walk, SEED is both the
//! walk's and the engine's seed (as in `fpbp reproduce`), CONFIG_JSON is
//! merged over the default engine config (objects recursively). The
//! environment variable PROFILE_PATCH (JSON) is merged over the walk's
//! simulator profile. SURVEY=alternate|with|against: robust-ekf with the
//! replica's walked survey database (as `fpbp reproduce`; the survey's
//! settings merged under CONFIG_JSON) instead of its model database.

use std::path::Path;

use anyhow::{Context, Result, bail};
use fpbp_core::engine::{Engine, InitialPosition, Task};
use fpbp_core::engines::{EngineConfig, EngineData, build_engine_with};
use fpbp_core::events::{LogEvent, TruthPoint};
use fpbp_eval::json_patch::merge;

fn truth_at(truth: &[TruthPoint], t: i64) -> Option<(f64, f64, Option<i32>)> {
    let i = truth.partition_point(|p| p.t_ns <= t);
    if i == 0 || i >= truth.len() {
        return None;
    }
    let (a, b) = (truth[i - 1], truth[i]);
    let w = (t - a.t_ns) as f64 / (b.t_ns - a.t_ns).max(1) as f64;
    Some((
        a.x_m + w * (b.x_m - a.x_m),
        a.y_m + w * (b.y_m - a.y_m),
        a.floor,
    ))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let truth_start = args.iter().any(|a| a == "--truth-start");
    let pos: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    if pos.len() < 4 {
        bail!("usage: trace_replica PAPER WALK SEED ENGINE [CONFIG_JSON] [--truth-start]");
    }
    let (paper, walk_k, seed, engine) = (
        pos[0].as_str(),
        pos[1].parse::<usize>()?,
        pos[2].parse::<u64>()?,
        pos[3].as_str(),
    );
    let mut value = serde_json::to_value(EngineConfig::default())?;
    let survey = std::env::var("SURVEY").ok();
    if survey.is_some() {
        merge(
            &mut value,
            &serde_json::from_str(fpbp_sim::replica_survey::BMW_SURVEY_CONFIG)?,
        );
    }
    if let Some(patch) = pos.get(4) {
        merge(&mut value, &serde_json::from_str(patch).context("config")?);
    }
    let mut cfg = EngineConfig::from_json(&value.to_string())?;
    cfg.seed = seed;
    let site = fpbp_core::site::files::load_site(
        &Path::new("maps")
            .join(format!("replica-{paper}"))
            .join("site.json"),
    )?;
    let walks = fpbp_sim::replica::replica_walks(paper)?;
    let walk = walks.get(walk_k).context("no such walk")?;
    // PROFILE_PATCH: JSON merged over the walk's simulator profile (channel
    // experiments, as `fpbp reproduce --profile-patch`).
    let mut profile = walk.profile.clone();
    if let Ok(patch) = std::env::var("PROFILE_PATCH") {
        let p = serde_json::from_str(&patch).context("PROFILE_PATCH")?;
        profile = fpbp_eval::json_patch::patched(&profile, &p)?;
        profile.validate()?;
    }
    let sim = fpbp_sim::simulate(
        &site,
        &fpbp_sim::SimRequest {
            duration_s: walk.duration_s,
            seed,
            floor: None,
            t0_ns: fpbp_sim::DEFAULT_T0_NS,
            profile,
        },
    )?;
    let truth: Vec<TruthPoint> = sim
        .events
        .iter()
        .filter_map(LogEvent::as_truth)
        .copied()
        .collect();
    let init = truth_start.then(|| InitialPosition {
        x_m: truth[0].x_m,
        y_m: truth[0].y_m,
        floor: truth[0].floor.unwrap_or(0),
        heading_rad: None,
    });
    let dump_ble_s: f64 = std::env::var("DUMP_BLE_S")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0);
    let mut data = EngineData::default();
    if let Some(pattern) = &survey {
        let pattern = fpbp_sim::replica_survey::parse_pattern(pattern)?;
        let (set, known, samples) =
            fpbp_sim::replica_survey::survey_db(paper, &site, &cfg, seed, pattern)?
                .context("this replica has no survey walks")?;
        eprintln!("walked survey DB: {known} known points, {samples} samples");
        data.fingerprints = Some(std::sync::Arc::new(set));
    }
    let mut e: Box<dyn Engine> = build_engine_with(engine, site.clone(), &cfg, init, &data)?;
    let periods = Task::ALL.map(|t| e.task_period_ns(t).filter(|p| *p > 0));
    let t0 = sim.events.first().map_or(0, LogEvent::t_ns);
    let mut due = periods.map(|p| p.map(|p| t0 + p));
    println!(
        "t_s,task,truth_x,truth_y,truth_floor,x,y,floor,err,fix_x,fix_y,fix_floor,fix_err,accuracy"
    );
    let (mut sum, mut n, mut fsum, mut fn_) = (0.0, 0usize, 0.0, 0usize);
    let mut run_until = |e: &mut Box<dyn Engine>, t: i64| loop {
        let mut best: Option<(i64, usize)> = None;
        for (i, d) in due.iter().enumerate() {
            if let Some(d) = *d
                && d <= t
                && best.is_none_or(|(b, _)| d < b)
            {
                best = Some((d, i));
            }
        }
        let Some((d, i)) = best else { break };
        e.run_task(Task::ALL[i], d);
        due[i] = Some(d + periods[i].unwrap_or(i64::MAX / 4));
        let Some((tx, ty, tf)) = truth_at(&truth, d) else {
            continue;
        };
        let pose = e.pose();
        let fix = e.ble_position().filter(|f| f.t_ns == d);
        let err = pose.map(|p| (p.x_m - tx).hypot(p.y_m - ty));
        let ferr = fix.map(|p| (p.x_m - tx).hypot(p.y_m - ty));
        if let Some(v) = err {
            sum += v;
            n += 1;
        }
        if let Some(v) = ferr {
            fsum += v;
            fn_ += 1;
        }
        let o = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.2}"));
        let oi = |v: Option<i32>| v.map_or(String::new(), |v| v.to_string());
        println!(
            "{:.2},{:?},{tx:.2},{ty:.2},{},{},{},{},{},{},{},{},{},{}",
            (d - t0) as f64 * 1e-9,
            Task::ALL[i],
            oi(tf),
            o(pose.map(|p| p.x_m)),
            o(pose.map(|p| p.y_m)),
            oi(pose.map(|p| p.floor)),
            o(err),
            o(fix.map(|p| p.x_m)),
            o(fix.map(|p| p.y_m)),
            oi(fix.map(|p| p.floor)),
            o(ferr),
            o(pose.map(|p| p.accuracy_m))
        );
    };
    for ev in &sim.events {
        run_until(&mut e, ev.t_ns());
        match ev {
            LogEvent::Sensor(s) => e.on_sensor(s),
            LogEvent::Ble(b) => {
                if (b.t_ns - t0) as f64 * 1e-9 < dump_ble_s {
                    eprintln!(
                        "ble {:.2} {} {:.1}",
                        (b.t_ns - t0) as f64 * 1e-9,
                        b.beacon_id,
                        b.rssi_dbm
                    );
                }
                e.on_ble(b)
            }
            LogEvent::Gnss(g) => e.on_gnss(g),
            LogEvent::Wifi(w) => e.on_wifi(w),
            LogEvent::Truth(_) => {}
        }
    }
    eprintln!(
        "{paper} walk {walk_k} seed {seed} {engine}: mean error at task runs {:.2} m ({n}), \
         BLE fixes {:.2} m ({fn_}); stats {:?}",
        sum / n.max(1) as f64,
        fsum / fn_.max(1) as f64,
        e.stats()
    );
    Ok(())
}
