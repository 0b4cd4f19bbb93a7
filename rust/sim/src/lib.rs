//! fpbp-sim: synthetic phone logs with dense ground truth on any fpbp site.
//!
//! [`simulate`] plans a walk on one floor of a [`Site`] ([`walk`], [`plan`]),
//! generates the phone's sensors along it ([`imu`]), the BLE scan reports
//! of the site's beacons ([`ble`]) and, when the profile asks, WiFi scans of
//! the site's access points ([`wifi`]), and returns the events in time order with
//! truth points at every step and at 10 Hz. No file I/O: the CLI writes the
//! events with `fpbp_logs`. All randomness comes from one `rand_pcg::Pcg64`
//! seeded with the request's seed, drawn in a fixed order: the same site,
//! profile and seed give the same events bit for bit.
#![forbid(unsafe_code)]

pub mod ble;
pub mod imu;
pub mod noise;
pub mod plan;
pub mod plan_draw;
pub mod profile;
pub mod replica;
pub mod replica_sites;
pub mod replica_survey;
pub mod stats;
pub mod walk;
pub mod wifi;

#[cfg(test)]
mod testmap;

use fpbp_core::events::{LogEvent, SensorData, TruthPoint};
use fpbp_core::site::Site;
use fpbp_core::{Error, Result};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

pub use profile::SimProfile;
pub use walk::{Trajectory, TrueStep};

/// Rate of the regular truth points, Hz.
pub const TRUTH_RATE_HZ: f64 = 10.0;
/// Default start of a simulated log on the elapsedRealtime clock, ns (an
/// arbitrary uptime of 1000 s, so that no timestamp is near zero).
pub const DEFAULT_T0_NS: i64 = 1_000_000_000_000;

/// What to simulate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimRequest {
    /// Length of the log, s.
    pub duration_s: f64,
    /// Seed of the one random generator.
    pub seed: u64,
    /// Floor to walk on (None: the site's first floor).
    pub floor: Option<i32>,
    /// Log start on the elapsedRealtime clock, ns.
    pub t0_ns: i64,
    pub profile: SimProfile,
}

impl SimRequest {
    /// A request with the default profile and start time.
    pub fn new(duration_s: f64, seed: u64) -> SimRequest {
        SimRequest {
            duration_s,
            seed,
            floor: None,
            t0_ns: DEFAULT_T0_NS,
            profile: SimProfile::default(),
        }
    }
}

/// Metadata of a simulated log (for the log header).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimHeader {
    /// Always "fpbp-sim".
    pub generator: String,
    pub generator_version: String,
    pub site_name: String,
    pub floor: i32,
    pub seed: u64,
    pub duration_s: f64,
    pub t0_ns: i64,
    /// The full profile used, so the log can be regenerated.
    pub profile: SimProfile,
    /// Number of true steps that end inside the log.
    pub steps: usize,
    /// Walked distance inside the log, m.
    pub distance_m: f64,
}

/// A simulated log: header, events in time order, and the trajectory
/// (for tests and analysis; it is not written to the log).
#[derive(Debug, Clone)]
pub struct SimLog {
    pub header: SimHeader,
    pub events: Vec<LogEvent>,
    pub trajectory: Trajectory,
}

/// Order of event kinds sharing a timestamp (sensors in Android type order,
/// then BLE, then truth).
fn kind_rank(e: &LogEvent) -> u8 {
    match e {
        LogEvent::Sensor(s) => match s.data {
            SensorData::Accelerometer(_) => 0,
            SensorData::Gyroscope(_) => 1,
            SensorData::Magnetometer(_) => 2,
            SensorData::RotationVector(_) => 3,
            SensorData::GameRotationVector(_) => 4,
            SensorData::Pressure(_) => 5,
        },
        LogEvent::Ble(_) => 6,
        LogEvent::Gnss(_) => 7,
        LogEvent::Wifi(_) => 8,
        LogEvent::Truth(_) => 9,
    }
}

/// Simulates one walk on `site`.
pub fn simulate(site: &Site, req: &SimRequest) -> Result<SimLog> {
    req.profile.validate()?;
    if !(req.duration_s.is_finite() && req.duration_s > 0.0 && req.duration_s <= 86_400.0) {
        return Err(Error::config(
            "duration_s",
            format!("must be in (0, 86400], got {}", req.duration_s),
        ));
    }
    let floor = req.floor.unwrap_or_else(|| site.default_floor());
    let map = site.floor(floor).ok_or_else(|| {
        Error::config(
            "floor",
            format!("site `{}` has no floor {floor}", site.spec.name),
        )
    })?;
    let floor_height_m = site
        .spec
        .floors
        .iter()
        .find(|f| f.id == floor)
        .map_or(0.0, |f| f.height_m);
    let p = &req.profile;
    let mut rng = Pcg64::seed_from_u64(req.seed);
    let traj = walk::walk(map, &p.walk, &p.imu, req.duration_s, &mut rng)?;
    let ctx = imu::ImuContext {
        imu: &p.imu,
        walk: &p.walk,
        map_from_enu_rad: site.spec.map_from_enu_rad,
        floor_height_m,
        floor_size_m: [map.width_m(), map.height_m()],
        t0_ns: req.t0_ns,
    };
    let sensors = imu::sensors(&traj, &ctx, &mut rng);
    let scans = ble::scans(
        site,
        &p.ble,
        &traj,
        floor,
        p.walk.phone_height_m,
        req.t0_ns,
        &mut rng,
    );
    // drawn after everything else, so logs without WiFi are unchanged
    let wifi_scans = match &p.wifi {
        Some(w) => wifi::scans(
            site,
            w,
            &p.ble,
            &traj,
            floor,
            p.walk.phone_height_m,
            req.t0_ns,
            &mut rng,
        ),
        None => Vec::new(),
    };

    // Truth: at every step end and at 10 Hz.
    let mut truth_t: Vec<f64> = traj.steps_in_log().map(|s| s.t_end_s).collect();
    let n10 = (req.duration_s * TRUTH_RATE_HZ).floor() as usize;
    truth_t.extend((0..=n10).map(|k| k as f64 / TRUTH_RATE_HZ));
    let mut truth: Vec<(i64, f64)> = truth_t
        .into_iter()
        .map(|t| (imu::to_ns(req.t0_ns, t), t))
        .collect();
    truth.sort_by_key(|a| a.0);
    truth.dedup_by_key(|a| a.0);

    let mut events: Vec<LogEvent> = Vec::with_capacity(sensors.len() + scans.len() + truth.len());
    events.extend(sensors.into_iter().map(LogEvent::Sensor));
    events.extend(scans.into_iter().map(LogEvent::Ble));
    events.extend(wifi_scans.into_iter().map(LogEvent::Wifi));
    events.extend(truth.into_iter().map(|(t_ns, t)| {
        let q = traj.position_at(t);
        LogEvent::Truth(TruthPoint {
            t_ns,
            x_m: q.x,
            y_m: q.y,
            floor: Some(floor),
        })
    }));
    // Stable: keeps each generator's own order within a (time, kind) tie.
    events.sort_by_key(|e| (e.t_ns(), kind_rank(e)));

    let steps = traj.steps_in_log().count();
    let distance_m = traj.arc_at(req.duration_s);
    Ok(SimLog {
        header: SimHeader {
            generator: "fpbp-sim".into(),
            generator_version: env!("CARGO_PKG_VERSION").into(),
            site_name: site.spec.name.clone(),
            floor,
            seed: req.seed,
            duration_s: req.duration_s,
            t0_ns: req.t0_ns,
            profile: req.profile.clone(),
            steps,
            distance_m,
        },
        events,
        trajectory: traj,
    })
}

#[cfg(test)]
mod sim_tests;
