//! Configuration of the EKF engines (`ekf` in the engine config).

use serde::{Deserialize, Serialize};

use crate::fingerprint::FingerprintConfig;
use crate::floor::FloorConfig;
use crate::{Error, Result};

/// Parameters of `robust-ekf` and `tc-ekf`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EkfConfig {
    /// Barometric floor tracker.
    pub floor: FloorConfig,
    /// Fingerprint database, clustering and WKNN (robust-ekf).
    pub fingerprint: FingerprintConfig,
    /// IGG3 k0 of eq. 22 (paper: [1, 1.5]). Default 1.5.
    pub igg3_k0: f64,
    /// IGG3 k1 of eq. 22 (paper: [2.5, 3]). Default 3.0.
    pub igg3_k1: f64,
    /// Process noise of position per second, m^2/s. Default 0.5.
    pub q_pos_m2_per_s: f64,
    /// Process noise of speed per second, (m/s)^2/s. Default 0.5.
    pub q_speed_m2_per_s3: f64,
    /// robust-ekf: process noise of heading per second, rad^2/s. Default 2.0:
    /// the heading state of eq. 20 is constant between observations, so a
    /// walker's turn must fit in the prediction's spread or IGG3 rejects the
    /// MEMS heading as an outlier. A 90-degree turn within one step (0.55 s)
    /// keeps full weight (|u| <= k0 = 1.5) when (pi/2 / 1.5)^2 <= q * 0.55 s,
    /// i.e. q >= 2.0. The paper gives no Q. (Was 0.05: every turn of the
    /// replica walk was rejected for ~5 s, docs/reproduction.md.)
    pub q_heading_rad2_per_s: f64,
    /// Standard deviation of a fingerprint (WKNN) position, metres. Default 3.0.
    pub fingerprint_sigma_m: f64,
    /// Standard deviation of the PDR speed, m/s. Default 0.2.
    pub speed_sigma_mps: f64,
    /// Standard deviation of the PDR heading, rad. Default 0.15.
    pub heading_sigma_rad: f64,
    /// tc-ekf: beacons at or above this filtered RSSI give a proximity fix (eq. 5), dBm. Default -62.
    pub proximity_rssi_dbm: f64,
    /// tc-ekf: read `proximity_rssi_dbm` relative to each beacon's own RSSI
    /// at 1 m (the fix is at the beacon with the largest RSSI - R0, when that
    /// is >= `proximity_rssi_dbm`). The paper's threshold RSSI_T belongs to
    /// its weak-signal (-20 dBm) transmitters, which a site with strong
    /// (+4 dBm) ones on the same posts cannot express as one absolute
    /// level: the strong ones are always the loudest. Default false (the
    /// absolute threshold at the loudest beacon).
    pub proximity_relative_to_r0: bool,
    /// tc-ekf: only beacons whose RSSI at 1 m (the site's R0) is at most
    /// this can give a proximity fix, dBm. The paper's proximity belongs to
    /// its weak-signal (-20 dBm) transmitters (eq. 5, Sec. III); with
    /// `proximity_relative_to_r0` a strong one on the same post can
    /// otherwise win on a loud reading. Default 0 (every beacon).
    pub proximity_max_rssi_1m_dbm: f64,
    /// tc-ekf: weigh proximity fixes with IGG3 (`igg3_k0`, `igg3_k1`, the
    /// BMW paper's robust gain) instead of the TC paper's plain EKF update
    /// of eq. 5. The TC paper gates nothing: a detected proximity puts the
    /// user at the transmitter. With IGG3 a filter that has drifted more
    /// than ~3 sigma from the post never accepts the fix that would bring it
    /// back (replica: 31 m behind at the post, every fix rejected; docs/
    /// reproduction.md "tc-ekf"). Default false (the paper's).
    pub proximity_igg3: bool,
    /// tc-ekf: standard deviation of a proximity fix, metres. Default 2.0.
    pub proximity_sigma_m: f64,
    /// tc-ekf: beacons at or above this filtered RSSI are ranged (eqs. 16-18), dBm. Default -85.
    pub ranging_rssi_dbm: f64,
    /// tc-ekf: most beacons ranged per BLE task. Default 6.
    pub ranging_max_beacons: usize,
    /// tc-ekf: only beacons whose RSSI at 1 m (the site's R0) is at least
    /// this are ranged, dBm. The paper ranges its strong-signal (+4 dBm)
    /// transmitters only (eqs. 22, 24), never the weak (-20 dBm) proximity
    /// ones; a site says which are which only through R0. Default -200
    /// (every beacon: a site with one kind of beacon).
    pub ranging_min_rssi_1m_dbm: f64,
    /// tc-ekf: range only beacons ahead of the walker (in front of the last
    /// step's direction), as the paper does against body shadowing (Sec.
    /// III-C 1, Fig. 6). Default false (every beacon).
    pub ranging_ahead_only: bool,
    /// tc-ekf: standard deviation of a ranging RSSI, dB. Default 5.0.
    pub ranging_sigma_db: f64,
    /// tc-ekf: random walk of the RSSI bias (eq. 19), dB^2/s. Default 0.01.
    pub q_bias_db2_per_s: f64,
    /// tc-ekf: prior standard deviation of the RSSI bias, dB. Default 6.0.
    pub bias_prior_sigma_db: f64,
    /// tc-ekf: process noise of the step-length error, m^2/s. Default 0.0005.
    pub q_step_length_m2_per_s: f64,
    /// tc-ekf: process noise of the heading error, rad^2/s. Default 0.002.
    pub q_heading_error_rad2_per_s: f64,
    /// tc-ekf: window of the adaptive GNSS error estimate (eqs. 6-8), fixes. Default 10.
    pub gnss_window: usize,
    /// tc-ekf: GNSS fixes with a reported accuracy above this are dropped, metres. Default 30.
    pub gnss_max_accuracy_m: f64,
    /// tc-ekf: walking direction of eq. 9 (BLE heading while it agrees with
    /// the phone's, kalman::walking_direction). Default true (the paper's;
    /// measured neutral to slightly better, docs/engines-ekf.md).
    pub walking_direction: bool,
    /// tc-ekf eq. 9: comparison window, seconds. Default 3.0 (the paper's).
    pub walking_window_s: f64,
    /// tc-ekf eq. 9: theta_T on the mean absolute BLE-phone heading
    /// difference over the window, rad. Default 0.35 (20 degrees, our choice:
    /// the paper gives no value).
    pub walking_threshold_rad: f64,
    /// tc-ekf eq. 9: the window's BLE positions must span this, metres.
    /// Default 2.0 (about 1.5 s of walking).
    pub walking_min_travel_m: f64,
}

impl Default for EkfConfig {
    fn default() -> Self {
        EkfConfig {
            floor: FloorConfig::default(),
            fingerprint: FingerprintConfig::default(),
            igg3_k0: 1.5,
            igg3_k1: 3.0,
            q_pos_m2_per_s: 0.5,
            q_speed_m2_per_s3: 0.5,
            q_heading_rad2_per_s: 2.0,
            fingerprint_sigma_m: 3.0,
            speed_sigma_mps: 0.2,
            heading_sigma_rad: 0.15,
            proximity_rssi_dbm: -62.0,
            proximity_relative_to_r0: false,
            proximity_max_rssi_1m_dbm: 0.0,
            proximity_igg3: false,
            proximity_sigma_m: 2.0,
            ranging_rssi_dbm: -90.0,
            ranging_max_beacons: 6,
            ranging_min_rssi_1m_dbm: -200.0,
            ranging_ahead_only: false,
            ranging_sigma_db: 5.0,
            q_bias_db2_per_s: 0.01,
            bias_prior_sigma_db: 6.0,
            q_step_length_m2_per_s: 0.0005,
            q_heading_error_rad2_per_s: 0.002,
            gnss_window: 10,
            gnss_max_accuracy_m: 30.0,
            walking_direction: true,
            walking_window_s: 3.0,
            walking_threshold_rad: 0.35,
            walking_min_travel_m: 2.0,
        }
    }
}

impl EkfConfig {
    /// Checks every field's range, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        self.floor.validate().map_err(|e| e.within("ekf."))?;
        self.fingerprint.validate().map_err(|e| e.within("ekf."))?;
        if !(self.igg3_k0 > 0.0 && self.igg3_k1 > self.igg3_k0 && self.igg3_k1.is_finite()) {
            return Err(Error::config("ekf.igg3_k1", "need 0 < igg3_k0 < igg3_k1"));
        }
        let pos = [
            ("q_pos_m2_per_s", self.q_pos_m2_per_s),
            ("q_speed_m2_per_s3", self.q_speed_m2_per_s3),
            ("q_heading_rad2_per_s", self.q_heading_rad2_per_s),
            ("fingerprint_sigma_m", self.fingerprint_sigma_m),
            ("speed_sigma_mps", self.speed_sigma_mps),
            ("heading_sigma_rad", self.heading_sigma_rad),
            ("proximity_sigma_m", self.proximity_sigma_m),
            ("ranging_sigma_db", self.ranging_sigma_db),
            ("q_bias_db2_per_s", self.q_bias_db2_per_s),
            ("bias_prior_sigma_db", self.bias_prior_sigma_db),
            ("q_step_length_m2_per_s", self.q_step_length_m2_per_s),
            (
                "q_heading_error_rad2_per_s",
                self.q_heading_error_rad2_per_s,
            ),
            ("gnss_max_accuracy_m", self.gnss_max_accuracy_m),
            ("walking_window_s", self.walking_window_s),
            ("walking_threshold_rad", self.walking_threshold_rad),
            ("walking_min_travel_m", self.walking_min_travel_m),
        ];
        for (f, v) in pos {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(format!("ekf.{f}"), "must be finite and > 0"));
            }
        }
        if !(self.proximity_rssi_dbm.is_finite()
            && self.ranging_rssi_dbm.is_finite()
            && self.ranging_min_rssi_1m_dbm.is_finite()
            && self.proximity_max_rssi_1m_dbm.is_finite())
        {
            return Err(Error::config("ekf.proximity_rssi_dbm", "must be finite"));
        }
        use crate::bounds::check_count;
        check_count(
            "ekf.ranging_max_beacons",
            self.ranging_max_beacons,
            1,
            10_000,
        )?;
        check_count("ekf.gnss_window", self.gnss_window, 1, 10_000)?;
        Ok(())
    }
}
