//! The magnetic update (`tcpf.magnetic`): the magnetometer's |B| summed
//! between fusion runs weighs the particles by the site's magnetic map.

use std::sync::Arc;

use super::TcpfEngine;

/// The magnetometer's |B| since the last fusion task, and the phone's
/// offset against the magnetic map.
#[derive(Debug, Default)]
pub(super) struct MagneticState {
    /// Sum and count of the magnetometer's |B| since the last fusion task.
    sum_ut: f64,
    n: u32,
    /// The phone's |B| offset against the magnetic map, uT.
    pub(super) offset_ut: f64,
}

impl MagneticState {
    /// Adds one |B| sample, uT (non-finite or implausible ones are left out).
    pub(super) fn add(&mut self, ut: f64) {
        if ut.is_finite() && ut < 1000.0 {
            self.sum_ut += ut;
            self.n += 1;
        }
    }

    /// The mean |B| of the samples since the last call (`None`: none),
    /// and starts the next sum.
    pub(super) fn take_mean(&mut self) -> Option<f64> {
        let (sum, n) = (self.sum_ut, self.n);
        (self.sum_ut, self.n) = (0.0, 0);
        (n > 0).then(|| sum / f64::from(n))
    }
}

impl TcpfEngine {
    /// Weighs the particles by the magnetic map at each against the
    /// task's mean |B| `b_ut` less the phone offset (`tcpf.magnetic`); a
    /// particle where the map has no value gets the valued ones' weighted
    /// mean (no evidence either way). Then moves the offset toward the
    /// cloud's mean residual.
    pub(super) fn magnetic_update(&mut self, b_ut: f64) {
        let model = Arc::clone(&self.model);
        let Some(grid) = model.magnetic().and_then(|m| m.grid(self.floor)) else {
            return;
        };
        let mc = &self.cfg.magnetic;
        let (nu, extra2) = (mc.nu, mc.extra_sd_ut * mc.extra_sd_ut);
        let mut log_l = std::mem::take(&mut self.scratch.log_l);
        log_l.clear();
        let (mut wsum, mut lsum, mut rsum) = (0.0, 0.0, 0.0);
        for (p, w) in self.pf.particles().iter().zip(self.pf.weights()) {
            match grid.sample(*p) {
                Some((mu, sd)) => {
                    let s2 = sd * sd + extra2;
                    let r = b_ut - self.magnetic.offset_ut - mu;
                    let l = -0.5 * (nu + 1.0) * (r * r / (nu * s2)).ln_1p() - 0.5 * s2.ln();
                    log_l.push(l);
                    wsum += w;
                    lsum += w * l;
                    rsum += w * (b_ut - mu);
                }
                None => log_l.push(f64::NAN),
            }
        }
        if wsum > 0.0 {
            let fill = lsum / wsum;
            let weight = mc.weight;
            for l in log_l.iter_mut() {
                *l = weight * if l.is_nan() { fill } else { *l };
            }
            self.pf.weight_log(&log_l);
            self.counts.magnetic_updates += 1;
            let innovation = (rsum / wsum - self.magnetic.offset_ut).clamp(-10.0, 10.0);
            self.magnetic.offset_ut = (self.magnetic.offset_ut + mc.offset_gain * innovation)
                .clamp(-mc.max_offset_ut, mc.max_offset_ut);
            // (the offset is the cloud's before resampling, as it was weighed)
            self.resample_if_degenerate();
        }
        self.scratch.log_l = log_l;
    }
}
