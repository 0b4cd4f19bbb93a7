//! Shared by the benches: the clock. On this shared 2-core machine the wall
//! clock counts the time other processes hold the CPU; with
//! `FPBP_BENCH_CLOCK=cpu` the benches time this thread's CPU time
//! (`CLOCK_THREAD_CPUTIME_ID`) instead, which load barely changes. Criterion
//! still prints it as "time".

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Bencher;

fn thread_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec to the valid pointer we pass.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID)");
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

/// Whether `FPBP_BENCH_CLOCK=cpu`.
pub fn cpu_clock() -> bool {
    static CPU: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *CPU.get_or_init(|| std::env::var("FPBP_BENCH_CLOCK").is_ok_and(|v| v == "cpu"))
}

/// Times `f` with the clock chosen by `FPBP_BENCH_CLOCK`.
#[allow(dead_code)] // not every bench times whole iterations
pub fn run<O>(b: &mut Bencher, mut f: impl FnMut() -> O) {
    let cpu = cpu_clock();
    b.iter_custom(|iters| {
        let (t0, w0) = (thread_cpu(), Instant::now());
        for _ in 0..iters {
            black_box(f());
        }
        if cpu { thread_cpu() - t0 } else { w0.elapsed() }
    })
}

/// A stopwatch on the clock chosen by `FPBP_BENCH_CLOCK`, for benches that
/// time only part of each iteration (`iter_custom`).
#[allow(dead_code)] // not every bench times parts
pub struct Stopwatch {
    cpu: Option<Duration>,
    wall: Instant,
}

#[allow(dead_code)]
impl Stopwatch {
    pub fn start() -> Stopwatch {
        Stopwatch {
            cpu: cpu_clock().then(thread_cpu),
            wall: Instant::now(),
        }
    }

    pub fn elapsed(&self) -> Duration {
        match self.cpu {
            Some(c0) => thread_cpu() - c0,
            None => self.wall.elapsed(),
        }
    }
}
