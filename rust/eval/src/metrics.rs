//! The error metrics `fpbp replay` and `fpbp eval` write: error statistics,
//! the IPIN score, task times, per-log and per-engine rows.

use std::collections::BTreeMap;

use fpbp_core::engine::Task;
use fpbp_core::engine::replay::ScoredPoint;
use fpbp_core::site::Site;
use fpbp_logs::ReadReport;
use serde::Serialize;

use crate::runner::{InitMode, LogRun};

/// Percentile `p` (0..=100) of sorted values: [`fpbp_core::stats::quantile_sorted`]
/// at `p / 100` (linear between order statistics, numpy's default); `None`
/// when empty.
pub fn percentile(sorted: &[f64], p: f64) -> Option<f64> {
    fpbp_core::stats::quantile_sorted(sorted, p / 100.0)
}

/// Error statistics at truth points.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Truth points scored (with or without a fix).
    pub points: usize,
    /// Truth points at which the engine had no pose yet (not in the errors).
    pub no_fix: usize,
    /// Share of the points with a pose, (points - no_fix) / points: the
    /// errors below are over that share only.
    pub coverage: Option<f64>,
    pub mpe_m: Option<f64>,
    pub p50_m: Option<f64>,
    pub p75_m: Option<f64>,
    pub p80_m: Option<f64>,
    pub p95_m: Option<f64>,
    pub max_m: Option<f64>,
    /// Fraction of fixes on the truth's floor (None when no truth has a floor).
    pub floor_accuracy: Option<f64>,
    /// IPIN competition metric: 75th percentile over the fixes of
    /// horizontal error + 15 m x |estimated floor - true floor| (floor ids as
    /// levels; a truth point without a floor adds nothing), metres.
    pub ipin_score_m: Option<f64>,
    /// Share of the points with a pose whose error is within the pose's
    /// `accuracy_m` (an honest 68 % radius gives about 0.68).
    pub within_accuracy: Option<f64>,
}

/// Penalty per floor of difference in the IPIN competition metric, metres.
pub const IPIN_FLOOR_PENALTY_M: f64 = 15.0;

/// One point's IPIN competition error: horizontal error + 15 m per floor of
/// difference (None without a fix).
pub fn ipin_error_m(p: &ScoredPoint) -> Option<f64> {
    let e = p.error_m()?;
    let floors = match (p.estimate, p.truth.floor) {
        (Some(est), Some(f)) => (i64::from(est.floor) - i64::from(f)).abs() as f64,
        _ => 0.0,
    };
    Some(e + IPIN_FLOOR_PENALTY_M * floors)
}

impl ErrorStats {
    pub fn from_points<'a>(pts: impl IntoIterator<Item = &'a ScoredPoint>) -> ErrorStats {
        let mut errors = Vec::new();
        let mut ipin = Vec::new();
        let (mut points, mut no_fix, mut floors, mut floors_ok) = (0, 0, 0usize, 0usize);
        let mut within = 0usize;
        for p in pts {
            points += 1;
            match p.error_m() {
                Some(e) if e.is_finite() => {
                    errors.push(e);
                    within += p.estimate.is_some_and(|est| e <= est.accuracy_m) as usize;
                    ipin.extend(ipin_error_m(p));
                }
                _ => no_fix += 1,
            }
            if let Some(ok) = p.floor_correct() {
                floors += 1;
                floors_ok += ok as usize;
            }
        }
        errors.sort_by(f64::total_cmp);
        ipin.sort_by(f64::total_cmp);
        let mean = (!errors.is_empty()).then(|| errors.iter().sum::<f64>() / errors.len() as f64);
        ErrorStats {
            points,
            no_fix,
            coverage: (points > 0).then(|| (points - no_fix) as f64 / points as f64),
            mpe_m: mean,
            p50_m: percentile(&errors, 50.0),
            p75_m: percentile(&errors, 75.0),
            p80_m: percentile(&errors, 80.0),
            p95_m: percentile(&errors, 95.0),
            max_m: errors.last().copied(),
            floor_accuracy: (floors > 0).then(|| floors_ok as f64 / floors as f64),
            ipin_score_m: percentile(&ipin, 75.0),
            within_accuracy: (!errors.is_empty()).then(|| within as f64 / errors.len() as f64),
        }
    }
}

/// Mean compute time per task call, microseconds (metrics.json `mct_us`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct MctUs {
    /// The radio task; metrics.json version 2 wrote it as `gml`, still read.
    #[serde(alias = "gml")]
    pub radio: Option<f64>,
    pub fusion: Option<f64>,
}

impl MctUs {
    pub fn from_runs<'a>(runs: impl IntoIterator<Item = &'a LogRun> + Clone) -> MctUs {
        let mean = |task: Task| {
            let (mut s, mut n) = (0.0, 0usize);
            for r in runs.clone() {
                for (t, us) in &r.out.task_us {
                    if *t == task {
                        s += us;
                        n += 1;
                    }
                }
            }
            (n > 0).then(|| s / n as f64)
        };
        MctUs {
            radio: mean(Task::Radio),
            fusion: mean(Task::Fusion),
        }
    }
}

/// The anomalies a log reader counted (non-zero ones matter).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ReadSummary {
    pub format: String,
    pub events: u64,
    pub malformed_skipped: u64,
    pub late_dropped: u64,
    pub duplicates_dropped: u64,
    pub non_finite_dropped: u64,
    pub truth_without_georef: u64,
    pub gaps_over_threshold: u64,
}

impl From<&ReadReport> for ReadSummary {
    fn from(r: &ReadReport) -> Self {
        ReadSummary {
            format: r.format.map_or("?", |f| f.name()).to_string(),
            events: r.events.total(),
            malformed_skipped: r.malformed_skipped,
            late_dropped: r.late_dropped,
            duplicates_dropped: r.duplicates_dropped,
            non_finite_dropped: r.non_finite_dropped,
            truth_without_georef: r.truth_without_georef,
            gaps_over_threshold: r.gaps_over_threshold,
        }
    }
}

/// One log's row in metrics.json.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogMetrics {
    pub log: String,
    #[serde(flatten)]
    pub errors: ErrorStats,
    /// Whether the engine started from the log's first truth point.
    pub init_from_truth: bool,
    pub duration_s: f64,
    pub wall_s: f64,
    pub steps: u64,
    pub engine_no_fix_runs: u64,
    /// The engine's step-length scale at the log's end (engines that
    /// learn one: `tcpf`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step_scale: Option<f64>,
    /// The phone's RSSI offset the engine estimated, at the log's end
    /// (heard minus model, dB; engines that estimate one: `tcpf`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rssi_offset_db: Option<f64>,
    /// The engine's trust in its radio at the log's end (engines that
    /// check it: `tcpf`, 1 unless `tcpf.integrity` lowered it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radio_trust: Option<f64>,
    /// The engine's own counters at the log's end (`Engine::diagnostics`:
    /// re-seedings, wall kills, ...; engines that keep them: `tcpf`).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub engine_counters: BTreeMap<&'static str, u64>,
    pub read: ReadSummary,
}

/// One engine's object in metrics.json (the keys of docs/ARCHITECTURE.md
/// "Evaluation protocol" plus `no_fix`, `init` and per-log rows).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EngineMetrics {
    pub engine: String,
    pub logs: usize,
    #[serde(flatten)]
    pub errors: ErrorStats,
    pub mct_us: MctUs,
    /// Log time replayed per second of wall time (engine work only; parsing excluded).
    pub realtime_factor: Option<f64>,
    /// `--init` as asked.
    pub init: InitMode,
    /// How this engine actually started (`pdr` always from truth).
    pub start: crate::report::StartMode,
    /// Jumps, wall crossings and poses in walls of the published tracks.
    pub track: crate::report::TrackQuality,
    pub per_log: Vec<LogMetrics>,
    /// The finite errors of every point with a pose (for the CDF).
    #[serde(skip)]
    pub cdf_errors: Vec<f64>,
}

impl EngineMetrics {
    /// Aggregates the runs of one engine (`reads[i]` belongs to `runs[i]`).
    pub fn from_runs(
        site: &Site,
        engine: &str,
        init: InitMode,
        runs: &[LogRun],
        reads: &[ReadSummary],
    ) -> EngineMetrics {
        let per_log = runs
            .iter()
            .zip(reads)
            .map(|(r, read)| LogMetrics {
                log: r.log.clone(),
                errors: ErrorStats::from_points(&r.out.scored),
                init_from_truth: r.init.is_some(),
                duration_s: r.out.log_duration_s,
                wall_s: r.out.wall_s,
                steps: r.out.stats.steps,
                engine_no_fix_runs: r.out.stats.no_fix,
                step_scale: r.out.stats.step_scale,
                rssi_offset_db: r.out.stats.rssi_offset_db,
                radio_trust: r.out.stats.radio_trust,
                engine_counters: r.out.diagnostics.iter().copied().collect(),
                read: read.clone(),
            })
            .collect();
        let dur: f64 = runs.iter().map(|r| r.out.log_duration_s).sum();
        let wall: f64 = runs.iter().map(|r| r.out.wall_s).sum();
        EngineMetrics {
            engine: engine.to_string(),
            logs: runs.len(),
            errors: ErrorStats::from_points(runs.iter().flat_map(|r| r.out.scored.iter())),
            mct_us: MctUs::from_runs(runs),
            realtime_factor: (wall > 0.0).then(|| dur / wall),
            init,
            start: crate::report::StartMode::of(runs),
            track: crate::report::TrackQuality::of(site, runs.iter().map(|r| &r.out)),
            per_log,
            cdf_errors: Self::errors_of(runs),
        }
    }

    /// All finite errors (for the CDF).
    pub fn errors_of(runs: &[LogRun]) -> Vec<f64> {
        runs.iter()
            .flat_map(|r| r.out.scored.iter())
            .filter_map(|p| p.error_m())
            .filter(|e| e.is_finite())
            .collect()
    }
}

/// Formats an optional number for the terminal table.
pub fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".to_string(), |x| format!("{x:.digits$}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runner::*;
    use crate::testkit::*;
    use fpbp_core::engines::EngineConfig;

    #[test]
    fn task_times_of_version_2_files_still_read() {
        let old: MctUs = serde_json::from_str(r#"{"gml": 41.5, "fusion": 3.2}"#).unwrap();
        let new: MctUs = serde_json::from_str(r#"{"radio": 41.5, "fusion": 3.2}"#).unwrap();
        assert_eq!((old.radio, &old), (Some(41.5), &new));
    }

    #[test]
    fn percentiles_interpolate_like_numpy() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(percentile(&v, 50.0), Some(2.5));
        assert_eq!(percentile(&v, 0.0), Some(1.0));
        assert_eq!(percentile(&v, 100.0), Some(4.0));
        assert!((percentile(&v, 80.0).unwrap() - 3.4).abs() < 1e-12);
        assert_eq!(percentile(&[], 50.0), None);
    }

    /// Hand-computed IPIN metric: horizontal error + 15 m per floor of
    /// difference, 75th percentile (numpy interpolation) over the fixes.
    #[test]
    fn ipin_score_adds_15_m_per_floor_and_takes_the_75th_percentile() {
        use fpbp_core::engine::Pose;
        use fpbp_core::events::TruthPoint;
        let pt = |err: f64, est_floor: i32, truth_floor: Option<i32>, fix: bool| ScoredPoint {
            truth: TruthPoint {
                t_ns: 0,
                x_m: 0.0,
                y_m: 0.0,
                floor: truth_floor,
            },
            estimate: fix.then_some(Pose {
                t_ns: 0,
                x_m: 0.6 * err,
                y_m: 0.8 * err,
                floor: est_floor,
                heading_rad: 0.0,
                accuracy_m: 1.0,
                floor_prob: 1.0,
                source: fpbp_core::engine::PoseSource::Fused,
            }),
        };
        let pts = [
            pt(2.0, 0, Some(0), true),   // 2
            pt(1.0, -2, Some(0), true),  // 1 + 2 x 15 = 31
            pt(3.0, -1, Some(0), true),  // 3 + 15 = 18
            pt(5.0, 0, Some(0), true),   // 5
            pt(4.0, 3, None, true),      // no truth floor: 4
            pt(9.0, 0, Some(-2), false), // no fix: not scored
        ];
        assert_eq!(ipin_error_m(&pts[1]), Some(31.0));
        assert_eq!(ipin_error_m(&pts[5]), None);
        let s = ErrorStats::from_points(&pts);
        // sorted 2, 4, 5, 18, 31: rank 0.75 x 4 = 3 -> 18
        assert!((s.ipin_score_m.unwrap() - 18.0).abs() < 1e-9, "{s:?}");
        // horizontal p75 of 1, 2, 3, 4, 5 is 4
        assert!((s.p75_m.unwrap() - 4.0).abs() < 1e-9);
        assert_eq!(s.floor_accuracy, Some(2.0 / 4.0));
    }

    #[test]
    fn pdr_starts_from_first_truth_others_do_not_and_no_fix_is_counted() {
        let d = tmp_dir("common");
        let p = d.join("walk.log");
        write_log(&p, 5);
        let site = site();
        let log = load_log(&p, &read_options(&site, None, true)).unwrap();
        assert_eq!(log.report.events.truth, 5);
        let cfg = EngineConfig::default();
        // pdr: starts at the first truth point (not scored), tracks the walk exactly
        // up to the 100 ms task grid.
        let run = run_log(&builder, "pdr", &site, &cfg, InitMode::None, &log).unwrap();
        assert!(run.init.is_some());
        let m = EngineMetrics::from_runs(
            &site,
            "pdr",
            InitMode::None,
            std::slice::from_ref(&run),
            &[ReadSummary::from(&log.report)],
        );
        assert_eq!(m.errors.points, 4);
        assert_eq!(m.errors.no_fix, 0);
        assert!(m.errors.max_m.unwrap() < 0.11, "{m:?}");
        assert_eq!(m.errors.floor_accuracy, Some(1.0));
        assert_eq!(m.errors.coverage, Some(1.0));
        // Another engine without --init truth gets no start: every point is a
        // no-fix, on the same 4 points (the first truth point is not scored).
        let run = run_log(&builder, "walk-east", &site, &cfg, InitMode::None, &log).unwrap();
        assert!(run.init.is_none());
        let s = ErrorStats::from_points(&run.out.scored);
        assert_eq!(
            (s.points, s.no_fix, s.mpe_m, s.coverage),
            (4, 4, None, Some(0.0))
        );
        // With --init truth it starts too.
        let run = run_log(&builder, "walk-east", &site, &cfg, InitMode::Truth, &log).unwrap();
        assert_eq!(ErrorStats::from_points(&run.out.scored).no_fix, 0);
        std::fs::remove_dir_all(&d).ok();
    }
}
