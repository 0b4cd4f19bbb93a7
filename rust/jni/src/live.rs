//! One live handle: the engine behind its own mutex, and the [`Snapshot`]
//! readers see behind a second lock that is only ever held for a copy.
//!
//! A running task holds the engine mutex for as long as it runs. Every call
//! that holds it publishes a fresh snapshot before letting go (lock order:
//! engine, then snapshot; nothing else is locked under either), so
//! `getPose`, `getBlePosition` and `stats` read the snapshot and never wait
//! for a task, a sensor call or a slow engine.

use std::sync::{Mutex, PoisonError};

use crate::error::BridgeError;
use crate::session::{Session, Snapshot};

/// A session and its published snapshot.
pub struct Live {
    engine: Mutex<Session>,
    published: Mutex<Snapshot>,
}

impl Live {
    /// Wraps `session`, publishing its first snapshot.
    pub fn new(session: Session) -> Live {
        let first = session.snapshot();
        Live {
            engine: Mutex::new(session),
            published: Mutex::new(first),
        }
    }

    /// Runs `f` on the session under the engine lock, then publishes the
    /// snapshot. A panic inside `f` poisons the engine lock: later calls on
    /// this handle (reads included) fail until it is stopped.
    pub fn call<R>(
        &self,
        handle: i64,
        f: impl FnOnce(&mut Session) -> Result<R, BridgeError>,
    ) -> Result<R, BridgeError> {
        let mut session = self.engine.lock().map_err(|_| poisoned(handle))?;
        let r = f(&mut session);
        let snapshot = session.snapshot();
        // Held only for this assignment: a reader waits for a copy, no more.
        *self
            .published
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = snapshot;
        r
    }

    /// A copy of the latest snapshot; never waits for the engine lock.
    pub fn snapshot(&self, handle: i64) -> Result<Snapshot, BridgeError> {
        if self.engine.is_poisoned() {
            return Err(poisoned(handle));
        }
        Ok(self
            .published
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone())
    }
}

fn poisoned(handle: i64) -> BridgeError {
    BridgeError::Internal(format!(
        "handle {handle}: an earlier call panicked inside the engine; stop() it and start a new one"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::selftest::{BlockingEngine, Gate};
    use std::sync::Arc;
    use std::time::Duration;

    #[test]
    fn a_blocked_task_does_not_block_the_snapshot() {
        let gate = Arc::new(Gate::default());
        gate.set_open(false);
        let live = Arc::new(Live::new(Session::from_engine(Box::new(
            BlockingEngine::new(Arc::clone(&gate)),
        ))));
        let before = live.snapshot(1).expect("snapshot").pose;
        let l2 = Arc::clone(&live);
        let task = std::thread::spawn(move || {
            l2.call(1, |s| {
                s.run_task(fpbp_core::engine::Task::Fusion, 7);
                Ok(())
            })
        });
        assert!(
            gate.wait_blocked(1, Duration::from_secs(30)),
            "the task never blocked"
        );
        // The task holds the engine lock now; the snapshot is still readable.
        assert_eq!(
            live.snapshot(1).expect("snapshot while blocked").pose,
            before
        );
        assert_eq!(gate.blocked(), 1);
        gate.set_open(true);
        task.join().expect("join").expect("task");
        let after = live.snapshot(1).expect("snapshot").pose.expect("pose");
        assert_eq!(after.t_ns, 7);
    }

    #[test]
    fn a_panic_poisons_reads_of_that_handle_only() {
        let a = Arc::new(Live::new(Session::from_engine(Box::new(
            BlockingEngine::new(Arc::new(Gate::default())),
        ))));
        let b = Live::new(Session::from_engine(Box::new(BlockingEngine::new(
            Arc::new(Gate::default()),
        ))));
        let a2 = Arc::clone(&a);
        let joined = std::thread::spawn(move || {
            let _ = a2.call(1, |_| -> Result<(), BridgeError> { panic!("boom") });
        })
        .join();
        assert!(joined.is_err());
        assert!(matches!(a.snapshot(1), Err(BridgeError::Internal(_))));
        assert!(matches!(
            a.call(1, |_| Ok(())),
            Err(BridgeError::Internal(_))
        ));
        assert!(b.snapshot(2).is_ok());
    }
}
