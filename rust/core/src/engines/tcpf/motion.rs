//! The particles' steps (with the wall check) and the online step scale
//! they feed.

use std::sync::Arc;

use super::TcpfEngine;

/// Sampling step of the particles' wall checks, metres (the published
/// point is checked as `fpbp eval` checks it: [`crate::map::FloorMap::track_crosses_wall`]).
const WALL_STEP_M: f64 = 0.1;

impl TcpfEngine {
    /// One step of every particle, with the wall check; the share of the
    /// particles the walls stopped.
    pub(super) fn step(&mut self, length_m: f64, yaw_rad: f64) -> f64 {
        let site = Arc::clone(&self.site);
        let map = site.floor(self.floor);
        if map.is_some() {
            self.scratch.before.clear();
            self.scratch.before.extend_from_slice(self.pf.particles());
        }
        self.pf.set_extra_noise(self.cfg.position_noise_m);
        self.pf.predict(length_m, yaw_rad);
        self.told_reach.on_step(length_m, yaw_rad);
        let mut frac = 0.0;
        if let Some(m) = map {
            m.crosses_wall_each(
                &self.scratch.before,
                self.pf.particles(),
                WALL_STEP_M,
                &mut self.scratch.crossed,
            );
            let n = self.scratch.crossed.iter().filter(|c| **c).count();
            frac = n as f64 / self.scratch.crossed.len().max(1) as f64;
            self.recovery.kill_ema += 0.1 * (frac - self.recovery.kill_ema);
            if n == self.scratch.crossed.len() {
                // every hypothesis hit a wall (an unmapped door, a bad
                // heading): the step is undone rather than the cloud lost
                self.pf.restore_positions(&self.scratch.before);
                self.counts.steps_blocked += 1;
            } else if n > 0 {
                self.pf.penalize_flagged(&self.scratch.crossed, 0.0);
                self.counts.wall_killed += n as u64;
            }
        }
        self.resample_if_degenerate();
        frac
    }
}
