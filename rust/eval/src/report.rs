//! What `fpbp eval`, `replay` and `demo` say about a run, in one place: the
//! metrics.json document they all write, the track CSV layout, the track
//! quality figures (jumps and wall crossings per 100 m), the start mode of
//! each engine, the multi-seed summary, and the reasons given on stderr when
//! an engine positioned nothing or a reader dropped events.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context;
use fpbp_core::Vec2;
use fpbp_core::engine::replay::ReplayOutput;
use fpbp_core::events::LogEvent;
use fpbp_core::site::Site;
use serde::Serialize;

use crate::metrics::EngineMetrics;
use crate::runner::{InitMode, LoadedLog, LogRun};

/// Keys every engine object of metrics.json has (eval, replay and demo):
/// the evaluation protocol's (docs/ARCHITECTURE.md) and the coverage and
/// start beside them. Other tools read these: they stay stable.
pub const ENGINE_KEYS: &[&str] = &[
    "engine",
    "logs",
    "points",
    "coverage",
    "start",
    "no_fix",
    "mpe_m",
    "p50_m",
    "p75_m",
    "p80_m",
    "p95_m",
    "max_m",
    "floor_accuracy",
    "ipin_score_m",
    "mct_us",
    "realtime_factor",
];

/// `format` of every metrics.json fpbp writes.
pub const METRICS_FORMAT: &str = "fpbp-metrics";
/// Its version: 3 = the radio task's times under `mct_us.radio` (version 2
/// wrote `mct_us.gml`; [`crate::metrics::MctUs`] reads both); 2 = one
/// document for eval, replay and demo (version 1 had `fpbp-eval-metrics` /
/// `fpbp-replay-metrics` and demo's bare list).
pub const METRICS_VERSION: u32 = 3;

/// A segment between consecutive poses longer than
/// `JUMP_BASE_M + JUMP_SPEED_MPS * dt` is a jump (walking is ~1.4 m/s; a
/// pose moving 3 m more than a brisk 2 m/s walk would is no walk).
pub const JUMP_BASE_M: f64 = 3.0;
pub const JUMP_SPEED_MPS: f64 = 2.0;

/// Whether the segment from `a` to `b` (same floor) is a jump.
pub fn is_jump(a: &fpbp_core::engine::Pose, b: &fpbp_core::engine::Pose) -> bool {
    let d = (b.x_m - a.x_m).hypot(b.y_m - a.y_m);
    let dt = (b.t_ns - a.t_ns).max(0) as f64 * 1e-9;
    d > JUMP_BASE_M + JUMP_SPEED_MPS * dt
}

/// How the engine started, per engine over its logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StartMode {
    /// Found its own start on every log.
    Own,
    /// Started from each log's first truth point.
    Truth,
    /// Some logs one way, some the other.
    Mixed,
}

impl StartMode {
    pub fn of(runs: &[LogRun]) -> StartMode {
        let n = runs.iter().filter(|r| r.init.is_some()).count();
        if n == 0 {
            StartMode::Own
        } else if n == runs.len() {
            StartMode::Truth
        } else {
            StartMode::Mixed
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            StartMode::Own => "own",
            StartMode::Truth => "truth",
            StartMode::Mixed => "mixed",
        }
    }
}

/// Figures of the published track itself (segments between consecutive
/// poses on one floor).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct TrackQuality {
    pub poses: usize,
    /// Summed segment length, metres.
    pub length_m: f64,
    /// Segments that are jumps ([`is_jump`]).
    pub jumps: usize,
    pub jumps_per_100m: Option<f64>,
    /// Segments whose straight line crosses a Wall of their floor
    /// ([`fpbp_core::engine::track_segment_crosses_wall`], the check the
    /// engines make before publishing).
    pub wall_crossings: usize,
    pub wall_crossings_per_100m: Option<f64>,
    /// Fraction of poses inside a Wall.
    pub poses_in_wall: f64,
}

impl TrackQuality {
    pub fn of<'a>(site: &Site, outs: impl IntoIterator<Item = &'a ReplayOutput>) -> TrackQuality {
        let mut q = TrackQuality::default();
        let mut in_wall = 0usize;
        for o in outs {
            q.poses += o.track.len();
            for p in &o.track {
                if site.floor(p.floor).is_some_and(|m| {
                    m.feature(Vec2::new(p.x_m, p.y_m)) == fpbp_core::map::Feature::Wall
                }) {
                    in_wall += 1;
                }
            }
            for w in o.track.windows(2) {
                let (a, b) = (&w[0], &w[1]);
                if a.floor != b.floor {
                    continue;
                }
                q.length_m += (b.x_m - a.x_m).hypot(b.y_m - a.y_m);
                q.jumps += usize::from(is_jump(a, b));
                if fpbp_core::engine::track_segment_crosses_wall(site, a, b) {
                    q.wall_crossings += 1;
                }
            }
        }
        let per100 = |n: usize| (q.length_m > 0.0).then(|| 100.0 * n as f64 / q.length_m);
        q.jumps_per_100m = per100(q.jumps);
        q.wall_crossings_per_100m = per100(q.wall_crossings);
        q.poses_in_wall = if q.poses == 0 {
            0.0
        } else {
            in_wall as f64 / q.poses as f64
        };
        q
    }
}

/// The one metrics.json document (eval, replay, demo).
#[derive(Serialize)]
pub struct MetricsDoc<'a, E: Serialize> {
    pub format: &'static str,
    pub version: u32,
    /// "eval", "replay" or "demo".
    pub command: &'static str,
    pub site: String,
    pub log_files: Vec<String>,
    /// The start mode asked for (`--init`); each engine's actual one is its `start`.
    pub init: InitMode,
    /// `--split` (eval only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split: Option<crate::eval::Split>,
    /// Engine seeds the figures come from.
    pub seeds: Vec<u64>,
    pub wall_s: f64,
    pub engines: &'a [E],
    /// The readers' full counts, one per log (replay).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub read_reports: Vec<&'a fpbp_logs::ReadReport>,
}

impl<'a, E: Serialize> MetricsDoc<'a, E> {
    /// The document of `command` (no split, no read reports: set them after).
    pub fn new(
        command: &'static str,
        site: &Path,
        log_files: &[std::path::PathBuf],
        init: InitMode,
        seeds: Vec<u64>,
        wall_s: f64,
        engines: &'a [E],
    ) -> Self {
        MetricsDoc {
            format: METRICS_FORMAT,
            version: METRICS_VERSION,
            command,
            site: site.display().to_string(),
            log_files: log_files.iter().map(|p| p.display().to_string()).collect(),
            init,
            split: None,
            seeds,
            wall_s,
            engines,
            read_reports: Vec::new(),
        }
    }

    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        let p = dir.join("metrics.json");
        std::fs::write(&p, serde_json::to_string_pretty(self)? + "\n")
            .with_context(|| format!("cannot write {}", p.display()))
    }
}

/// The track CSV of replay and demo: one row per published pose
/// (`kind` = pose) and one per scored truth point (`kind` = truth: the
/// estimate then is the pose scored there, with the truth and the error);
/// rows in time order, t_s with nanosecond precision, empty fields where a
/// value does not exist (no fix yet, no truth floor).
pub const TRACK_CSV_HEADER: &str = "kind,t_s,x_m,y_m,floor,heading_rad,accuracy_m,floor_prob,source,truth_x_m,truth_y_m,truth_floor,error_m";

pub fn track_csv(out: &ReplayOutput) -> String {
    use std::fmt::Write as _;
    let mut rows: Vec<(i64, u8, String)> = Vec::new();
    let pose = |p: &fpbp_core::engine::Pose| {
        format!(
            "{},{},{},{},{},{},{}",
            p.x_m,
            p.y_m,
            p.floor,
            p.heading_rad,
            p.accuracy_m,
            p.floor_prob,
            p.source.code()
        )
    };
    for p in &out.track {
        rows.push((p.t_ns, 0, format!("pose,{},{},,,,", t_s(p.t_ns), pose(p))));
    }
    for s in &out.scored {
        let t = &s.truth;
        let est = s.estimate.as_ref().map_or(",,,,,,".to_string(), pose);
        rows.push((
            t.t_ns,
            1,
            format!(
                "truth,{},{est},{},{},{},{}",
                t_s(t.t_ns),
                t.x_m,
                t.y_m,
                t.floor.map_or(String::new(), |f| f.to_string()),
                s.error_m().map_or(String::new(), |e| e.to_string())
            ),
        ));
    }
    rows.sort_by_key(|(t, k, _)| (*t, *k));
    let mut s = String::from(TRACK_CSV_HEADER);
    s.push('\n');
    for (_, _, r) in rows {
        let _ = writeln!(s, "{r}");
    }
    s
}

/// Nanoseconds as seconds with all nine decimals.
pub fn t_s(t_ns: i64) -> String {
    let sign = if t_ns < 0 { "-" } else { "" };
    let a = t_ns.unsigned_abs();
    format!("{sign}{}.{:09}", a / 1_000_000_000, a % 1_000_000_000)
}

/// Writes [`track_csv`] to `path`.
pub fn write_track_csv(path: &Path, out: &ReplayOutput) -> anyhow::Result<()> {
    std::fs::write(path, track_csv(out)).with_context(|| format!("cannot write {}", path.display()))
}

/// Says on stderr when a reader dropped more than 1 % of a log's events.
pub fn warn_dropped(log: &LoadedLog) {
    let r = &log.report;
    let dropped =
        r.late_dropped + r.duplicates_dropped + r.non_finite_dropped + r.malformed_skipped;
    let total = r.events.total() + dropped;
    if total == 0 || (dropped as f64) <= 0.01 * total as f64 {
        return;
    }
    let mut parts = Vec::new();
    for (n, what) in [
        (
            r.late_dropped,
            "late (events out of time order beyond the reorder window)",
        ),
        (r.duplicates_dropped, "exact duplicates"),
        (r.non_finite_dropped, "with NaN or infinite values"),
        (r.malformed_skipped, "malformed lines"),
    ] {
        if n > 0 {
            parts.push(format!("{n} {what}"));
        }
    }
    eprintln!(
        "warning: {}: {dropped} of {total} events ({:.1} %) dropped: {}",
        log.path.display(),
        100.0 * dropped as f64 / total as f64,
        parts.join(", ")
    );
}

/// Why `engine` gave no pose at any truth point of `logs`: the reasons
/// that apply (no site beacons, no id match with the five most heard ids, no
/// BLE rows, an empty grid, events out of order).
pub fn no_pose_reasons(site: &Site, logs: &[&LoadedLog], runs: &[LogRun]) -> Vec<String> {
    let mut why = Vec::new();
    let ble: u64 = logs.iter().map(|l| l.report.events.ble).sum();
    let late: u64 = logs.iter().map(|l| l.report.late_dropped).sum();
    if site.spec.beacons.is_empty() {
        why.push(
            "the site has no beacons (an imported site has none before `fpbp calibrate`: run it)"
                .into(),
        );
    }
    if ble == 0 {
        why.push("the logs have no BLE rows".into());
    } else if !site.spec.beacons.is_empty() {
        let unknown: u64 = runs.iter().map(|r| r.out.stats.unknown_beacons).sum();
        let seen: u64 = runs.iter().map(|r| r.out.stats.ble_observations).sum();
        if seen > 0 && unknown == seen {
            let mut heard: BTreeMap<&str, u64> = BTreeMap::new();
            for l in logs {
                for e in &l.events {
                    if let LogEvent::Ble(b) = e {
                        *heard.entry(b.beacon_id.as_str()).or_default() += 1;
                    }
                }
            }
            let mut top: Vec<(&str, u64)> = heard.into_iter().collect();
            top.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
            let list: Vec<String> = top
                .iter()
                .take(5)
                .map(|(id, n)| format!("{} ({n})", fpbp_core::bounds::echo(id)))
                .collect();
            why.push(format!(
                "no heard beacon id matches a site beacon; the 5 most heard ids: {}",
                list.join(", ")
            ));
        }
    }
    for (f, m) in site.spec.floors.iter().zip(&site.floors) {
        if m.grid().is_empty() {
            why.push(format!(
                "floor {}'s GML grid is empty (grid_interval_m {} on a {:.1} x {:.1} m floor)",
                f.id,
                site.spec.grid_interval_m,
                m.width_m(),
                m.height_m()
            ));
        }
    }
    if late > 0 {
        why.push(format!(
            "{late} events were dropped as out of time order (is the log reversed?)"
        ));
    }
    if why.is_empty() {
        why.push("no known cause: see the per-log counts in metrics.json".into());
    }
    why
}

/// Says on stderr, with reasons, which engines gave no pose at any truth
/// point; an error (non-zero exit) when one did not position anything.
pub fn check_positioned(
    site: &Site,
    logs: &[&LoadedLog],
    engines: &[String],
    runs: &[Vec<LogRun>],
    metrics: &[&EngineMetrics],
) -> anyhow::Result<()> {
    let mut empty = Vec::new();
    for ((name, r), m) in engines.iter().zip(runs).zip(metrics) {
        let poses: usize = r.iter().map(|x| x.out.track.len()).sum();
        let nothing = if m.errors.points > 0 {
            m.errors.no_fix == m.errors.points
        } else {
            poses == 0
        };
        if nothing {
            eprintln!(
                "error: engine `{name}` gave no pose at any of {} truth points ({} poses in all):",
                m.errors.points, poses
            );
            for w in no_pose_reasons(site, logs, r) {
                eprintln!("  - {w}");
            }
            empty.push(name.clone());
        }
    }
    if empty.is_empty() {
        Ok(())
    } else {
        anyhow::bail!(
            "nothing positioned by {} (outputs written; reasons above)",
            empty.join(", ")
        )
    }
}

/// Mean, spread and range of one figure over seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OverSeeds {
    pub mean: Option<f64>,
    /// Sample standard deviation over the seeds (None with fewer than 2).
    pub sd: Option<f64>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub per_seed: Vec<Option<f64>>,
}

impl OverSeeds {
    pub fn of(v: Vec<Option<f64>>) -> OverSeeds {
        let x: Vec<f64> = v.iter().flatten().copied().collect();
        let n = x.len();
        let mean = (n > 0 && n == v.len()).then(|| x.iter().sum::<f64>() / n as f64);
        let sd = mean
            .filter(|_| n >= 2)
            .map(|m| (x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1) as f64).sqrt());
        OverSeeds {
            mean,
            sd,
            min: x.iter().copied().reduce(f64::min),
            max: x.iter().copied().reduce(f64::max),
            per_seed: v,
        }
    }
}

/// One engine over several seeds (`fpbp eval --seeds`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeedSummary {
    pub engine: String,
    pub start: StartMode,
    pub logs: usize,
    pub points: usize,
    pub mpe_m: OverSeeds,
    pub p50_m: OverSeeds,
    pub p80_m: OverSeeds,
    pub coverage: OverSeeds,
    pub ipin_score_m: OverSeeds,
    pub within_accuracy: OverSeeds,
    pub jumps_per_100m: OverSeeds,
    pub wall_crossings_per_100m: OverSeeds,
}

impl SeedSummary {
    /// `per_seed[k]` is the engine's metrics with seed k.
    pub fn of(per_seed: &[&EngineMetrics]) -> SeedSummary {
        let f = |g: &dyn Fn(&EngineMetrics) -> Option<f64>| {
            OverSeeds::of(per_seed.iter().map(|m| g(m)).collect())
        };
        let first = per_seed[0];
        SeedSummary {
            engine: first.engine.clone(),
            start: first.start,
            logs: first.logs,
            points: first.errors.points,
            mpe_m: f(&|m| m.errors.mpe_m),
            p50_m: f(&|m| m.errors.p50_m),
            p80_m: f(&|m| m.errors.p80_m),
            coverage: f(&|m| m.errors.coverage),
            ipin_score_m: f(&|m| m.errors.ipin_score_m),
            within_accuracy: f(&|m| m.errors.within_accuracy),
            jumps_per_100m: f(&|m| m.track.jumps_per_100m),
            wall_crossings_per_100m: f(&|m| m.track.wall_crossings_per_100m),
        }
    }
}

/// The CDF curve of one engine, labelled with its start mode.
pub fn cdf_series(m: &EngineMetrics) -> crate::plot::CdfSeries {
    crate::plot::CdfSeries {
        label: format!("{} ({} start)", m.engine, m.start.name()),
        errors: m.cdf_errors.clone(),
        points: m.errors.points,
    }
}

/// The track panel of one engine's run on `floor`: its poses there, jumps
/// marked, gaps where the track left the floor; the caption gives the
/// start mode and the track's jumps and wall crossings.
pub fn track_panel(site: &Site, name: &str, run: &LogRun, floor: i32) -> crate::plot::Panel {
    let mut points = Vec::new();
    let mut jump = Vec::new();
    let mut gap = Vec::new();
    let mut prev: Option<&fpbp_core::engine::Pose> = None;
    let mut left = false;
    for p in &run.out.track {
        if p.floor != floor {
            left = true;
            continue;
        }
        if let Some(a) = prev {
            jump.push(!left && is_jump(a, p));
            gap.push(left);
        }
        points.push(crate::plot::TrackPoint {
            x_m: p.x_m,
            y_m: p.y_m,
        });
        prev = Some(p);
        left = false;
    }
    let q = TrackQuality::of(site, [&run.out]);
    let start = if run.init.is_some() { "truth" } else { "own" };
    crate::plot::Panel {
        label: name.to_string(),
        note: format!(
            "{start} start, {} poses, {} jumps, {} wall crossings ({} per 100 m)",
            q.poses,
            q.jumps,
            q.wall_crossings,
            crate::metrics::fmt_opt(q.wall_crossings_per_100m, 1)
        ),
        points,
        jump,
        gap,
    }
}

/// The seeds of `eval --seeds` (one clap value holding the list).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeedList(pub Vec<u64>);

/// `--seeds` as a clap value parser.
pub fn seed_list(s: &str) -> Result<SeedList, String> {
    parse_seeds(s).map(SeedList)
}

/// `1-5`, `3`, `1,2,7` or `1-3,9` as a list of seeds (at most 1000).
pub fn parse_seeds(s: &str) -> Result<Vec<u64>, String> {
    let mut out = Vec::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (a.trim(), b.trim()),
            None => (part, part),
        };
        let num = |x: &str| {
            x.parse::<u64>().map_err(|_| {
                format!(
                    "`{}` is not a seed (a non-negative integer)",
                    fpbp_core::bounds::echo(x)
                )
            })
        };
        let (a, b) = (num(a)?, num(b)?);
        if b < a {
            return Err(format!("range {a}-{b} is empty"));
        }
        if b - a >= 1000 || out.len() as u64 + (b - a) >= 1000 {
            return Err("at most 1000 seeds".into());
        }
        out.extend(a..=b);
    }
    if out.is_empty() {
        return Err("no seed given".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::engine::{Pose, PoseSource};

    fn pose(t_s: f64, x: f64) -> Pose {
        Pose {
            t_ns: (t_s * 1e9) as i64,
            x_m: x,
            y_m: 5.0,
            floor: 0,
            heading_rad: 0.0,
            accuracy_m: 1.0,
            floor_prob: 1.0,
            source: PoseSource::Fused,
        }
    }

    #[test]
    fn a_jump_is_faster_than_a_brisk_walk_by_3_m() {
        assert!(!is_jump(&pose(0.0, 0.0), &pose(1.0, 4.9)));
        assert!(is_jump(&pose(0.0, 0.0), &pose(1.0, 5.1)));
        // the 12.6 m in 0.6 s
        assert!(is_jump(&pose(0.0, 0.0), &pose(0.6, 12.6)));
    }

    #[test]
    fn jumps_and_wall_crossings_count_segments() {
        // 30 x 10 m open floor at 2 px/m with a wall at x = 15 m
        let site = crate::testkit::site();
        let mut site = (*site).clone();
        let (w, h) = (60, 20);
        let f = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                if i == 0 || j == 0 || i == w - 1 || j == h - 1 || i == 30 || i == 31 {
                    fpbp_core::map::Feature::Wall
                } else {
                    fpbp_core::map::Feature::Walkable
                }
            })
            .collect();
        site.floors = vec![fpbp_core::map::FloorMap::from_features(w, h, 2.0, f)];
        let out = ReplayOutput {
            // 10 -> 11 -> 20 (a jump through the wall) -> 21
            track: vec![
                pose(0.0, 10.0),
                pose(1.0, 11.0),
                pose(1.5, 20.0),
                pose(2.5, 21.0),
            ],
            ..Default::default()
        };
        let q = TrackQuality::of(&site, [&out]);
        assert_eq!((q.poses, q.jumps, q.wall_crossings), (4, 1, 1));
        assert!((q.length_m - 11.0).abs() < 1e-9);
        assert!((q.jumps_per_100m.unwrap() - 100.0 / 11.0).abs() < 1e-9);
    }

    #[test]
    fn track_csv_has_truth_rows_with_errors() {
        use fpbp_core::engine::replay::ScoredPoint;
        use fpbp_core::events::TruthPoint;
        let out = ReplayOutput {
            track: vec![pose(0.5, 1.0), pose(1.5, 2.0)],
            scored: vec![
                ScoredPoint {
                    truth: TruthPoint {
                        t_ns: 0,
                        x_m: 0.0,
                        y_m: 5.0,
                        floor: None,
                    },
                    estimate: None,
                },
                ScoredPoint {
                    truth: TruthPoint {
                        t_ns: 1_000_000_001,
                        x_m: 4.0,
                        y_m: 5.0,
                        floor: Some(0),
                    },
                    estimate: Some(pose(0.5, 1.0)),
                },
            ],
            ..Default::default()
        };
        let csv = track_csv(&out);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], TRACK_CSV_HEADER);
        let n = TRACK_CSV_HEADER.split(',').count();
        assert!(lines.iter().all(|l| l.split(',').count() == n), "{csv}");
        assert_eq!(lines[1], "truth,0.000000000,,,,,,,,0,5,,");
        assert!(lines[2].starts_with("pose,0.500000000,1,5,0,"));
        assert!(lines[3].starts_with("truth,1.000000001,1,5,0,") && lines[3].ends_with(",4,5,0,3"));
        assert_eq!(t_s(-1_500_000_000), "-1.500000000");
    }

    #[test]
    fn seeds_parse_ranges_and_lists() {
        assert_eq!(parse_seeds("1-5").unwrap(), vec![1, 2, 3, 4, 5]);
        assert_eq!(parse_seeds("3").unwrap(), vec![3]);
        assert_eq!(parse_seeds("1-2,7").unwrap(), vec![1, 2, 7]);
        assert!(parse_seeds("5-1").is_err());
        assert!(parse_seeds("x").is_err());
        assert!(parse_seeds("0-100000").is_err());
    }

    #[test]
    fn over_seeds_mean_sd_and_missing_values() {
        let s = OverSeeds::of(vec![Some(1.0), Some(2.0), Some(3.0)]);
        assert_eq!(
            (s.mean, s.sd, s.min, s.max),
            (Some(2.0), Some(1.0), Some(1.0), Some(3.0))
        );
        // a seed without a value: no mean (it would hide the missing seed)
        let s = OverSeeds::of(vec![Some(1.0), None]);
        assert_eq!((s.mean, s.min), (None, Some(1.0)));
    }
}
