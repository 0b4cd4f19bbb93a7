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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::EngineConfig;
    use crate::engines::pdr::PdrEngine;
    use crate::events::{SensorData, WifiResult};

    /// Guards that the wrapper counts every input it passes on, those the
    /// engine ignores too (`pdr` uses neither BLE nor WiFi), and keeps the
    /// engine's own counters: without it such inputs would go uncounted.
    #[test]
    fn counts_the_inputs_and_keeps_the_engines_own_counters() {
        let at = InitialPosition {
            x_m: 7.0,
            y_m: 4.0,
            floor: 0,
            heading_rad: None,
        };
        let site = crate::engines::prox_pf::testkit::site();
        let pdr = PdrEngine::new(site, &EngineConfig::default(), Some(at)).unwrap();
        let mut e = CountedInputs::new(Box::new(pdr));
        for t in 0..3 {
            e.on_sensor(&SensorEvent {
                t_ns: t,
                // a gyroscope sample with a NaN: the PDR's own rejection
                data: SensorData::Gyroscope([f64::NAN, 0.0, 0.0]),
            });
        }
        e.on_ble(&BleObservation {
            t_ns: 5,
            beacon_id: "b".into(),
            rssi_dbm: -60.0,
            tx_power_dbm: None,
        });
        let result = WifiResult {
            bssid: "02:00:00:00:00:01".into(),
            rssi_dbm: -70.0,
            freq_mhz: 2412,
            seen_t_ns: 5,
        };
        e.on_wifi(&WifiScan {
            t_ns: 6,
            results: vec![result.clone(), result],
        });
        e.on_wifi(&WifiScan {
            t_ns: 7,
            results: Vec::new(),
        });
        let s = e.stats();
        assert_eq!((s.sensor_events, s.ble_observations), (3, 1));
        assert_eq!((s.wifi_scans, s.wifi_results), (2, 2));
        assert_eq!((s.rejected_inputs, e.name()), (3, "pdr"));
    }
}
