//! Test hooks, reachable only through the `selfTest*` entry points (never
//! through `start` or an engine name): a test double whose task blocks on a
//! gate until the test opens it, so the host tests can show that reads
//! (`getPose`, `getBlePosition`, `stats`) return while a task is running.
//! No real engine and no other entry point goes through this module.
//! Compiled only with the crate's `self-test` feature (the host JNI library of
//! host-tests/jvm) and in this crate's own unit tests; the Android library is
//! built without it.

use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};

use fpbp_core::engine::{Engine, EngineStats, Pose, PoseSource, Task};
use fpbp_core::events::{BleObservation, SensorEvent};

/// Longest a blocked task waits for the gate before it gives up (so a test
/// that forgets to open it cannot hang the JVM forever).
pub const MAX_BLOCK: Duration = Duration::from_secs(60);

/// A gate tasks wait on while it is closed, and how many are waiting.
#[derive(Debug, Default)]
pub struct Gate {
    state: Mutex<GateState>,
    changed: Condvar,
}

#[derive(Debug, Default)]
struct GateState {
    closed: bool,
    blocked: usize,
}

impl Gate {
    /// Opens (wakes every waiting task) or closes the gate.
    pub fn set_open(&self, open: bool) {
        let mut s = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        s.closed = !open;
        self.changed.notify_all();
    }

    /// Tasks waiting at the gate now.
    pub fn blocked(&self) -> usize {
        self.state
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .blocked
    }

    /// Waits (at most `timeout`) until `n` tasks wait at the gate.
    pub fn wait_blocked(&self, n: usize, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        let mut s = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        while s.blocked < n {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            s = self
                .changed
                .wait_timeout(s, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
        true
    }

    fn pass(&self) {
        let deadline = Instant::now() + MAX_BLOCK;
        let mut s = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        s.blocked += 1;
        self.changed.notify_all();
        while s.closed {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            s = self
                .changed
                .wait_timeout(s, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
        s.blocked -= 1;
        self.changed.notify_all();
    }
}

/// The gate of the `selfTest*` entry points (one per process).
pub static GATE: std::sync::LazyLock<Arc<Gate>> = std::sync::LazyLock::new(Arc::default);

/// A test double: every task run waits at its gate, then publishes a pose
/// at the task's time (x = number of runs). Starts with a pose at t = 1.
pub struct BlockingEngine {
    gate: Arc<Gate>,
    runs: u64,
    pose: Pose,
    stats: EngineStats,
}

impl BlockingEngine {
    pub fn new(gate: Arc<Gate>) -> Self {
        BlockingEngine {
            gate,
            runs: 0,
            pose: Pose {
                t_ns: 1,
                x_m: 0.0,
                y_m: 0.0,
                floor: 0,
                heading_rad: 0.0,
                accuracy_m: 1.0,
                floor_prob: 1.0,
                source: PoseSource::Fused,
            },
            stats: EngineStats::default(),
        }
    }
}

impl Engine for BlockingEngine {
    fn name(&self) -> &'static str {
        "self-test-blocking"
    }
    fn on_sensor(&mut self, _: &SensorEvent) {
        self.stats.sensor_events += 1;
    }
    fn on_ble(&mut self, _: &BleObservation) {
        self.stats.ble_observations += 1;
    }
    fn run_task(&mut self, _task: Task, t_ns: i64) {
        self.gate.pass();
        self.runs += 1;
        self.pose.t_ns = t_ns;
        self.pose.x_m = self.runs as f64;
    }
    fn task_period_ns(&self, _: Task) -> Option<i64> {
        Some(100_000_000)
    }
    fn pose(&self) -> Option<Pose> {
        Some(self.pose)
    }
    fn ble_position(&self) -> Option<Pose> {
        Some(Pose {
            source: PoseSource::Radio,
            ..self.pose
        })
    }
    fn stats(&self) -> EngineStats {
        self.stats.clone()
    }
}
