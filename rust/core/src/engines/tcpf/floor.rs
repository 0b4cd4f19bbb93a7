//! The floor: votes of the strongest beacons or of the anchors, runs of
//! them, and the change of floor with the barometer or without.

use std::sync::Arc;

use super::TcpfEngine;
use super::anchors::Anchor;
use crate::radio::reference_scans::candidate_fix;
use crate::radio::{Measurement, TxKind};

/// Runs of floor votes for a floor other than the cloud's.
#[derive(Debug, Default)]
pub(super) struct FloorVotes {
    /// Consecutive radio votes for another floor (no barometer).
    pub(super) other_floor: Option<(i32, u32)>,
    /// Consecutive anchor floor votes for another floor.
    anchor_run: Option<(i32, u32)>,
}

impl TcpfEngine {
    /// The floor of the strongest beacons heard: the floor most of the
    /// three strongest BLE beacons stand on (ties: the strongest's). WiFi
    /// APs do not vote: their calibrated floors are the survey's floor,
    /// and they carry through floors.
    pub(super) fn radio_floor_vote(&self, meas: &[Measurement]) -> Option<i32> {
        let tx = self.model.transmitters();
        let top: Vec<i32> = meas
            .iter()
            .filter_map(|m| tx.get(m.tx))
            .filter(|t| t.kind == TxKind::Ble)
            .take(3)
            .map(|t| t.floor)
            .collect();
        let mut best: Option<(usize, i32)> = None;
        for f in &top {
            let n = top.iter().filter(|g| *g == f).count();
            if best.is_none_or(|(c, _)| n > c) {
                best = Some((n, *f));
            }
        }
        best.map(|(_, f)| f)
    }

    /// The floor after a radio update: the anchors' or the beacons' vote
    /// feeds the barometer's tracker (or, without a barometer, a run of
    /// votes decides); a change moves the cloud to the new floor where the
    /// track is, or starts it there globally.
    pub(super) fn update_floor(&mut self, t_ns: i64, meas: &[Measurement], anchors: &[Anchor]) {
        if self.site.spec.floors.len() < 2 {
            return;
        }
        let (target, from_barometer) = self.floor_target(t_ns, meas, anchors);
        let Some(f) = target.filter(|f| *f != self.floor && self.site.floor(*f).is_some()) else {
            return;
        };
        self.change_floor(t_ns, meas, f, from_barometer);
    }

    /// The floor this update's votes (anchors or strongest beacons) and the
    /// barometer ask for, and whether it is the barometer's.
    fn floor_target(
        &mut self,
        t_ns: i64,
        meas: &[Measurement],
        anchors: &[Anchor],
    ) -> (Option<i32>, bool) {
        let share = self.cfg.anchors.floor_vote_share;
        let vote = if share > 0.0 && !anchors.is_empty() {
            candidate_fix(anchors)
                .filter(|fix| fix.share >= share)
                .map(|fix| fix.floor)
        } else {
            self.radio_floor_vote(meas)
        };
        if let Some(v) = vote {
            self.floors.on_ble_floor(t_ns, v);
        }
        let ac = &self.cfg.anchors;
        // a told floor holds against the anchors (whose votes, on a route
        // the survey never walked, can name a floor above or below) until
        // the walls say the told position was wrong
        let force = if self.told_reach.held() {
            0
        } else {
            ac.floor_force_votes
        };
        let anchor_vote = vote.filter(|_| !anchors.is_empty());
        self.votes.anchor_run = match (anchor_vote, self.votes.anchor_run) {
            (Some(v), _) if v == self.floor => None,
            (Some(v), Some((f, n))) if f == v => Some((v, n + 1)),
            (Some(v), _) => Some((v, 1)),
            (None, run) => run,
        };
        let mut from_barometer = false;
        let target = if self.floors.has_pressure() {
            match self.votes.anchor_run {
                Some((v, n)) if force > 0 && n >= force => {
                    // the anchors have said another floor for long: the
                    // barometer only gives changes, its start was wrong
                    self.floors.reset_to_floor(v);
                    Some(v)
                }
                _ => {
                    from_barometer = true;
                    self.floors.floor()
                }
            }
        } else {
            match (vote, self.votes.other_floor) {
                (Some(v), _) if v == self.floor => {
                    self.votes.other_floor = None;
                    None
                }
                (Some(v), Some((f, n))) if f == v => {
                    self.votes.other_floor = Some((v, n + 1));
                    (n + 1 >= self.cfg.floor_switch_votes).then_some(v)
                }
                (Some(v), _) => {
                    self.votes.other_floor = Some((v, 1));
                    (1 >= self.cfg.floor_switch_votes).then_some(v)
                }
                (None, _) => None,
            }
        };
        (target, from_barometer)
    }

    /// Moves the cloud to floor `f`.
    fn change_floor(&mut self, t_ns: i64, meas: &[Measurement], f: i32, from_barometer: bool) {
        // floors share the x, y frame: the walker changes floor where the
        // track is (stairs, lift), or at the nearest walkable point within
        // `floor_snap_m` (a stairwell drawn as a wall); with none there, a
        // change the barometer alone asks for is not made (the plan lacks
        // the place the walker passes through: a global start on that
        // floor would put the track wherever its plan has room); a change
        // the radio asks for is a global start there
        let at = self.publisher.published.or_else(|| self.pf.mean());
        let site = Arc::clone(&self.site);
        let Some(m) = site.floor(f) else { return };
        let snapped = at.and_then(|p| m.nearest_walkable_within(p, self.cfg.floor_snap_m));
        if snapped.is_none() && at.is_some() && from_barometer {
            self.counts.floor_changes_off_map += 1;
            return;
        }
        self.counts.floor_changes += 1;
        self.votes.other_floor = None;
        self.votes.anchor_run = None;
        match snapped {
            Some(p) => {
                self.floor = f;
                self.set_init_count(false);
                self.pf.init_at(p, 3.0, |q| m.is_walkable(q));
                self.draw_offsets_from_belief();
                self.recovery.monitor.reset();
                self.publisher.published = Some(p);
            }
            None => {
                self.global_start(t_ns, meas, &[], Some(f));
            }
        }
    }
}
