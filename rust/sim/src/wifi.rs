//! WiFi: access points (the site's `access_points`, or a generated square
//! layout when the site has none), Android scans every 2-4 s (optionally
//! throttled as Android 9+ does for foreground apps: at most 4 scans in any
//! 2 minutes) and the channel of [`crate::ble`]: the AP's log-distance model,
//! walls, doors and floors on the straight line (`ble::link`), AR(1)
//! shadowing in distance walked, fast fading, integer RSSI, a sensitivity.
//! Each result has its own last-seen time: APs are measured during the
//! scan's sweep (`sweep_s` before the results arrive), and an AP missed by a
//! scan is reported again with its last result (old RSSI, old last-seen
//! time) with `cached_probability` while that is at most `cache_max_age_s`
//! old, as Android's scan cache does.

use fpbp_core::Vec2;
use fpbp_core::events::{WifiResult, WifiScan};
use fpbp_core::map::Feature;
use fpbp_core::site::{BeaconSpec, Site};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::imu::to_ns;
use crate::noise::{chance, normal, uniform};
use crate::profile::{BleConfig, non_negative, positive, probability};
use crate::walk::Trajectory;
use fpbp_core::{Error, Result};

/// WiFi simulation parameters (`wifi` section of a profile; none = no WiFi).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WifiSimConfig {
    /// Sites without `access_points`: APs on a square lattice of this pitch
    /// over the floor, on walkable points, m. Default 15.
    pub layout_spacing_m: f64,
    /// Generated APs: mounting height, RSSI at 1 m, path-loss exponent
    /// (2.4 GHz). Default 2.8 m, -40 dBm, 2.5.
    pub layout_z_m: f64,
    pub layout_rssi_1m_dbm: f64,
    pub layout_path_loss_exponent: f64,
    /// Time between scan requests, uniform in [min, max], s. Default 2-4.
    pub scan_interval_min_s: f64,
    pub scan_interval_max_s: f64,
    /// Android's foreground throttle: a request is refused when
    /// `throttle_max_scans` requests succeeded in the last
    /// `throttle_window_s`. Default off; 4 per 120 s when on.
    pub throttled: bool,
    pub throttle_max_scans: usize,
    pub throttle_window_s: f64,
    /// Results are measured up to this long before the scan arrives, s. Default 1.5.
    pub sweep_s: f64,
    /// Probability that an AP missed by a scan is reported from the cache. Default 0.3.
    pub cached_probability: f64,
    /// Oldest cached result reported, s. Default 30.
    pub cache_max_age_s: f64,
    /// Probability that an AP in range is measured by a scan. Default 0.9.
    pub detection_probability: f64,
    pub sensitivity_dbm: f64,
    pub shadowing_sigma_db: f64,
    pub shadowing_decorrelation_m: f64,
    pub fast_fading_sigma_db: f64,
    pub wall_attenuation_db: f64,
    pub door_attenuation_db: f64,
    pub floor_attenuation_db: f64,
}

impl Default for WifiSimConfig {
    fn default() -> Self {
        WifiSimConfig {
            layout_spacing_m: 15.0,
            layout_z_m: 2.8,
            layout_rssi_1m_dbm: -40.0,
            layout_path_loss_exponent: 2.5,
            scan_interval_min_s: 2.0,
            scan_interval_max_s: 4.0,
            throttled: false,
            throttle_max_scans: 4,
            throttle_window_s: 120.0,
            sweep_s: 1.5,
            cached_probability: 0.3,
            cache_max_age_s: 30.0,
            detection_probability: 0.9,
            sensitivity_dbm: -95.0,
            shadowing_sigma_db: 4.0,
            shadowing_decorrelation_m: 3.0,
            fast_fading_sigma_db: 2.0,
            wall_attenuation_db: 4.0,
            door_attenuation_db: 0.0,
            floor_attenuation_db: 15.0,
        }
    }
}

impl WifiSimConfig {
    pub fn validate(&self) -> Result<()> {
        let pos = |name: &str, v: f64| positive(&format!("wifi.{name}"), v);
        let non_neg = |name: &str, v: f64| non_negative(&format!("wifi.{name}"), v);
        let prob = |name: &str, v: f64| probability(&format!("wifi.{name}"), v);
        if !(self.layout_spacing_m.is_finite() && self.layout_spacing_m >= 1.0) {
            return Err(Error::config("wifi.layout_spacing_m", "must be >= 1"));
        }
        non_neg("layout_z_m", self.layout_z_m)?;
        if !(self.layout_rssi_1m_dbm.is_finite() && self.layout_rssi_1m_dbm < 0.0) {
            return Err(Error::config("wifi.layout_rssi_1m_dbm", "must be < 0"));
        }
        pos("layout_path_loss_exponent", self.layout_path_loss_exponent)?;
        if !(self.scan_interval_min_s >= 0.5
            && self.scan_interval_max_s >= self.scan_interval_min_s
            && self.scan_interval_max_s.is_finite())
        {
            return Err(Error::config(
                "wifi.scan_interval_min_s",
                "need 0.5 <= scan_interval_min_s <= scan_interval_max_s",
            ));
        }
        if self.throttle_max_scans == 0 {
            return Err(Error::config("wifi.throttle_max_scans", "must be >= 1"));
        }
        pos("throttle_window_s", self.throttle_window_s)?;
        non_neg("sweep_s", self.sweep_s)?;
        prob("cached_probability", self.cached_probability)?;
        non_neg("cache_max_age_s", self.cache_max_age_s)?;
        prob("detection_probability", self.detection_probability)?;
        if !self.sensitivity_dbm.is_finite() {
            return Err(Error::config("wifi.sensitivity_dbm", "must be finite"));
        }
        non_neg("shadowing_sigma_db", self.shadowing_sigma_db)?;
        pos("shadowing_decorrelation_m", self.shadowing_decorrelation_m)?;
        non_neg("fast_fading_sigma_db", self.fast_fading_sigma_db)?;
        non_neg("wall_attenuation_db", self.wall_attenuation_db)?;
        non_neg("door_attenuation_db", self.door_attenuation_db)?;
        non_neg("floor_attenuation_db", self.floor_attenuation_db)
    }
}

/// Most generated APs (a lattice over a very large floor is thinned to this).
pub const MAX_LAYOUT_APS: usize = 4096;

/// The site's APs, or (none declared) a lattice of `layout_spacing_m` over
/// floor `floor`, keeping lattice points on walkable or door pixels; BSSIDs
/// `02:5f:00:00:hh:ll` (locally administered), numbered row by row.
pub fn access_points(site: &Site, cfg: &WifiSimConfig, floor: i32) -> Vec<BeaconSpec> {
    if !site.spec.access_points.is_empty() {
        return site.spec.access_points.clone();
    }
    let Some(map) = site.floor(floor) else {
        return Vec::new();
    };
    let s = cfg.layout_spacing_m;
    let nx = (map.width_m() / s).floor() as usize;
    let ny = (map.height_m() / s).floor() as usize;
    let mut out = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let p = Vec2::new((i as f64 + 0.5) * s, (j as f64 + 0.5) * s);
            if map.feature(p) == Feature::Wall || out.len() >= MAX_LAYOUT_APS {
                continue;
            }
            let k = out.len();
            out.push(BeaconSpec {
                id: format!("02:5f:00:00:{:02x}:{:02x}", k / 256, k % 256),
                floor,
                x_m: p.x,
                y_m: p.y,
                z_m: cfg.layout_z_m,
                rssi_1m_dbm: cfg.layout_rssi_1m_dbm,
                path_loss_exponent: cfg.layout_path_loss_exponent,
            });
        }
    }
    out
}

/// Per-AP state: shadowing and the last result (the scan cache).
struct ApState {
    shadow_db: f64,
    last_pos: Option<Vec2>,
    last: Option<WifiResult>,
}

/// The WiFi scans of the whole log, in time order. Random draws: scan
/// times first, then per scan and per AP in a fixed order.
#[allow(clippy::too_many_arguments)]
pub fn scans(
    site: &Site,
    cfg: &WifiSimConfig,
    ble: &BleConfig,
    traj: &Trajectory,
    floor: i32,
    phone_height_m: f64,
    t0_ns: i64,
    rng: &mut Pcg64,
) -> Vec<WifiScan> {
    let aps = access_points(site, cfg, floor);
    // the BLE channel's deterministic part with the WiFi attenuations
    let chan = BleConfig {
        wall_attenuation_db: cfg.wall_attenuation_db,
        door_attenuation_db: cfg.door_attenuation_db,
        floor_attenuation_db: cfg.floor_attenuation_db,
        ..ble.clone()
    };
    let mut times = Vec::new();
    let mut accepted: Vec<f64> = Vec::new();
    let mut t = uniform(rng, 0.0, cfg.scan_interval_max_s);
    while t <= traj.duration_s {
        let recent = accepted
            .iter()
            .filter(|a| t - **a < cfg.throttle_window_s)
            .count();
        if !cfg.throttled || recent < cfg.throttle_max_scans {
            accepted.push(t);
            times.push(t);
        }
        t += uniform(rng, cfg.scan_interval_min_s, cfg.scan_interval_max_s);
    }
    let mut state: Vec<ApState> = aps
        .iter()
        .map(|_| ApState {
            shadow_db: normal(rng, 0.0, cfg.shadowing_sigma_db),
            last_pos: None,
            last: None,
        })
        .collect();
    let mut out = Vec::with_capacity(times.len());
    for t_scan in times {
        let t_ns = to_ns(t0_ns, t_scan);
        let mut results = Vec::new();
        for (a, st) in aps.iter().zip(state.iter_mut()) {
            let seen = (t_scan - uniform(rng, 0.0, cfg.sweep_s)).max(0.0);
            let detected = chance(rng, cfg.detection_probability);
            let cached = chance(rng, cfg.cached_probability);
            let fading = normal(rng, 0.0, cfg.fast_fading_sigma_db);
            let innovation = normal(rng, 0.0, cfg.shadowing_sigma_db);
            let pos = traj.position_at(seen);
            let moved = st.last_pos.map_or(f64::INFINITY, |p| (pos - p).norm());
            if moved > 0.0 {
                let rho = (-moved / cfg.shadowing_decorrelation_m).exp();
                st.shadow_db = rho * st.shadow_db + (1.0 - rho * rho).sqrt() * innovation;
            }
            st.last_pos = Some(pos);
            let l = crate::ble::link(site, &chan, a, floor, pos, phone_height_m);
            let rssi = (l.model_rssi_dbm + st.shadow_db + fading).round();
            if detected && rssi >= cfg.sensitivity_dbm {
                let r = WifiResult {
                    bssid: a.id.clone(),
                    rssi_dbm: rssi,
                    freq_mhz: 2437,
                    seen_t_ns: to_ns(t0_ns, seen).min(t_ns),
                };
                st.last = Some(r.clone());
                results.push(r);
            } else if let Some(old) = &st.last
                && cached
                && t_ns - old.seen_t_ns <= (cfg.cache_max_age_s * 1e9) as i64
            {
                results.push(old.clone());
            }
        }
        results.sort_by(|a, b| {
            b.rssi_dbm
                .total_cmp(&a.rssi_dbm)
                .then(a.bssid.cmp(&b.bssid))
        });
        out.push(WifiScan { t_ns, results });
    }
    out
}
