//! The data engines are built with beside the site and config: a
//! fingerprint database (`robust-ekf`) and a radio map (`tcpf`).

use std::path::Path;
use std::sync::Arc;

use anyhow::Context;
use fpbp_core::engines::EngineData;
use fpbp_core::fingerprint::FingerprintSet;
use fpbp_core::site::Site;

/// Reads a fingerprint database file and resolves it against `site`
/// (errors name the file, and the field or line at fault).
pub fn load(
    path: &Path,
    site: &Site,
    cfg: &fpbp_core::engines::EngineConfig,
) -> anyhow::Result<FingerprintSet> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read fingerprint database {}", path.display()))?;
    FingerprintSet::from_json(&text, site, &cfg.ble).with_context(|| format!("{}", path.display()))
}

/// The engine data of an eval: the database of `--fingerprints FILE`, else,
/// when `engines` include `robust-ekf`, the site's model database built once
/// here (instead of once per log inside each engine).
pub fn engine_data(
    path: Option<&Path>,
    engines: &[String],
    site: &Arc<Site>,
    cfg: &fpbp_core::engines::EngineConfig,
) -> anyhow::Result<EngineData> {
    let fingerprints = match path {
        Some(p) => Some(Arc::new(load(p, site, cfg)?)),
        None if engines.iter().any(|e| e.trim() == "robust-ekf") => Some(Arc::new(
            FingerprintSet::model(site, &cfg.ble, &cfg.ekf.fingerprint),
        )),
        None => None,
    };
    Ok(EngineData {
        fingerprints,
        ..EngineData::default()
    })
}
