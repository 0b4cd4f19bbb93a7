//! Deterministic replay: drives an engine's two tasks at their nominal periods
//! by the log's clock and scores its poses at the truth points.
//!
//! Scheduling rule (the JNI host tests reproduce it exactly): task clocks start
//! at the first event's time; before an event at `t` is handed to the engine,
//! every task whose next due time is <= `t` runs, earliest first, `Ble` before
//! `Fusion` on ties, and its due time advances by its period. Truth points are
//! never given to the engine: the pose scored for a truth point at `t` is the
//! engine's latest pose after the tasks due at or before `t` have run.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Engine, EngineStats, Pose, Task};
use crate::events::{LogEvent, TruthPoint};

/// A truth point and the engine's estimate at that time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScoredPoint {
    pub truth: TruthPoint,
    /// `None` when the engine had no fix yet.
    pub estimate: Option<Pose>,
}

impl ScoredPoint {
    /// Horizontal error, metres, when there is an estimate.
    pub fn error_m(&self) -> Option<f64> {
        self.estimate
            .map(|p| (p.x_m - self.truth.x_m).hypot(p.y_m - self.truth.y_m))
    }

    /// Whether the estimate's floor matches the truth's (None if either is unknown).
    pub fn floor_correct(&self) -> Option<bool> {
        match (self.estimate, self.truth.floor) {
            (Some(p), Some(f)) => Some(p.floor == f),
            _ => None,
        }
    }
}

/// What a replay produced.
#[derive(Debug, Clone, Default)]
pub struct ReplayOutput {
    /// The engine's pose after every task run that changed it.
    pub track: Vec<Pose>,
    pub scored: Vec<ScoredPoint>,
    /// Compute time of every run of each task, microseconds.
    pub task_us: Vec<(Task, f64)>,
    pub stats: EngineStats,
    /// [`Engine::diagnostics`] at the end of the replay.
    pub diagnostics: Vec<(&'static str, u64)>,
    /// Time spanned by the log, seconds.
    pub log_duration_s: f64,
    /// Wall time of the whole replay, seconds.
    pub wall_s: f64,
}

impl ReplayOutput {
    /// Mean compute time per call of `task`, microseconds (the paper's MCT).
    pub fn mct_us(&self, task: Task) -> Option<f64> {
        let v: Vec<f64> = self
            .task_us
            .iter()
            .filter(|(t, _)| *t == task)
            .map(|(_, us)| *us)
            .collect();
        if v.is_empty() {
            None
        } else {
            Some(v.iter().sum::<f64>() / v.len() as f64)
        }
    }
}

/// Drives one engine over one log.
pub struct Replayer<'a> {
    engine: &'a mut dyn Engine,
    next_due: [Option<i64>; 2],
    periods: [Option<i64>; 2],
    first_t: Option<i64>,
    last_t: Option<i64>,
    out: ReplayOutput,
    started: Instant,
}

impl<'a> Replayer<'a> {
    pub fn new(engine: &'a mut dyn Engine) -> Self {
        let periods = Task::ALL.map(|t| engine.task_period_ns(t).filter(|p| *p > 0));
        Replayer {
            engine,
            next_due: [None, None],
            periods,
            first_t: None,
            last_t: None,
            out: ReplayOutput::default(),
            started: Instant::now(),
        }
    }

    /// Feeds one event (events must come in time order; the log readers sort).
    pub fn push(&mut self, event: &LogEvent) {
        let t = event.t_ns();
        if self.first_t.is_none() {
            self.first_t = Some(t);
            for (i, p) in self.periods.iter().enumerate() {
                self.next_due[i] = p.map(|p| t + p);
            }
        }
        self.run_due(t);
        self.last_t = Some(self.last_t.map_or(t, |l| l.max(t)));
        match event {
            LogEvent::Truth(tp) => self.out.scored.push(ScoredPoint {
                truth: *tp,
                estimate: self.engine.pose(),
            }),
            _ => hand_over(self.engine, event),
        }
    }

    fn run_due(&mut self, t: i64) {
        loop {
            let mut best: Option<(i64, usize)> = None;
            for i in 0..2 {
                if let Some(due) = self.next_due[i]
                    && due <= t
                    && best.is_none_or(|(b, _)| due < b)
                {
                    best = Some((due, i));
                }
            }
            let Some((due, i)) = best else { break };
            let task = Task::ALL[i];
            let before = self.engine.pose();
            let clock = Instant::now();
            self.engine.run_task(task, due);
            let us = clock.elapsed().as_secs_f64() * 1e6;
            self.out.task_us.push((task, us));
            let after = self.engine.pose();
            if after.is_some() && after != before {
                self.out.track.extend(after);
            }
            self.next_due[i] = Some(due + self.periods[i].unwrap_or(i64::MAX / 4));
        }
    }

    /// Ends the replay.
    pub fn finish(mut self) -> ReplayOutput {
        if let Some(t) = self.last_t {
            self.run_due(t);
        }
        self.out.stats = self.engine.stats();
        self.out.diagnostics = self.engine.diagnostics();
        self.out.log_duration_s = match (self.first_t, self.last_t) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
            _ => 0.0,
        };
        self.out.wall_s = self.started.elapsed().as_secs_f64();
        self.out
    }
}

/// Hands one input event (sensor, BLE, GNSS, WiFi) to `engine`; truth
/// points are never given to an engine and are ignored here.
pub fn hand_over(engine: &mut dyn Engine, event: &LogEvent) {
    match event {
        LogEvent::Sensor(e) => engine.on_sensor(e),
        LogEvent::Ble(b) => engine.on_ble(b),
        LogEvent::Gnss(g) => engine.on_gnss(g),
        LogEvent::Wifi(w) => engine.on_wifi(w),
        LogEvent::Truth(_) => {}
    }
}

/// Replays `events` through `engine`.
pub fn replay<I: IntoIterator<Item = LogEvent>>(
    engine: &mut dyn Engine,
    events: I,
) -> ReplayOutput {
    let mut r = Replayer::new(engine);
    for e in events {
        r.push(&e);
    }
    r.finish()
}
