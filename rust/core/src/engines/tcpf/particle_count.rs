//! The particle count: fixed (`particle_count`), or adapted to the
//! cloud's extent at each resampling (`adaptive_count`, KLD-sampling:
//! [`crate::fusion::kld`]): a global start spreads `max_particles` over the
//! floor, and the count falls as the walls, the turns and the radio
//! narrow the cloud down.

use super::TcpfEngine;

impl TcpfEngine {
    /// Resamples when the weights have degenerated (the effective sample
    /// size below `resample_ess_fraction` of the count); returns whether
    /// it did.
    pub(super) fn resample_if_degenerate(&mut self) -> bool {
        if !self.pf.is_degenerate() {
            return false;
        }
        self.resample_now();
        true
    }

    /// Resamples now: to the adaptive count when it is on, else to the
    /// same count.
    pub(super) fn resample_now(&mut self) {
        let kc = &self.cfg.adaptive_count;
        if kc.enabled() {
            let n = kc.count(self.pf.particles(), self.pf.weights());
            self.pf.resample_to(n);
        } else {
            self.pf.resample();
        }
    }

    /// Sets the count of the next initialisation: `max_particles` for a
    /// global start (`wide`) when the count adapts, else `particle_count`.
    pub(super) fn set_init_count(&mut self, wide: bool) {
        let kc = &self.cfg.adaptive_count;
        let n = if wide && kc.enabled() {
            kc.max_particles
        } else {
            self.cfg.particle_count
        };
        self.pf.set_count(n);
    }
}
