//! Simulation profiles: every parameter of the walker, the phone's motion
//! sensors and the BLE channel, as serde structs with documented defaults.
//! Named profiles (`default`, `swinging`, `ilc-like`, `ipin-like`) are
//! built by [`SimProfile::named`]. Provenance of the defaults is written in
//! docs/parameters.md, section "Simulator".

use fpbp_core::{Error, Result};
use serde::{Deserialize, Serialize};

/// All parameters of one simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimProfile {
    /// Name written into the log header. Default "default".
    pub name: String,
    /// The walker and route planner.
    pub walk: WalkConfig,
    /// Motion and environment sensors.
    pub imu: ImuConfig,
    /// BLE advertising, scanning and channel.
    pub ble: BleConfig,
    /// WiFi APs and scans (`None`: no WiFi, and nothing in the log header).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wifi: Option<crate::wifi::WifiSimConfig>,
}

impl Default for SimProfile {
    fn default() -> Self {
        SimProfile {
            name: "default".into(),
            walk: WalkConfig::default(),
            imu: ImuConfig::default(),
            ble: BleConfig::default(),
            wifi: None,
        }
    }
}

/// The names [`SimProfile::named`] knows.
pub const PROFILE_NAMES: &[&str] = &[
    "default",
    "swinging",
    "ilc-like",
    "ipin-like",
    "wifi",
    "wifi-throttled",
];

impl SimProfile {
    /// A named profile: `default` (phone held in front; vertical p-p like
    /// ILC's, BLE repeat like IPIN's), `swinging` (phone in a swinging hand), `ilc-like`
    /// (closer to ILC's phone and walkers), `ipin-like` (closer to IPIN's),
    /// and the replica walks `replica-<paper>-<n>` ([`crate::replica`]).
    /// Figures behind them: docs/sim.md, docs/reproduction.md.
    pub fn named(name: &str) -> Result<SimProfile> {
        let mut p = SimProfile::default();
        match name {
            "default" => {}
            "swinging" => {
                p.walk.carry = Carry::Swinging;
            }
            "ilc-like" => {
                // ILC: faster steps, same-id repeat p50 0.29 s (the default's
                // vertical p-p already matches ILC's).
                p.walk.step_freq_min_hz = 1.7;
                p.walk.step_freq_max_hz = 2.1;
                p.ble.reception_probability = 0.3;
            }
            "ipin-like" => {
                // IPIN's Samsungs: slower steps, smaller vertical
                // accelerations, sparser reports (repeat p50 0.39 s).
                p.imu.weinberg_beta *= 1.25;
                p.walk.step_freq_min_hz = 1.4;
                p.walk.step_freq_max_hz = 1.9;
                p.walk.step_len_at_min_freq_m = 0.5;
                p.walk.step_len_at_max_freq_m = 0.7;
                p.ble.reception_probability = 0.15;
            }
            // default + WiFi scans every 2-4 s (site APs or a 15 m lattice)
            "wifi" => p.wifi = Some(crate::wifi::WifiSimConfig::default()),
            // ... with Android's foreground throttle (4 scans per 2 minutes)
            "wifi-throttled" => {
                p.wifi = Some(crate::wifi::WifiSimConfig {
                    throttled: true,
                    ..Default::default()
                })
            }
            other => {
                if let Some(r) = crate::replica::replica_profile(other) {
                    return Ok(r);
                }
                return Err(Error::config(
                    "profile",
                    format!(
                        "unknown simulation profile `{other}` (known: {}, {})",
                        PROFILE_NAMES.join(", "),
                        crate::replica::REPLICA_PROFILE_NAMES.join(", ")
                    ),
                ));
            }
        }
        p.name = name.to_string();
        Ok(p)
    }

    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<()> {
        self.walk.validate()?;
        self.imu.validate()?;
        if let Some(w) = &self.wifi {
            w.validate()?;
        }
        self.ble.validate()
    }
}

/// Most waypoints of a fixed route.
pub const MAX_WAYPOINTS: usize = 1000;

/// How the phone is carried.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Carry {
    /// Held in front of the body, screen up, top pointing forward (the ILC
    /// and IPIN surveyors' way).
    InFront,
    /// In a hand swinging at the side, screen forward, top pointing down.
    Swinging,
}

/// The walker and the route planner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WalkConfig {
    /// How the phone is carried. Default in-front.
    pub carry: Carry,
    /// Cell size of the planning grid, m. Default 0.1.
    pub grid_cell_m: f64,
    /// Smallest distance from a wall the route keeps, m (doors narrower than about
    /// 2 * (clearance + cell) are not passed). Default 0.3.
    pub clearance_m: f64,
    /// Smallest distance from a wall of a goal, m. Default 0.6.
    pub goal_clearance_m: f64,
    /// Smallest straight-line distance between consecutive goals, m. Default 4.
    pub min_goal_distance_m: f64,
    /// Slowest step frequency, Hz. Default 1.5.
    pub step_freq_min_hz: f64,
    /// Fastest step frequency, Hz. Default 2.1.
    pub step_freq_max_hz: f64,
    /// Mean step length at the slowest step frequency, m. Default 0.56.
    pub step_len_at_min_freq_m: f64,
    /// Mean step length at the fastest step frequency, m. Default 0.74.
    pub step_len_at_max_freq_m: f64,
    /// Step-to-step relative standard deviation of step length. Default 0.05.
    pub step_len_cv: f64,
    /// Step-to-step relative standard deviation of step duration. Default 0.03.
    pub step_time_cv: f64,
    /// Standing still at the start of the log, s. Default 3.
    pub initial_still_s: f64,
    /// Probability of a pause at a goal. Default 0.5.
    pub pause_probability: f64,
    /// Shortest pause, s. Default 1.
    pub pause_min_s: f64,
    /// Longest pause, s. Default 5.
    pub pause_max_s: f64,
    /// Highest body turn rate, rad/s. Default 3.
    pub max_turn_rate_rad_s: f64,
    /// Time constant of the body yaw following the path direction, s. Default 0.15.
    pub yaw_time_constant_s: f64,
    /// Height of the phone above the floor, m. Default 1.2.
    pub phone_height_m: f64,
    /// A fixed route (MCS metres): when not empty the walk starts at the
    /// first waypoint and visits the others in order, then starts over at
    /// the first, instead of drawing random goals (the replica testbeds'
    /// walking courses, docs/reproduction.md). Each waypoint is snapped to
    /// the nearest cell the walker may stand on, at most 1 m away. Default
    /// empty (random goals).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub waypoints_m: Vec<[f64; 2]>,
}

impl Default for WalkConfig {
    fn default() -> Self {
        WalkConfig {
            carry: Carry::InFront,
            grid_cell_m: 0.1,
            clearance_m: 0.3,
            goal_clearance_m: 0.6,
            min_goal_distance_m: 4.0,
            step_freq_min_hz: 1.5,
            step_freq_max_hz: 2.1,
            step_len_at_min_freq_m: 0.56,
            step_len_at_max_freq_m: 0.74,
            step_len_cv: 0.05,
            step_time_cv: 0.03,
            initial_still_s: 3.0,
            pause_probability: 0.5,
            pause_min_s: 1.0,
            pause_max_s: 5.0,
            max_turn_rate_rad_s: 3.0,
            yaw_time_constant_s: 0.15,
            phone_height_m: 1.2,
            waypoints_m: Vec::new(),
        }
    }
}

pub(crate) fn positive(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::config(field, format!("must be > 0, got {v}")))
    }
}

pub(crate) fn non_negative(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(Error::config(field, format!("must be >= 0, got {v}")))
    }
}

pub(crate) fn probability(field: &str, v: f64) -> Result<()> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(Error::config(field, format!("must be in [0, 1], got {v}")))
    }
}

impl WalkConfig {
    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<()> {
        positive("walk.grid_cell_m", self.grid_cell_m)?;
        if self.grid_cell_m > 1.0 {
            return Err(Error::config("walk.grid_cell_m", "must be <= 1"));
        }
        positive("walk.clearance_m", self.clearance_m)?;
        positive("walk.goal_clearance_m", self.goal_clearance_m)?;
        non_negative("walk.min_goal_distance_m", self.min_goal_distance_m)?;
        positive("walk.step_freq_min_hz", self.step_freq_min_hz)?;
        positive("walk.step_freq_max_hz", self.step_freq_max_hz)?;
        if self.step_freq_max_hz < self.step_freq_min_hz {
            return Err(Error::config(
                "walk.step_freq_max_hz",
                "must be >= walk.step_freq_min_hz",
            ));
        }
        positive("walk.step_len_at_min_freq_m", self.step_len_at_min_freq_m)?;
        positive("walk.step_len_at_max_freq_m", self.step_len_at_max_freq_m)?;
        non_negative("walk.step_len_cv", self.step_len_cv)?;
        if self.step_len_cv > 0.3 {
            return Err(Error::config("walk.step_len_cv", "must be <= 0.3"));
        }
        non_negative("walk.step_time_cv", self.step_time_cv)?;
        if self.step_time_cv > 0.3 {
            return Err(Error::config("walk.step_time_cv", "must be <= 0.3"));
        }
        non_negative("walk.initial_still_s", self.initial_still_s)?;
        probability("walk.pause_probability", self.pause_probability)?;
        non_negative("walk.pause_min_s", self.pause_min_s)?;
        if self.pause_max_s.is_nan() || self.pause_max_s < self.pause_min_s {
            return Err(Error::config(
                "walk.pause_max_s",
                "must be >= walk.pause_min_s",
            ));
        }
        positive("walk.max_turn_rate_rad_s", self.max_turn_rate_rad_s)?;
        non_negative("walk.yaw_time_constant_s", self.yaw_time_constant_s)?;
        non_negative("walk.phone_height_m", self.phone_height_m)?;
        if self.waypoints_m.len() == 1 || self.waypoints_m.len() > MAX_WAYPOINTS {
            return Err(Error::config(
                "walk.waypoints_m",
                format!(
                    "needs 0 or 2..={MAX_WAYPOINTS} waypoints, got {}",
                    self.waypoints_m.len()
                ),
            ));
        }
        for (k, w) in self.waypoints_m.iter().enumerate() {
            if !(w[0].is_finite() && w[1].is_finite()) {
                return Err(Error::config(
                    format!("walk.waypoints_m[{k}]"),
                    "must be finite",
                ));
            }
        }
        Ok(())
    }
}

/// Motion and environment sensors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuConfig {
    /// Accelerometer, gyroscope, magnetometer and rotation-vector rate, Hz. Default 50.
    pub rate_hz: f64,
    /// Standard deviation of the sample timestamp jitter, s. Default 0.0002.
    pub timestamp_jitter_s: f64,
    /// Weinberg coefficient beta: step length = beta * (vertical acceleration
    /// peak-to-peak)^(1/4). Default: the PDR's default
    /// (`fpbp_core::pdr::PdrConfig::default().step_length_beta`, 0.40).
    pub weinberg_beta: f64,
    /// Cut-off of the first-order low-pass the PDR applies before measuring the
    /// peak-to-peak, Hz; the generated profile is boosted by 1/|H(f_step)| so
    /// that the low-passed peak-to-peak follows Weinberg. 0 disables the boost.
    /// Default: the PDR's default (`PdrConfig::default().low_pass_cutoff_hz`, 3.0).
    pub weinberg_lowpass_hz: f64,
    /// How far off the PDR's step lengths are for this walker, relative
    /// standard deviation (drawn once per log): the vertical peak-to-peak of
    /// every step is scaled so that Weinberg with `weinberg_beta` measures
    /// the true length times (1 + N(0, sd)), clamped to [0.6, 1.4] — people
    /// differ from the PDR's beta. Default 0.12: per-path scale of the `pdr`
    /// track against the truth on ILC site1/F1 (p10 / p50 / p90 0.87 / 0.98 /
    /// 1.18; docs/sim.md "PDR drift"). 0 = every walker is the PDR's.
    pub walker_step_length_sd_rel: f64,
    /// Forward (surge) acceleration amplitude as a fraction of the vertical
    /// peak-to-peak. Default 0.25.
    pub surge_ratio: f64,
    /// Lateral sway acceleration amplitude, m/s^2 (at half the step frequency). Default 0.4.
    pub sway_accel_mps2: f64,
    /// Accelerometer white noise, m/s^2. Default 0.12.
    pub accel_noise_mps2: f64,
    /// Accelerometer constant bias per axis (drawn once), standard deviation, m/s^2. Default 0.05.
    pub accel_bias_mps2: f64,
    /// Gyroscope white noise, rad/s. Default 0.01.
    pub gyro_noise_rad_s: f64,
    /// Gyroscope constant bias per axis (drawn once), standard deviation, rad/s. Default 0.005.
    pub gyro_bias_rad_s: f64,
    /// Pitch of the phone held in front (top raised), rad. Default 0.35.
    pub in_front_pitch_rad: f64,
    /// Roll sway amplitude while walking, rad. Default 0.03.
    pub roll_sway_rad: f64,
    /// Pitch bob amplitude while walking, rad. Default 0.02.
    pub pitch_bob_rad: f64,
    /// Hand tremor orientation noise (random walk, reverting), rad. Default 0.01.
    pub tremor_rad: f64,
    /// Swinging hand: arm length, m. Default 0.6.
    pub swing_arm_m: f64,
    /// Swinging hand: swing amplitude, rad. Default 0.35.
    pub swing_amplitude_rad: f64,
    /// Constant yaw offset of the phone from the walking direction, standard
    /// deviation (drawn once), rad. Default 0.17 (about 10 deg): with the
    /// PDR's other heading errors it gives a per-path rotation of the `pdr`
    /// track of 11.7-14.6 deg sd (0.16-0.20) against 13.9 (ILC site1/F1),
    /// 11.3 (site2/F4) and 12.3 (IPIN) deg over the first 40 m walked
    /// (docs/sim.md "PDR drift").
    pub yaw_offset_rad: f64,
    /// Rotation-vector yaw drift rate, standard deviation (drawn once), rad/s. Default 0.002.
    pub yaw_drift_rate_rad_s: f64,
    /// Rotation-vector yaw random walk, rad/sqrt(s). Default 0.003.
    pub yaw_random_walk_rad_sqrt_s: f64,
    /// Rotation-vector orientation noise, rad. Default 0.005.
    pub rotvec_noise_rad: f64,
    /// Earth field magnitude, microtesla. Default 48.
    pub earth_field_ut: f64,
    /// Earth field inclination (dip, downward), rad. Default 1.1 (about 63 deg).
    pub inclination_rad: f64,
    /// Local magnetic disturbances per 100 m^2 of floor. Default 1.
    pub mag_disturbances_per_100m2: f64,
    /// Peak field of one disturbance per axis, microtesla. Default 15.
    pub mag_disturbance_ut: f64,
    /// Radius (Gaussian sigma) of one disturbance, m. Default 1.5.
    pub mag_disturbance_radius_m: f64,
    /// Magnetometer white noise, microtesla. Default 0.4.
    pub mag_noise_ut: f64,
    /// Magnetometer hard-iron residual per axis, standard deviation, microtesla. Default 2.
    pub mag_bias_ut: f64,
    /// Barometer rate, Hz. Default 10.
    pub baro_rate_hz: f64,
    /// Sea-level reference pressure at the start, hPa. Default 1013.25.
    pub baro_p0_hpa: f64,
    /// Barometer white noise, hPa. Default 0.03.
    pub baro_noise_hpa: f64,
    /// Weather drift of the pressure (random walk), hPa/sqrt(s). Default 0.002.
    pub baro_drift_hpa_sqrt_s: f64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        ImuConfig {
            rate_hz: 50.0,
            timestamp_jitter_s: 0.0002,
            weinberg_beta: fpbp_core::pdr::PdrConfig::default().step_length_beta,
            weinberg_lowpass_hz: fpbp_core::pdr::PdrConfig::default().low_pass_cutoff_hz,
            walker_step_length_sd_rel: 0.12,
            surge_ratio: 0.25,
            sway_accel_mps2: 0.4,
            accel_noise_mps2: 0.12,
            accel_bias_mps2: 0.05,
            gyro_noise_rad_s: 0.01,
            gyro_bias_rad_s: 0.005,
            in_front_pitch_rad: 0.35,
            roll_sway_rad: 0.03,
            pitch_bob_rad: 0.02,
            tremor_rad: 0.01,
            swing_arm_m: 0.6,
            swing_amplitude_rad: 0.35,
            yaw_offset_rad: 0.17,
            yaw_drift_rate_rad_s: 0.002,
            yaw_random_walk_rad_sqrt_s: 0.003,
            rotvec_noise_rad: 0.005,
            earth_field_ut: 48.0,
            inclination_rad: 1.1,
            mag_disturbances_per_100m2: 1.0,
            mag_disturbance_ut: 15.0,
            mag_disturbance_radius_m: 1.5,
            mag_noise_ut: 0.4,
            mag_bias_ut: 2.0,
            baro_rate_hz: 10.0,
            baro_p0_hpa: 1013.25,
            baro_noise_hpa: 0.03,
            baro_drift_hpa_sqrt_s: 0.002,
        }
    }
}

impl ImuConfig {
    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<()> {
        positive("imu.rate_hz", self.rate_hz)?;
        if self.rate_hz > 1000.0 {
            return Err(Error::config("imu.rate_hz", "must be <= 1000"));
        }
        non_negative("imu.timestamp_jitter_s", self.timestamp_jitter_s)?;
        if self.timestamp_jitter_s * self.rate_hz > 0.1 {
            return Err(Error::config(
                "imu.timestamp_jitter_s",
                "must be below a tenth of the sample period",
            ));
        }
        positive("imu.weinberg_beta", self.weinberg_beta)?;
        for (f, v) in [
            ("imu.weinberg_lowpass_hz", self.weinberg_lowpass_hz),
            ("imu.surge_ratio", self.surge_ratio),
            (
                "imu.walker_step_length_sd_rel",
                self.walker_step_length_sd_rel,
            ),
            ("imu.sway_accel_mps2", self.sway_accel_mps2),
            ("imu.accel_noise_mps2", self.accel_noise_mps2),
            ("imu.accel_bias_mps2", self.accel_bias_mps2),
            ("imu.gyro_noise_rad_s", self.gyro_noise_rad_s),
            ("imu.gyro_bias_rad_s", self.gyro_bias_rad_s),
            ("imu.roll_sway_rad", self.roll_sway_rad),
            ("imu.pitch_bob_rad", self.pitch_bob_rad),
            ("imu.tremor_rad", self.tremor_rad),
            ("imu.swing_arm_m", self.swing_arm_m),
            ("imu.swing_amplitude_rad", self.swing_amplitude_rad),
            ("imu.yaw_offset_rad", self.yaw_offset_rad),
            ("imu.yaw_drift_rate_rad_s", self.yaw_drift_rate_rad_s),
            (
                "imu.yaw_random_walk_rad_sqrt_s",
                self.yaw_random_walk_rad_sqrt_s,
            ),
            ("imu.rotvec_noise_rad", self.rotvec_noise_rad),
            ("imu.earth_field_ut", self.earth_field_ut),
            (
                "imu.mag_disturbances_per_100m2",
                self.mag_disturbances_per_100m2,
            ),
            ("imu.mag_disturbance_ut", self.mag_disturbance_ut),
            ("imu.mag_noise_ut", self.mag_noise_ut),
            ("imu.mag_bias_ut", self.mag_bias_ut),
            ("imu.baro_noise_hpa", self.baro_noise_hpa),
            ("imu.baro_drift_hpa_sqrt_s", self.baro_drift_hpa_sqrt_s),
        ] {
            non_negative(f, v)?;
        }
        if !self.in_front_pitch_rad.is_finite() || self.in_front_pitch_rad.abs() > 1.5 {
            return Err(Error::config(
                "imu.in_front_pitch_rad",
                "must be within [-1.5, 1.5]",
            ));
        }
        if !self.inclination_rad.is_finite()
            || self.inclination_rad.abs() > std::f64::consts::FRAC_PI_2
        {
            return Err(Error::config(
                "imu.inclination_rad",
                "must be within [-pi/2, pi/2]",
            ));
        }
        positive(
            "imu.mag_disturbance_radius_m",
            self.mag_disturbance_radius_m,
        )?;
        positive("imu.baro_rate_hz", self.baro_rate_hz)?;
        positive("imu.baro_p0_hpa", self.baro_p0_hpa)
    }
}

/// BLE advertising, scanning and the radio channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BleConfig {
    /// Advertising interval of every beacon, s. Default 0.1.
    pub advert_interval_s: f64,
    /// Largest random advDelay added to each interval (BLE spec: 0-10 ms), s. Default 0.01.
    pub advert_delay_max_s: f64,
    /// Scan window, s (Android low-latency mode: window = interval). Default 4.096.
    pub scan_window_s: f64,
    /// Scan interval, s. Default 4.096.
    pub scan_interval_s: f64,
    /// Probability that an advert sent inside the scan window is reported
    /// (one of three advertising channels scanned, collisions, the stack
    /// dropping results). Default 0.25.
    pub reception_probability: f64,
    /// Fraction of time a given beacon is not heard at all (per-beacon
    /// burst losses: body shadowing, interference), alternating exponential
    /// good and bad spans. Default 0.4.
    pub burst_loss_fraction: f64,
    /// Mean length of one per-beacon burst loss, s. Default 2.
    pub burst_loss_mean_s: f64,
    /// Probability per second that the scanner stalls (a drop-out). Default 0.02.
    pub dropout_rate_per_s: f64,
    /// Mean drop-out length, s (exponential). Default 2.
    pub dropout_mean_s: f64,
    /// Batch report delay (ScanSettings.setReportDelay), s; 0 reports each
    /// advert at once. Batched adverts are stamped with the delivery time,
    /// as the ILC logger does. Default 0.
    pub report_delay_s: f64,
    /// Weakest RSSI the radio reports, dBm. Default -100.
    pub sensitivity_dbm: f64,
    /// Spatially correlated (log-normal) shadowing, standard deviation, dB. Default 4.
    pub shadowing_sigma_db: f64,
    /// Decorrelation distance of the shadowing, m. Default 2.
    pub shadowing_decorrelation_m: f64,
    /// Per-advert fast fading, standard deviation, dB. Default 3.
    pub fast_fading_sigma_db: f64,
    /// Attenuation per wall crossed on the straight line, dB. Default 5.
    pub wall_attenuation_db: f64,
    /// Attenuation per door crossed on the straight line, dB. Default 0 (open doorway).
    pub door_attenuation_db: f64,
    /// Attenuation per floor between beacon and phone, dB. Default 20.
    pub floor_attenuation_db: f64,
    /// RSSI bias of the phone, dB, added to every reading. Default 0.
    pub device_bias_dbm: f64,
    /// Fraction of adverts given an extra NLOS attenuation (PPSA experiments). Default 0.
    pub nlos_rate: f64,
    /// Mean extra NLOS attenuation, dB (PPSA eq. 4: w_NLOS ~ N(mu, sigma^2)). Default 10.
    pub nlos_mean_db: f64,
    /// Standard deviation of the extra NLOS attenuation, dB. Default 4.
    pub nlos_sigma_db: f64,
    /// Round RSSI to whole dBm as Android does. Default true.
    pub integer_rssi: bool,
}

impl Default for BleConfig {
    fn default() -> Self {
        BleConfig {
            advert_interval_s: 0.1,
            advert_delay_max_s: 0.01,
            scan_window_s: 4.096,
            scan_interval_s: 4.096,
            reception_probability: 0.25,
            burst_loss_fraction: 0.4,
            burst_loss_mean_s: 2.0,
            dropout_rate_per_s: 0.02,
            dropout_mean_s: 2.0,
            report_delay_s: 0.0,
            sensitivity_dbm: -100.0,
            shadowing_sigma_db: 4.0,
            shadowing_decorrelation_m: 2.0,
            fast_fading_sigma_db: 3.0,
            wall_attenuation_db: 5.0,
            door_attenuation_db: 0.0,
            floor_attenuation_db: 20.0,
            device_bias_dbm: 0.0,
            nlos_rate: 0.0,
            nlos_mean_db: 10.0,
            nlos_sigma_db: 4.0,
            integer_rssi: true,
        }
    }
}

impl BleConfig {
    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<()> {
        positive("ble.advert_interval_s", self.advert_interval_s)?;
        if self.advert_interval_s < 0.02 {
            return Err(Error::config(
                "ble.advert_interval_s",
                "must be >= 0.02 (BLE minimum)",
            ));
        }
        non_negative("ble.advert_delay_max_s", self.advert_delay_max_s)?;
        positive("ble.scan_window_s", self.scan_window_s)?;
        positive("ble.scan_interval_s", self.scan_interval_s)?;
        if self.scan_window_s > self.scan_interval_s {
            return Err(Error::config(
                "ble.scan_window_s",
                "must be <= ble.scan_interval_s",
            ));
        }
        probability("ble.reception_probability", self.reception_probability)?;
        probability("ble.burst_loss_fraction", self.burst_loss_fraction)?;
        if self.burst_loss_fraction >= 1.0 {
            return Err(Error::config("ble.burst_loss_fraction", "must be < 1"));
        }
        non_negative("ble.burst_loss_mean_s", self.burst_loss_mean_s)?;
        non_negative("ble.dropout_rate_per_s", self.dropout_rate_per_s)?;
        non_negative("ble.dropout_mean_s", self.dropout_mean_s)?;
        non_negative("ble.report_delay_s", self.report_delay_s)?;
        if !self.sensitivity_dbm.is_finite() {
            return Err(Error::config("ble.sensitivity_dbm", "must be finite"));
        }
        non_negative("ble.shadowing_sigma_db", self.shadowing_sigma_db)?;
        positive(
            "ble.shadowing_decorrelation_m",
            self.shadowing_decorrelation_m,
        )?;
        non_negative("ble.fast_fading_sigma_db", self.fast_fading_sigma_db)?;
        non_negative("ble.wall_attenuation_db", self.wall_attenuation_db)?;
        non_negative("ble.door_attenuation_db", self.door_attenuation_db)?;
        non_negative("ble.floor_attenuation_db", self.floor_attenuation_db)?;
        if !self.device_bias_dbm.is_finite() {
            return Err(Error::config("ble.device_bias_dbm", "must be finite"));
        }
        probability("ble.nlos_rate", self.nlos_rate)?;
        non_negative("ble.nlos_mean_db", self.nlos_mean_db)?;
        non_negative("ble.nlos_sigma_db", self.nlos_sigma_db)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_profiles_validate() {
        for n in PROFILE_NAMES {
            let p = SimProfile::named(n).unwrap();
            p.validate().unwrap();
            assert_eq!(p.name, *n);
        }
        assert!(SimProfile::named("nope").is_err());
    }

    #[test]
    fn unknown_field_is_rejected_and_bad_value_named() {
        let e = serde_json::from_str::<SimProfile>(r#"{"walk": {"speed": 1}}"#);
        assert!(e.is_err());
        let mut p = SimProfile::default();
        p.ble.nlos_rate = 1.5;
        let msg = p.validate().unwrap_err().to_string();
        assert!(msg.contains("ble.nlos_rate"), "{msg}");
    }

    #[test]
    fn partial_json_keeps_defaults() {
        let p: SimProfile = serde_json::from_str(r#"{"ble": {"nlos_rate": 0.2}}"#).unwrap();
        assert_eq!(p.ble.nlos_rate, 0.2);
        assert_eq!(p.imu, ImuConfig::default());
    }
}
