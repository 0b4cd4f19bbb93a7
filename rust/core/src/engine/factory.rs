//! Builds an engine by name. Every engine the harness and JNI know is listed here.

use std::sync::Arc;

use super::{Engine, EngineConfig, InitialPosition};
use crate::{Error, Result, site::Site};

/// Names accepted by [`build_engine`], in the order `fpbp eval` lists them.
pub const ENGINE_NAMES: &[&str] = &[
    "fpbp",
    "bp",
    "pdr",
    "gml",
    "trilat",
    "frbw",
    "ml",
    "wcentroid",
    "prox-pf",
    "ppsa",
    "robust-ekf",
    "tc-ekf",
];

/// Builds engine `name` on `site`. `init` hands the engine a start position;
/// without it the engine finds its own start (only `pdr` requires one).
pub fn build_engine(
    name: &str,
    site: Arc<Site>,
    config: &EngineConfig,
    init: Option<InitialPosition>,
) -> Result<Box<dyn Engine>> {
    config.validate()?;
    if let Some(kind) = crate::ble::PositionerKind::from_name(name) {
        return Ok(Box::new(crate::engines::ble_only::BleOnlyEngine::new(
            kind, site, config, init,
        )));
    }
    match name {
        "fpbp" | "bp" => Ok(Box::new(crate::engines::fpbp::FpbpEngine::new(
            site,
            config,
            name == "fpbp",
            init,
        )?)),
        "pdr" => Ok(Box::new(crate::engines::pdr::PdrEngine::new(
            site, config, init,
        )?)),
        "prox-pf" => Ok(Box::new(crate::engines::prox_pf::ProxPfEngine::new(
            site, config, init,
        )?)),
        "ppsa" => Ok(Box::new(crate::engines::ppsa::PpsaEngine::new(
            site, config, init,
        )?)),
        "robust-ekf" => Ok(Box::new(crate::engines::robust_ekf::RobustEkfEngine::new(
            site, config, init,
        )?)),
        "tc-ekf" => Ok(Box::new(crate::engines::tc_ekf::TcEkfEngine::new(
            site, config, init,
        )?)),
        _ => Err(Error::UnknownEngine(
            name.to_string(),
            ENGINE_NAMES.join(", "),
        )),
    }
}
