//! Extensions that let persistent BLE evidence move the cloud between rooms
//! (not in the paper; each off in [`super::FusionConfig::paper`]).
//!
//! The paper's PPC moves the published position only through free space or
//! doors and drags every particle with it (eq. 44); with the particle wall
//! check the particles cannot cross walls either. A track that entered the
//! wrong room then stays there whatever x_B says. Two mechanisms fix this:
//!
//! - [`LikelihoodMonitor`]: augmented MCL (Thrun, Burgard, Fox,
//!   *Probabilistic Robotics*, Table 8.3). A slow and a fast exponential
//!   average of the cloud's mean BLE likelihood; when the fast one falls
//!   below the slow one (x_B has disagreed with the cloud for a while, not
//!   for one outlier), a fraction 1 - w_fast / w_slow of the particles is
//!   re-seeded around x_B on walkable ground (sensor resetting, Lenser and
//!   Veloso 2000). The re-seeded particles then compete on the BLE weights.
//! - [`dominant_room`]: a room-level hypothesis. The estimate is the
//!   weighted mean of the particles in the room that holds the most weight
//!   (not the mean of the whole cloud, which can fall in a wall between two
//!   rooms); when that room holds at least `room_switch_mass` of the weight
//!   and differs from the room of x^(k-1), the track moves there even
//!   through a wall, because the cloud, not one step, says so.

use std::collections::BTreeMap;

use crate::Vec2;

/// Slow and fast averages of the cloud's BLE likelihood (augmented MCL).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LikelihoodMonitor {
    w_slow: f64,
    w_fast: f64,
    started: bool,
}

impl LikelihoodMonitor {
    /// Feeds one likelihood `l` (mean over the cloud) and returns the
    /// re-seeding fraction max(0, 1 - w_fast / w_slow), capped at
    /// `max_fraction`. `alpha_slow` < `alpha_fast`, both in (0, 1].
    pub fn update(&mut self, l: f64, alpha_slow: f64, alpha_fast: f64, max_fraction: f64) -> f64 {
        if !l.is_finite() || l < 0.0 {
            return 0.0;
        }
        if !self.started {
            self.w_slow = l;
            self.w_fast = l;
            self.started = true;
            return 0.0;
        }
        self.w_slow += alpha_slow * (l - self.w_slow);
        self.w_fast += alpha_fast * (l - self.w_fast);
        if self.w_slow <= 0.0 {
            return 0.0;
        }
        (1.0 - self.w_fast / self.w_slow).clamp(0.0, max_fraction.max(0.0))
    }

    /// Forgets the averages (after a restart of the filter).
    pub fn reset(&mut self) {
        *self = LikelihoodMonitor::default();
    }

    /// (w_slow, w_fast).
    pub fn averages(&self) -> (f64, f64) {
        (self.w_slow, self.w_fast)
    }
}

/// The room holding the most particle weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoomMode {
    pub room: u32,
    /// Fraction of the total weight in the room.
    pub mass: f64,
    /// Weighted mean of the room's particles.
    pub mean: Vec2,
}

/// The room with the largest total weight among `particles` (weights
/// `weights`, any scale), with its weighted mean; particles on no room are
/// ignored. `None` when no particle lies in a room or all weights are 0.
/// Ties go to the lower room id (deterministic).
pub fn dominant_room(
    particles: &[Vec2],
    weights: &[f64],
    room_of: impl Fn(Vec2) -> Option<u32>,
) -> Option<RoomMode> {
    let mut acc: BTreeMap<u32, (f64, Vec2)> = BTreeMap::new();
    let mut total = 0.0;
    for (p, w) in particles.iter().zip(weights) {
        total += w;
        if let Some(r) = room_of(*p) {
            let e = acc.entry(r).or_insert((0.0, Vec2::zeros()));
            e.0 += w;
            e.1 += p * *w;
        }
    }
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let mut best: Option<(u32, f64, Vec2)> = None;
    for (r, (w, s)) in acc {
        if w > 0.0 && best.is_none_or(|(_, bw, _)| w > bw) {
            best = Some((r, w, s));
        }
    }
    best.map(|(room, w, s)| RoomMode {
        room,
        mass: w / total,
        mean: s / w,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monitor_reseeds_only_after_a_persistent_drop() {
        let mut m = LikelihoodMonitor::default();
        for _ in 0..50 {
            assert_eq!(m.update(0.5, 0.05, 0.5, 0.3), 0.0);
        }
        // One outlier: some re-seeding but far less than the cap... after
        // recovery it returns to 0.
        let one = m.update(0.01, 0.05, 0.5, 1.0);
        assert!(one > 0.0 && one < 0.6, "{one}");
        for _ in 0..20 {
            m.update(0.5, 0.05, 0.5, 1.0);
        }
        assert_eq!(m.update(0.5, 0.05, 0.5, 1.0), 0.0);
        // A persistent drop drives the fraction to the cap.
        let mut f = 0.0;
        for _ in 0..10 {
            f = m.update(0.001, 0.05, 0.5, 0.3);
        }
        assert_eq!(f, 0.3);
    }

    #[test]
    fn dominant_room_is_the_heaviest_not_the_most_populous() {
        let pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(2.0, 0.0),
            Vec2::new(10.0, 0.0),
            Vec2::new(12.0, 0.0),
            Vec2::new(50.0, 50.0),
        ];
        let w = [0.1, 0.1, 0.1, 0.3, 0.3, 0.1];
        let room = |p: Vec2| {
            if p.x < 5.0 {
                Some(1)
            } else if p.x < 20.0 {
                Some(0)
            } else {
                None
            }
        };
        let r = dominant_room(&pts, &w, room).unwrap();
        assert_eq!(r.room, 0);
        assert!((r.mass - 0.6).abs() < 1e-12);
        assert!((r.mean - Vec2::new(11.0, 0.0)).norm() < 1e-12);
        assert!(dominant_room(&pts, &[0.0; 6], room).is_none());
    }
}
