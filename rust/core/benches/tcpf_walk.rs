//! `tcpf` as it runs on a walk: a simulated 120 s walk of the demo site
//! (sim seed 7, steps from the phone's accelerometer, the beacons as the
//! simulator hears them) replayed through the engine with the replay's
//! task schedule (`engine::replay`), one criterion iteration per radio
//! period (1 s) of the walk. The benches differ from the `tcpf` bench's
//! `engine radio + fusion task` (one spot, no step, a cloud 1-2 m wide):
//! here the cloud follows the steps and is several metres wide.
//!
//! Cases, each with the site's path-loss model and with a radio map built
//! from three simulated survey walks (sim seeds 41-43, 240 s; with the
//! reference scans, as `fpbp calibrate --radio-map` builds it):
//! - `told start, radio update`: after a start at the walk's first truth
//!   point, each second's radio task (which takes the window) and the
//!   fusion task after it (the steps since the last one, then the
//!   weighting, the phone offset, the integrity and recovery checks and
//!   the published point); with the path-loss model also with the fit
//!   off (neither the fit check nor the radius's fit term: their cost is
//!   the difference);
//! - `told start, tasks`: the radio task and the five fusion tasks of
//!   each second (the steps' predict and the published point);
//! - `told start, all`: the same seconds with every event handed to the
//!   engine timed too (the PDR's step detection and the per-step predict
//!   included: everything the engine spends per second of walking);
//! - `own start, first 15 s, tasks`: the engine's global start, its
//!   first 15 s replayed over and over (the wide cloud of a start);
//! - `told start, tasks, adaptive count` and `own start, first 15 s,
//!   tasks, adaptive count`: the same with the adaptive particle count
//!   (`adaptive_count` 4000 / 500, off by default), to compare.
//!
//! Before timing, each case is run once untimed and its mean accuracy
//! radius and mean error are printed, so the figures say which cloud they
//! were measured on. Compare the cases within one run.
//!
//! Run: `FPBP_BENCH_CLOCK=cpu cargo bench -p fpbp-core --bench tcpf_walk`.

use std::sync::Arc;
use std::time::Duration;

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::engine::replay::hand_over;
use fpbp_core::engine::{Engine, InitialPosition, Task};
use fpbp_core::engines::{EngineConfig, EngineData, build_engine_with};
use fpbp_core::events::LogEvent;
use fpbp_core::radio::RadioMap;
use fpbp_core::radio::radio_map::{RadioMapBuilder, RadioMapConfig};
use fpbp_core::radio::reference_scans::ReferenceScanConfig;
use fpbp_core::site::Site;
use fpbp_sim::{SimRequest, simulate};

/// Radio period of the engine's schedule (the defaults' 1 s).
const SECOND_NS: i64 = 1_000_000_000;

fn demo_site() -> Arc<Site> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo/site.json");
    fpbp_core::site::files::load_site(&path).expect("maps/demo/site.json")
}

fn walk(site: &Site, seed: u64, seconds: f64) -> Vec<LogEvent> {
    simulate(site, &SimRequest::new(seconds, seed))
        .expect("simulated walk")
        .events
}

fn survey_map(site: &Site) -> Arc<RadioMap> {
    let cfg = RadioMapConfig::default();
    // with the reference scans, as `fpbp calibrate --radio-map` builds it
    // (the fit check reads the survey's own misfit from them)
    let mut b = RadioMapBuilder::new(site, &cfg)
        .and_then(|b| b.with_reference_scans(&ReferenceScanConfig::default()))
        .expect("radio map builder");
    for seed in [41, 42, 43] {
        b.add_log(&walk(site, seed, 240.0));
    }
    Arc::new(b.finish().expect("radio map").0)
}

/// What a bench times of each second of the walk.
#[derive(Clone, Copy, PartialEq)]
enum Timed {
    /// The radio update: the radio task (which takes the window of
    /// readings) and the fusion task after it (which weighs the cloud with
    /// them, after the steps since the last fusion task): once a second.
    RadioUpdate,
    /// The radio task and the fusion tasks (five per second).
    Tasks,
    /// Everything: the tasks and every event handed to the engine.
    All,
}

/// One engine replaying one walk, one radio period at a time, with the
/// replay's schedule: before an event at `t`, every task due at or before
/// `t` runs, earliest first, the radio task before fusion on ties.
struct WalkDriver<'a> {
    build: &'a dyn Fn() -> Box<dyn Engine>,
    events: &'a [LogEvent],
    /// Replay restarts (a fresh engine) once the walk passes this time.
    end_ns: i64,
    engine: Box<dyn Engine>,
    next: usize,
    due: [i64; 2],
    period: [i64; 2],
    /// The radio task ran and no fusion task since.
    radio_pending: bool,
}

impl<'a> WalkDriver<'a> {
    fn new(build: &'a dyn Fn() -> Box<dyn Engine>, events: &'a [LogEvent], end_ns: i64) -> Self {
        let engine = build();
        let period = Task::ALL.map(|t| engine.task_period_ns(t).unwrap_or(SECOND_NS));
        let t0 = events[0].t_ns();
        WalkDriver {
            build,
            events,
            end_ns,
            engine,
            next: 0,
            due: [t0 + period[0], t0 + period[1]],
            period,
            radio_pending: false,
        }
    }

    fn restart(&mut self) {
        *self = WalkDriver::new(self.build, self.events, self.end_ns);
    }

    /// Runs the tasks due at or before `t`; returns the time of those
    /// `timed` selects.
    fn run_due(&mut self, t: i64, timed: Option<Timed>) -> Duration {
        let mut spent = Duration::ZERO;
        loop {
            let i = if self.due[0] <= self.due[1] { 0 } else { 1 };
            if self.due[i] > t {
                return spent;
            }
            let clock = common::Stopwatch::start();
            self.engine.run_task(Task::ALL[i], self.due[i]);
            let task = Task::ALL[i];
            let update = task == Task::Radio || self.radio_pending;
            self.radio_pending = task == Task::Radio;
            if timed == Some(Timed::Tasks) || (timed == Some(Timed::RadioUpdate) && update) {
                spent += clock.elapsed();
            }
            self.due[i] += self.period[i];
        }
    }

    /// Replays the next radio period of the walk (restarting at its end);
    /// returns the time of what `timed` selects.
    fn second(&mut self, timed: Timed) -> Duration {
        if self.next >= self.events.len() || self.events[self.next].t_ns() > self.end_ns {
            self.restart();
        }
        let until = self.due[0];
        let whole = common::Stopwatch::start();
        let mut tasks = Duration::ZERO;
        while let Some(e) = self.events.get(self.next) {
            let t = e.t_ns();
            if t > until || t > self.end_ns {
                break;
            }
            tasks += self.run_due(t, Some(timed));
            hand_over(self.engine.as_mut(), e);
            self.next += 1;
        }
        if timed == Timed::All {
            whole.elapsed()
        } else {
            tasks
        }
    }

    /// Mean accuracy radius and mean error at the truth points, one pass
    /// over the replayed stretch from a fresh engine.
    fn describe(&mut self) -> (f64, f64) {
        self.restart();
        let (mut acc, mut err, mut n) = (0.0, 0.0, 0usize);
        while self.next < self.events.len() && self.events[self.next].t_ns() <= self.end_ns {
            let e = &self.events[self.next];
            self.run_due(e.t_ns(), None);
            if let (LogEvent::Truth(tp), Some(p)) = (e, self.engine.pose()) {
                acc += p.accuracy_m;
                err += (p.x_m - tp.x_m).hypot(p.y_m - tp.y_m);
                n += 1;
            }
            hand_over(self.engine.as_mut(), e);
            self.next += 1;
        }
        self.restart();
        let n = n.max(1) as f64;
        (acc / n, err / n)
    }
}

fn engine_walk(c: &mut Criterion) {
    let site = demo_site();
    let events = walk(&site, 7, 120.0);
    let first = events
        .iter()
        .find_map(|e| e.as_truth().copied())
        .expect("the simulated walk has truth");
    let told = InitialPosition {
        x_m: first.x_m,
        y_m: first.y_m,
        floor: first.floor.unwrap_or_else(|| site.default_floor()),
        heading_rad: None,
    };
    let cfg = EngineConfig::default();
    let mut adaptive = EngineConfig::default();
    adaptive.tcpf.adaptive_count.max_particles = 4000;
    adaptive.tcpf.adaptive_count.min_particles = 500;
    let mut fit_off = EngineConfig::default();
    fit_off.tcpf.integrity.fit_free_z2 = 0.0;
    fit_off.tcpf.integrity.fit_accuracy_m_per_z2 = 0.0;
    fit_off.tcpf.integrity.fit_free_z2 = 0.0;
    fit_off.tcpf.integrity.fit_accuracy_m_per_z2_without_map = 0.0;
    let mut reach_off = EngineConfig::default();
    reach_off.tcpf.told_reach_m = 0.0;
    let with_map = EngineData {
        radio_map: Some(survey_map(&site)),
        ..EngineData::default()
    };
    let last_ns = events.last().expect("events").t_ns();
    let own_end_ns = events[0].t_ns() + 15 * SECOND_NS;
    let told_all = Some(told);
    for (data, model) in [
        (EngineData::default(), "path-loss model"),
        (with_map, "radio map"),
    ] {
        let mut cases: Vec<(&str, &EngineConfig, Option<InitialPosition>, i64, Timed)> = vec![
            (
                "told start, radio update",
                &cfg,
                told_all,
                last_ns,
                Timed::RadioUpdate,
            ),
            ("told start, tasks", &cfg, told_all, last_ns, Timed::Tasks),
            ("told start, all", &cfg, told_all, last_ns, Timed::All),
            (
                "own start, first 15 s, tasks",
                &cfg,
                None,
                own_end_ns,
                Timed::Tasks,
            ),
            // the adaptive count (`adaptive_count`, 4000 / 500 particles;
            // off by default): what it saves or costs
            (
                "told start, tasks, adaptive count",
                &adaptive,
                told_all,
                last_ns,
                Timed::Tasks,
            ),
            (
                "own start, first 15 s, tasks, adaptive count",
                &adaptive,
                None,
                own_end_ns,
                Timed::Tasks,
            ),
        ];
        // the fit check (with a radio map, against the survey's own misfit
        // around the cloud) runs by default under both models
        cases.insert(
            1,
            (
                "told start, radio update, fit off",
                &fit_off,
                told_all,
                last_ns,
                Timed::RadioUpdate,
            ),
        );
        // the told start's reach (`told_reach_m`): one distance per
        // particle per radio update
        cases.insert(
            2,
            (
                "told start, radio update, told reach off",
                &reach_off,
                told_all,
                last_ns,
                Timed::RadioUpdate,
            ),
        );
        for (case, cfg, init, end_ns, timed) in cases {
            let build =
                || build_engine_with("tcpf", site.clone(), cfg, init, &data).expect("tcpf engine");
            let mut d = WalkDriver::new(&build, &events, end_ns);
            let (acc, err) = d.describe();
            let name = format!("tcpf on a walk, {model}, {case}, per second");
            eprintln!("{name}: mean accuracy radius {acc:.1} m, mean error {err:.1} m");
            c.bench_function(&name, |b| {
                b.iter_custom(|iters| (0..iters).map(|_| d.second(timed)).sum())
            });
        }
    }
}

criterion_group!(benches, engine_walk);
criterion_main!(benches);
