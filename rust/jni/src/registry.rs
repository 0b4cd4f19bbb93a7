//! Handle registry: maps the `Long` handles Kotlin holds to live sessions.
//!
//! Handles are ids from an atomic counter, never reused, so a stale id can
//! only miss (IllegalStateException), never reach freed or foreign memory.
//! Each call clones the entry's `Arc` under the read lock and drops the lock
//! before doing anything with it (the entry, [`crate::live::Live`], holds its
//! own locks): calls on different handles never wait for each other, and
//! `remove` (stop) while a call is in flight is safe: the entry dies when the
//! last in-flight call drops its `Arc`.

use std::collections::HashMap;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, RwLock};

use crate::error::BridgeError;

/// Live entries by handle. `T` is the entry type (generic for tests).
#[derive(Debug)]
pub struct Registry<T> {
    next_id: AtomicI64,
    live: RwLock<HashMap<i64, Arc<T>>>,
}

impl<T> Default for Registry<T> {
    fn default() -> Self {
        Registry {
            next_id: AtomicI64::new(1),
            live: RwLock::new(HashMap::new()),
        }
    }
}

impl<T> Registry<T> {
    /// Stores `value` and returns its new handle (> 0, never reused).
    pub fn insert(&self, value: T) -> Result<i64, BridgeError> {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let mut live = self
            .live
            .write()
            .map_err(|_| BridgeError::Internal("handle registry lock poisoned".into()))?;
        live.insert(id, Arc::new(value));
        Ok(id)
    }

    /// The entry of `handle`, or IllegalState when it is unknown or stopped.
    pub fn get(&self, handle: i64) -> Result<Arc<T>, BridgeError> {
        let live = self
            .live
            .read()
            .map_err(|_| BridgeError::Internal("handle registry lock poisoned".into()))?;
        live.get(&handle).cloned().ok_or_else(|| stale(handle))
    }

    /// Removes `handle`; IllegalState when it is unknown or already stopped.
    pub fn remove(&self, handle: i64) -> Result<(), BridgeError> {
        let mut live = self
            .live
            .write()
            .map_err(|_| BridgeError::Internal("handle registry lock poisoned".into()))?;
        live.remove(&handle)
            .map(|_| ())
            .ok_or_else(|| stale(handle))
    }

    /// Number of live handles.
    pub fn len(&self) -> usize {
        self.live.read().map(|l| l.len()).unwrap_or(0)
    }

    /// Whether no handle is live.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

fn stale(handle: i64) -> BridgeError {
    BridgeError::IllegalState(format!(
        "handle {handle} is not a live engine (never started, or already stopped)"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn handles_are_never_reused_and_stale_ones_miss() {
        let r: Registry<u32> = Registry::default();
        let a = r.insert(1).expect("insert");
        r.remove(a).expect("remove");
        let b = r.insert(2).expect("insert");
        assert_ne!(a, b);
        assert!(matches!(r.get(a), Err(BridgeError::IllegalState(_))));
        assert!(matches!(r.remove(a), Err(BridgeError::IllegalState(_))));
        assert_eq!(*r.get(b).expect("get"), 2);
        assert!(matches!(r.get(0), Err(BridgeError::IllegalState(_))));
    }

    #[test]
    fn remove_while_in_flight_keeps_the_session_alive_until_the_call_ends() {
        let r: Registry<Vec<u8>> = Registry::default();
        let h = r.insert(vec![1, 2, 3]).expect("insert");
        let in_flight = r.get(h).expect("get");
        r.remove(h).expect("remove");
        assert_eq!(in_flight.len(), 3);
        assert!(r.is_empty());
    }

    #[test]
    fn concurrent_inserts_get_distinct_handles() {
        let r: Arc<Registry<usize>> = Arc::new(Registry::default());
        let threads: Vec<_> = (0..4)
            .map(|t| {
                let r = Arc::clone(&r);
                std::thread::spawn(move || {
                    (0..100)
                        .map(|i| r.insert(t * 1000 + i).expect("insert"))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut all: Vec<i64> = threads
            .into_iter()
            .flat_map(|t| t.join().expect("join"))
            .collect();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), 400);
    }
}
