//! Engine `pdr`: dead reckoning from a given start (FP-BP's PDR baseline).
//!
//! The start comes from the caller (`InitialPosition`: a tap on the map, or
//! the first truth point under the harness); building without one is an
//! error. On every Fusion task run the steps detected since the last run move
//! the position by length_m along yaw_rad (eq. 3). No BLE, no map: positions
//! may cross walls. The accuracy radius grows linearly with the distance
//! walked (`pdr.start_accuracy_m + pdr.accuracy_per_walked_m * walked`).

use std::sync::Arc;

use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::SensorEvent;
use crate::pdr::Pdr;
use crate::site::Site;
use crate::{Error, Result};

/// Dead reckoning from a known start.
#[derive(Debug, Clone)]
pub struct PdrEngine {
    site: Arc<Site>,
    pdr: Pdr,
    fusion_period_ns: i64,
    x_m: f64,
    y_m: f64,
    floor: i32,
    heading_rad: f64,
    walked_m: f64,
    start_accuracy_m: f64,
    accuracy_per_walked_m: f64,
    last_task_t_ns: Option<i64>,
    stats: EngineStats,
}

impl PdrEngine {
    /// Builds the engine; `init` is required.
    pub fn new(
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Result<Self> {
        config.validate()?;
        let init = init.ok_or_else(|| {
            Error::Input(
                "engine `pdr` needs an initial position (the harness passes the first truth point; \
                 use --init truth)"
                    .to_string(),
            )
        })?;
        crate::engine::check_initial_position(&site, &init)?;
        Ok(PdrEngine {
            pdr: Pdr::new(&config.pdr, site.spec.pdr_rotation_rad()),
            site,
            fusion_period_ns: i64::from(config.tasks.fusion_period_ms) * 1_000_000,
            x_m: init.x_m,
            y_m: init.y_m,
            floor: init.floor,
            heading_rad: init.heading_rad.filter(|h| h.is_finite()).unwrap_or(0.0),
            walked_m: 0.0,
            start_accuracy_m: config.pdr.start_accuracy_m,
            accuracy_per_walked_m: config.pdr.accuracy_per_walked_m,
            last_task_t_ns: None,
            stats: EngineStats::default(),
        })
    }

    /// Distance walked so far, metres.
    pub fn walked_m(&self) -> f64 {
        self.walked_m
    }
}

impl Engine for PdrEngine {
    fn name(&self) -> &'static str {
        "pdr"
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.pdr.on_sensor(event);
    }

    /// Dead reckoning restarts from `at` at `t_ns`: the distance walked (and
    /// so the accuracy radius) starts again, steps detected before are dropped,
    /// the heading is kept when `at` has none.
    fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<()> {
        crate::engine::check_initial_position(&self.site, &at)?;
        drop(self.pdr.take_steps());
        self.x_m = at.x_m;
        self.y_m = at.y_m;
        self.floor = at.floor;
        if let Some(h) = at.heading_rad {
            self.heading_rad = h;
        }
        self.walked_m = 0.0;
        self.last_task_t_ns = Some(t_ns);
        Ok(())
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        if task != Task::Fusion {
            return;
        }
        for step in self.pdr.take_steps() {
            let (s, c) = step.yaw_rad.sin_cos();
            self.x_m += step.length_m * c;
            self.y_m += step.length_m * s;
            self.walked_m += step.length_m;
            self.heading_rad = step.yaw_rad;
            self.stats.steps += 1;
        }
        self.last_task_t_ns = Some(t_ns);
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        match task {
            Task::Radio => None,
            Task::Fusion => Some(self.fusion_period_ns),
        }
    }

    fn pose(&self) -> Option<Pose> {
        Some(Pose {
            t_ns: self.last_task_t_ns.unwrap_or(0),
            x_m: self.x_m,
            y_m: self.y_m,
            floor: self.floor,
            heading_rad: self.heading_rad,
            accuracy_m: self.start_accuracy_m + self.accuracy_per_walked_m * self.walked_m,
            floor_prob: 1.0,
            source: crate::engine::PoseSource::DeadReckoning,
        })
    }

    fn stats(&self) -> EngineStats {
        let pdr = self.pdr.stats().rejected();
        self.stats.with_stages(Default::default(), pdr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::replay::replay;
    use crate::events::{LogEvent, SensorData, TruthPoint};
    use crate::pdr::PdrConfig;
    use crate::pdr::orientation::to_android;
    use crate::site::testkit::open_map;
    use nalgebra::{UnitQuaternion, Vector3};

    fn open_site() -> Arc<Site> {
        let model = crate::ble::pathloss::PathLoss {
            rssi_1m_dbm: -59.0,
            exponent: 2.0,
        };
        crate::site::testkit::beacon_site("t", vec![open_map(50, 50)], &[], model)
    }

    #[test]
    fn needs_an_initial_position() {
        let err = PdrEngine::new(open_site(), &EngineConfig::default(), None).unwrap_err();
        assert!(err.to_string().contains("initial position"), "{err}");
    }

    #[test]
    fn set_position_restarts_dead_reckoning_there() {
        let init = InitialPosition {
            x_m: 10.0,
            y_m: 5.0,
            floor: 0,
            heading_rad: Some(1.0),
        };
        let mut eng = PdrEngine::new(open_site(), &EngineConfig::default(), Some(init)).unwrap();
        let at = InitialPosition {
            x_m: 2.0,
            y_m: 3.0,
            floor: 0,
            heading_rad: None,
        };
        eng.set_position(77, at).unwrap();
        let p = eng.pose().unwrap();
        assert_eq!((p.t_ns, p.x_m, p.y_m, p.heading_rad), (77, 2.0, 3.0, 1.0));
        assert_eq!(p.accuracy_m, PdrConfig::default().start_accuracy_m);
        let bad = InitialPosition { floor: 2, ..at };
        assert!(eng.set_position(78, bad).is_err());
        assert_eq!(eng.pose().unwrap().t_ns, 77);
    }

    #[test]
    fn walks_north_from_the_start_and_is_scored() {
        let init = InitialPosition {
            x_m: 10.0,
            y_m: 5.0,
            floor: 0,
            heading_rad: None,
        };
        let mut eng = PdrEngine::new(open_site(), &EngineConfig::default(), Some(init)).unwrap();
        assert_eq!(eng.task_period_ns(Task::Radio), None);
        // 20 s of walking at 1.8 Hz, phone flat, top pointing north (identity quaternion).
        let q = UnitQuaternion::identity();
        let mut events = Vec::new();
        for i in 0..1000i64 {
            let t_ns = i * 20_000_000;
            let t = t_ns as f64 * 1e-9;
            let acc = Vector3::new(
                0.0,
                0.0,
                9.81 + 2.5 * (std::f64::consts::TAU * 1.8 * t).sin(),
            );
            events.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::Accelerometer(acc.into()),
            }));
            events.push(LogEvent::Sensor(SensorEvent {
                t_ns,
                data: SensorData::RotationVector(to_android(&q)),
            }));
        }
        events.push(LogEvent::Truth(TruthPoint {
            t_ns: 19_990_000_000,
            x_m: 10.0,
            y_m: 30.0,
            floor: Some(0),
        }));
        let out = replay(&mut eng, events);
        let pose = eng.pose().unwrap();
        let stats = eng.stats();
        // 36 peaks; the first (0.14 s) comes before the window is full and the
        // last is detected after the last task run, so 34 are applied.
        assert!((34..=36).contains(&stats.steps), "{} steps", stats.steps);
        let cfg = PdrConfig::default();
        let amp = 2.5 / (1.0f64 + (1.8 / cfg.low_pass_cutoff_hz).powi(2)).sqrt();
        let z_pp = amp * (1.0 - (std::f64::consts::TAU * 1.8 * cfg.half_window_s).cos());
        let expect_len = cfg.step_length_beta * z_pp.powf(0.25);
        assert!((pose.x_m - 10.0).abs() < 1e-6);
        let walked = pose.y_m - 5.0;
        assert!((walked - eng.walked_m()).abs() < 1e-9);
        assert!(
            (walked / stats.steps as f64 - expect_len).abs() < 0.05,
            "mean step {}",
            walked / stats.steps as f64
        );
        assert!(pose.accuracy_m > cfg.start_accuracy_m + cfg.accuracy_per_walked_m * 10.0);
        assert_eq!(out.scored.len(), 1);
        assert!(out.scored[0].error_m().unwrap() < 10.0);
    }
}
