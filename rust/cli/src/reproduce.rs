//! `fpbp reproduce PAPER|all`: the five papers' headline results on their
//! replica testbeds (docs/reproduction.md); the runner and the papers'
//! figures live in `fpbp_eval::reproduce`, this prints them.

use std::path::PathBuf;

use anyhow::{Context, bail};
use fpbp_eval::metrics;
use fpbp_eval::plot;
use fpbp_eval::reproduce::{Experiment, PaperResult, paper_spec, reproduce_paper};
use fpbp_sim::replica::SurveyPattern;
use fpbp_sim::replica_survey::parse_pattern;

/// Arguments of `fpbp reproduce`.
#[derive(clap::Args)]
pub struct Args {
    /// `fpbp`, `prox-pf`, `ppsa`, `bmw`, `tc` or `all`.
    pub paper: String,
    /// Seeds 1..=N (each both the walk's and the engines' seed).
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    /// Folder holding the replica-* site folders.
    #[arg(long, default_value = "maps")]
    pub maps: PathBuf,
    /// Output folder (OUT/<paper>/cdf.png, results.json).
    #[arg(long, default_value = "out/reproduce")]
    pub out: PathBuf,
    /// Scale every walk's length (1 = the replica walks; CI uses a small one).
    #[arg(long, default_value_t = 1.0)]
    pub duration_scale: f64,
    /// JSON merged over every replica walk's simulator profile, e.g.
    /// `{"ble":{"shadowing_sigma_db":2}}` (channel experiments; the printed
    /// figures are then not the pinned replica's).
    #[arg(long)]
    pub profile_patch: Option<String>,
    /// JSON merged over every variant's engine config after the paper's
    /// base config and the variant's own (experiments; the printed figures
    /// are then not the paper set-up's).
    #[arg(long)]
    pub engine_patch: Option<String>,
    /// Direction of the walked survey's lines (papers with a walked
    /// fingerprint survey, BMW): `alternate` (the replica's), `with` or
    /// `against` the test walk (experiments).
    #[arg(long, default_value = "alternate")]
    pub survey: String,
    /// JSON merged over the engine config the walked survey database is
    /// built with (after `--engine-patch`; e.g. a different BLE front end
    /// for the survey than for the test walks; experiments).
    #[arg(long)]
    pub survey_patch: Option<String>,
}

fn fmt(v: Option<f64>) -> String {
    metrics::fmt_opt(v, 2)
}

fn print_result(r: &PaperResult) {
    println!("\n== {} ==", r.title);
    println!(
        "replica maps/replica-{}, seeds 1-{}, walks: {}",
        r.paper,
        r.seeds,
        r.walks.join("; ")
    );
    println!(
        "{:<36} {:<16} {:>7} {:>7} {:>7}  source",
        "engine", "figure", "paper", "ours", "diff"
    );
    for fig in &r.figures {
        println!(
            "{:<36} {:<16} {:>7.2} {:>7} {:>7}  {}",
            fig.variant,
            fig.stat,
            fig.paper_m,
            fmt(fig.ours_m),
            fig.difference
                .map_or("-".into(), |d| format!("{:+.0}%", 100.0 * d)),
            fig.source
        );
    }
    println!(
        "{:<36} {:>5} {:>8} {:>7} {:>7} {:>7} {:>7} {:>9} {:>10}",
        "engine", "start", "coverage", "mean_m", "rmse_m", "p50_m", "p80_m", "ble_us", "fusion_us"
    );
    for v in &r.variants {
        println!(
            "{:<36} {:>5} {:>7.1}% {:>7} {:>7} {:>7} {:>7} {:>9} {:>10}",
            v.label,
            v.start,
            100.0 * v.coverage,
            fmt(v.mean_m),
            fmt(v.rmse_m),
            fmt(v.p50_m),
            fmt(v.p80_m),
            metrics::fmt_opt(v.mct_ble_us, 1),
            metrics::fmt_opt(v.mct_fusion_us, 1)
        );
    }
    for m in &r.missing {
        println!("not run: {m}");
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.seeds == 0 || args.seeds > 100 {
        bail!("--seeds must be in 1..=100, got {}", args.seeds);
    }
    if !(args.duration_scale > 0.0 && args.duration_scale <= 10.0) {
        bail!(
            "--duration-scale must be in (0, 10], got {}",
            args.duration_scale
        );
    }
    let papers: Vec<&str> = if args.paper == "all" {
        crate_replicas().to_vec()
    } else {
        vec![args.paper.as_str()]
    };
    let survey = parse_pattern(&args.survey)?;
    if let Some(p) = &args.survey_patch {
        println!("survey config patch (not the replica's survey): {p}");
    }
    if survey != SurveyPattern::Alternate {
        println!(
            "survey lines {} the test walk (not the pinned replica)",
            args.survey
        );
    }
    let maps = crate::demo::resolve(&args.maps);
    let started = std::time::Instant::now();
    if let Some(p) = &args.profile_patch {
        println!("simulator profile patch (not the pinned replicas): {p}");
    }
    if let Some(p) = &args.engine_patch {
        println!("engine config patch (not the papers' set-ups): {p}");
    }
    for name in papers {
        let spec = paper_spec(name)?;
        let site_path = maps
            .join(format!("replica-{}", spec.replica))
            .join("site.json");
        let site = fpbp_core::site::files::load_site(&site_path)?;
        let r = reproduce_paper(
            &spec,
            &site,
            args.seeds,
            args.duration_scale,
            &Experiment {
                profile_patch: args.profile_patch.as_deref(),
                engine_patch: args.engine_patch.as_deref(),
                survey,
                survey_patch: args.survey_patch.as_deref(),
            },
        )?;
        let dir = args.out.join(spec.replica);
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let cdf: Vec<plot::CdfSeries> = r
            .variants
            .iter()
            .map(|v| plot::CdfSeries {
                label: format!("{} ({} start)", v.label, v.start),
                errors: v.pooled(),
                points: v.errors.iter().flatten().map(|w| w.len()).sum(),
            })
            .collect();
        plot::cdf_png(
            &dir.join("cdf.png"),
            &format!("{} on its replica, seeds 1-{}", spec.title, args.seeds),
            &cdf,
        )?;
        let json = dir.join("results.json");
        std::fs::write(&json, serde_json::to_string_pretty(&r)?)
            .with_context(|| format!("cannot write {}", json.display()))?;
        print_result(&r);
        println!("cdf.png and results.json in {}", dir.display());
    }
    println!("\n({:.1} s)", started.elapsed().as_secs_f64());
    Ok(())
}

fn crate_replicas() -> &'static [&'static str] {
    fpbp_sim::replica_sites::REPLICAS
}
