//! The five papers' headline results on their
//! replica testbeds (issue 18, docs/reproduction.md). For each paper it
//! simulates the replica walks (maps/replica-<paper>, simulator profiles
//! `replica-<paper>-<n>`) with seeds 1..=N, runs that paper's engine and
//! the comparisons the paper made with the same seed as engine seed,
//! prints our figure beside the paper's with its table or figure number,
//! and writes OUT/<paper>/cdf.png and OUT/<paper>/results.json.
//!
//! Every figure is the mean over the seeds of the per-seed figure (errors
//! pooled over the paper's walks within a seed). Coverage is the share of
//! truth points with a pose; figures are over the points with one.

use std::path::PathBuf;
use std::sync::Arc;

use crate::json_patch::{merge, patched};
use anyhow::{Context, bail};
use fpbp_core::engine::Task;
use fpbp_core::engines::{EngineConfig, EngineData};
use fpbp_core::site::Site;
use fpbp_sim::SimRequest;
use fpbp_sim::replica::{SurveyPattern, replica_walks};
use fpbp_sim::replica_survey::survey_db;
use serde::Serialize;

use crate::metrics::percentile;
use crate::runner::{InitMode, LoadedLog};

/// What a paper figure is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stat {
    /// Mean error.
    Mpe,
    /// Root mean square error.
    Rmse,
    /// Percentile of the error.
    Pct(u8),
    /// Mean error on walk k (0-based) alone.
    WalkMpe(usize),
    /// RMSE on walk k alone.
    WalkRmse(usize),
    /// Median error.
    Median,
}

impl Stat {
    fn name(self) -> String {
        match self {
            Stat::Mpe => "mean".into(),
            Stat::Rmse => "RMSE".into(),
            Stat::Pct(p) => format!("p{p}"),
            Stat::WalkMpe(k) => format!("mean, walk {}", k + 1),
            Stat::WalkRmse(k) => format!("RMSE, walk {}", k + 1),
            Stat::Median => "median".into(),
        }
    }
}

/// One engine run the paper compared.
pub struct Variant {
    pub label: &'static str,
    pub engine: &'static str,
    /// JSON merged over the replica's engine config.
    pub config: &'static str,
    pub init: InitMode,
    /// Use the replica's walked survey database (`fpbp_sim::replica::survey_walks`,
    /// built per seed) instead of the engine's own model database.
    pub walked_db: bool,
}

/// One figure of the paper and where it is printed.
pub struct PaperFigure {
    pub variant: &'static str,
    pub stat: Stat,
    pub paper_m: f64,
    pub source: &'static str,
}

/// A paper's reproduction set-up.
pub struct PaperSpec {
    pub replica: &'static str,
    pub title: &'static str,
    /// JSON merged over the default engine config for every variant (the
    /// replica's deployment values the paper states).
    pub base_config: &'static str,
    pub variants: Vec<Variant>,
    pub figures: Vec<PaperFigure>,
    /// Comparisons the paper made that fpbp has no engine for.
    pub missing: &'static [&'static str],
}

fn v(label: &'static str, engine: &'static str, config: &'static str, init: InitMode) -> Variant {
    Variant {
        label,
        engine,
        config,
        init,
        walked_db: false,
    }
}

/// A variant that uses the replica's walked survey database.
fn walked(
    label: &'static str,
    engine: &'static str,
    config: &'static str,
    init: InitMode,
) -> Variant {
    Variant {
        walked_db: true,
        ..v(label, engine, config, init)
    }
}

fn f(variant: &'static str, stat: Stat, paper_m: f64, source: &'static str) -> PaperFigure {
    PaperFigure {
        variant,
        stat,
        paper_m,
        source,
    }
}

/// The papers' set-ups (figures: docs/reproduction.md).
pub fn paper_spec(name: &str) -> anyhow::Result<PaperSpec> {
    use InitMode::{None as Own, Truth};
    Ok(match name {
        "fpbp" => PaperSpec {
            replica: "fpbp",
            title: "FP-BP (Pan et al.): Table II, Fig. 11",
            base_config: "{}",
            variants: vec![
                v("fpbp", "fpbp", "{}", Own),
                v("bp", "bp", "{}", Own),
                v("gml", "gml", "{}", Own),
                v("pdr", "pdr", "{}", Truth),
                v("trilat", "trilat", "{}", Own),
                v("frbw", "frbw", "{}", Own),
                v("ml", "ml", "{}", Own),
            ],
            figures: vec![
                f("fpbp", Stat::WalkMpe(0), 1.19, "Table II, trajectory 1"),
                f("bp", Stat::WalkMpe(0), 1.51, "Table II, trajectory 1"),
                f("fpbp", Stat::WalkMpe(1), 1.08, "Table II, trajectory 2"),
                f("bp", Stat::WalkMpe(1), 1.25, "Table II, trajectory 2"),
                f("fpbp", Stat::WalkMpe(2), 0.89, "Table II, trajectory 3"),
                f("bp", Stat::WalkMpe(2), 1.18, "Table II, trajectory 3"),
                f("fpbp", Stat::Pct(50), 1.13, "Table II, trajectory 1"),
                f("fpbp", Stat::Pct(80), 1.60, "Table II, trajectory 1"),
                f("bp", Stat::Pct(50), 1.32, "Table II, trajectory 1"),
                f("bp", Stat::Pct(80), 2.14, "Table II, trajectory 1"),
                f("gml", Stat::WalkMpe(0), 2.01, "Fig. 11(b), trajectory 1"),
                f("gml", Stat::Pct(80), 2.90, "Fig. 11(c)"),
                f("pdr", Stat::WalkMpe(0), 7.41, "Fig. 11(e), trajectory 1"),
                f("trilat", Stat::WalkMpe(0), 9.39, "Fig. 11(b)"),
                f("frbw", Stat::WalkMpe(0), 2.55, "Fig. 11(b)"),
                f("frbw", Stat::Pct(80), 3.51, "Fig. 11(c)"),
                f("ml", Stat::WalkMpe(0), 2.63, "Fig. 11(b)"),
                f("ml", Stat::Pct(80), 3.55, "Fig. 11(c)"),
            ],
            missing: &[
                "Jin et al. [48] (Fig. 11(h): 2.20 m)",
                "Xia et al. [33] (1.67 m)",
                "Wang et al. [37] (2.02 m)",
                "Xu et al. [39] (1.97 m)",
            ],
        },
        "prox-pf" => PaperSpec {
            replica: "prox-pf",
            title: "Proximity PF (Momose et al.): Table I",
            base_config: r#"{"ble":{"phone_height_m":1.0}}"#,
            variants: vec![
                v("prox-pf", "prox-pf", "{}", Own),
                v(
                    "prox-pf, no floormap (Algorithm C)",
                    "prox-pf",
                    r#"{"prox_pf":{"floormap":false}}"#,
                    Own,
                ),
                v(
                    "prox-pf, restart when all weights 0",
                    "prox-pf",
                    r#"{"prox_pf":{"restart_when_all_zero":true}}"#,
                    Own,
                ),
                v("pdr", "pdr", "{}", Truth),
            ],
            figures: vec![
                f("prox-pf", Stat::Mpe, 0.999, "Table I, Ours, Ave."),
                f(
                    "prox-pf, no floormap (Algorithm C)",
                    Stat::Mpe,
                    2.711,
                    "Table I, Algorithm C, Ave.",
                ),
            ],
            missing: &[
                "Algorithm A, trilateration PF + map matching (Table I: 4.72 m)",
                "Algorithm B, trilateration PF (Table I: 4.921 m)",
            ],
        },
        "ppsa" => PaperSpec {
            replica: "ppsa",
            title: "PPSA (Sun et al.): Table 4, Sec. 4.1.1",
            base_config: "{}",
            variants: vec![
                v("ppsa", "ppsa", "{}", Own),
                v("ppsa, start given", "ppsa", "{}", Truth),
                v(
                    "ppsa, P2 in degrees",
                    "ppsa",
                    r#"{"ppsa":{"heading_score_degrees":true}}"#,
                    Own,
                ),
                v("trilat (BLE only)", "trilat", "{}", Own),
                v("ml (BLE only)", "ml", "{}", Own),
            ],
            figures: vec![
                f("ppsa", Stat::Mpe, 0.966, "Table 4, PPSA, mean of 25 points"),
                f(
                    "ppsa",
                    Stat::Rmse,
                    1.031,
                    "Table 4, PPSA, RMSE of 25 points",
                ),
                f(
                    "trilat (BLE only)",
                    Stat::Mpe,
                    1.729,
                    "Table 4, trilateration + PDR, mean",
                ),
                f(
                    "ml (BLE only)",
                    Stat::Mpe,
                    2.010,
                    "Table 4, MLE + PDR, mean",
                ),
            ],
            missing: &["trilateration + PDR and MLE + PDR (fpbp has the BLE parts only)"],
        },
        "bmw" => PaperSpec {
            replica: "bmw",
            title: "BMW robust EKF (Table 3)",
            // the walked survey's settings (reference points 0.6 m apart,
            // known points at the survey lines' ends)
            base_config: fpbp_sim::replica_survey::BMW_SURVEY_CONFIG,
            variants: vec![
                v("robust-ekf", "robust-ekf", "{}", Own),
                walked("robust-ekf, walked DB", "robust-ekf", "{}", Own),
                v("gml (BLE)", "gml", "{}", Own),
                v("pdr (MEMS)", "pdr", "{}", Truth),
            ],
            figures: vec![
                f("robust-ekf", Stat::Pct(50), 0.60, "Table 3, fusion, 50 %"),
                f("robust-ekf", Stat::Pct(70), 0.77, "Table 3, fusion, 70 %"),
                f("robust-ekf", Stat::Pct(90), 1.03, "Table 3, fusion, 90 %"),
                f(
                    "robust-ekf, walked DB",
                    Stat::Pct(50),
                    0.60,
                    "Table 3, fusion, 50 %",
                ),
                f(
                    "robust-ekf, walked DB",
                    Stat::Pct(70),
                    0.77,
                    "Table 3, fusion, 70 %",
                ),
                f(
                    "robust-ekf, walked DB",
                    Stat::Pct(90),
                    1.03,
                    "Table 3, fusion, 90 %",
                ),
                f("gml (BLE)", Stat::Pct(50), 3.80, "Table 3, BLE, 50 %"),
                f("gml (BLE)", Stat::Pct(90), 5.26, "Table 3, BLE, 90 %"),
                f("pdr (MEMS)", Stat::Pct(50), 2.29, "Table 3, MEMS, 50 %"),
                f("pdr (MEMS)", Stat::Pct(90), 8.41, "Table 3, MEMS, 90 %"),
            ],
            missing: &["WKNN fingerprinting alone (the paper's BLE column; gml stands in)"],
        },
        "tc" => PaperSpec {
            replica: "tc",
            title: "TC BLE/GNSS/PDR EKF (Wang et al.): Tables III, IV",
            // RSSI_T relative to each transmitter's R0 (the weak ones' -8 dB:
            // 2.5 m); ranging to the strong-signal (+4 dBm, R0 -55) transmitters
            // only, as eqs. 22 and 24 (the weak ones have R0 -79); proximity
            // fixes at the weak ones only (Sec. III)
            base_config: r#"{"ekf":{"proximity_relative_to_r0":true,"proximity_rssi_dbm":-8.0,"ranging_min_rssi_1m_dbm":-70.0,"proximity_max_rssi_1m_dbm":-70.0}}"#,
            variants: vec![
                v("tc-ekf", "tc-ekf", "{}", Truth),
                v(
                    "tc-ekf, no HC",
                    "tc-ekf",
                    r#"{"ekf":{"walking_direction":false}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, no BLES",
                    "tc-ekf",
                    r#"{"ekf":{"ranging_rssi_dbm":0.0}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, absolute RSSI_T",
                    "tc-ekf",
                    r#"{"ekf":{"proximity_relative_to_r0":false,"proximity_rssi_dbm":-62.0}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, IGG3 on proximity",
                    "tc-ekf",
                    r#"{"ekf":{"proximity_igg3":true}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, ranging ahead only",
                    "tc-ekf",
                    r#"{"ekf":{"ranging_ahead_only":true}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, ranging sigma 10 dB",
                    "tc-ekf",
                    r#"{"ekf":{"ranging_sigma_db":10.0}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, proximity at strong ones too",
                    "tc-ekf",
                    r#"{"ekf":{"proximity_max_rssi_1m_dbm":0.0}}"#,
                    Truth,
                ),
                v(
                    "tc-ekf, weak ones ranged too",
                    "tc-ekf",
                    r#"{"ekf":{"ranging_min_rssi_1m_dbm":-200.0}}"#,
                    Truth,
                ),
                v("pdr", "pdr", "{}", Truth),
            ],
            figures: vec![
                f(
                    "tc-ekf",
                    Stat::WalkRmse(0),
                    4.31,
                    "Table III, TC+GE+HC+BLES, RMSE_T",
                ),
                f(
                    "tc-ekf",
                    Stat::WalkRmse(1),
                    4.71,
                    "Table IV, TC+GE+HC+RB+BLES, RMSE_T",
                ),
                f(
                    "tc-ekf",
                    Stat::Median,
                    3.29,
                    "Tables III/IV, TC+GE+HC(+RB)+BLES, Median_T",
                ),
            ],
            missing: &[
                "GNSS and the GE estimate (the simulator has no GNSS): every row is without GE",
                "the LC configurations (Table III: LC 5.21 m, LC+GE+HC 4.37 m)",
            ],
        },
        other => bail!("unknown paper `{other}` (known: fpbp, prox-pf, ppsa, bmw, tc, all)"),
    })
}

/// The engine config of `var`: the defaults with the paper's base config,
/// the variant's, then each of `patches` (`--engine-patch`, for a walked
/// survey `--survey-patch`) merged over them, and `seed`.
fn config_for(
    spec: &PaperSpec,
    var: &Variant,
    seed: u64,
    patches: &[Option<&str>],
) -> anyhow::Result<EngineConfig> {
    let mut value = serde_json::to_value(EngineConfig::default())?;
    let given = [Some(spec.base_config), Some(var.config)];
    for patch in given.iter().chain(patches).flatten() {
        let p: serde_json::Value =
            serde_json::from_str(patch).with_context(|| format!("config patch {patch}"))?;
        merge(&mut value, &p);
    }
    let mut cfg = EngineConfig::from_json(&value.to_string())
        .with_context(|| format!("config of `{}`", var.label))?;
    cfg.seed = seed;
    cfg.validate()?;
    Ok(cfg)
}

/// One variant's results.
#[derive(Debug, Clone, Serialize)]
pub struct VariantResult {
    pub label: String,
    pub engine: String,
    pub start: &'static str,
    /// Per seed, per walk: the errors at truth points (None: no pose).
    #[serde(skip)]
    pub errors: Vec<Vec<Vec<Option<f64>>>>,
    pub coverage: f64,
    pub mean_m: Option<f64>,
    pub rmse_m: Option<f64>,
    pub p50_m: Option<f64>,
    pub p80_m: Option<f64>,
    pub mct_ble_us: Option<f64>,
    pub mct_fusion_us: Option<f64>,
}

fn finite(v: &[Option<f64>]) -> Vec<f64> {
    let mut e: Vec<f64> = v
        .iter()
        .flatten()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    e.sort_by(f64::total_cmp);
    e
}

fn stat_of(sorted: &[f64], stat: Stat) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let n = sorted.len() as f64;
    match stat {
        Stat::Mpe | Stat::WalkMpe(_) => Some(sorted.iter().sum::<f64>() / n),
        Stat::Rmse | Stat::WalkRmse(_) => {
            Some((sorted.iter().map(|e| e * e).sum::<f64>() / n).sqrt())
        }
        Stat::Pct(p) => percentile(sorted, f64::from(p)),
        Stat::Median => percentile(sorted, 50.0),
    }
}

impl VariantResult {
    /// The seed-mean of `stat` (per seed over the pooled walks, or walk k).
    pub fn seed_mean(&self, stat: Stat) -> Option<f64> {
        let per_seed: Vec<f64> = self
            .errors
            .iter()
            .filter_map(|walks| {
                let pooled: Vec<Option<f64>> = match stat {
                    Stat::WalkMpe(k) | Stat::WalkRmse(k) => walks.get(k)?.clone(),
                    _ => walks.iter().flatten().copied().collect(),
                };
                stat_of(&finite(&pooled), stat)
            })
            .collect();
        (!per_seed.is_empty()).then(|| per_seed.iter().sum::<f64>() / per_seed.len() as f64)
    }

    pub fn pooled(&self) -> Vec<f64> {
        let all: Vec<Option<f64>> = self.errors.iter().flatten().flatten().copied().collect();
        finite(&all)
    }
}

/// A paper's results: every variant and every figure.
#[derive(Debug, Clone, Serialize)]
pub struct PaperResult {
    pub paper: String,
    pub title: String,
    pub seeds: u64,
    pub walks: Vec<String>,
    pub variants: Vec<VariantResult>,
    pub figures: Vec<FigureResult>,
    pub missing: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct FigureResult {
    pub variant: String,
    pub stat: String,
    pub source: String,
    pub paper_m: f64,
    pub ours_m: Option<f64>,
    /// (ours - paper) / paper.
    pub difference: Option<f64>,
}

/// Departures from the pinned replica set-up (experiments; all off by default).
#[derive(Debug, Clone, Copy)]
pub struct Experiment<'a> {
    /// JSON merged over every walk's simulator profile.
    pub profile_patch: Option<&'a str>,
    /// JSON merged over every variant's engine config.
    pub engine_patch: Option<&'a str>,
    /// Direction of the walked survey's lines.
    pub survey: SurveyPattern,
    /// JSON merged over the config the walked survey database is built with.
    pub survey_patch: Option<&'a str>,
}

impl Default for Experiment<'_> {
    fn default() -> Self {
        Experiment {
            profile_patch: None,
            engine_patch: None,
            survey: SurveyPattern::Alternate,
            survey_patch: None,
        }
    }
}

/// Runs one paper on its replica.
pub fn reproduce_paper(
    spec: &PaperSpec,
    site: &Arc<Site>,
    seeds: u64,
    duration_scale: f64,
    exp: &Experiment,
) -> anyhow::Result<PaperResult> {
    let Experiment {
        profile_patch,
        engine_patch,
        survey,
        survey_patch,
    } = *exp;
    let mut walks = replica_walks(spec.replica)?;
    if let Some(patch) = profile_patch {
        let p: serde_json::Value =
            serde_json::from_str(patch).with_context(|| format!("profile patch {patch}"))?;
        for w in &mut walks {
            w.profile = patched(&w.profile, &p)
                .with_context(|| format!("profile patch {patch} on {}", w.name))?;
            w.profile.validate()?;
        }
    }
    let mut results: Vec<VariantResult> = spec
        .variants
        .iter()
        .map(|var| VariantResult {
            label: var.label.into(),
            engine: var.engine.into(),
            start: if var.init == InitMode::Truth {
                "truth"
            } else {
                "own"
            },
            errors: Vec::new(),
            coverage: 0.0,
            mean_m: None,
            rmse_m: None,
            p50_m: None,
            p80_m: None,
            mct_ble_us: None,
            mct_fusion_us: None,
        })
        .collect();
    let mut mct: Vec<[(f64, usize); 2]> = vec![[(0.0, 0); 2]; spec.variants.len()];
    for seed in 1..=seeds {
        for r in results.iter_mut() {
            r.errors.push(Vec::new());
        }
        // the walked survey database of this seed, per variant that uses one
        let mut data: Vec<EngineData> = Vec::with_capacity(spec.variants.len());
        for var in &spec.variants {
            let mut d = EngineData::default();
            if var.walked_db {
                let cfg = config_for(spec, var, seed, &[engine_patch, survey_patch])?;
                let (set, _, _) = survey_db(spec.replica, site, &cfg, seed, survey)?
                    .with_context(|| format!("replica {} has no survey walks", spec.replica))?;
                d.fingerprints = Some(Arc::new(set));
            }
            data.push(d);
        }
        for walk in &walks {
            let req = SimRequest {
                duration_s: (walk.duration_s * duration_scale).max(5.0),
                seed,
                floor: None,
                t0_ns: fpbp_sim::DEFAULT_T0_NS,
                profile: walk.profile.clone(),
            };
            let sim = fpbp_sim::simulate(site, &req)
                .with_context(|| format!("simulating {} seed {seed}", walk.name))?;
            let log = LoadedLog {
                path: PathBuf::from(format!("{}-seed{seed}", walk.name)),
                name: format!("{}-seed{seed}", walk.name),
                events: sim.events,
                report: Default::default(),
            };
            for (k, var) in spec.variants.iter().enumerate() {
                let cfg = config_for(spec, var, seed, &[engine_patch])?;
                let run = crate::runner::run_log(
                    &crate::runner::builder_with(data[k].clone()),
                    var.engine,
                    site,
                    &cfg,
                    var.init,
                    &log,
                )
                .with_context(|| format!("{} on {}", var.label, log.name))?;
                let errs: Vec<Option<f64>> = run.out.scored.iter().map(|p| p.error_m()).collect();
                results[k].errors.last_mut().expect("pushed").push(errs);
                for (task, us) in &run.out.task_us {
                    let i = usize::from(*task == Task::Fusion);
                    mct[k][i].0 += us;
                    mct[k][i].1 += 1;
                }
            }
        }
    }
    for (r, m) in results.iter_mut().zip(&mct) {
        let (n, fixed) = r
            .errors
            .iter()
            .flatten()
            .flatten()
            .fold((0, 0), |(n, k), e| {
                (n + 1, k + usize::from(e.is_some_and(f64::is_finite)))
            });
        r.coverage = if n == 0 { 0.0 } else { fixed as f64 / n as f64 };
        r.mean_m = r.seed_mean(Stat::Mpe);
        r.rmse_m = r.seed_mean(Stat::Rmse);
        r.p50_m = r.seed_mean(Stat::Pct(50));
        r.p80_m = r.seed_mean(Stat::Pct(80));
        r.mct_ble_us = (m[0].1 > 0).then(|| m[0].0 / m[0].1 as f64);
        r.mct_fusion_us = (m[1].1 > 0).then(|| m[1].0 / m[1].1 as f64);
    }
    let figures = spec
        .figures
        .iter()
        .map(|fig| {
            let ours = results
                .iter()
                .find(|r| r.label == fig.variant)
                .and_then(|r| r.seed_mean(fig.stat));
            FigureResult {
                variant: fig.variant.into(),
                stat: fig.stat.name(),
                source: fig.source.into(),
                paper_m: fig.paper_m,
                ours_m: ours,
                difference: ours.map(|o| (o - fig.paper_m) / fig.paper_m),
            }
        })
        .collect();
    Ok(PaperResult {
        paper: spec.replica.into(),
        title: spec.title.into(),
        seeds,
        walks: walks
            .iter()
            .map(|w| {
                format!(
                    "{} ({}, {:.0} s)",
                    w.name,
                    w.paper_walk,
                    w.duration_s * duration_scale
                )
            })
            .collect(),
        variants: results,
        figures,
        missing: spec.missing.iter().map(|s| s.to_string()).collect(),
    })
}

/// Writes replica `r` into `maps_dir/<r.dir>/` (plan.png, site.json).
pub fn write_replica(
    r: &fpbp_sim::replica_sites::Replica,
    maps_dir: &std::path::Path,
) -> anyhow::Result<()> {
    let dir = maps_dir.join(&r.dir);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let plan = dir.join("plan.png");
    r.plan
        .save(&plan)
        .with_context(|| format!("cannot write {}", plan.display()))?;
    let site = dir.join("site.json");
    std::fs::write(&site, r.spec.to_json_pretty() + "\n")
        .with_context(|| format!("cannot write {}", site.display()))
}
