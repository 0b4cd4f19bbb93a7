//! Parameters of the fusion subsystem (particle filter and PPC).
//!
//! Every default and where it comes from is listed in docs/parameters.md,
//! section "Fusion".

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Resampling scheme of the particle filter (the paper cites [46] without
/// naming one).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Resampling {
    /// One uniform draw u ~ U[0, 1/m); pointers u + i/m.
    Systematic,
    /// One uniform draw per stratum: pointers (i + u_i)/m.
    Stratified,
}

/// `Ok` when `v` is finite and `ok`, else a config error naming the field
/// `section` + `name`.
fn in_range(v: f64, ok: bool, section: &str, name: &str, what: &str) -> Result<()> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(Error::config(format!("{section}{name}"), what))
    }
}

/// Parameters of the post-position correction (Algorithm 2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PpcConfig {
    /// Whether Algorithm 2 runs at all (`fpbp` only). `false` keeps the
    /// engine's other map extensions (particle wall check, room-level
    /// estimate and switch) and publishes the estimate x̂ uncorrected: an
    /// ablation. Default true.
    pub enabled: bool,
    /// phi: unit rotation angle of the candidate sequence Phi = {±j phi}, rad.
    /// Default 0.1745 (10 degrees).
    pub phi_rad: f64,
    /// N: number of multiples of phi on each side (Phi has 2N elements).
    /// Default 6 (search up to ±60 degrees).
    pub n_angles: u32,
    /// f: scale factor (>= 1) of the test step in eq. 39, dimensionless.
    /// Default 1.5 (the rotated step must stay clear half a step further).
    pub scale_f: f64,
    /// epsilon: fraction of the estimated step moved back from the hit point
    /// (eq. 42) or forward from the door's far side (eq. 43), dimensionless.
    /// Default 0.1.
    pub epsilon: f64,
    /// alpha_0: incident-angle threshold of eq. 37, rad. A step meeting a door
    /// at alpha > alpha_0 is deflected, otherwise it may pass. Default 1.0472
    /// (60 degrees).
    pub alpha0_rad: f64,
    /// delta: update step of Raycast (Function 1), metres. Default 0.05 (the
    /// paper's value).
    pub raycast_step_m: f64,
    /// Farthest distance beyond a door's hit point searched for its far side
    /// (x_c of eq. 43), metres. Default 1.0.
    pub door_search_m: f64,
    /// Whether a head-on door step also needs x_B in another room to pass
    /// (the room test of eq. 43). `false`: the incident angle alone decides.
    /// Default false (chosen on the demo logs, see docs/fusion.md; the
    /// paper's value is true).
    pub door_room_test: bool,
    /// Door-snap extension (not in the paper): a step blocked by a wall with
    /// no free candidate angle (Case 2) passes a door within this distance of
    /// the hit point when it meets that door head-on, metres; 0 disables it.
    /// Default 3.0 (chosen on the demo logs, see docs/fusion.md; the paper's
    /// PPC is 0).
    pub door_snap_m: f64,
    /// Whether a correction also shifts every particle (eq. 44). `false`
    /// corrects the published position only and leaves the particle cloud to
    /// the BLE weights (particles on obstacles are still replaced by copies of
    /// walkable ones). Default true (the paper; `false` measured worse on the
    /// demo logs: 7.36 vs 6.89 m, docs/fusion.md).
    pub shift_particles: bool,
}

impl Default for PpcConfig {
    fn default() -> Self {
        PpcConfig {
            enabled: true,
            phi_rad: 10f64.to_radians(),
            n_angles: 6,
            scale_f: 1.5,
            epsilon: 0.1,
            alpha0_rad: 60f64.to_radians(),
            raycast_step_m: 0.05,
            door_search_m: 1.0,
            door_room_test: false,
            door_snap_m: 3.0,
            shift_particles: true,
        }
    }
}

impl PpcConfig {
    /// The paper's PPC with no extension: room test on, no door snap.
    pub fn paper() -> Self {
        PpcConfig {
            door_room_test: true,
            door_snap_m: 0.0,
            shift_particles: true,
            ..PpcConfig::default()
        }
    }
}

impl PpcConfig {
    /// Checks every field's range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        let pos = |v: f64, name: &str| in_range(v, v > 0.0, "fusion.ppc.", name, "must be > 0");
        pos(self.phi_rad, "phi_rad")?;
        crate::bounds::check_ray_step("fusion.ppc.raycast_step_m", self.raycast_step_m)?;
        pos(self.door_search_m, "door_search_m")?;
        if !(self.door_snap_m.is_finite() && (0.0..=10.0).contains(&self.door_snap_m)) {
            return Err(Error::config(
                "fusion.ppc.door_snap_m",
                "must be in [0, 10]",
            ));
        }
        if self.n_angles == 0 || self.n_angles as f64 * self.phi_rad > std::f64::consts::PI {
            return Err(Error::config(
                "fusion.ppc.n_angles",
                "must be >= 1 and n_angles * phi_rad <= pi",
            ));
        }
        if !(self.scale_f.is_finite() && self.scale_f >= 1.0) {
            return Err(Error::config("fusion.ppc.scale_f", "must be >= 1"));
        }
        if !(self.epsilon.is_finite() && (0.0..=1.0).contains(&self.epsilon)) {
            return Err(Error::config("fusion.ppc.epsilon", "must be in [0, 1]"));
        }
        if !(self.alpha0_rad.is_finite()
            && (0.0..=std::f64::consts::FRAC_PI_2).contains(&self.alpha0_rad))
        {
            return Err(Error::config(
                "fusion.ppc.alpha0_rad",
                "must be in [0, pi/2]",
            ));
        }
        Ok(())
    }
}

/// Parameters of the fusion subsystem: the particle filter (Sec. IV-C) and PPC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FusionConfig {
    /// m: number of particles. Default 1000.
    pub particle_count: usize,
    /// Half-width of the uniform step-length noise nu_s of eq. 34, metres.
    /// Default 0.15.
    pub step_noise_m: f64,
    /// Half-width of the uniform heading noise nu_theta of eq. 34, rad.
    /// Default 0.35 (20 degrees).
    pub heading_noise_rad: f64,
    /// sigma_x: standard deviation of the BLE likelihood of eq. 36, metres.
    /// Default 3.0.
    pub sigma_x_m: f64,
    /// Resampling scheme. Default `systematic`.
    pub resampling: Resampling,
    /// Extension (not in the paper): resample only when the effective
    /// sample size 1 / sum w^2 falls below this fraction of m, and let each
    /// fix multiply the weights the particles carry (sequential importance
    /// sampling, Doucet et al.), in (0, 1]. 1 (default) resamples after
    /// every step with weights set by eq. 36 alone, as the paper does.
    pub resample_ess_fraction: f64,
    /// Number of first BLE positions averaged into the start position
    /// (x̄_B^(0), Sec. IV-C). Default 3.
    pub init_ble_fixes: u32,
    /// Radius of the uniform disc the particles start in around a start
    /// from BLE fixes, metres (0 = all on the start point, as in the paper;
    /// a caller's `InitialPosition` always starts them on its point).
    /// Default 3.0 (about half the demo's GML error; chosen on the demo
    /// logs, docs/fusion.md): a start in the wrong room keeps hypotheses in
    /// the neighbouring rooms instead of being trapped by the walls.
    pub init_spread_m: f64,
    /// A BLE position older than this is not used to weight particles (the
    /// filter dead-reckons on the map instead), seconds. Default 5.0.
    pub ble_max_age_s: f64,
    /// Re-localisation (not in the paper): when this many consecutive fresh
    /// x_B lie farther than `relocalize_distance_m` from the fused position,
    /// the filter restarts at their mean (a track trapped in a wrong room by
    /// PPC cannot leave it otherwise). 0 disables it (the paper). Default 5
    /// (chosen on the demo logs, see docs/fusion.md).
    pub relocalize_after_fixes: u32,
    /// Distance of the re-localisation test, metres. Default 8.0.
    pub relocalize_distance_m: f64,
    /// Whether re-localisation also runs after a start the caller gave
    /// (`InitialPosition`: a tap, a QR code, `--init truth`). Default false:
    /// a given start is trusted, and re-localising on x_B errs when x_B is
    /// poor (ILC site1/F1 even paths, `--init truth`: fpbp 5.79 m with it,
    /// 4.40 m without; docs/fusion.md). Starts from BLE fixes always use it.
    pub relocalize_after_given_start: bool,
    /// Extension (not in the paper): particles whose own move crosses a
    /// Wall (or a Door, without `particles_pass_doors`) have their weight
    /// multiplied by `wall_crossing_weight` before resampling (`fpbp`
    /// only). Default
    /// true (chosen on the demo logs, see docs/fusion.md; the paper has none).
    pub particle_wall_check: bool,
    /// With `particle_wall_check`: the factor a crossing particle's weight
    /// is multiplied by, in [0, 1] (0 = the particle dies). Default 0.01
    /// (24 simulated tuning logs, docs/parameters.md).
    pub wall_crossing_weight: f64,
    /// Recovery extension (not in the paper, `fpbp` only): the largest
    /// fraction of the particles re-seeded around x_B in one fused step when
    /// the cloud's BLE likelihood has dropped (augmented MCL,
    /// `fusion::recovery`), dimensionless in [0, 1]; 0 disables it (the
    /// paper). Default 0.0: measured harmful on the demo walks, where x_B
    /// errs by 5-6 m and the re-seeded particles make the track follow it
    /// (docs/fusion.md); available for sites with better BLE.
    pub recovery_max_fraction: f64,
    /// Slow averaging rate of the cloud's BLE likelihood (per fused step),
    /// in (0, 1]. Default 0.05 (about 20 steps).
    pub recovery_alpha_slow: f64,
    /// Fast averaging rate (per fused step), in (0, 1], >= the slow one.
    /// Default 0.3 (about 3 steps).
    pub recovery_alpha_fast: f64,
    /// Standard deviation of the Gaussian the re-seeded particles are drawn
    /// from around x_B, metres. Default 2.0.
    pub recovery_sigma_m: f64,
    /// Room-level estimate (not in the paper, `fpbp` only): the estimate x̂
    /// is the weighted mean of the particles in the room holding the most
    /// weight instead of the mean of the whole cloud. Default true (chosen
    /// on the demo logs, docs/fusion.md; the paper: false).
    pub room_estimate: bool,
    /// With `room_estimate`: when the heaviest room holds at least this
    /// fraction of the weight and is not the room of x^(k-1), the track
    /// moves there even through a wall (PPC is skipped for that step),
    /// dimensionless in [0, 1]; 0 disables the switch. Default 0.4 (0.6
    /// before; 24 simulated tuning logs, docs/lab/fusion-sessions.md
    /// "Session 3").
    pub room_switch_mass: f64,
    /// Whether each x_B weights the particles at one step only (the first
    /// step after it arrived) instead of at every step while it is fresh.
    /// x_B comes every T_gml (1 s) and steps about every 0.5 s, so reusing
    /// it counts one measurement as several independent ones. Default
    /// false (the paper reuses the latest x_B).
    pub weight_each_fix_once: bool,
    /// With `particle_wall_check`: whether particles may cross and stand on
    /// Door pixels (only a Wall crossing zeroes a particle's weight, and
    /// only particles on Wall pixels are replaced after PPC). `false`
    /// treats doors like walls for the particles, so a cloud can change
    /// rooms only through PPC's eq. 44 shift. Default true (measured on the
    /// demo logs, docs/fusion.md).
    pub particles_pass_doors: bool,
    /// Whether a floor change (`init_ble_fixes` fresh x_B on another floor)
    /// restarts the filter at the track's last x, y (the floors share the
    /// site frame) instead of at the mean of those x_B. Default false
    /// (measured in docs/fusion.md).
    pub floor_change_keeps_position: bool,
    /// Extension (not in the paper): standard deviation of each particle's
    /// own heading offset, drawn at the start (Gaussian, clamped to ±0.6
    /// rad) and added to the PDR yaw at every step of that particle, rad;
    /// 0 disables it (the paper). Default: see docs/fusion.md.
    pub heading_offset_sd_rad: f64,
    /// Random-walk standard deviation of each particle's heading offset per
    /// step, rad (0 = constant offsets).
    pub heading_offset_walk_rad: f64,
    /// Correlation length of the heading offsets, PDR steps: when > 0 each
    /// offset is a first-order Gauss-Markov process (off <- a off + sd
    /// sqrt(1 - a^2) n, a = exp(-1 / corr), stationary sd
    /// `heading_offset_sd_rad`), the textbook model of a slowly varying
    /// heading bias; `heading_offset_walk_rad` must then be 0. 0 (default)
    /// keeps constant offsets or the random walk.
    pub heading_offset_corr_steps: f64,
    /// Extension (not in the paper): standard deviation of each particle's
    /// own step-length scale (1 + N(0, sd), clamped to [0.6, 1.4]) that
    /// multiplies the PDR step length; 0 disables it (the paper).
    pub step_scale_sd: f64,
    /// Random-walk standard deviation of each particle's step scale per step.
    pub step_scale_walk: f64,
    /// Innovation-driven process noise (not in the paper): when a fresh
    /// x_B lies d > `innovation_free_m` from the last output position, the
    /// following moves add isotropic Gaussian noise of standard deviation
    /// gain (d - innovation_free_m) (capped at `innovation_noise_max_m`)
    /// per axis, so a cloud that BLE disagrees with spreads and BLE can
    /// pull it. 0 disables it. Default: see docs/fusion.md.
    pub innovation_noise_gain: f64,
    /// Innovation below which no extra noise is added, metres.
    pub innovation_free_m: f64,
    /// Largest extra noise per move, metres.
    pub innovation_noise_max_m: f64,
    /// The free innovation is at least this multiple of the running mean
    /// innovation (0 = `innovation_free_m` alone): a site whose BLE errs by
    /// 10-20 m then adds noise only on its unusually large innovations.
    pub innovation_typical_ratio: f64,
    /// Rate of that running mean per fresh fix, in (0, 1].
    pub innovation_average_rate: f64,
    /// Post-position correction (Algorithm 2).
    pub ppc: PpcConfig,
}

impl Default for FusionConfig {
    fn default() -> Self {
        FusionConfig {
            particle_count: 1000,
            step_noise_m: 0.15,
            heading_noise_rad: 20f64.to_radians(),
            sigma_x_m: 3.0,
            resampling: Resampling::Systematic,
            resample_ess_fraction: 1.0,
            init_ble_fixes: 3,
            init_spread_m: 3.0,
            ble_max_age_s: 5.0,
            relocalize_after_fixes: 5,
            relocalize_distance_m: 8.0,
            relocalize_after_given_start: false,
            particle_wall_check: true,
            wall_crossing_weight: 0.01,
            recovery_max_fraction: 0.0,
            recovery_alpha_slow: 0.05,
            recovery_alpha_fast: 0.3,
            recovery_sigma_m: 2.0,
            room_estimate: true,
            room_switch_mass: 0.4,
            weight_each_fix_once: false,
            particles_pass_doors: true,
            floor_change_keeps_position: false,
            heading_offset_sd_rad: 0.0,
            heading_offset_walk_rad: 0.0,
            heading_offset_corr_steps: 0.0,
            step_scale_sd: 0.0,
            step_scale_walk: 0.0,
            innovation_noise_gain: 0.0,
            innovation_free_m: 3.0,
            innovation_noise_max_m: 1.0,
            innovation_typical_ratio: 0.0,
            innovation_average_rate: 0.05,
            ppc: PpcConfig::default(),
        }
    }
}

impl FusionConfig {
    /// The paper's FP-BP alone: no extension (no re-localisation, particle
    /// wall check, recovery or room-level estimate) and [`PpcConfig::paper`].
    pub fn paper() -> Self {
        FusionConfig {
            init_spread_m: 0.0,
            relocalize_after_fixes: 0,
            relocalize_after_given_start: true,
            particle_wall_check: false,
            recovery_max_fraction: 0.0,
            room_estimate: false,
            room_switch_mass: 0.0,
            weight_each_fix_once: false,
            particles_pass_doors: false,
            heading_offset_sd_rad: 0.0,
            heading_offset_walk_rad: 0.0,
            heading_offset_corr_steps: 0.0,
            step_scale_sd: 0.0,
            step_scale_walk: 0.0,
            innovation_noise_gain: 0.0,
            ppc: PpcConfig::paper(),
            ..FusionConfig::default()
        }
    }
}

impl FusionConfig {
    /// Checks every field's range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        if self.particle_count == 0 || self.particle_count > 1_000_000 {
            return Err(Error::config(
                "fusion.particle_count",
                "must be in 1..=1000000",
            ));
        }
        let nonneg = |v: f64, name: &str| in_range(v, v >= 0.0, "fusion.", name, "must be >= 0");
        nonneg(self.step_noise_m, "step_noise_m")?;
        nonneg(self.heading_noise_rad, "heading_noise_rad")?;
        nonneg(self.init_spread_m, "init_spread_m")?;
        nonneg(self.ble_max_age_s, "ble_max_age_s")?;
        nonneg(self.relocalize_distance_m, "relocalize_distance_m")?;
        nonneg(self.heading_offset_sd_rad, "heading_offset_sd_rad")?;
        nonneg(self.heading_offset_walk_rad, "heading_offset_walk_rad")?;
        nonneg(self.heading_offset_corr_steps, "heading_offset_corr_steps")?;
        if self.heading_offset_corr_steps > 0.0 && self.heading_offset_walk_rad > 0.0 {
            return Err(Error::config(
                "fusion.heading_offset_corr_steps",
                "a Gauss-Markov offset (corr_steps > 0) takes no heading_offset_walk_rad",
            ));
        }
        nonneg(self.step_scale_sd, "step_scale_sd")?;
        nonneg(self.innovation_noise_gain, "innovation_noise_gain")?;
        nonneg(self.innovation_free_m, "innovation_free_m")?;
        nonneg(self.innovation_noise_max_m, "innovation_noise_max_m")?;
        nonneg(self.innovation_typical_ratio, "innovation_typical_ratio")?;
        nonneg(self.step_scale_walk, "step_scale_walk")?;
        if !(0.0..=1.0).contains(&self.wall_crossing_weight) {
            return Err(Error::config(
                "fusion.wall_crossing_weight",
                "must be in [0, 1]",
            ));
        }
        if !(self.sigma_x_m.is_finite() && self.sigma_x_m > 0.0) {
            return Err(Error::config("fusion.sigma_x_m", "must be > 0"));
        }
        let unit = |v: f64, name: &str| {
            in_range(
                v,
                (0.0..=1.0).contains(&v),
                "fusion.",
                name,
                "must be in [0, 1]",
            )
        };
        unit(self.recovery_max_fraction, "recovery_max_fraction")?;
        unit(self.room_switch_mass, "room_switch_mass")?;
        let open_unit = |v: f64, name: &str| {
            in_range(v, v > 0.0 && v <= 1.0, "fusion.", name, "must be in (0, 1]")
        };
        open_unit(self.resample_ess_fraction, "resample_ess_fraction")?;
        open_unit(self.recovery_alpha_slow, "recovery_alpha_slow")?;
        open_unit(self.innovation_average_rate, "innovation_average_rate")?;
        if !(self.recovery_alpha_fast.is_finite()
            && self.recovery_alpha_fast >= self.recovery_alpha_slow
            && self.recovery_alpha_fast <= 1.0)
        {
            return Err(Error::config(
                "fusion.recovery_alpha_fast",
                "must be in [recovery_alpha_slow, 1]",
            ));
        }
        if !(self.recovery_sigma_m.is_finite() && self.recovery_sigma_m > 0.0) {
            return Err(Error::config("fusion.recovery_sigma_m", "must be > 0"));
        }
        if self.init_ble_fixes == 0 {
            return Err(Error::config("fusion.init_ble_fixes", "must be >= 1"));
        }
        self.ppc.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate() {
        FusionConfig::default().validate().unwrap();
    }

    #[test]
    fn bad_field_is_named() {
        let c = FusionConfig {
            ppc: PpcConfig {
                scale_f: 0.5,
                ..PpcConfig::default()
            },
            ..FusionConfig::default()
        };
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("fusion.ppc.scale_f"), "{e}");
        let c = FusionConfig {
            sigma_x_m: 0.0,
            ..FusionConfig::default()
        };
        assert!(c.validate().unwrap_err().to_string().contains("sigma_x_m"));
    }

    #[test]
    fn unknown_field_is_rejected() {
        let r: std::result::Result<FusionConfig, _> =
            serde_json::from_str(r#"{"particle_count": 10, "bogus": 1}"#);
        assert!(r.is_err());
        let c: FusionConfig =
            serde_json::from_str(r#"{"particle_count": 10, "resampling": "stratified"}"#).unwrap();
        assert_eq!(c.particle_count, 10);
        assert_eq!(c.resampling, Resampling::Stratified);
        assert_eq!(c.ppc, PpcConfig::default());
    }
}
