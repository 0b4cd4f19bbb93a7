//! Recovery: when the cloud has lost the radio, part of it is re-seeded
//! from the likelihood surface (augmented MCL, gated by the walls, the
//! survey's reach and the radio's trust).

use std::collections::BTreeMap;
use std::sync::Arc;

use super::TcpfEngine;
use crate::fusion::recovery::LikelihoodMonitor;
use crate::radio::Measurement;
use crate::site::Site;

/// What says the cloud is lost.
pub(super) struct RecoveryState {
    /// The cloud's likelihood, slow against fast.
    pub(super) monitor: LikelihoodMonitor,
    /// The cloud was last placed at a told position (`InitialPosition`,
    /// `set_position`), not by the radio.
    pub(super) told_start: bool,
    /// Moving average (rate 0.1 per step) of the share of particles a step
    /// kills at walls: a cloud whose steps keep hitting walls is lost.
    pub(super) kill_ema: f64,
    /// Floors whose map has more than one room: there the walls can say a
    /// cloud is lost (the re-seeding gate); on a floor that is one open
    /// area the radio alone decides.
    walled: BTreeMap<i32, bool>,
}

impl RecoveryState {
    /// Nothing lost yet on `site`'s floors.
    pub(super) fn of_site(site: &Site) -> Self {
        let walled = site
            .spec
            .floors
            .iter()
            .zip(&site.floors)
            .map(|(f, m)| (f.id, m.rooms().len() > 1))
            .collect();
        RecoveryState {
            monitor: LikelihoodMonitor::default(),
            told_start: false,
            kill_ema: 0.0,
            walled,
        }
    }
}

/// What one radio update found of the cloud: its mean likelihood per
/// transmitter (the monitor's input), its tempered log mean likelihood
/// (what the surface must beat), and its spread before the update, m.
pub(super) struct RadioFit {
    pub(super) mean_l: f64,
    pub(super) cloud_ll: f64,
}

impl TcpfEngine {
    /// Whether the walls say the cloud is lost: the moving share of
    /// particles a step kills at walls is at least
    /// `recovery_min_wall_kill` (the re-seeding's consent, and what drops
    /// a told start's reach).
    pub(super) fn walls_say_lost(&self) -> bool {
        self.recovery.kill_ema >= self.cfg.recovery_min_wall_kill
    }

    /// After a radio update on `floor` with `meas`: re-seeds
    /// part of the cloud from the likelihood surface when the monitor saw
    /// a dip and the walls agree, or when the surface beats the cloud by
    /// far; not far from the survey, and only with a `trusted` radio.
    pub(super) fn recover(
        &mut self,
        floor: i32,
        meas: &[Measurement],
        fit: RadioFit,
        trusted: bool,
    ) {
        let RadioFit { mean_l, cloud_ll } = fit;
        let reseed = self.recovery.monitor.update(
            mean_l,
            self.cfg.recovery_alpha_slow,
            self.cfg.recovery_alpha_fast,
            self.cfg.recovery_max_fraction,
        );
        // after a dip of the likelihood, re-seed only when the surface's
        // best cell beats the cloud (tempered log-likelihood) and the walls
        // say the cloud is lost (a biased radio model has better-fitting
        // spots away from the walker: re-seeding there on every dip loses a
        // good track), or when the surface beats the cloud by far
        // far from every survey walk (with reference scans to tell) the
        // surface is the radio map's extrapolation: no re-seeding from it
        let far = self.far_from_survey();
        if far && reseed > 0.0 {
            self.counts.reseed_far += 1;
        }
        // on a floor without inner walls nothing but the radio can say the
        // cloud is lost
        let open = !self.recovery.walled.get(&floor).copied().unwrap_or(false);
        let walls_agree = self.walls_say_lost() || open;
        // the gap that re-seeds: past `recovery_radio_alone_margin`, or
        // with a dip and the walls' consent past 0; when
        // the bound says the gap cannot pass it, the surface (the largest
        // share of an update that computes it) would change nothing
        let alone = if self.recovery.told_start {
            self.cfg.recovery_radio_alone_margin
        } else {
            self.cfg.recovery_global_radio_alone_margin
        };
        let needed = if reseed > 0.0 && walls_agree {
            0.0
        } else {
            alone
        };
        if reseed > 0.0
            && !far
            && trusted
            && self
                .surface_gap_bound(floor, meas, cloud_ll)
                .is_none_or(|b| b > needed)
            && let Some(mut surf) = self.surface(floor, meas, &[], self.profile_prior(true))
            && let best_ll = surf.lse - surf.w.iter().sum::<f64>().ln()
            && let Some(kept_ln) = self.keep_within_told_reach(floor, &mut surf)
            && let gap = best_ll + kept_ln - cloud_ll
            && let Some(reseed) = if gap > alone {
                Some(self.cfg.recovery_max_fraction)
            } else {
                (reseed > 0.0 && gap > 0.0 && walls_agree).then_some(reseed)
            }
        {
            self.resample_now();
            let site = Arc::clone(&self.site);
            let map = site.floor(floor);
            let n = self
                .pf
                .inject_from_cells(reseed, &surf.cells, &surf.w, self.cfg.cell_m, |q| {
                    map.is_none_or(|m| m.is_walkable(q))
                });
            self.draw_offsets_from_cells(&surf);
            let share = n as f64 / self.pf.particles().len().max(1) as f64;
            self.mix_offset_with_surface(&surf, share);
            self.counts.reseeded += n as u64;
        }
    }
}
