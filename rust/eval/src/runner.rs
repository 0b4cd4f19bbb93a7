//! Running engines over logs: sites, configs and logs from disk, the start
//! of each engine (own or from truth), one engine over one log.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, bail};
use fpbp_core::engine::replay::{ReplayOutput, Replayer};
use fpbp_core::engine::{Engine, InitialPosition};
use fpbp_core::engines::EngineConfig;
use fpbp_core::events::LogEvent;
use fpbp_core::site::Site;
use fpbp_logs::{ReadOptions, ReadReport};
use serde::Serialize;

/// Loads a site file (site.json + plans) with the map loader.
pub fn load_site(path: &Path) -> anyhow::Result<Arc<Site>> {
    Ok(fpbp_core::site::files::load_site(path)?)
}

/// Reads an engine config (JSON; missing fields take defaults) and applies `--seed`.
/// `path` is a file, or the JSON itself when it starts with `{` and no
/// such file exists (`--config '{"tcpf":{"anchors":{"k":4}}}'`).
pub fn load_config(path: Option<&Path>, seed: Option<u64>) -> anyhow::Result<EngineConfig> {
    let mut cfg = match path {
        Some(p) if p.to_string_lossy().trim_start().starts_with('{') && !p.exists() => {
            EngineConfig::from_json(&p.to_string_lossy())
                .context("inline config (--config '{...}')")?
        }
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read config {}", p.display()))?;
            EngineConfig::from_json(&text).with_context(|| format!("config {}", p.display()))?
        }
        None => EngineConfig::default(),
    };
    if let Some(s) = seed {
        cfg.seed = s;
    }
    cfg.validate()?;
    Ok(cfg)
}

/// Read options for logs replayed on `site`: its georeference (lat/lon truth)
/// and the floor given to truth points that carry none (`--floor`, else the
/// site's floor when it has exactly one).
pub fn read_options(site: &Site, floor: Option<i32>, strict: bool) -> ReadOptions {
    let single = (site.spec.floors.len() == 1).then(|| site.default_floor());
    ReadOptions {
        strict,
        site_georef: site.spec.georef.map(|g| (g, site.spec.map_from_enu_rad)),
        default_floor: floor.or(single),
        ..Default::default()
    }
}

/// A log read into memory (so replay timing measures the engine, not parsing).
pub struct LoadedLog {
    pub path: PathBuf,
    /// The file name, used as the log's name in metrics.
    pub name: String,
    pub events: Vec<LogEvent>,
    pub report: ReadReport,
}

/// Reads a whole log; in lenient mode an I/O error keeps what was read and warns.
pub fn load_log(path: &Path, opts: &ReadOptions) -> anyhow::Result<LoadedLog> {
    let mut r = fpbp_logs::open_log(path, opts)?;
    let mut events = Vec::new();
    loop {
        match r.try_next() {
            Ok(Some(e)) => events.push(e),
            Ok(None) => break,
            Err(e) if !opts.strict && matches!(e, fpbp_logs::LogError::Io { .. }) => {
                log::warn!("{e} (keeping the {} events read before it)", events.len());
                break;
            }
            Err(e) => return Err(e.into()),
        }
    }
    let report = r.report();
    if report.malformed_skipped > 0 {
        log::warn!(
            "{}: {} malformed lines skipped (first: {})",
            path.display(),
            report.malformed_skipped,
            report.first_malformed.as_deref().unwrap_or("?")
        );
    }
    if report.truth_without_georef > 0 {
        log::warn!(
            "{}: {} lat/lon truth points skipped: the site has no georef",
            path.display(),
            report.truth_without_georef
        );
    }
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let log = LoadedLog {
        path: path.to_path_buf(),
        name,
        events,
        report,
    };
    crate::report::warn_dropped(&log);
    Ok(log)
}

/// Whether engines get the first truth point as their start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum InitMode {
    /// Engines find their own start; only `pdr` gets the first truth point.
    None,
    /// Every engine gets the first truth point (as after a tap on the map).
    Truth,
}

/// Engines that need a start position and may read the first truth point.
pub const NEEDS_TRUTH_START: &[&str] = &["pdr"];

/// The start handed to `engine` on `log`, and the index of the event replay
/// begins at. With a start from truth point k at t0 the replay begins after
/// event k: the position is only known from t0 on, and that truth point is not
/// scored (its error would be zero by construction).
pub fn start_for(
    engine: &str,
    mode: InitMode,
    log: &LoadedLog,
    site: &Site,
) -> anyhow::Result<(Option<InitialPosition>, usize)> {
    let wants = mode == InitMode::Truth || NEEDS_TRUTH_START.contains(&engine);
    if !wants {
        return Ok((None, 0));
    }
    let Some((k, tp)) = log
        .events
        .iter()
        .enumerate()
        .find_map(|(k, e)| Some((k, *e.as_truth()?)))
    else {
        bail!(
            "{}: engine `{engine}` needs a start from truth, but the log has no truth point",
            log.path.display()
        );
    };
    let init = InitialPosition {
        x_m: tp.x_m,
        y_m: tp.y_m,
        floor: tp.floor.unwrap_or_else(|| site.default_floor()),
        heading_rad: None,
    };
    Ok((Some(init), k + 1))
}

/// Builds engines by name (the real factory, or a test double).
pub type EngineBuilder<'a> = dyn Fn(&str, Arc<Site>, &EngineConfig, Option<InitialPosition>) -> anyhow::Result<Box<dyn Engine>>
    + Sync
    + 'a;

/// The core's factory.
pub fn core_builder(
    name: &str,
    site: Arc<Site>,
    cfg: &EngineConfig,
    init: Option<InitialPosition>,
) -> anyhow::Result<Box<dyn Engine>> {
    Ok(fpbp_core::engines::build_engine(name, site, cfg, init)?)
}

/// One engine's replay of one log.
pub struct LogRun {
    pub log: String,
    pub init: Option<InitialPosition>,
    pub out: ReplayOutput,
}

/// Replays `log` through engine `name`.
pub fn run_log(
    build: &EngineBuilder,
    name: &str,
    site: &Arc<Site>,
    cfg: &EngineConfig,
    mode: InitMode,
    log: &LoadedLog,
) -> anyhow::Result<LogRun> {
    let (init, start) = start_for(name, mode, log, site)?;
    // the phone model the log says recorded it, unless the config names one
    let with_device;
    let cfg = match &log.report.device {
        Some(d) if cfg.device.is_empty() && fpbp_core::radio::device_offsets::valid_name(d) => {
            with_device = EngineConfig {
                device: d.clone(),
                ..cfg.clone()
            };
            &with_device
        }
        _ => cfg,
    };
    let mut engine =
        build(name, site.clone(), cfg, init).with_context(|| format!("engine `{name}`"))?;
    let mut r = Replayer::new(engine.as_mut());
    for e in &log.events[start..] {
        r.push(e);
    }
    let mut out = r.finish();
    // Both start modes are scored on the same points: every truth point
    // after the log's first (nothing can be known at a log's first instant;
    // with a start from truth that point is the start and is not replayed).
    if start == 0
        && let Some(first) = log.events.iter().find_map(LogEvent::as_truth).copied()
        && out.scored.first().is_some_and(|s| s.truth == first)
    {
        out.scored.remove(0);
    }
    Ok(LogRun {
        log: log.name.clone(),
        init,
        out,
    })
}

/// The engine builder of `eval` and `replay`: `build_engine_with` over
/// `data` (fingerprints, radio map), errors as anyhow.
pub fn builder_with(
    data: fpbp_core::engines::EngineData,
) -> impl Fn(
    &str,
    Arc<fpbp_core::site::Site>,
    &fpbp_core::engines::EngineConfig,
    Option<fpbp_core::engine::InitialPosition>,
) -> anyhow::Result<Box<dyn fpbp_core::engine::Engine>> {
    move |name, site, cfg, init| {
        Ok(fpbp_core::engines::build_engine_with(
            name, site, cfg, init, &data,
        )?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_config_is_a_file_or_inline_json() {
        let cfg = load_config(Some(Path::new(r#"{"tcpf":{"anchors":{"k":4}}}"#)), Some(7)).unwrap();
        assert_eq!(cfg.tcpf.anchors.k, 4);
        assert_eq!(cfg.seed, 7);
        let err =
            load_config(Some(Path::new(r#"{"tcpf":{"no_such_field":1}}"#)), None).unwrap_err();
        assert!(format!("{err:#}").contains("inline config"), "{err:#}");
        let err = load_config(Some(Path::new("no/such/config.json")), None).unwrap_err();
        assert!(
            format!("{err:#}").contains("cannot read config no/such/config.json"),
            "{err:#}"
        );
    }
}
