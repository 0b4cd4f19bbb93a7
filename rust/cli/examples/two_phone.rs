//! The two-phone measure of issue 16 on simulated walks of the demo site
//! (the test `a_phone_nine_db_weaker_is_seen_as_one` on any walks and
//! config): each walk replayed as heard and with every beacon `OFFSET` dB
//! weaker, engine seed 1; per walk the two offsets, the tracks' separation
//! after 60 s (median, p90) and each phone's mean error against the truth.
//!
//! Usage: cargo run --release -p fpbp-cli --example two_phone --
//!        SIMS [CONFIG_JSON] [--offset DB] [--seconds S] [--seed-pair]
//!
//! SIMS: comma-separated simulation seeds (e.g. 3,4). CONFIG_JSON is
//! merged over the default engine config (objects recursively).
//! `--seed-pair`: the same readings with engine seeds 1 and 2 instead
//! (the floor of the measure).

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use fpbp_core::engine::Pose;
use fpbp_core::engine::replay::{ReplayOutput, replay};
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::LogEvent;
use fpbp_core::site::Site;
use fpbp_eval::json_patch::merge;
use fpbp_sim::{SimRequest, simulate};

fn run(site: &Arc<Site>, events: &[LogEvent], cfg: &EngineConfig, seed: u64) -> ReplayOutput {
    let cfg = EngineConfig {
        seed,
        ..cfg.clone()
    };
    let mut e = build_engine("tcpf", site.clone(), &cfg, None).expect("engine");
    replay(e.as_mut(), events.iter().cloned())
}

fn at(track: &[Pose], t_ns: i64) -> Option<Pose> {
    let k = track.partition_point(|p| p.t_ns <= t_ns);
    k.checked_sub(1).map(|i| track[i])
}

/// Mean error over the scored points from `t_ns` on.
fn mean_err(out: &ReplayOutput, t_ns: i64) -> f64 {
    let e: Vec<f64> = out
        .scored
        .iter()
        .filter(|s| s.truth.t_ns >= t_ns)
        .filter_map(|s| s.error_m())
        .collect();
    e.iter().sum::<f64>() / e.len().max(1) as f64
}

/// Mean error over the scored points of the first 20 s after `t0`.
fn first(out: &ReplayOutput, t0: i64) -> f64 {
    let e: Vec<f64> = out
        .scored
        .iter()
        .filter(|s| s.truth.t_ns < t0 + 20_000_000_000)
        .filter_map(|s| s.error_m())
        .collect();
    e.iter().sum::<f64>() / e.len().max(1) as f64
}

fn quantile(v: &[f64], q: f64) -> f64 {
    fpbp_core::stats::quantile(v, q).unwrap_or(f64::NAN)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut offset_db = 9.0;
    let mut seconds = 180.0;
    let mut seed_pair = false;
    let mut pos = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--offset" => offset_db = it.next().context("--offset DB")?.parse()?,
            "--seconds" => seconds = it.next().context("--seconds S")?.parse()?,
            "--seed-pair" => seed_pair = true,
            _ => pos.push(a.clone()),
        }
    }
    if pos.is_empty() {
        bail!("usage: two_phone SIMS [CONFIG_JSON] [--offset DB] [--seconds S] [--seed-pair]");
    }
    let sims: Vec<u64> = pos[0]
        .split(',')
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let mut value = serde_json::to_value(EngineConfig::default())?;
    if let Some(patch) = pos.get(1) {
        merge(&mut value, &serde_json::from_str(patch).context("config")?);
    }
    let cfg = EngineConfig::from_json(&value.to_string())?;
    let site = fpbp_core::site::files::load_site(Path::new("maps/demo/site.json"))?;
    let mut all = Vec::new();
    for sim in sims {
        let log = simulate(&site, &SimRequest::new(seconds, sim))?;
        let other: Vec<LogEvent> = if seed_pair {
            log.events.clone()
        } else {
            log.events
                .iter()
                .cloned()
                .map(|e| match e {
                    LogEvent::Ble(mut b) => {
                        b.rssi_dbm -= offset_db;
                        LogEvent::Ble(b)
                    }
                    o => o,
                })
                .collect()
        };
        let a = run(&site, &log.events, &cfg, 1);
        let b = run(&site, &other, &cfg, if seed_pair { 2 } else { 1 });
        let t0 = log.events[0].t_ns();
        let sep: Vec<f64> = a
            .track
            .iter()
            .filter(|p| p.t_ns - t0 > 60_000_000_000)
            .filter_map(|p| at(&b.track, p.t_ns).map(|q| (p.x_m - q.x_m).hypot(p.y_m - q.y_m)))
            .collect();
        let (oa, ob) = (
            a.stats.rssi_offset_db.unwrap_or(f64::NAN),
            b.stats.rssi_offset_db.unwrap_or(f64::NAN),
        );
        println!(
            "sim {sim}: offsets {oa:.2} / {ob:.2} (apart {:.2}) dB, separation median {:.2} m p90 {:.2} m, errors {:.2} / {:.2} m (first 20 s {:.2} / {:.2}, after 60 s {:.2} / {:.2})",
            oa - ob,
            quantile(&sep, 0.5),
            quantile(&sep, 0.9),
            mean_err(&a, 0),
            mean_err(&b, 0),
            first(&a, t0),
            first(&b, t0),
            mean_err(&a, t0 + 60_000_000_000),
            mean_err(&b, t0 + 60_000_000_000)
        );
        all.extend(sep);
    }
    println!(
        "all: separation median {:.2} m p90 {:.2} m ({} poses)",
        quantile(&all, 0.5),
        quantile(&all, 0.9),
        all.len()
    );
    Ok(())
}
