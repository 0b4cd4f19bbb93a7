//! The engine registry: every engine the harness and JNI know, by name,
//! and how each is built from the site, the config and its data.

use std::sync::Arc;

use super::EngineConfig;
#[cfg(test)]
use crate::engine::EngineStats;
use crate::engine::{CountedInputs, Engine, InitialPosition, check_initial_position};
use crate::{Error, Result, site::Site};

/// Names accepted by [`build_engine`], in the order `fpbp eval` lists them.
pub const ENGINE_NAMES: &[&str] = &[
    "tcpf",
    "scan-knn",
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
    "wifi-wcentroid",
];

/// The sections of [`EngineConfig`] engine `name` reads (its settings:
/// what `fpbp config --engine NAME` prints), in the config's field order.
/// Errors on an unknown name.
pub fn config_sections(name: &str) -> Result<&'static [&'static str]> {
    Ok(match name {
        "tcpf" => &["seed", "device", "tasks", "pdr", "ble", "ekf", "tcpf"],
        "scan-knn" => &["tasks", "tcpf"],
        "fpbp" | "bp" => &["seed", "tasks", "pdr", "ble", "fusion"],
        "pdr" => &["tasks", "pdr"],
        "gml" | "trilat" | "frbw" | "ml" | "wcentroid" => &["tasks", "ble"],
        "wifi-wcentroid" => &["tasks", "ble", "wifi"],
        "prox-pf" => &["seed", "pdr", "ble", "prox_pf"],
        "ppsa" => &["seed", "pdr", "ble", "ppsa"],
        "robust-ekf" | "tc-ekf" => &["tasks", "pdr", "ble", "ekf"],
        _ => return Err(unknown_engine(name)),
    })
}

/// The settings engine `name` reads from `config`, as the JSON text
/// `--config` takes (pretty-printed, in the config's field order): the
/// sections of [`config_sections`] with every field written, so a config
/// read back from it builds the same engine.
pub fn engine_settings_json(name: &str, config: &EngineConfig) -> Result<String> {
    fn pretty<T: serde::Serialize>(v: &T) -> Result<String> {
        serde_json::to_string_pretty(v).map_err(|e| Error::Input(format!("config: {e}")))
    }
    let mut out = String::from("{");
    for (k, section) in config_sections(name)?.iter().enumerate() {
        let text = match *section {
            "seed" => pretty(&config.seed)?,
            "device" => pretty(&config.device)?,
            "tasks" => pretty(&config.tasks)?,
            "pdr" => pretty(&config.pdr)?,
            "ble" => pretty(&config.ble)?,
            "fusion" => pretty(&config.fusion)?,
            "prox_pf" => pretty(&config.prox_pf)?,
            "ppsa" => pretty(&config.ppsa)?,
            "ekf" => pretty(&config.ekf)?,
            "wifi" => pretty(&config.wifi)?,
            "tcpf" => pretty(&config.tcpf)?,
            other => unreachable!("config_sections names no section `{other}`"),
        };
        let sep = if k == 0 { "" } else { "," };
        out.push_str(&format!(
            "{sep}\n  \"{section}\": {}",
            text.replace('\n', "\n  ")
        ));
    }
    out.push_str("\n}\n");
    Ok(out)
}

fn unknown_engine(name: &str) -> Error {
    Error::UnknownEngine(name.to_string(), ENGINE_NAMES.join(", "))
}

/// Data some engines can use besides site and config (handed as parsed
/// structs: the core does no I/O).
#[derive(Debug, Clone, Default)]
pub struct EngineData {
    /// Fingerprint databases for `robust-ekf` (e.g. a walked survey database,
    /// [`crate::fingerprint::FingerprintSet::from_json`]); without them it
    /// builds model databases from the site.
    pub fingerprints: Option<Arc<crate::fingerprint::FingerprintSet>>,
    /// A radio map learned from survey walks for `tcpf`
    /// ([`crate::radio::RadioMap::from_json`]); without it `tcpf` weighs
    /// with the site's path-loss models.
    pub radio_map: Option<Arc<crate::radio::RadioMap>>,
}

impl EngineData {
    /// The data in one JSON document, told apart by its `format` field: an
    /// `fpbp-radio-map` ([`crate::radio::RadioMap::from_json`], for `tcpf`)
    /// or an `fpbp-fingerprints` database (anything else, including text
    /// that does not parse: its errors are the fingerprint parser's). Both
    /// are resolved against `site`; errors name the field.
    pub fn from_json(text: &str, site: &Site, ble: &crate::ble::BleConfig) -> Result<Self> {
        #[derive(serde::Deserialize)]
        struct Head {
            #[serde(default)]
            format: String,
        }
        let head = serde_json::from_str::<Head>(text).ok().map(|h| h.format);
        if head.as_deref() == Some(crate::radio::radio_map_file::FORMAT) {
            return Ok(EngineData {
                radio_map: Some(Arc::new(crate::radio::RadioMap::from_json(text, site)?)),
                ..EngineData::default()
            });
        }
        Ok(EngineData {
            fingerprints: Some(Arc::new(crate::fingerprint::FingerprintSet::from_json(
                text, site, ble,
            )?)),
            ..EngineData::default()
        })
    }
}

/// Builds engine `name` on `site`. `init` hands the engine a start position;
/// without it the engine finds its own start (only `pdr` requires one).
pub fn build_engine(
    name: &str,
    site: Arc<Site>,
    config: &EngineConfig,
    init: Option<InitialPosition>,
) -> Result<Box<dyn Engine>> {
    build_engine_with(name, site, config, init, &EngineData::default())
}

/// [`build_engine`] with extra data (engines that do not use it ignore it).
/// The engine comes wrapped in [`CountedInputs`].
pub fn build_engine_with(
    name: &str,
    site: Arc<Site>,
    config: &EngineConfig,
    init: Option<InitialPosition>,
    data: &EngineData,
) -> Result<Box<dyn Engine>> {
    config.validate()?;
    if let Some(at) = &init {
        check_initial_position(&site, at)?;
    }
    let engine: Box<dyn Engine> = if let Some(e) =
        super::ble_only::BleOnlyEngine::new_wifi(name, site.clone(), config, init)
    {
        Box::new(e)
    } else if let Some(kind) = crate::ble::PositionerKind::from_name(name) {
        Box::new(super::ble_only::BleOnlyEngine::new(
            kind, site, config, init,
        ))
    } else {
        match name {
            "fpbp" | "bp" => Box::new(super::fpbp::FpbpEngine::new(
                site,
                config,
                name == "fpbp",
                init,
            )?),
            "tcpf" => Box::new(match &data.radio_map {
                Some(m) => super::tcpf::TcpfEngine::with_model(site, config, init, m.clone())?,
                None => super::tcpf::TcpfEngine::new(site, config, init)?,
            }),
            "scan-knn" => {
                let model: Arc<dyn crate::radio::RadioModel> = match &data.radio_map {
                    Some(m) => m.clone(),
                    None => {
                        return Err(Error::Input(
                            "engine `scan-knn` needs a radio map with reference scans \
                             (`fpbp calibrate --radio-map`, then `--radio-map`)"
                                .into(),
                        ));
                    }
                };
                Box::new(super::scan_knn::ScanKnnEngine::new(config, model)?)
            }
            "pdr" => Box::new(super::pdr::PdrEngine::new(site, config, init)?),
            "prox-pf" => Box::new(super::prox_pf::ProxPfEngine::new(site, config, init)?),
            "ppsa" => Box::new(super::ppsa::PpsaEngine::new(site, config, init)?),
            "robust-ekf" => Box::new(match &data.fingerprints {
                Some(fp) => super::robust_ekf::RobustEkfEngine::with_fingerprints(
                    site,
                    config,
                    init,
                    fp.clone(),
                )?,
                None => super::robust_ekf::RobustEkfEngine::new(site, config, init)?,
            }),
            "tc-ekf" => Box::new(super::tc_ekf::TcEkfEngine::new(site, config, init)?),
            _ => return Err(unknown_engine(name)),
        }
    };
    Ok(Box::new(CountedInputs::new(engine)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::replay::replay;
    use crate::engines::prox_pf::testkit::{site, walk_north};
    use crate::events::{BleObservation, LogEvent, SensorData, SensorEvent, WifiResult, WifiScan};

    #[test]
    fn every_engine_prints_settings_that_read_back_as_the_defaults() {
        let defaults = EngineConfig::default();
        for name in ENGINE_NAMES {
            let text = engine_settings_json(name, &defaults).unwrap();
            let back =
                EngineConfig::from_json(&text).unwrap_or_else(|e| panic!("{name}: {e}\n{text}"));
            assert_eq!(back, defaults, "{name}");
        }
        let mut other = EngineConfig::default();
        other.tcpf.particle_count = 7;
        other.seed = 9;
        let text = engine_settings_json("tcpf", &other).unwrap();
        assert_eq!(EngineConfig::from_json(&text).unwrap(), other);
        let pdr: serde_json::Value =
            serde_json::from_str(&engine_settings_json("pdr", &defaults).unwrap()).unwrap();
        let keys: Vec<&str> = pdr
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        assert_eq!(keys, ["pdr", "tasks"], "sorted by serde_json's map");
        assert!(matches!(
            engine_settings_json("nope", &defaults),
            Err(Error::UnknownEngine(..))
        ));
    }

    fn scan(t_ns: i64, n: usize) -> LogEvent {
        LogEvent::Wifi(WifiScan {
            t_ns,
            results: (0..n)
                .map(|k| WifiResult {
                    bssid: format!("02:00:00:00:00:{k:02x}"),
                    rssi_dbm: -60.0 - k as f64,
                    freq_mhz: 2412,
                    seen_t_ns: t_ns - 1_000_000,
                })
                .collect(),
        })
    }

    /// The one start-position rule (builds and `set_position` alike): each
    /// way a position can be wrong is refused with the field named. Guards
    /// against a rule dropped or an engine checking its own way.
    #[test]
    fn a_start_position_is_checked_field_by_field() {
        let site = site();
        let at = |x_m: f64, floor: i32, heading_rad: Option<f64>| InitialPosition {
            x_m,
            y_m: 1.0,
            floor,
            heading_rad,
        };
        assert!(check_initial_position(&site, &at(1.0, 0, Some(0.5))).is_ok());
        assert!(check_initial_position(&site, &at(1.0, 0, None)).is_ok());
        let wrong = |a: InitialPosition| check_initial_position(&site, &a).unwrap_err().to_string();
        assert!(wrong(at(f64::NAN, 0, None)).contains("must be finite"));
        assert!(wrong(at(1.0, 0, Some(f64::INFINITY))).contains("heading_rad"));
        let e = wrong(at(1.0, 3, None));
        assert!(e.contains("floor 3") && e.contains("floors: 0"), "{e}");
        assert!(wrong(at(-1.0, 0, None)).contains("outside floor 0's plan"));
        // an engine's set_position refuses what a build refuses
        let cfg = EngineConfig::default();
        for name in ["pdr", "fpbp", "gml"] {
            let mut e = build_engine(name, site.clone(), &cfg, Some(at(1.0, 0, None))).unwrap();
            let msg = e
                .set_position(0, at(-1.0, 0, None))
                .unwrap_err()
                .to_string();
            assert!(msg.contains("outside floor 0's plan"), "{name}: {msg}");
            assert!(e.set_position(0, at(2.0, 0, None)).is_ok(), "{name}");
        }
    }

    /// Engines that do not use WiFi count its scans and results and
    /// otherwise behave exactly as without them.
    #[test]
    fn every_engine_counts_and_ignores_wifi_scans() {
        let plain = walk_north(12, None);
        let mut with_wifi = Vec::new();
        for (i, e) in plain.iter().enumerate() {
            with_wifi.push(e.clone());
            // after the first event, so the task clocks start alike
            if i == 5 {
                with_wifi.push(scan(e.t_ns(), 3));
            }
            if i == plain.len() / 2 {
                with_wifi.push(scan(e.t_ns(), 0));
            }
        }
        let init = Some(InitialPosition {
            x_m: 7.0,
            y_m: 4.0,
            floor: 0,
            heading_rad: None,
        });
        // the WiFi engines use the scans (tests in engines::ble_only);
        // scan-knn needs a radio map (tests in rust/core/tests/tcpf_anchors.rs)
        for name in ENGINE_NAMES
            .iter()
            .filter(|n| !n.starts_with("wifi-") && **n != "scan-knn")
        {
            let cfg = EngineConfig::default();
            let run = |events: &[LogEvent]| {
                let mut e = build_engine(name, site(), &cfg, init).unwrap();
                replay(e.as_mut(), events.iter().cloned())
            };
            let a = run(&plain);
            let b = run(&with_wifi);
            assert_eq!((b.stats.wifi_scans, b.stats.wifi_results), (2, 3), "{name}");
            assert_eq!((a.stats.wifi_scans, a.stats.wifi_results), (0, 0), "{name}");
            let strip = |s: &EngineStats| EngineStats {
                wifi_scans: 0,
                wifi_results: 0,
                ..s.clone()
            };
            assert_eq!(strip(&a.stats), strip(&b.stats), "{name}");
            assert_eq!(a.track, b.track, "{name}");
            assert!(!a.track.is_empty(), "{name}: no pose at all");
        }
    }

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
        let pdr =
            crate::engines::pdr::PdrEngine::new(site, &EngineConfig::default(), Some(at)).unwrap();
        let mut e = crate::engine::CountedInputs::new(Box::new(pdr));
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
