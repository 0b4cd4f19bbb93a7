//! The BLE task of `fpbp` / `bp` ([`BleSide`]): front end, GML and the
//! eq. 22 mean filter, publishing x_B.

use crate::Vec2;
use crate::ble::{BleTask, PositionerKind, task::BleFix};
use crate::engines::EngineConfig;
use crate::events::BleObservation;
use crate::site::Site;

/// The BLE task: front end, GML and the eq. 22 mean filter.
pub struct BleSide {
    task: BleTask,
    /// Period of `Task::Radio`, ns.
    pub(super) period_ns: i64,
}

impl BleSide {
    /// A GML task on `site`.
    pub fn new(site: &Site, config: &EngineConfig) -> Self {
        BleSide {
            task: BleTask::new(PositionerKind::Gml, &config.ble, site),
            period_ns: i64::from(config.tasks.radio_period_ms) * 1_000_000,
        }
    }

    /// Hands one scan result to the front end; true when it was used.
    pub fn on_ble(&mut self, obs: &BleObservation) -> bool {
        self.task.on_observation(obs)
    }

    /// One sensor sample (pressure feeds the BLE task's floor tracker).
    pub fn on_sensor(&mut self, e: &crate::events::SensorEvent) {
        self.task.on_sensor(e);
    }

    /// One GML run at `t_ns`; `prev` is the last published fused position.
    pub fn run(&mut self, t_ns: i64, prev: Option<Vec2>) -> Option<BleFix> {
        self.task.run(t_ns, prev)
    }

    /// The last x_B.
    pub fn last(&self) -> Option<BleFix> {
        self.task.last()
    }

    /// Forgets the mean filter and the last x_B (see [`BleTask::reset_position`]).
    pub fn reset_position(&mut self) {
        self.task.reset_position();
    }
}
