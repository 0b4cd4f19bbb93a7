//! `fpbp eval`: engines over logs -> DIR/metrics.json, DIR/cdf.png, per-log
//! rows; the work is `fpbp_eval::eval`, this prints the table.

use fpbp_eval::eval::{EvalOptions, fmt_pct, run_seeds, run_with};
use fpbp_eval::metrics::{EngineMetrics, fmt_opt};
use fpbp_eval::report::{SeedList, SeedSummary};
use fpbp_eval::{engine_data, radio_map, runner};

pub fn run(args: EvalOptions) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let site = runner::load_site(&args.site)?;
    let mut data = engine_data::engine_data(
        args.fingerprints.as_deref(),
        &args.engine,
        &site,
        &runner::load_config(args.config.as_deref(), args.seed)?,
    )?;
    if let Some(p) = &args.radio_map {
        data.radio_map = Some(radio_map::load(p, &site)?);
    }
    let build = runner::builder_with(data);
    if let Some(SeedList(seeds)) = args.seeds.clone() {
        let summary = run_seeds(&args, &seeds, &build, true)?;
        print_seed_table(&summary, &seeds);
    } else {
        let metrics = run_with(&args, &build, true)?;
        print_table(&metrics);
    }
    println!(
        "wrote {} and {} ({:.1} s)",
        args.out.join("metrics.json").display(),
        args.out.join("cdf.png").display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn print_seed_table(ss: &[SeedSummary], seeds: &[u64]) {
    let pm = |o: &fpbp_eval::report::OverSeeds, d: usize| match (o.mean, o.sd) {
        (Some(m), Some(s)) => format!("{m:.d$}±{s:.d$}"),
        (Some(m), None) => format!("{m:.d$}"),
        _ => "-".into(),
    };
    println!(
        "mean ± sd over seeds {} ({} runs per engine)",
        seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(","),
        seeds.len()
    );
    println!(
        "{:<12} {:>5} {:>6} {:>11} {:>9} {:>11} {:>11} {:>11} {:>11} {:>6} {:>7}",
        "engine",
        "logs",
        "points",
        "mpe_m",
        "coverage",
        "p50_m",
        "p80_m",
        "ipin_m",
        "jumps/100m",
        "start",
        "in_acc"
    );
    for s in ss {
        let cov = match (s.coverage.mean, s.coverage.sd) {
            (Some(m), Some(sd)) => format!("{:.0}±{:.0}%", 100.0 * m, 100.0 * sd),
            (m, _) => fmt_pct(m),
        };
        println!(
            "{:<12} {:>5} {:>6} {:>11} {:>9} {:>11} {:>11} {:>11} {:>11} {:>6} {:>7}",
            s.engine,
            s.logs,
            s.points,
            pm(&s.mpe_m, 2),
            cov,
            pm(&s.p50_m, 2),
            pm(&s.p80_m, 2),
            pm(&s.ipin_score_m, 2),
            pm(&s.jumps_per_100m, 2),
            s.start.name(),
            fmt_pct(s.within_accuracy.mean)
        );
    }
}

/// The eval table. Column 5 stays `mpe_m` (scripts read it); coverage
/// stands beside it.
fn print_table(ms: &[EngineMetrics]) {
    println!(
        "{:<12} {:>5} {:>6} {:>6} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>8} {:>7} {:>7} {:>10} {:>10} {:>9} {:>6}",
        "engine",
        "logs",
        "points",
        "no_fix",
        "mpe_m",
        "coverage",
        "p50_m",
        "p80_m",
        "p95_m",
        "max_m",
        "floor",
        "ipin_m",
        "jmp/hm",
        "wall/hm",
        "mct_radio",
        "mct_fus",
        "realtime",
        "start"
    );
    for m in ms {
        let e = &m.errors;
        println!(
            "{:<12} {:>5} {:>6} {:>6} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>8} {:>7} {:>7} {:>10} {:>10} {:>9} {:>6}",
            m.engine,
            m.logs,
            e.points,
            e.no_fix,
            fmt_opt(e.mpe_m, 2),
            fmt_pct(e.coverage),
            fmt_opt(e.p50_m, 2),
            fmt_opt(e.p80_m, 2),
            fmt_opt(e.p95_m, 2),
            fmt_opt(e.max_m, 2),
            fmt_opt(e.floor_accuracy, 2),
            fmt_opt(e.ipin_score_m, 2),
            fmt_opt(m.track.jumps_per_100m, 1),
            fmt_opt(m.track.wall_crossings_per_100m, 1),
            fmt_opt(m.mct_us.radio, 1),
            fmt_opt(m.mct_us.fusion, 1),
            fmt_opt(m.realtime_factor, 0),
            m.start.name(),
        );
    }
    println!(
        "(errors over the points with a pose; coverage = their share; jmp/hm, wall/hm: \
         track jumps and wall crossings per 100 m of track)"
    );
}
