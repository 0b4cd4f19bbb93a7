//! The input counting every engine shares.
//!
//! [`CountedInputs`] wraps an engine and counts what it is handed (sensor
//! events, BLE observations, WiFi scans and their results) before passing it
//! on, so an engine counts only what is its own (rejected inputs, unknown
//! beacons, steps, runs without a fix). An input an engine does not use is
//! left to the [`Engine`] trait's default, which ignores it: the wrapper has
//! counted it already. [`super::build_engine`] hands out every engine
//! wrapped.

use super::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::ble::frontend::FrontEndCounts;
use crate::events::{BleObservation, GnssFix, SensorEvent, WifiScan};

impl EngineStats {
    /// These counters (an engine's own) with what its input stages counted:
    /// the unknown beacons and rejected observations of its BLE front end
    /// (`front`, default when it has none) and `rejected` inputs the other
    /// stages refused (the PDR's skipped samples, the floor tracker's bad
    /// pressures, ...), each added to the engine's own.
    pub fn with_stages(&self, front: FrontEndCounts, rejected: u64) -> EngineStats {
        EngineStats {
            unknown_beacons: self.unknown_beacons + front.unknown,
            rejected_inputs: self.rejected_inputs + front.rejected + rejected,
            ..self.clone()
        }
    }
}

/// An engine with its inputs counted (see the module).
pub struct CountedInputs {
    engine: Box<dyn Engine>,
    sensor_events: u64,
    ble_observations: u64,
    wifi_scans: u64,
    wifi_results: u64,
}

impl CountedInputs {
    pub fn new(engine: Box<dyn Engine>) -> Self {
        CountedInputs {
            engine,
            sensor_events: 0,
            ble_observations: 0,
            wifi_scans: 0,
            wifi_results: 0,
        }
    }
}

impl Engine for CountedInputs {
    fn name(&self) -> &'static str {
        self.engine.name()
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.sensor_events += 1;
        self.engine.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        self.ble_observations += 1;
        self.engine.on_ble(obs);
    }

    fn on_gnss(&mut self, fix: &GnssFix) {
        self.engine.on_gnss(fix);
    }

    fn on_wifi(&mut self, scan: &WifiScan) {
        self.wifi_scans += 1;
        self.wifi_results += scan.results.len() as u64;
        self.engine.on_wifi(scan);
    }

    fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> crate::Result<()> {
        self.engine.set_position(t_ns, at)
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        self.engine.run_task(task, t_ns);
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        self.engine.task_period_ns(task)
    }

    fn pose(&self) -> Option<Pose> {
        self.engine.pose()
    }

    fn ble_position(&self) -> Option<Pose> {
        self.engine.ble_position()
    }

    fn stats(&self) -> EngineStats {
        EngineStats {
            sensor_events: self.sensor_events,
            ble_observations: self.ble_observations,
            wifi_scans: self.wifi_scans,
            wifi_results: self.wifi_results,
            ..self.engine.stats()
        }
    }

    fn diagnostics(&self) -> Vec<(&'static str, u64)> {
        self.engine.diagnostics()
    }
}
