//! The periods of an engine's two tasks (`tasks` in the engine config).

use serde::{Deserialize, Serialize};

/// Periods of the two tasks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TaskConfig {
    /// T_gml: period of the BLE task, ms. Default 1000.
    pub gml_period_ms: u32,
    /// T_fusion: period of the fusion task, ms. Default 200.
    pub fusion_period_ms: u32,
}

impl Default for TaskConfig {
    fn default() -> Self {
        TaskConfig {
            gml_period_ms: 1000,
            fusion_period_ms: 200,
        }
    }
}
