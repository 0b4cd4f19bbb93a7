//! Step detection on the vertical acceleration (FP-BP eqs. 28-31).
//!
//! Input: the up component of the accelerometer in the 3-D MCS (eq. 28; the
//! accelerometer includes gravity). Preprocessing, ours (the paper leaves it
//! open): gravity is removed by subtracting a slow exponential mean of the
//! up component (time constant `gravity_tau_s`, absorbs accelerometer scale
//! bias), then a first-order low-pass at `low_pass_cutoff_hz` removes the
//! heel-strike ringing that otherwise gives double peaks.
//!
//! The window conditions are evaluated in time rather than sample counts, so
//! they hold at any sampling rate and under jitter: for the newest sample at
//! time t, the candidate is the sample nearest to t - h; it is a step when
//! (29a) it is the maximum of the samples in [t - 2h, t], (29b) it exceeds
//! z_th, and (29c) it comes more than k_th after the previous step. Then
//! z_pp = z_peak - min over the window (30) and s = beta * z_pp^(1/4) (31).

use std::collections::VecDeque;

/// A detected step peak, before a heading is attached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepPeak {
    /// Time of the acceleration peak (k - h), ns.
    pub t_ns: i64,
    /// Peak-to-peak vertical acceleration in the window, m/s^2 (eq. 30).
    pub z_pp: f64,
}

/// Parameters of [`StepDetector`] (a view of `PdrConfig`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepParams {
    pub half_window_s: f64,
    pub z_th_mps2: f64,
    pub min_step_interval_s: f64,
    pub low_pass_cutoff_hz: f64,
    pub gravity_tau_s: f64,
    pub max_gap_s: f64,
}

/// Streaming step detector.
#[derive(Debug, Clone)]
pub struct StepDetector {
    p: StepParams,
    /// (t_ns, z) of the last 2h (plus one sample).
    window: VecDeque<(i64, f64)>,
    gravity: Option<f64>,
    low_pass: Option<f64>,
    last_t_ns: Option<i64>,
    last_step_t_ns: Option<i64>,
    last_candidate_t_ns: Option<i64>,
    /// Samples dropped because their time did not advance.
    pub skipped_samples: u64,
    /// Gaps longer than `max_gap_s` that reset the detector.
    pub gaps: u64,
}

impl StepDetector {
    pub fn new(p: StepParams) -> Self {
        StepDetector {
            p,
            window: VecDeque::new(),
            gravity: None,
            low_pass: None,
            last_t_ns: None,
            last_step_t_ns: None,
            last_candidate_t_ns: None,
            skipped_samples: 0,
            gaps: 0,
        }
    }

    /// The preprocessed vertical acceleration z of the last sample, m/s^2.
    pub fn last_z(&self) -> Option<f64> {
        self.window.back().map(|s| s.1)
    }

    /// Feeds the up component of the acceleration (with gravity), m/s^2, at
    /// `t_ns`. Returns a step when one is recognised at this sample.
    pub fn push(&mut self, t_ns: i64, acc_up_mps2: f64) -> Option<StepPeak> {
        if !acc_up_mps2.is_finite() {
            self.skipped_samples += 1;
            return None;
        }
        let dt_s = match self.last_t_ns {
            Some(last) if t_ns <= last => {
                self.skipped_samples += 1;
                return None;
            }
            Some(last) => (t_ns - last) as f64 * 1e-9,
            None => 0.0,
        };
        if dt_s > self.p.max_gap_s {
            self.gaps += 1;
            self.window.clear();
            self.low_pass = None;
        }
        self.last_t_ns = Some(t_ns);
        let dt_s = dt_s.min(self.p.max_gap_s);

        let g = match self.gravity {
            None => acc_up_mps2,
            Some(g) => {
                let alpha = dt_s / (self.p.gravity_tau_s + dt_s);
                g + alpha * (acc_up_mps2 - g)
            }
        };
        self.gravity = Some(g);
        let raw = acc_up_mps2 - g;
        let z = match self.low_pass {
            Some(prev) if self.p.low_pass_cutoff_hz > 0.0 => {
                let rc = 1.0 / (std::f64::consts::TAU * self.p.low_pass_cutoff_hz);
                prev + dt_s / (rc + dt_s) * (raw - prev)
            }
            _ => raw,
        };
        self.low_pass = Some(z);

        let h_ns = (self.p.half_window_s * 1e9) as i64;
        self.window.push_back((t_ns, z));
        while self
            .window
            .get(1)
            .is_some_and(|&(t1, _)| t1 <= t_ns - 2 * h_ns)
        {
            self.window.pop_front();
        }
        // The window must reach back to t - 2h (no decision during start-up).
        let &(t_first, _) = self.window.front()?;
        if t_first > t_ns - 2 * h_ns {
            return None;
        }
        // Candidate: the sample nearest to t - h.
        let target = t_ns - h_ns;
        let (ci, &(tc, zc)) = self
            .window
            .iter()
            .enumerate()
            .min_by_key(|(_, (t, _))| (t - target).abs())?;
        if self.last_candidate_t_ns == Some(tc) {
            return None;
        }
        self.last_candidate_t_ns = Some(tc);
        // (29a): maximum of the window; earlier equal values win, so a flat
        // top is counted once.
        let is_max = self
            .window
            .iter()
            .enumerate()
            .all(|(i, &(_, z))| if i < ci { z < zc } else { z <= zc });
        if !is_max || zc <= self.p.z_th_mps2 {
            return None;
        }
        let min_interval_ns = (self.p.min_step_interval_s * 1e9) as i64;
        if self
            .last_step_t_ns
            .is_some_and(|last| tc - last <= min_interval_ns)
        {
            return None;
        }
        self.last_step_t_ns = Some(tc);
        let z_min = self
            .window
            .iter()
            .map(|s| s.1)
            .fold(f64::INFINITY, f64::min);
        Some(StepPeak {
            t_ns: tc,
            z_pp: zc - z_min,
        })
    }
}

/// Step length s = beta * z_pp^(1/4) (eq. 31), metres.
pub fn step_length_m(beta: f64, z_pp: f64) -> f64 {
    beta * z_pp.max(0.0).powf(0.25)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn params() -> StepParams {
        StepParams {
            half_window_s: 0.2,
            z_th_mps2: 0.8,
            min_step_interval_s: 0.3,
            low_pass_cutoff_hz: 3.0,
            gravity_tau_s: 2.0,
            max_gap_s: 0.5,
        }
    }

    /// Steps detected on a sinusoidal vertical acceleration of `freq_hz`,
    /// amplitude `amp`, for `secs` seconds at `rate_hz`, with jitter.
    fn count_steps(freq_hz: f64, amp: f64, secs: f64, rate_hz: f64) -> (usize, Vec<StepPeak>) {
        let mut d = StepDetector::new(params());
        let mut steps = Vec::new();
        let n = (secs * rate_hz) as usize;
        for i in 0..n {
            let jitter_ns = [0i64, 3_000_000, -2_000_000][i % 3];
            let t_ns = (i as f64 / rate_hz * 1e9) as i64 + jitter_ns;
            let t = t_ns as f64 * 1e-9;
            let a = 9.81 + amp * (std::f64::consts::TAU * freq_hz * t).sin();
            if let Some(s) = d.push(t_ns, a) {
                steps.push(s);
            }
        }
        (steps.len(), steps)
    }

    #[test]
    fn sinusoid_at_1_8_hz_gives_n_times_1_8_steps() {
        for secs in [10.0, 30.0, 60.0] {
            let (n, _) = count_steps(1.8, 2.5, secs, 50.0);
            let expect = secs * 1.8;
            assert!(
                (n as f64 - expect).abs() <= 1.0,
                "{secs} s: {n} steps, expected {expect}"
            );
        }
    }

    #[test]
    fn works_at_100_hz_too() {
        let (n, _) = count_steps(1.8, 2.5, 20.0, 100.0);
        assert!((n as f64 - 36.0).abs() <= 1.0, "{n}");
    }

    #[test]
    fn weak_motion_below_threshold_gives_no_steps() {
        let (n, _) = count_steps(1.8, 0.5, 20.0, 50.0);
        assert_eq!(n, 0);
    }

    #[test]
    fn peak_to_peak_is_about_twice_the_amplitude() {
        let (_, steps) = count_steps(1.8, 2.5, 20.0, 50.0);
        let last = steps.last().unwrap();
        // The 3 Hz low-pass attenuates a 1.8 Hz sine by 1/sqrt(1 + (1.8/3)^2);
        // eq. 30 takes the minimum inside +-h of the peak, where the sine has
        // come down to cos(2 pi f h) of the amplitude (the trough is 1/(2f) away).
        let amp = 2.5 / (1.0f64 + 0.36).sqrt();
        let h = params().half_window_s;
        let expect = amp * (1.0 - (std::f64::consts::TAU * 1.8 * h.min(0.5 / 1.8)).cos());
        assert!(
            (last.z_pp - expect).abs() < 0.3,
            "z_pp {} vs {expect}",
            last.z_pp
        );
    }

    #[test]
    fn step_length_formula() {
        assert!((step_length_m(0.5, 16.0) - 1.0).abs() < 1e-12);
        assert!((step_length_m(0.45, 3.0) - 0.45 * 3f64.powf(0.25)).abs() < 1e-12);
        assert_eq!(step_length_m(0.5, -1.0), 0.0);
    }

    #[test]
    fn bad_samples_are_counted_not_fatal() {
        let mut d = StepDetector::new(params());
        assert!(d.push(10, 9.8).is_none());
        assert!(d.push(10, 9.8).is_none());
        assert!(d.push(5, 9.8).is_none());
        assert!(d.push(20, f64::NAN).is_none());
        assert_eq!(d.skipped_samples, 3);
        d.push(2_000_000_000, 9.8);
        assert_eq!(d.gaps, 1);
    }

    proptest! {
        #[test]
        fn steps_are_ordered_and_spaced(freq in 0.8f64..3.0, amp in 1.0f64..6.0) {
            let (_, steps) = count_steps(freq, amp, 15.0, 50.0);
            for w in steps.windows(2) {
                prop_assert!(w[1].t_ns - w[0].t_ns > 300_000_000);
                prop_assert!(w[1].z_pp >= 0.0);
            }
        }
    }
}
