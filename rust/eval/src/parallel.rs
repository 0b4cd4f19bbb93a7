//! Independent work on several threads with results in input order, so a
//! command's output does not depend on how many threads ran it.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// `f` applied to every item on up to `jobs` threads (at least one); the
/// results come back in the order of `items`. Items are handed out one at a
/// time, so long and short items balance across the threads. A panic in `f`
/// is propagated.
pub fn map_in_order<T, R, F>(items: &[T], jobs: usize, f: F) -> Vec<R>
where
    T: Sync,
    R: Send,
    F: Fn(&T) -> R + Sync,
{
    let threads = jobs.clamp(1, items.len().max(1));
    if threads == 1 {
        return items.iter().map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<R>>> = Mutex::new(items.iter().map(|_| None).collect());
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        let Some(item) = items.get(k) else { break };
                        let r = f(item);
                        slots.lock().unwrap_or_else(|e| e.into_inner())[k] = Some(r);
                    }
                })
            })
            .collect();
        for w in workers {
            if let Err(payload) = w.join() {
                std::panic::resume_unwind(payload);
            }
        }
    });
    slots
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.expect("every item ran"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_keep_the_input_order_whatever_the_thread_count() {
        let items: Vec<u64> = (0..200).collect();
        // uneven work so threads finish out of order
        let f = |&x: &u64| {
            let mut acc = x;
            for _ in 0..(x % 7) * 10_000 {
                acc = acc.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            (x, acc)
        };
        let serial = map_in_order(&items, 1, f);
        for jobs in [2, 3, 8, 500] {
            assert_eq!(map_in_order(&items, jobs, f), serial, "jobs {jobs}");
        }
        assert_eq!(serial[17].0, 17);
        assert!(map_in_order(&[] as &[u64], 4, f).is_empty());
    }

    #[test]
    #[should_panic(expected = "boom")]
    fn a_panic_in_the_work_reaches_the_caller() {
        map_in_order(&[1, 2, 3], 2, |&x: &i32| {
            if x == 2 {
                panic!("boom");
            }
            x
        });
    }
}
