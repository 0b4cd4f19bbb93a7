//! A fingerprint database from walked survey logs (BMW Sec. 3.2, eq. 3 and
//! eqs. 4-6): the surveyor walks between known points (ILC waypoints, IPIN
//! truth points); the PDR steps between two known points are corrected so
//! that the track ends on the second one (the start/end error compensation
//! of [`compensate_walk`]); the filtered RSSI vector the engine would see
//! (the BLE front end's output, every `survey_sample_interval_s`) is placed
//! on the corrected track at its time; samples are averaged in square cells
//! of `survey_cell_m`; beacons of the floor never heard in a cell are filled
//! from their path-loss model (eqs. 4-6). The result is clustered (AP +
//! relative-density outliers) once, in [`SurveyBuilder::finish`].
//!
//! Pure: takes the events of each log, returns a [`FingerprintSet`].

use std::collections::BTreeMap;

use super::FingerprintConfig;
use super::db::{FingerprintDb, compensate_walk};
use super::store::{FingerprintSet, FloorDb, Source, floor_beacons, walkable_grid};
use crate::Vec2;
use crate::ble::registry::BeaconRegistry;
use crate::ble::{BleConfig, BleFrontEnd};
use crate::events::LogEvent;
use crate::pdr::{Pdr, PdrConfig};
use crate::site::Site;

/// What one log contributed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogSurvey {
    /// Pairs of consecutive known points used as survey lines.
    pub segments: usize,
    /// Pairs skipped: floor change, gap longer than `survey_max_segment_s`, unknown floor.
    pub segments_skipped: usize,
    /// Used segments without a PDR step (positions interpolated in time).
    pub segments_without_steps: usize,
    /// RSSI samples placed on survey lines.
    pub samples: usize,
    /// Sum of |end - start| over segments of >= 3 m with >= 3 steps, metres.
    pub truth_displacement_m: f64,
    /// Sum of |sum of PDR step vectors| over the same segments, metres.
    pub pdr_displacement_m: f64,
    /// PDR steps in the log.
    pub steps: usize,
    /// Known points used (all truth points, or the line ends with
    /// `survey_line_tolerance_m`).
    pub known_points: usize,
}

impl LogSurvey {
    /// Truth over PDR displacement (the step-length scale error; 1 = right), when measured.
    pub fn step_scale(&self) -> Option<f64> {
        (self.pdr_displacement_m > 1.0).then(|| self.truth_displacement_m / self.pdr_displacement_m)
    }
}

/// Accumulated samples of one cell.
#[derive(Debug, Clone, Default)]
struct Cell {
    n: usize,
    pos_sum: Vec2,
    /// Registry index -> (sum of RSSI, count).
    rssi: BTreeMap<usize, (f64, usize)>,
}

/// One RSSI sample placed on the floor.
#[derive(Debug, Clone)]
struct Sample {
    floor: i32,
    pos: Vec2,
    rssi: Vec<(usize, f64)>,
}

/// The front end's output at one time: (t, [(registry index, floor, RSSI)]).
type Snapshot = (i64, Vec<(usize, i32, f64)>);

/// Builds a survey database log by log.
pub struct SurveyBuilder<'a> {
    site: &'a Site,
    ble: BleConfig,
    pdr: PdrConfig,
    cfg: FingerprintConfig,
    registry: BeaconRegistry,
    samples: Vec<Sample>,
}

impl<'a> SurveyBuilder<'a> {
    pub fn new(site: &'a Site, ble: &BleConfig, pdr: &PdrConfig, cfg: &FingerprintConfig) -> Self {
        SurveyBuilder {
            site,
            ble: ble.clone(),
            pdr: pdr.clone(),
            cfg: cfg.clone(),
            registry: BeaconRegistry::new(&site.spec.beacons),
            samples: Vec::new(),
        }
    }

    /// Adds one walked log (time-ordered events with truth points).
    pub fn add_log(&mut self, events: &[LogEvent]) -> LogSurvey {
        let mut rep = LogSurvey::default();
        let mut pdr = Pdr::new(&self.pdr, self.site.spec.pdr_rotation_rad());
        let mut front = BleFrontEnd::new(&self.ble, self.site);
        let interval_ns = (self.cfg.survey_sample_interval_s * 1e9) as i64;
        let mut steps = Vec::new();
        let mut truth = Vec::new();
        // (t, heard beacons) snapshots of the front end, every interval
        let mut snaps: Vec<Snapshot> = Vec::new();
        let mut next_snap: Option<i64> = None;
        for e in events {
            let t = e.t_ns();
            while let Some(ts) = next_snap.filter(|ts| t > *ts) {
                let heard = front
                    .current(ts)
                    .iter()
                    .map(|b| (b.index, b.floor, b.rssi_dbm))
                    .collect();
                snaps.push((ts, heard));
                next_snap = Some(ts + interval_ns);
            }
            match e {
                LogEvent::Sensor(s) => pdr.on_sensor(s),
                LogEvent::Ble(o) => {
                    if front.on_observation(o) && next_snap.is_none() {
                        next_snap = Some(o.t_ns + interval_ns);
                    }
                }
                LogEvent::Truth(tp) => {
                    if tp.x_m.is_finite() && tp.y_m.is_finite() {
                        truth.push((tp.t_ns, Vec2::new(tp.x_m, tp.y_m), tp.floor));
                    }
                }
                LogEvent::Gnss(_) | LogEvent::Wifi(_) => {}
            }
            steps.extend(pdr.take_steps());
        }
        rep.steps = steps.len();
        if self.cfg.survey_line_tolerance_m > 0.0 {
            truth = line_ends(&truth, self.cfg.survey_line_tolerance_m);
        }
        rep.known_points = truth.len();
        let max_ns = (self.cfg.survey_max_segment_s * 1e9) as i64;
        let single_floor = (self.site.spec.floors.len() == 1).then(|| self.site.default_floor());
        for w in truth.windows(2) {
            let ((t0, a, fa), (t1, b, fb)) = (w[0], w[1]);
            let floor = match (fa.or(single_floor), fb.or(single_floor)) {
                (Some(x), Some(y)) if x == y => x,
                _ => {
                    rep.segments_skipped += 1;
                    continue;
                }
            };
            if t1 <= t0 || t1 - t0 > max_ns {
                rep.segments_skipped += 1;
                continue;
            }
            rep.segments += 1;
            let seg: Vec<(i64, f64, f64)> = steps
                .iter()
                .filter(|s| s.t_ns > t0 && s.t_ns <= t1)
                .map(|s| (s.t_ns, s.length_m, s.yaw_rad))
                .collect();
            if seg.is_empty() {
                rep.segments_without_steps += 1;
            }
            let lh: Vec<(f64, f64)> = seg.iter().map(|&(_, l, h)| (l, h)).collect();
            let truth_d = (b - a).norm();
            if truth_d >= 3.0 && seg.len() >= 3 {
                let v = lh.iter().fold(Vec2::zeros(), |acc, &(l, h)| {
                    acc + Vec2::new(l * h.cos(), l * h.sin())
                });
                rep.truth_displacement_m += truth_d;
                rep.pdr_displacement_m += v.norm();
            }
            // knots of the corrected track: start, each step, end
            let mut knots: Vec<(i64, Vec2)> = vec![(t0, a)];
            knots.extend(seg.iter().map(|s| s.0).zip(compensate_walk(a, b, &lh)));
            knots.push((t1, b));
            for (ts, heard) in snaps.iter().filter(|(ts, _)| *ts >= t0 && *ts < t1) {
                let rssi: Vec<(usize, f64)> = heard
                    .iter()
                    .filter(|(_, f, r)| *f == floor && r.is_finite())
                    .map(|&(i, _, r)| (i, r))
                    .collect();
                if rssi.is_empty() {
                    continue;
                }
                self.samples.push(Sample {
                    floor,
                    pos: track_at(&knots, *ts),
                    rssi,
                });
                rep.samples += 1;
            }
        }
        rep
    }

    /// Samples placed so far.
    pub fn samples(&self) -> usize {
        self.samples.len()
    }

    /// Averages the samples into cells (coarsened by 1.25x until each floor
    /// has at most `max_points_per_floor`), fills unheard beacons from the
    /// model and clusters each floor.
    pub fn finish(self) -> FingerprintSet {
        let mut floors = BTreeMap::new();
        let mut ids: Vec<i32> = self.samples.iter().map(|s| s.floor).collect();
        ids.sort_unstable();
        ids.dedup();
        for floor in ids {
            let beacons = floor_beacons(&self.registry, &self.ble, floor);
            if beacons.is_empty() {
                continue;
            }
            let samples: Vec<&Sample> = self.samples.iter().filter(|s| s.floor == floor).collect();
            let mut cell_m = self.cfg.survey_cell_m;
            let mut cells = bin(&samples, cell_m);
            while cells.len() > self.cfg.max_points_per_floor {
                cell_m *= 1.25;
                cells = bin(&samples, cell_m);
            }
            let mut db = FingerprintDb::new(beacons, self.cfg.missing_rssi_dbm);
            for c in cells.values() {
                let pos = c.pos_sum / c.n as f64;
                let measured: Vec<Option<f64>> = db
                    .beacons
                    .iter()
                    .map(|b| {
                        c.rssi
                            .get(&b.registry_index)
                            .map(|(sum, n)| sum / *n as f64)
                    })
                    .collect();
                db.push(pos, &measured, self.ble.min_distance_m);
            }
            let fill = self.cfg.survey_model_fill_m;
            if fill > 0.0
                && let Some(map) = self.site.floor(floor)
            {
                let surveyed: Vec<Vec2> = db.points.iter().map(|p| p.pos).collect();
                let none = vec![None; db.beacons.len()];
                let mut step = self.cfg.grid_step_m;
                let mut grid = walkable_grid(map, step);
                while grid.len() > self.cfg.max_points_per_floor {
                    step *= 1.25;
                    grid = walkable_grid(map, step);
                }
                for g in grid {
                    if surveyed.iter().all(|s| (s - g).norm() > fill) {
                        db.push(g, &none, self.ble.min_distance_m);
                    }
                }
            }
            if !db.points.is_empty() {
                floors.insert(floor, FloorDb::cluster(db, &self.cfg));
            }
        }
        FingerprintSet {
            source: Source::Survey,
            floors,
        }
    }
}

/// Samples averaged per square cell of `cell_m` (keyed by cell indices: deterministic order).
fn bin(samples: &[&Sample], cell_m: f64) -> BTreeMap<(i64, i64), Cell> {
    let mut cells: BTreeMap<(i64, i64), Cell> = BTreeMap::new();
    for s in samples {
        let key = (
            (s.pos.x / cell_m).floor() as i64,
            (s.pos.y / cell_m).floor() as i64,
        );
        let c = cells.entry(key).or_default();
        c.n += 1;
        c.pos_sum += s.pos;
        for &(i, r) in &s.rssi {
            let e = c.rssi.entry(i).or_insert((0.0, 0));
            e.0 += r;
            e.1 += 1;
        }
    }
    cells
}

/// The start and end points of the straight lines of a truth track: the
/// vertices of its Douglas-Peucker simplification within `tol_m` (first and
/// last always kept; a point whose floor differs from its neighbour's is
/// kept with that neighbour, so floor changes stay segment ends).
fn line_ends(truth: &[(i64, Vec2, Option<i32>)], tol_m: f64) -> Vec<(i64, Vec2, Option<i32>)> {
    let n = truth.len();
    if n <= 2 {
        return truth.to_vec();
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    for i in 1..n {
        if truth[i].2 != truth[i - 1].2 {
            keep[i] = true;
            keep[i - 1] = true;
        }
    }
    let anchors: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
    let mut stack: Vec<(usize, usize)> = anchors.windows(2).map(|w| (w[0], w[1])).collect();
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (truth[a].1, truth[b].1);
        let d = pb - pa;
        let len = d.norm();
        let (mut worst, mut at) = (0.0, a);
        for (i, p) in truth.iter().enumerate().take(b).skip(a + 1) {
            let r = p.1 - pa;
            let dist = if len < 1e-9 {
                r.norm()
            } else {
                (d.x * r.y - d.y * r.x).abs() / len
            };
            if dist > worst {
                (worst, at) = (dist, i);
            }
        }
        if worst > tol_m {
            keep[at] = true;
            stack.push((a, at));
            stack.push((at, b));
        }
    }
    truth
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(t, _)| *t)
        .collect()
}

/// Position on the piecewise-linear track through `knots` (time-ordered) at `t`.
fn track_at(knots: &[(i64, Vec2)], t: i64) -> Vec2 {
    for w in knots.windows(2) {
        let ((ta, pa), (tb, pb)) = (w[0], w[1]);
        if t >= ta && t <= tb {
            if tb == ta {
                return pb;
            }
            let u = (t - ta) as f64 / (tb - ta) as f64;
            return pa + (pb - pa) * u;
        }
    }
    knots.last().map_or(Vec2::zeros(), |k| k.1)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::ble::pathloss::{PathLoss, range_m};
    use crate::events::{BleObservation, SensorData, SensorEvent, TruthPoint};
    use crate::pdr::HeadingSource;
    use crate::pdr::orientation;
    use crate::site::testkit::{beacon_site, open_map};
    use nalgebra::{UnitQuaternion, Vector3};
    use std::sync::Arc;

    pub const MODEL: PathLoss = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };
    pub const BEACONS: [(f64, f64); 6] = [
        (2.0, 2.0),
        (18.0, 2.0),
        (38.0, 2.0),
        (2.0, 28.0),
        (20.0, 28.0),
        (38.0, 28.0),
    ];

    /// A 40 x 30 m open floor 0 with six beacons.
    pub fn site() -> Arc<Site> {
        beacon_site("survey-test", vec![open_map(40, 30)], &BEACONS, MODEL)
    }

    /// A walk east along y = 12.5 from x = 5 at `speed` m/s for `secs`:
    /// flat phone stepping at 1.8 Hz (the PDR's own step length is ~0.57 m,
    /// i.e. ~1.0 m/s), exact model RSSI of every beacon every 0.2 s, known
    /// points at the start and end. Returns events and the true position at t.
    pub fn straight_walk(speed: f64, secs: f64) -> (Vec<LogEvent>, impl Fn(i64) -> Vec2) {
        let truth = move |t_ns: i64| Vec2::new(5.0 + speed * t_ns as f64 * 1e-9, 12.5);
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -std::f64::consts::FRAC_PI_2);
        let rv = orientation::to_android(&q);
        let mut ev = Vec::new();
        let n = (secs * 50.0) as i64;
        for i in 0..=n {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let acc = Vector3::new(
                0.0,
                0.0,
                9.81 + 2.0 * (std::f64::consts::TAU * 1.8 * t).sin(),
            );
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::Accelerometer((q.inverse() * acc).into()),
            }));
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::RotationVector(rv),
            }));
            if i % 10 == 0 {
                let p = truth(t_ns);
                for (k, &(x, y)) in BEACONS.iter().enumerate() {
                    ev.push(LogEvent::Ble(BleObservation {
                        t_ns,
                        beacon_id: format!("mac:00:00:00:00:00:{k:02X}"),
                        rssi_dbm: MODEL.rssi_at(range_m(p, Vec2::new(x, y), 0.0, 0.5), 0.5),
                        tx_power_dbm: None,
                    }));
                }
            }
            if i == 0 || i == n {
                let p = truth(t_ns);
                ev.push(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                }));
            }
        }
        (ev, truth)
    }

    pub fn rv_pdr() -> PdrConfig {
        PdrConfig {
            heading_source: HeadingSource::RotationVector,
            ..PdrConfig::default()
        }
    }

    #[test]
    fn compensation_places_samples_on_the_true_track() {
        let site = site();
        let cfg = FingerprintConfig::default();
        let pdr = rv_pdr();
        let mut b = SurveyBuilder::new(&site, &BleConfig::default(), &pdr, &cfg);
        // the walker covers 1.4 m/s, the PDR steps say ~1.0 m/s
        let (ev, truth) = straight_walk(1.4, 20.0);
        let rep = b.add_log(&ev);
        assert_eq!((rep.segments, rep.segments_skipped), (1, 0));
        assert!(rep.steps >= 34, "{rep:?}");
        assert!(rep.samples >= 18, "{rep:?}");
        // the PDR's own step scale error is measured
        let scale = rep.step_scale().unwrap();
        assert!((1.2..1.6).contains(&scale), "scale {scale}");
        // every sample lies on the true track at its time, within a step
        let t_first = ev.iter().find_map(|e| match e {
            LogEvent::Ble(o) => Some(o.t_ns),
            _ => None,
        });
        let t0 = t_first.unwrap();
        let interval = (cfg.survey_sample_interval_s * 1e9) as i64;
        let mut worst: f64 = 0.0;
        let mut pdr_only_worst: f64 = 0.0;
        for (k, s) in b.samples.iter().enumerate() {
            let t = t0 + (k as i64 + 1) * interval;
            worst = worst.max((s.pos - truth(t)).norm());
            // where the uncompensated PDR would have put it: 1/scale of the distance
            let raw = Vec2::new(5.0 + (truth(t).x - 5.0) / scale, 12.5);
            pdr_only_worst = pdr_only_worst.max((raw - truth(t)).norm());
            assert_eq!(s.floor, 0);
        }
        assert!(worst < 0.8, "worst compensated error {worst} m");
        assert!(pdr_only_worst > 5.0, "uncompensated {pdr_only_worst} m");
        // the database: one point per 1 m cell on the line, all six beacons
        let set = b.finish();
        let f = &set.floors[&0];
        assert_eq!(f.db.beacons.len(), 6);
        assert!(f.db.points.len() >= 15, "{}", f.db.points.len());
        assert_eq!(f.sub.label.len(), f.db.points.len());
        for p in &f.db.points {
            assert!((p.pos.y - 12.5).abs() < 1e-6 && p.pos.x > 4.0 && p.pos.x < 34.0);
        }
    }

    #[test]
    fn line_ends_are_the_corners_of_a_walked_track() {
        // 10 Hz truth: east 10 m, north 6 m, a 0.1 m wobble; floor 0, then
        // two points on floor 1
        let mut truth = Vec::new();
        let mut t = 0i64;
        let mut push = |p: Vec2, f: i32| {
            truth.push((t, p, Some(f)));
            t += 100_000_000;
        };
        for k in 0..=100 {
            let wobble = if k % 2 == 0 { 0.05 } else { -0.05 };
            push(Vec2::new(k as f64 * 0.1, 2.0 + wobble), 0);
        }
        for k in 1..=60 {
            push(Vec2::new(10.0, 2.0 + k as f64 * 0.1), 0);
        }
        push(Vec2::new(10.0, 8.5), 1);
        push(Vec2::new(10.0, 9.0), 1);
        let ends = line_ends(&truth, 0.3);
        let pts: Vec<(f64, f64, i32)> = ends
            .iter()
            .map(|(_, p, f)| (p.x, p.y, f.unwrap()))
            .collect();
        // start, the corner (within the wobble), the last point of floor 0
        // and the two of floor 1
        assert_eq!(pts.len(), 5, "{pts:?}");
        assert_eq!(pts[0], (0.0, 2.05, 0));
        let (cx, cy, cf) = pts[1];
        assert!(
            (cx - 10.0).abs() <= 0.11 && (cy - 2.0).abs() <= 0.06 && cf == 0,
            "{pts:?}"
        );
        assert_eq!(&pts[2..], &[(10.0, 8.0, 0), (10.0, 8.5, 1), (10.0, 9.0, 1)]);
        // tolerance 0 keeps every point off the lines
        assert!(line_ends(&truth, 0.0).len() > 100);
    }

    #[test]
    fn with_a_line_tolerance_only_the_line_ends_are_known_points() {
        let site = site();
        let (mut ev, truth) = straight_walk(1.4, 20.0);
        // dense truth (10 Hz) along the straight walk, as the simulator writes
        let mut dense: Vec<LogEvent> = (1..200)
            .map(|k| {
                let t_ns = k * 100_000_000;
                let p = truth(t_ns);
                LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                })
            })
            .collect();
        ev.append(&mut dense);
        ev.sort_by_key(LogEvent::t_ns);
        let all = SurveyBuilder::new(
            &site,
            &BleConfig::default(),
            &rv_pdr(),
            &FingerprintConfig::default(),
        )
        .add_log(&ev);
        assert_eq!((all.known_points, all.segments), (201, 200));
        let cfg = FingerprintConfig {
            survey_line_tolerance_m: 0.3,
            ..FingerprintConfig::default()
        };
        let mut b = SurveyBuilder::new(&site, &BleConfig::default(), &rv_pdr(), &cfg);
        let rep = b.add_log(&ev);
        assert_eq!((rep.known_points, rep.segments), (2, 1));
        assert_eq!(rep.samples, all.samples);
    }

    #[test]
    fn floor_changes_long_gaps_and_logs_without_truth_give_no_line() {
        let site = site();
        let cfg = FingerprintConfig {
            survey_max_segment_s: 10.0,
            ..FingerprintConfig::default()
        };
        let mut b = SurveyBuilder::new(&site, &BleConfig::default(), &rv_pdr(), &cfg);
        let (ev, _) = straight_walk(1.4, 20.0);
        let rep = b.add_log(&ev);
        assert_eq!((rep.segments, rep.segments_skipped, rep.samples), (0, 1, 0));
        let no_truth: Vec<LogEvent> = ev
            .into_iter()
            .filter(|e| !matches!(e, LogEvent::Truth(_)))
            .collect();
        let rep = b.add_log(&no_truth);
        assert_eq!((rep.segments, rep.samples), (0, 0));
        assert!(b.finish().floors.is_empty());
    }
}
