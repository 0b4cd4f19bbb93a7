//! The periods of an engine's two tasks (`tasks` in the engine config).

use serde::{Deserialize, Serialize};

/// Periods of the two tasks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TaskConfig {
    /// T_gml: period of the radio task, ms. Default 1000. Also read under
    /// its earlier name `gml_period_ms`.
    #[serde(alias = "gml_period_ms")]
    pub radio_period_ms: u32,
    /// T_fusion: period of the fusion task, ms. Default 200.
    pub fusion_period_ms: u32,
}

impl Default for TaskConfig {
    fn default() -> Self {
        TaskConfig {
            radio_period_ms: 1000,
            fusion_period_ms: 200,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::TaskConfig;

    #[test]
    fn the_radio_period_reads_under_its_earlier_name_too() {
        let old: TaskConfig = serde_json::from_str(r#"{"gml_period_ms": 700}"#).unwrap();
        let new: TaskConfig = serde_json::from_str(r#"{"radio_period_ms": 700}"#).unwrap();
        assert_eq!((old.radio_period_ms, old), (700, new));
    }
}
