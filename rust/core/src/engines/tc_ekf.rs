//! Engine `tc-ekf` (TC paper): a tightly coupled EKF over
//! [x, y, dS, dtheta, RSSI_b] (eqs. 2, 21; full state in the MCS rather than
//! an error state): PDR steps propagate the position with step-length error
//! dS and heading error dtheta; near beacons give proximity fixes (eq. 5);
//! strong beacons give RSSI ranging with the bias-linearised path-loss model
//! (eqs. 16-18, 22-25), the RSSI bias a random-walk state (eq. 19); GNSS fixes
//! (converted with the site georef) update the position with the adaptive
//! error estimate of eqs. 6-8 (GE fixed at each proximity fix, then carried by
//! GNSS-minus-PDR displacement; before the first proximity fix the reported
//! accuracy is used). Floors from the barometric floor tracker when the log
//! has pressure, else the BLE likely floor. Walking direction of eq. 9
//! (`ekf.walking_direction`, on by default): each BLE task's weighted
//! centroid of the strongest three beacons feeds a BLE heading
//! (kalman::walking_direction) that a step takes while it agrees with the
//! phone's heading.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use crate::Result;
use crate::Vec2;
use crate::ble::{BleConfig, BleFrontEnd, FilteredBeacon};
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, GnssFix, SensorData, SensorEvent};
use crate::floor::FloorTracker;
use crate::kalman::walking_direction::WalkingDirection;
use crate::kalman::{EkfConfig, robust_update};
use crate::pdr::Pdr;
use crate::site::Site;

const LN10: f64 = std::f64::consts::LN_10;

/// The tightly coupled EKF engine.
pub struct TcEkfEngine {
    site: Arc<Site>,
    ble_cfg: BleConfig,
    cfg: EkfConfig,
    front: BleFrontEnd,
    pdr: Pdr,
    floors: FloorTracker,
    x: DVector<f64>,
    p: DMatrix<f64>,
    initialised: bool,
    floor: i32,
    last_t_ns: Option<i64>,
    /// GE of eqs. 6-7 and the GNSS / PDR positions it was last carried from.
    ge: Option<Vec2>,
    last_gnss: Option<Vec2>,
    pdr_since_gnss: Vec2,
    pose: Option<Pose>,
    ble_period_ns: i64,
    fusion_period_ns: i64,
    /// GNSS fixes used / dropped.
    pub gnss_used: u64,
    /// Eq. 9 state (when `ekf.walking_direction`).
    walking: Option<WalkingDirection>,
    /// Time of the last BLE task: a beacon whose last report is not newer
    /// has nothing new to say (its filtered RSSI was already used).
    last_ble_task_ns: Option<i64>,
    /// Direction of the last step (the walking direction), MCS radians.
    last_step_dir_rad: Option<f64>,
    stats: EngineStats,
}

impl TcEkfEngine {
    /// Builds the engine; `init` (optional) seeds position, floor and heading.
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        config.validate()?;
        let front = BleFrontEnd::new(&config.ble, &site);
        let start_floor = init.map_or(site.default_floor(), |i| i.floor);
        let floors = FloorTracker::new(&config.ekf.floor, &site.floor_heights(), start_floor);
        let mut x = DVector::zeros(5);
        let mut p = DMatrix::zeros(5, 5);
        p[(0, 0)] = 100.0;
        p[(1, 1)] = 100.0;
        p[(2, 2)] = 0.01;
        p[(3, 3)] = 0.01;
        p[(4, 4)] = config.ekf.bias_prior_sigma_db.powi(2);
        let mut initialised = false;
        if let Some(i) = init.filter(|i| i.x_m.is_finite() && i.y_m.is_finite()) {
            x[0] = i.x_m;
            x[1] = i.y_m;
            p[(0, 0)] = 1.0;
            p[(1, 1)] = 1.0;
            initialised = true;
        }
        Ok(TcEkfEngine {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            ble_cfg: config.ble.clone(),
            cfg: config.ekf.clone(),
            front,
            floors,
            x,
            p,
            initialised,
            floor: start_floor,
            last_t_ns: None,
            ge: None,
            last_gnss: None,
            pdr_since_gnss: Vec2::zeros(),
            pose: None,
            ble_period_ns: i64::from(config.tasks.radio_period_ms) * 1_000_000,
            fusion_period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            gnss_used: 0,
            walking: config.ekf.walking_direction.then(|| {
                WalkingDirection::new(
                    config.ekf.walking_window_s,
                    config.ekf.walking_threshold_rad,
                    config.ekf.walking_min_travel_m,
                )
            }),
            last_ble_task_ns: None,
            last_step_dir_rad: None,
            stats: EngineStats::default(),
            site,
        })
    }

    /// The current RSSI bias estimate RSSI_b (measured minus model), dB, and its sigma.
    pub fn rssi_bias_db(&self) -> (f64, f64) {
        (self.x[4], self.p[(4, 4)].max(0.0).sqrt())
    }

    fn add_process_noise(&mut self, t_ns: i64) {
        let dt = match self.last_t_ns {
            Some(t0) if t_ns > t0 => (t_ns - t0) as f64 * 1e-9,
            _ => 0.0,
        };
        if self.last_t_ns.is_none_or(|t0| t_ns > t0) {
            self.last_t_ns = Some(t_ns);
        }
        self.p[(2, 2)] += self.cfg.q_step_length_m2_per_s * dt;
        self.p[(3, 3)] += self.cfg.q_heading_error_rad2_per_s * dt;
        self.p[(4, 4)] += self.cfg.q_bias_db2_per_s * dt;
        self.p[(0, 0)] += 0.01 * dt;
        self.p[(1, 1)] += 0.01 * dt;
    }

    /// One step of `length_m` (plus dS) along `yaw_rad` + dtheta. With
    /// `heading_from_state` false the step took eq. 9's BLE heading, which
    /// does not depend on dtheta: the Jacobian's dtheta column is then 0
    /// (it linearises the propagation actually done).
    fn step(&mut self, length_m: f64, yaw_rad: f64, heading_from_state: bool) {
        let (l, th) = (length_m + self.x[2], yaw_rad + self.x[3]);
        let (s, c) = th.sin_cos();
        let mut f = DMatrix::identity(5, 5);
        f[(0, 2)] = c;
        f[(1, 2)] = s;
        if heading_from_state {
            f[(0, 3)] = -l * s;
            f[(1, 3)] = l * c;
        }
        self.x[0] += l * c;
        self.x[1] += l * s;
        self.pdr_since_gnss += Vec2::new(l * c, l * s);
        let mut q = DMatrix::zeros(5, 5);
        // per-step position noise: 5 % of the step
        q[(0, 0)] = (0.05 * length_m).powi(2);
        q[(1, 1)] = (0.05 * length_m).powi(2);
        self.p = &f * &self.p * f.transpose() + q;
    }

    fn position_update(&mut self, z: Vec2, var_x: f64, var_y: f64, robust: bool) -> bool {
        let mut h = DMatrix::zeros(2, 5);
        h[(0, 0)] = 1.0;
        h[(1, 1)] = 1.0;
        let v = DVector::from_vec(vec![z.x - self.x[0], z.y - self.x[1]]);
        let r = DVector::from_vec(vec![var_x, var_y]);
        let k = robust.then_some((self.cfg.igg3_k0, self.cfg.igg3_k1));
        robust_update(&mut self.x, &mut self.p, &v, &h, &r, k).is_ok()
    }

    fn ble_update(&mut self, t_ns: i64) -> bool {
        let all = self.front.current(t_ns);
        let Some(ble_floor) = BleFrontEnd::likely_floor(&all, self.ble_cfg.gml.top_n) else {
            return false;
        };
        let floor = tracked_floor(
            &mut self.floors,
            t_ns,
            &all,
            self.ble_cfg.gml.top_n,
            ble_floor,
        );
        let beacons: Vec<_> = all.into_iter().filter(|b| b.floor == floor).collect();
        if beacons.is_empty() {
            return false;
        }
        // weighted centroid of the strongest three: the start, and the BLE
        // position of eq. 9's heading
        let top = &beacons[..beacons.len().min(3)];
        let w: Vec<f64> = top.iter().map(|b| 10f64.powf(b.rssi_dbm / 20.0)).collect();
        let ws: f64 = w.iter().sum();
        let c = top
            .iter()
            .zip(&w)
            .fold(Vec2::zeros(), |a, (b, w)| a + b.pos * *w)
            / ws;
        if let Some(wd) = self.walking.as_mut() {
            wd.on_ble_position(t_ns as f64 * 1e-9, c);
        }
        // a beacon's filtered RSSI is a new measurement only when a report
        // arrived since the last task; between reports the front end keeps
        // the same value (up to its staleness timeout), which must not be
        // fed to the filter again as if it were independent
        let since = self.last_ble_task_ns.replace(t_ns);
        let fresh: Vec<FilteredBeacon> = beacons
            .iter()
            .filter(|b| since.is_none_or(|s| b.last_t_ns > s))
            .copied()
            .collect();
        if !self.initialised || floor != self.floor {
            self.x[0] = c.x;
            self.x[1] = c.y;
            self.p[(0, 0)] = 25.0;
            self.p[(1, 1)] = 25.0;
            self.p[(0, 1)] = 0.0;
            self.p[(1, 0)] = 0.0;
            self.initialised = true;
            self.floor = floor;
        }
        if fresh.is_empty() {
            return true;
        }
        // proximity (eq. 5): the strongest weak-signal beacon when it is near
        let near: Vec<FilteredBeacon> = fresh
            .iter()
            .filter(|b| b.model.rssi_1m_dbm <= self.cfg.proximity_max_rssi_1m_dbm)
            .copied()
            .collect();
        let candidate = (!near.is_empty())
            .then(|| proximity_candidate(&near, self.cfg.proximity_relative_to_r0));
        let mut corrected = false;
        if let Some((strongest, level)) = candidate
            && level - self.x[4] >= self.cfg.proximity_rssi_dbm
        {
            let var = self.cfg.proximity_sigma_m.powi(2);
            if self.position_update(strongest.pos, var, var, self.cfg.proximity_igg3) {
                corrected = true;
                // eqs. 6: GE fixed at this instant
                if let Some(g) = self.last_gnss {
                    self.ge = Some(g - Vec2::new(self.x[0], self.x[1]));
                    self.pdr_since_gnss = Vec2::zeros();
                }
            }
        }
        // ranging (eqs. 16-18, 22-25): z = RSSI, h = R0 - 10 n log10(d) + b,
        // to the strong-signal transmitters (R0 >= ranging_min_rssi_1m_dbm),
        // with `ranging_ahead_only` those in front of the walker
        let pos = Vec2::new(self.x[0], self.x[1]);
        let ahead = self
            .last_step_dir_rad
            .filter(|_| self.cfg.ranging_ahead_only)
            .map(|a| Vec2::new(a.cos(), a.sin()));
        let ranged: Vec<_> = fresh
            .iter()
            .filter(|b| b.rssi_dbm >= self.cfg.ranging_rssi_dbm)
            .filter(|b| b.model.rssi_1m_dbm >= self.cfg.ranging_min_rssi_1m_dbm)
            .filter(|b| ahead.is_none_or(|u| (b.pos - pos).dot(&u) > 0.0))
            .take(self.cfg.ranging_max_beacons)
            .collect();
        // the bias is observed only where the position was just corrected by
        // a proximity fix (eq. 23, Sec. III-C 1); elsewhere the ranging uses
        // the bias as estimated and leaves it alone (eq. 25: its column is 0)
        let bias_column = if corrected { 1.0 } else { 0.0 };
        let m = ranged.len();
        if m > 0 {
            let mut h = DMatrix::zeros(m, 5);
            let mut v = DVector::zeros(m);
            let mut r = DVector::zeros(m);
            for (k, b) in ranged.iter().enumerate() {
                let dxy = pos - b.pos;
                let d2 = dxy.norm_squared() + b.dz_m * b.dz_m;
                let d = d2.sqrt().max(self.ble_cfg.min_distance_m);
                let pred = b.model.rssi_at(d, self.ble_cfg.min_distance_m) + self.x[4];
                let g = -10.0 * b.model.exponent / (LN10 * d.max(1e-6).powi(2));
                h[(k, 0)] = g * dxy.x;
                h[(k, 1)] = g * dxy.y;
                h[(k, 4)] = bias_column;
                v[k] = b.rssi_dbm - pred;
                r[k] = self.cfg.ranging_sigma_db.powi(2);
            }
            let k = Some((self.cfg.igg3_k0, self.cfg.igg3_k1));
            if robust_update(&mut self.x, &mut self.p, &v, &h, &r, k).is_err() {
                self.stats.rejected_inputs += 1;
            }
        }
        true
    }

    fn publish(&mut self, t_ns: i64, heading_rad: f64) {
        if !self.initialised {
            return;
        }
        if !(self.x.iter().all(|v| v.is_finite())) {
            // never publish NaN: restart from the last pose
            self.initialised = false;
            return;
        }
        self.pose = Some(ekf_pose(t_ns, &self.x, &self.p, self.floor, heading_rad));
    }
}

/// The floor an EKF engine works on at `t_ns`: the floor tracker's
/// (barometer changes + this task's BLE floor vote among the strongest
/// `top_n` of `beacons`) when the log has pressure, else `ble_floor`.
/// Shared with `robust-ekf`.
pub(super) fn tracked_floor(
    floors: &mut FloorTracker,
    t_ns: i64,
    beacons: &[FilteredBeacon],
    top_n: usize,
    ble_floor: i32,
) -> i32 {
    if let Some(v) = crate::ble::BleFrontEnd::floor_vote(floors.config(), beacons, top_n) {
        floors.on_ble_floor(t_ns, v);
    }
    if floors.has_pressure() {
        floors.floor().unwrap_or(ble_floor)
    } else {
        ble_floor
    }
}

/// The published pose of an EKF whose state starts with the position
/// [x, y]: its accuracy radius is the root of the position variances' sum.
/// Shared with `robust-ekf`.
pub(super) fn ekf_pose(
    t_ns: i64,
    x: &DVector<f64>,
    p: &DMatrix<f64>,
    floor: i32,
    heading_rad: f64,
) -> Pose {
    Pose {
        t_ns,
        x_m: x[0],
        y_m: x[1],
        floor,
        heading_rad,
        accuracy_m: (p[(0, 0)] + p[(1, 1)]).max(0.0).sqrt(),
        floor_prob: 1.0,
        source: crate::engine::PoseSource::Fused,
    }
}

/// A sensor event of an EKF engine: pressure samples to the floor
/// tracker, everything to the PDR. Shared with `robust-ekf`.
pub(super) fn on_sensor(floors: &mut FloorTracker, pdr: &mut Pdr, event: &SensorEvent) {
    if let SensorData::Pressure(p) = event.data {
        floors.on_pressure(event.t_ns, p);
    }
    pdr.on_sensor(event);
}

impl Engine for TcEkfEngine {
    fn name(&self) -> &'static str {
        "tc-ekf"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        on_sensor(&mut self.floors, &mut self.pdr, event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        self.front.on_observation(obs);
    }

    fn on_gnss(&mut self, fix: &GnssFix) {
        let Some(georef) = self.site.spec.georef.as_ref() else {
            return;
        };
        if !(fix.lat_deg.is_finite() && fix.lon_deg.is_finite())
            || fix.lat_deg.abs() > 90.0
            || fix.lon_deg.abs() > 180.0
        {
            self.stats.rejected_inputs += 1;
            return;
        }
        let acc = fix
            .accuracy_m
            .filter(|a| a.is_finite() && *a > 0.0)
            .unwrap_or(10.0);
        let z = crate::geo::mcs_from_wgs84(
            georef,
            self.site.spec.map_from_enu_rad,
            fix.lat_deg,
            fix.lon_deg,
        );
        // eq. 7: carry GE by GNSS minus PDR displacement
        if let (Some(ge), Some(prev)) = (self.ge, self.last_gnss) {
            self.ge = Some(ge + (z - prev) - self.pdr_since_gnss);
        }
        self.last_gnss = Some(z);
        self.pdr_since_gnss = Vec2::zeros();
        if !self.initialised || acc > self.cfg.gnss_max_accuracy_m {
            return;
        }
        // eq. 8, floored at 1 m; the reported accuracy before the first proximity fix
        let (vx, vy) = match self.ge {
            Some(ge) => (ge.x.abs().max(1.0).powi(2), ge.y.abs().max(1.0).powi(2)),
            None => (acc * acc, acc * acc),
        };
        if self.position_update(z, vx, vy, true) {
            self.gnss_used += 1;
        }
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        self.add_process_noise(t_ns);
        match task {
            Task::Radio => {
                if !self.ble_update(t_ns) {
                    self.stats.no_fix += 1;
                }
                let h = self.pose.map_or(0.0, |p| p.heading_rad);
                self.publish(t_ns, h);
            }
            Task::Fusion => {
                let mut heading = self.pose.map_or(0.0, |p| p.heading_rad);
                for s in self.pdr.take_steps() {
                    self.stats.steps += 1;
                    self.floors.on_step(true);
                    // eq. 9: the walking direction replaces the phone heading
                    // (yaw + dtheta) while the BLE heading agrees with it
                    let phone = s.yaw_rad + self.x[3];
                    let walk = match self.walking.as_mut() {
                        Some(wd) => wd.direction(s.t_ns as f64 * 1e-9, phone),
                        None => phone,
                    };
                    if self.initialised {
                        self.step(s.length_m, walk - self.x[3], walk == phone);
                    }
                    self.last_step_dir_rad = Some(walk);
                    heading = walk;
                }
                if self.floors.has_pressure()
                    && self.initialised
                    && let Some(f) = self.floors.floor()
                {
                    self.floor = f;
                }
                self.publish(t_ns, heading);
            }
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        Some(match task {
            Task::Radio => self.ble_period_ns,
            Task::Fusion => self.fusion_period_ns,
        })
    }

    fn pose(&self) -> Option<Pose> {
        self.pose
    }

    fn stats(&self) -> EngineStats {
        let stages = self.floors.rejected + self.pdr.stats().rejected();
        self.stats.with_stages(self.front.counts(), stages)
    }
}

/// The beacon a proximity fix (eq. 5) would be at, and its level: the
/// loudest beacon and its RSSI, or with `relative_to_r0` the beacon with the
/// largest RSSI - R0 and that difference. `beacons` is not empty.
fn proximity_candidate(beacons: &[FilteredBeacon], relative_to_r0: bool) -> (FilteredBeacon, f64) {
    if !relative_to_r0 {
        return (beacons[0], beacons[0].rssi_dbm);
    }
    beacons
        .iter()
        .map(|b| (*b, b.rssi_dbm - b.model.rssi_1m_dbm))
        .fold(None::<(FilteredBeacon, f64)>, |best, c| match best {
            Some(b) if b.1 >= c.1 => Some(b),
            _ => Some(c),
        })
        .unwrap_or((beacons[0], beacons[0].rssi_dbm))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use crate::site::testkit::{beacon_site, open_map};

    const MODEL: PathLoss = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };
    const SEC: i64 = 1_000_000_000;

    const BEACONS: [(f64, f64); 3] = [(2.0, 2.0), (12.0, 2.0), (2.0, 12.0)];

    /// The beacons of `BEACONS` on a 40 x 30 m open floor; R0 -59 dBm, n 2,
    /// at the phone's height.
    fn engine(at: Vec2, cfg: &EngineConfig) -> TcEkfEngine {
        let site = beacon_site("tc", vec![open_map(40, 30)], &BEACONS, MODEL);
        let init = InitialPosition {
            x_m: at.x,
            y_m: at.y,
            floor: 0,
            heading_rad: None,
        };
        TcEkfEngine::new(site, cfg, Some(init)).unwrap()
    }

    fn report(e: &mut TcEkfEngine, t_ns: i64, beacon: usize, rssi_dbm: f64) {
        e.on_ble(&BleObservation {
            t_ns,
            beacon_id: format!("mac:00:00:00:00:00:{beacon:02X}"),
            rssi_dbm,
            tx_power_dbm: None,
        });
    }

    fn pos(e: &TcEkfEngine) -> Vec2 {
        Vec2::new(e.x[0], e.x[1])
    }

    /// Noise-free reports of `beacons` at `at` from a phone `bias_db` off the models.
    fn hear(e: &mut TcEkfEngine, t_ns: i64, at: Vec2, beacons: &[usize], bias_db: f64) {
        for &i in beacons {
            let b = Vec2::new(BEACONS[i].0, BEACONS[i].1);
            report(e, t_ns, i, MODEL.rssi_at((b - at).norm(), 0.5) + bias_db);
        }
    }

    /// Fault found on the TC replica (issue 18): the front end keeps a
    /// beacon's filtered RSSI for its staleness timeout (6 s) after the last
    /// report, and every BLE task fed that same value to the filter again:
    /// one report at the post gave six proximity fixes, each as confident as
    /// a new one, while the walker moved on. A report is one measurement.
    #[test]
    fn one_report_is_used_by_one_ble_task_only() {
        let mut e = engine(Vec2::new(5.0, 2.0), &EngineConfig::default());
        // one loud report of beacon 0 (3 m away): a proximity fix at (2, 2)
        report(&mut e, SEC / 2, 0, -58.0);
        e.run_task(Task::Radio, SEC);
        let after_fix = pos(&e);
        assert!(after_fix.x < 4.5, "{after_fix:?}");
        // nothing new heard for the next 4 s: nothing may move
        for k in 2..6 {
            e.run_task(Task::Radio, k * SEC);
        }
        assert!(
            (pos(&e) - after_fix).norm() < 1e-9,
            "{after_fix:?} -> {:?}",
            pos(&e)
        );
    }

    /// Eq. 25: away from a proximity fix the ranging uses the bias as
    /// estimated and its column of H is 0; only eq. 23 (ranging at the epoch
    /// of a proximity fix) observes it. Before the fix every ranging update
    /// moved the bias, which then traded off against the distance to a row
    /// of posts (replica: +5 dB at the first post, then the track 25 m off
    /// the walkway).
    #[test]
    fn ranging_away_from_a_proximity_fix_leaves_the_bias_alone() {
        // 7 m from every beacon (-76 dBm, -82 with the bias): no proximity
        let at = Vec2::new(7.0, 7.0);
        let mut e = engine(at, &EngineConfig::default());
        for k in 1..=20 {
            // a phone 6 dB weaker than the models, standing still
            hear(&mut e, k * SEC - SEC / 2, at, &[0, 1, 2], -6.0);
            e.run_task(Task::Radio, k * SEC);
        }
        assert_eq!(e.rssi_bias_db().0, 0.0);
    }

    /// Eq. 23: at a proximity fix the ranging to the other beacons observes
    /// the bias (measured minus model, so -6 for a phone 6 dB weaker).
    /// (Replaces robust_ekf's `tc_ekf_estimates_an_injected_rssi_bias`,
    /// which found the bias of a phone standing 10 m from every beacon, with
    /// no proximity fix: eq. 25 does not allow that.)
    #[test]
    fn ranging_at_proximity_fixes_estimates_the_bias() {
        // 0.5 m from beacon 0 (-53 dBm, -59 with the bias: above -62), 9.5
        // and 10 m from the others
        let at = Vec2::new(2.5, 2.0);
        let mut e = engine(at, &EngineConfig::default());
        for k in 1..=30 {
            hear(&mut e, k * SEC - SEC / 2, at, &[0, 1, 2], -6.0);
            e.run_task(Task::Radio, k * SEC);
        }
        let (b, sd) = e.rssi_bias_db();
        assert!((b + 6.0).abs() < 1.5 && sd < 2.0, "bias {b} +- {sd}");
    }

    /// Sec. III: proximity is the weak-signal transmitters' job. With
    /// `proximity_max_rssi_1m_dbm` below a strong transmitter's R0 a loud
    /// reading of the strong one (R0 -55) cannot give a fix; the weak one
    /// (R0 -79) still can.
    #[test]
    fn proximity_can_be_kept_to_the_weak_transmitters() {
        let mut cfg = EngineConfig::default();
        cfg.ekf.proximity_relative_to_r0 = true;
        cfg.ekf.proximity_rssi_dbm = -8.0;
        cfg.ekf.ranging_rssi_dbm = 0.0;
        let fixes = |max_r0: f64, rssi: f64| {
            let mut c = cfg.clone();
            c.ekf.proximity_max_rssi_1m_dbm = max_r0;
            // beacon 0 at (2, 2) read 2 dB below R0 -59, the filter at (8, 2)
            let mut e = engine(Vec2::new(8.0, 2.0), &c);
            report(&mut e, SEC / 2, 0, rssi);
            e.run_task(Task::Radio, SEC);
            pos(&e).x < 7.0
        };
        assert!(fixes(0.0, -61.0));
        assert!(!fixes(-70.0, -61.0));
        assert!(fixes(-50.0, -61.0));
    }

    /// Fault found on the TC replica: a step that took eq. 9's BLE heading
    /// was propagated along it (position independent of dtheta) but
    /// linearised as if along yaw + dtheta, so the heading error's variance
    /// leaked into the position (replica seed 1: lateral sigma 11.6 m while
    /// the steps followed the BLE heading).
    #[test]
    fn a_step_along_the_ble_heading_does_not_depend_on_the_heading_error() {
        let mut e = engine(Vec2::new(20.0, 12.0), &EngineConfig::default());
        e.p[(3, 3)] = 0.25;
        let p_yy = e.p[(1, 1)];
        e.step(0.7, 0.0 - e.x[3], false);
        let q = (0.05f64 * 0.7).powi(2);
        assert!((e.p[(1, 1)] - p_yy - q).abs() < 1e-12, "{}", e.p[(1, 1)]);
        assert_eq!(e.p[(1, 3)], 0.0);
        // along the phone heading the heading error moves the position
        e.step(0.7, 0.0 - e.x[3], true);
        assert!(e.p[(1, 1)] > p_yy + 0.7 * 0.7 * 0.25 * 0.9);
    }

    /// Eq. 5 is a plain EKF update: a detected proximity puts the user at
    /// the transmitter, however far the filter has drifted. With the BMW
    /// paper's IGG3 gain (`ekf.proximity_igg3`) a filter 20 m off with a
    /// confident covariance rejects every fix that would bring it back
    /// (replica: 31 m behind at a post, every fix rejected).
    #[test]
    fn a_proximity_fix_far_from_a_drifted_filter_is_taken() {
        let start = Vec2::new(22.0, 2.0);
        let mut paper = engine(start, &EngineConfig::default());
        let mut cfg = EngineConfig::default();
        cfg.ekf.proximity_igg3 = true;
        let mut gated = engine(start, &cfg);
        for e in [&mut paper, &mut gated] {
            report(e, SEC / 2, 0, -56.0);
            e.run_task(Task::Radio, SEC);
        }
        // the plain update moves by the gain P / (P + R) = 1 / (1 + 4) of 20 m
        assert!(pos(&paper).x < 19.0, "{:?}", pos(&paper));
        assert!(pos(&gated).x > 21.5, "{:?}", pos(&gated));
    }

    fn beacon(index: usize, rssi_dbm: f64, r0: f64) -> FilteredBeacon {
        FilteredBeacon {
            index,
            floor: 0,
            pos: Vec2::new(index as f64, 0.0),
            dz_m: 1.0,
            model: PathLoss {
                rssi_1m_dbm: r0,
                exponent: 2.0,
            },
            rssi_dbm,
            var_dbm2: 1.0,
            samples: 5,
            last_t_ns: 0,
        }
    }

    /// Issue 18 (TC replica): a weak-signal transmitter (R0 -79 dBm) 1 m
    /// away and a strong one (R0 -55 dBm) 3 m up on the same post. The
    /// absolute rule can only ever pick the strong one (-64.5 dBm), which
    /// at -62 dBm never fires and at -80 dBm fires 17 m away; relative to
    /// R0 the weak one is chosen, 1 dB below its R0.
    #[test]
    fn relative_proximity_picks_the_weak_transmitter_beside_a_strong_one() {
        let loud_far = beacon(0, -64.5, -55.0);
        let weak_near = beacon(1, -80.0, -79.0);
        let sorted = [loud_far, weak_near]; // the front end sorts loudest first
        let (b, level) = proximity_candidate(&sorted, false);
        assert_eq!((b.index, level), (0, -64.5));
        let (b, level) = proximity_candidate(&sorted, true);
        assert_eq!((b.index, level), (1, -1.0));
        // the strong one far away (17.8 m: -80 dBm) is 25 dB below its R0
        let strong_17m = beacon(2, -80.0, -55.0);
        let (b, level) = proximity_candidate(&[strong_17m], true);
        assert_eq!((b.index, level), (2, -25.0));
    }
}
