//! The mean filter of FP-BP eq. 22: x_B(t) = (y* + sum_{i=1}^{n-1} x_B(t-i)) / n.
//!
//! The paper's text ("mean filtering to multiple historical results") leaves
//! open whether x_B(t-i) are the previous *outputs* (a recursive filter, the
//! literal reading of the equation) or the previous raw estimates y* (a
//! moving average). Both are here ([`MeanMode`]); the moving average lags less
//! and is the default (docs/parameters.md gives the measurements). Fewer terms
//! at start-up: the divisor is 1 + the number of terms kept. The history is
//! forgotten after a gap longer than `reset_s` or on a floor change.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::Vec2;

/// Which history eq. 22 averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeanMode {
    /// The previous n - 1 raw estimates y* (a moving average).
    Estimates,
    /// The previous n - 1 filter outputs x_B (the literal, recursive reading).
    Outputs,
}

/// State of the eq. 22 filter.
#[derive(Debug, Clone)]
pub struct MeanFilter {
    n: usize,
    reset_ns: i64,
    mode: MeanMode,
    /// (time, term kept for the next calls, output).
    history: VecDeque<(i64, Vec2, Vec2)>,
}

impl MeanFilter {
    /// The literal (recursive) eq. 22; `n` >= 1 (1 passes estimates through), `reset_s` > 0.
    pub fn new(n: usize, reset_s: f64) -> Self {
        Self::with_mode(n, reset_s, MeanMode::Outputs)
    }

    /// Eq. 22 over the history chosen by `mode`.
    pub fn with_mode(n: usize, reset_s: f64, mode: MeanMode) -> Self {
        MeanFilter {
            n: n.max(1),
            reset_ns: (reset_s * 1e9) as i64,
            mode,
            history: VecDeque::new(),
        }
    }

    /// Forgets every output.
    pub fn clear(&mut self) {
        self.history.clear();
    }

    /// Filters the estimate `y` made at `t_ns` and returns x_B(t).
    pub fn push(&mut self, t_ns: i64, y: Vec2) -> Vec2 {
        if let Some(&(t_last, _, _)) = self.history.back()
            && t_ns - t_last > self.reset_ns
        {
            self.history.clear();
        }
        let keep = self.n - 1;
        while self.history.len() > keep {
            self.history.pop_front();
        }
        let sum = self.history.iter().fold(y, |acc, (_, p, _)| acc + p);
        let out = sum / (self.history.len() + 1) as f64;
        if keep > 0 {
            if self.history.len() == keep {
                self.history.pop_front();
            }
            let term = match self.mode {
                MeanMode::Estimates => y,
                MeanMode::Outputs => out,
            };
            self.history.push_back((t_ns, term, out));
        }
        out
    }

    /// The latest output.
    pub fn last(&self) -> Option<(i64, Vec2)> {
        self.history.back().map(|&(t, _, out)| (t, out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn behaves_as_eq_22() {
        let mut f = MeanFilter::new(3, 5.0);
        let s = 1_000_000_000;
        let a = f.push(0, Vec2::new(3.0, 0.0));
        assert_eq!(a, Vec2::new(3.0, 0.0));
        let b = f.push(s, Vec2::new(6.0, 0.0));
        assert_eq!(b, Vec2::new(4.5, 0.0)); // (6 + 3) / 2
        let c = f.push(2 * s, Vec2::new(9.0, 3.0));
        assert_eq!(c, Vec2::new((9.0 + 4.5 + 3.0) / 3.0, 1.0));
        let d = f.push(3 * s, Vec2::new(0.0, 0.0));
        // uses the two previous outputs b and c only
        assert!((d - (Vec2::new(0.0, 0.0) + b + c) / 3.0).norm() < 1e-12);
        // a gap longer than reset_s forgets the history
        let e = f.push(20 * s, Vec2::new(1.0, 1.0));
        assert_eq!(e, Vec2::new(1.0, 1.0));
    }

    #[test]
    fn estimates_mode_is_a_moving_average_of_raw_estimates() {
        let mut f = MeanFilter::with_mode(3, 5.0, MeanMode::Estimates);
        let s = 1_000_000_000;
        assert_eq!(f.push(0, Vec2::new(3.0, 0.0)), Vec2::new(3.0, 0.0));
        assert_eq!(f.push(s, Vec2::new(6.0, 0.0)), Vec2::new(4.5, 0.0));
        assert_eq!(f.push(2 * s, Vec2::new(9.0, 3.0)), Vec2::new(6.0, 1.0));
        // the oldest estimate (3, 0) has left the window
        assert_eq!(f.push(3 * s, Vec2::new(0.0, 0.0)), Vec2::new(5.0, 1.0));
        assert_eq!(f.last(), Some((3 * s, Vec2::new(5.0, 1.0))));
    }

    #[test]
    fn n1_passes_through() {
        let mut f = MeanFilter::new(1, 5.0);
        for i in 0..5 {
            let y = Vec2::new(i as f64, -(i as f64));
            assert_eq!(f.push(i, y), y);
        }
    }
}
