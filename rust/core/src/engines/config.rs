//! The one config object an engine is built from (JSON through JNI and the
//! CLI): the task periods, the shared parts' sections and every engine's own.

use serde::{Deserialize, Serialize};

use crate::engine::TaskConfig;
use crate::{Result, ble::BleConfig, fusion::FusionConfig, pdr::PdrConfig};

/// Everything an engine needs besides the site.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EngineConfig {
    /// Seed of every RNG the engine owns.
    pub seed: u64,
    /// The phone model the engine runs on (Android `Build.MODEL`; a
    /// replayed log's own, when it says): a radio map whose survey recorded
    /// walks with this model corrects its readings by the model's offsets
    /// per radio (`tcpf`). Empty = not known.
    pub device: String,
    pub tasks: TaskConfig,
    pub pdr: PdrConfig,
    pub ble: BleConfig,
    pub fusion: FusionConfig,
    /// Engine `prox-pf` (proximity-PF paper).
    pub prox_pf: super::prox_pf::ProxPfConfig,
    /// Engine `ppsa` (PPSA paper).
    pub ppsa: super::ppsa::PpsaConfig,
    /// The EKF engines (`robust-ekf`, `tc-ekf`) and the floor tracker.
    pub ekf: crate::kalman::EkfConfig,
    /// WiFi: fresh results, BSSID grouping, AP calibration, `wifi-wcentroid`.
    pub wifi: crate::wifi::WifiConfig,
    /// Engine `tcpf` (tightly coupled radio-likelihood particle filter).
    pub tcpf: super::tcpf::TcpfConfig,
}

impl Default for EngineConfig {
    fn default() -> Self {
        EngineConfig {
            seed: 1,
            device: String::new(),
            tasks: TaskConfig::default(),
            pdr: PdrConfig::default(),
            ble: BleConfig::default(),
            fusion: FusionConfig::default(),
            prox_pf: Default::default(),
            ppsa: Default::default(),
            ekf: crate::kalman::EkfConfig::default(),
            wifi: crate::wifi::WifiConfig::default(),
            tcpf: Default::default(),
        }
    }
}

impl EngineConfig {
    /// Parses a JSON config (missing fields take their defaults, unknown ones are errors).
    pub fn from_json(text: &str) -> Result<Self> {
        let cfg: EngineConfig = serde_json::from_str(text).map_err(|e| {
            let (field, msg) = crate::site::json_path::describe(text.as_bytes(), &e);
            crate::Error::config(field, msg)
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        if !self.device.is_empty() && !crate::radio::device_offsets::valid_name(&self.device) {
            return Err(crate::Error::config(
                "device",
                format!(
                    "a phone model name has 1-{} characters and no control characters",
                    crate::radio::device_offsets::MAX_DEVICE_CHARS
                ),
            ));
        }
        if self.tasks.radio_period_ms == 0 {
            return Err(crate::Error::config("tasks.radio_period_ms", "must be > 0"));
        }
        if self.tasks.fusion_period_ms == 0 {
            return Err(crate::Error::config(
                "tasks.fusion_period_ms",
                "must be > 0",
            ));
        }
        self.pdr.validate()?;
        self.ble.validate()?;
        self.prox_pf.validate()?;
        self.ppsa.validate()?;
        self.ekf.validate()?;
        self.wifi.validate()?;
        self.tcpf.validate()?;
        self.fusion.validate()
    }
}
