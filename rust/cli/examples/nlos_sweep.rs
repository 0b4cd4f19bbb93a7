//! The PPSA paper's experiment (Sec. 4.1.2, Figs. 12-13) on simulated logs:
//! positioning error versus NLOS rate for several engines.
//!
//! For each NLOS rate r and seed, `fpbp_sim` simulates a walk on the site
//! (the `fpbp simulate` code path, profile `default` with `ble.nlos_rate = r`:
//! each advert gets an extra attenuation N(nlos_mean_db, nlos_sigma_db) >= 0
//! with probability r). Every engine replays the log from its own start (no
//! `--init truth`) and is scored at every truth point of the log (the
//! simulator writes truth at every step and at 10 Hz), as `fpbp eval` does.
//!
//! Usage: cargo run --release -p fpbp-cli --example nlos_sweep --
//!        [--site maps/demo/site.json] [--seconds 120] [--seeds 3]
//!        [--rates 0,0.2,0.4,0.6,0.8,1] [--engines ppsa,trilat,fpbp,gml,gml-nlos-drop]
//!        [--out out/nlos_sweep] [--init-truth]
//! `--init-truth` hands every engine the log's first truth point (as
//! `fpbp eval --init truth`); without it engines find their own start.
//! Engine `gml-nlos-drop` is `gml` with `ble.nlos.gml_mode = drop`,
//! `gml-nlos-correct` with `correct`; `ppsa-no-nlos` is `ppsa` with NLOS
//! identification disabled (mu_NLOS = 1000 dB), `ppsa-sim-sigmas` uses
//! sigma_LOS 4.5 / sigma_NLOS 6 dB (close to the simulator's spread). Writes OUT/table.md, OUT/table.csv and
//! OUT/rmse_vs_nlos_rate.png.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use fpbp_core::ble::nlos::NlosGmlMode;
use fpbp_core::engine::InitialPosition;
use fpbp_core::engine::replay::replay;
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::LogEvent;
use fpbp_core::site::files::load_site;
use fpbp_eval::plot::{LegendPosition, LineChart, lines_png};
use fpbp_sim::{SimProfile, SimRequest};

fn engine_config(name: &str, seed: u64) -> (String, EngineConfig) {
    let mut cfg = EngineConfig {
        seed,
        ..EngineConfig::default()
    };
    let base = match name {
        "gml-nlos-drop" => {
            cfg.ble.nlos.gml_mode = NlosGmlMode::Drop;
            "gml"
        }
        "gml-nlos-correct" => {
            cfg.ble.nlos.gml_mode = NlosGmlMode::Correct;
            "gml"
        }
        "ppsa-no-nlos" => {
            // TH_best far above any attenuation: every path counts as LOS
            cfg.ble.nlos.mu_nlos_dbm = 1000.0;
            "ppsa"
        }
        "ppsa-sim-sigmas" => {
            // sigmas of the simulator's default profile (shadowing 4 dB and
            // fading 3 dB: about 4.5 dB on a slot mean; NLOS adds 4 dB spread)
            cfg.ble.nlos.sigma_los_dbm = 4.5;
            cfg.ble.nlos.sigma_nlos_dbm = 6.0;
            "ppsa"
        }
        n => n,
    };
    (base.to_string(), cfg)
}

#[derive(Default, Clone)]
struct Acc {
    errors: Vec<f64>,
    points: usize,
    no_fix: usize,
}

fn main() -> Result<()> {
    let mut site_path = PathBuf::from("maps/demo/site.json");
    let mut seconds = 120.0;
    let mut seeds = 3u64;
    let mut rates = vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0];
    let mut engines: Vec<String> = ["ppsa", "trilat", "fpbp", "gml", "gml-nlos-drop"]
        .map(String::from)
        .to_vec();
    let mut out = PathBuf::from("out/nlos_sweep");
    let mut init_truth = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || args.next().ok_or_else(|| anyhow!("{a} needs a value"));
        match a.as_str() {
            "--site" => site_path = PathBuf::from(val()?),
            "--seconds" => seconds = val()?.parse().context("--seconds")?,
            "--seeds" => seeds = val()?.parse().context("--seeds")?,
            "--rates" => {
                rates = val()?
                    .split(',')
                    .map(|s| s.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .context("--rates")?
            }
            "--engines" => engines = val()?.split(',').map(|s| s.trim().to_string()).collect(),
            "--out" => out = PathBuf::from(val()?),
            "--init-truth" => init_truth = true,
            other => bail!("unknown argument {other}"),
        }
    }
    if rates.iter().any(|r| !(0.0..=1.0).contains(r)) {
        bail!("--rates: every rate must be in [0, 1]");
    }
    let site = load_site(&site_path)?;
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    // acc[engine][rate]
    let mut acc = vec![vec![Acc::default(); rates.len()]; engines.len()];
    for (ri, &rate) in rates.iter().enumerate() {
        for seed in 1..=seeds {
            let mut req = SimRequest::new(seconds, seed);
            req.profile = SimProfile::named("default")?;
            req.profile.ble.nlos_rate = rate;
            let log = fpbp_sim::simulate(&site, &req).context("simulating")?;
            for (ei, name) in engines.iter().enumerate() {
                let (base, cfg) = engine_config(name, seed);
                let init = init_truth
                    .then(|| {
                        log.events
                            .iter()
                            .find_map(LogEvent::as_truth)
                            .map(|t| InitialPosition {
                                x_m: t.x_m,
                                y_m: t.y_m,
                                floor: t.floor.unwrap_or(0),
                                heading_rad: None,
                            })
                    })
                    .flatten();
                let mut e = build_engine(&base, site.clone(), &cfg, init)
                    .with_context(|| format!("engine {name}"))?;
                let r = replay(e.as_mut(), log.events.iter().cloned());
                let a = &mut acc[ei][ri];
                a.points += r.scored.len();
                for s in &r.scored {
                    match s.error_m() {
                        Some(x) => a.errors.push(x),
                        None => a.no_fix += 1,
                    }
                }
            }
            eprintln!("rate {rate:.2} seed {seed} done");
        }
    }
    // table
    let mut md = String::new();
    let mut csv = String::from("engine,nlos_rate,points,no_fix,rmse_m,mean_m,p50_m,p90_m\n");
    writeln!(
        md,
        "NLOS sweep: site {}, init {}, {} s x {} seeds per rate, profile default (nlos_mean_db {}, nlos_sigma_db {}); RMSE / mean / p90 error in m over all truth points with a fix (no-fix share)\n",
        site_path.display(),
        if init_truth { "truth" } else { "none" },
        seconds,
        seeds,
        SimProfile::default().ble.nlos_mean_db,
        SimProfile::default().ble.nlos_sigma_db
    )?;
    write!(md, "| engine |")?;
    for r in &rates {
        write!(md, " r={r:.1} |")?;
    }
    writeln!(md)?;
    writeln!(md, "|---|{}", "---|".repeat(rates.len()))?;
    let mut series = Vec::new();
    for (ei, name) in engines.iter().enumerate() {
        write!(md, "| {name} |")?;
        let mut pts = Vec::new();
        for (ri, &rate) in rates.iter().enumerate() {
            let a = &acc[ei][ri];
            let mut v = a.errors.clone();
            v.sort_by(f64::total_cmp);
            let n = v.len().max(1) as f64;
            let rmse = (v.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
            let mean = v.iter().sum::<f64>() / n;
            let pct = |p: f64| fpbp_core::stats::quantile_sorted(&v, p);
            let p50 = pct(0.5).unwrap_or(f64::NAN);
            let p90 = pct(0.9).unwrap_or(f64::NAN);
            let nf = a.no_fix as f64 / a.points.max(1) as f64;
            write!(
                md,
                " {rmse:.2} / {mean:.2} / {p90:.2} ({:.0}%) |",
                nf * 100.0
            )?;
            writeln!(
                csv,
                "{name},{rate},{},{},{rmse:.4},{mean:.4},{p50:.4},{p90:.4}",
                a.points, a.no_fix
            )?;
            if !v.is_empty() {
                pts.push((rate, rmse));
            }
        }
        writeln!(md)?;
        series.push((name.clone(), pts));
    }
    std::fs::write(out.join("table.md"), &md)?;
    std::fs::write(out.join("table.csv"), &csv)?;
    plot(&out.join("rmse_vs_nlos_rate.png"), &series)?;
    print!("{md}");
    println!("wrote {}", out.display());
    Ok(())
}

fn plot(path: &Path, series: &[(String, Vec<(f64, f64)>)]) -> Result<()> {
    let y_max = series
        .iter()
        .flat_map(|(_, v)| v.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(1.0f64, f64::max)
        * 1.1;
    let spec = LineChart {
        title: "RMSE vs NLOS rate (simulated)",
        x_desc: "NLOS rate",
        y_desc: "RMSE (m)",
        x_range: 0.0..1.0,
        y_range: 0.0..y_max,
        markers: true,
        legend: LegendPosition::UpperLeft,
    };
    lines_png(path, &spec, series)
}
