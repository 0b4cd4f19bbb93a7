//! The JSON form of a [`RadioMap`]: format `fpbp-radio-map`, version 1
//! (docs/formats.md, "Radio map"). The core does no I/O: callers hand the
//! text (CLI: a file; app: a string through JNI) and get the map, resolved
//! against the site (its floors; the map carries its own fallback models).
//! Errors name the field at fault (`transmitters[3].grids[0].nx`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::device_offsets::{self, DeviceOffset};

use super::magnetic_map::MagneticMap;
use super::model::{Transmitter, TxKind};
use super::radio_map::{FallbackParams, Grid, MapEntry, NO_VALUE, RadioMap};
use super::reference_scans::{ReferenceScan, ReferenceScanConfig, ReferenceScans};
use crate::Vec2;
use crate::ble::pathloss::PathLoss;
use crate::bounds::{MAX_RADIO_MAP_CELLS, MAX_RADIO_MAP_GRID_CELLS, MAX_RADIO_MAP_TRANSMITTERS};
use crate::radio_id::normalize_beacon_id;
use crate::site::Site;
use crate::{Error, Result};

/// `format` of a radio map file.
pub const FORMAT: &str = "fpbp-radio-map";
/// Current `version`: 2 added the optional `reference_scans` section, 3
/// the optional `magnetic` section, 4 the optional `device_offsets`; older
/// files (without them) still read.
pub const VERSION: u32 = 4;

/// The file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadioMapFile {
    /// Always `fpbp-radio-map`.
    pub format: String,
    pub version: u32,
    /// Name of the site it was built on (informative).
    #[serde(default)]
    pub site: String,
    #[serde(default)]
    pub fallback: FallbackParams,
    /// At most [`MAX_RADIO_MAP_TRANSMITTERS`] (counted while parsing).
    #[serde(deserialize_with = "transmitters")]
    pub transmitters: Vec<TxFile>,
    /// The survey's scan vectors (version 2), for `tcpf`'s anchors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_scans: Option<ReferenceScansFile>,
    /// The survey's magnetic field (version 3), for `tcpf`'s magnetic
    /// likelihood.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub magnetic: Option<MagneticFile>,
    /// The survey's phone models' offsets per radio, dB (version 4;
    /// [`super::device_offsets`]).
    #[serde(
        default,
        skip_serializing_if = "BTreeMap::is_empty",
        deserialize_with = "devices"
    )]
    pub device_offsets: BTreeMap<String, DeviceOffset>,
}

// Element limits applied while parsing (`bounds::json`): a file past one is
// refused at the element past it, before the collection grows further.
fn transmitters<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<TxFile>, D::Error> {
    crate::bounds::json::vec(d, MAX_RADIO_MAP_TRANSMITTERS)
}
pub(crate) fn grids<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<Grid>, D::Error> {
    crate::bounds::json::vec(d, crate::bounds::MAX_RADIO_MAP_GRIDS)
}
fn devices<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<BTreeMap<String, DeviceOffset>, D::Error> {
    crate::bounds::json::map(d, device_offsets::MAX_DEVICES)
}
fn reference_ids<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<IdFile>, D::Error> {
    crate::bounds::json::vec(d, super::reference_scans::MAX_REFERENCE_IDS)
}
fn reference_scans<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<ReferenceScan>, D::Error> {
    crate::bounds::json::vec(d, super::reference_scans::MAX_REFERENCE_SCANS)
}

/// The `magnetic` section ([`MagneticMap`]): one grid per floor of the
/// field's magnitude, in the transmitters' grid layout with values in
/// 0.1 uT (`mean_dbm_x10` / `sd_dbm_x10` hold uT x 10 here).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagneticFile {
    #[serde(deserialize_with = "grids")]
    pub grids: Vec<Grid>,
}

/// The `reference_scans` section ([`ReferenceScans`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceScansFile {
    #[serde(default)]
    pub config: ReferenceScanConfig,
    /// Transmitters, indexed by the scans' entries.
    #[serde(deserialize_with = "reference_ids")]
    pub ids: Vec<IdFile>,
    #[serde(deserialize_with = "reference_scans")]
    pub scans: Vec<ReferenceScan>,
}

/// One transmitter of the reference scans.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdFile {
    pub kind: KindFile,
    /// Beacon id (any spelling) or BSSID.
    pub id: String,
}

/// `ble` or `wifi`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KindFile {
    Ble,
    Wifi,
}

/// One transmitter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TxFile {
    /// Beacon id (any spelling) or BSSID.
    pub id: String,
    pub kind: KindFile,
    /// Its floor (path-loss fallback) and position (the site's, or its
    /// strongest cell's), MCS metres.
    pub floor: i32,
    pub x_m: f64,
    pub y_m: f64,
    /// The site's path-loss model, when it had one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pathloss: Option<PathLossFile>,
    /// Readings and walks it was learned from.
    #[serde(default)]
    pub samples: usize,
    #[serde(default)]
    pub walks: usize,
    #[serde(default, deserialize_with = "grids")]
    pub grids: Vec<Grid>,
}

/// A path-loss fallback.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathLossFile {
    /// Mounting height minus phone height, metres.
    pub dz_m: f64,
    pub rssi_1m_dbm: f64,
    pub exponent: f64,
}

fn kind_of(k: KindFile) -> TxKind {
    match k {
        KindFile::Ble => TxKind::Ble,
        KindFile::Wifi => TxKind::Wifi,
    }
}

fn bad<T>(field: String, msg: String) -> Result<T> {
    Err(Error::Input(format!("radio map: field `{field}`: {msg}")))
}

impl RadioMap {
    /// The serialisable form.
    pub fn to_file(&self) -> RadioMapFile {
        RadioMapFile {
            format: FORMAT.into(),
            // the lowest version that holds what the file carries, so a
            // map without a magnetic section stays readable by builds
            // that read version 2
            version: if !self.devices.is_empty() {
                4
            } else if self.magnetic.is_some() {
                3
            } else {
                2
            },
            site: self.site_name.clone(),
            fallback: self.fallback,
            transmitters: self
                .tx
                .iter()
                .zip(&self.entries)
                .map(|(t, e)| TxFile {
                    id: t.id.clone(),
                    kind: match t.kind {
                        TxKind::Ble => KindFile::Ble,
                        TxKind::Wifi => KindFile::Wifi,
                    },
                    floor: t.floor,
                    x_m: (t.pos.x * 100.0).round() / 100.0,
                    y_m: (t.pos.y * 100.0).round() / 100.0,
                    pathloss: e.has_pathloss.then_some(PathLossFile {
                        dz_m: t.dz_m,
                        rssi_1m_dbm: t.model.rssi_1m_dbm,
                        exponent: t.model.exponent,
                    }),
                    samples: e.samples,
                    walks: e.walks,
                    grids: e.grids.clone(),
                })
                .collect(),
            reference_scans: self.scans.as_ref().map(|r| ReferenceScansFile {
                config: *r.config(),
                ids: r
                    .ids()
                    .iter()
                    .map(|(k, id)| IdFile {
                        kind: match k {
                            TxKind::Ble => KindFile::Ble,
                            TxKind::Wifi => KindFile::Wifi,
                        },
                        id: id.clone(),
                    })
                    .collect(),
                scans: r.scans().to_vec(),
            }),
            magnetic: self.magnetic.as_ref().map(|m| MagneticFile {
                grids: m.grids().to_vec(),
            }),
            device_offsets: self.devices.clone(),
        }
    }

    /// JSON text of [`RadioMap::to_file`].
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(&self.to_file())
            .map_err(|e| Error::Input(format!("radio map: cannot serialise: {e}")))
    }

    /// Parses and resolves JSON text (see [`RadioMap::from_file`]); syntax
    /// and type errors name the field.
    pub fn from_json(text: &str, site: &Site) -> Result<Self> {
        let file: RadioMapFile = serde_json::from_str(text).map_err(|e| {
            let (field, msg) = crate::site::json_path::describe(text.as_bytes(), &e);
            Error::Input(format!("radio map: field `{field}`: {msg}"))
        })?;
        Self::from_file_owned(file, site)
    }

    /// Checks a parsed file and resolves it against `site`: every floor
    /// must be one of the site's, every number finite and in range, every
    /// grid's arrays `nx * ny` long; sizes bounded. Errors name the field.
    pub fn from_file(file: &RadioMapFile, site: &Site) -> Result<Self> {
        Self::from_file_owned(file.clone(), site)
    }

    /// [`RadioMap::from_file`] taking the file: its grids and scans move
    /// into the map instead of being copied (a parsed map is not held
    /// twice).
    pub fn from_file_owned(file: RadioMapFile, site: &Site) -> Result<Self> {
        if file.format != FORMAT {
            return bad(
                "format".into(),
                format!(
                    "is `{}`, expected `{FORMAT}`",
                    crate::bounds::echo(&file.format)
                ),
            );
        }
        if !(1..=VERSION).contains(&file.version) {
            return bad(
                "version".into(),
                format!("is {}, this build reads 1 to {VERSION}", file.version),
            );
        }
        file.fallback.validate("fallback")?;
        if file.transmitters.len() > MAX_RADIO_MAP_TRANSMITTERS {
            return bad(
                "transmitters".into(),
                format!(
                    "{} entries, over the limit of {MAX_RADIO_MAP_TRANSMITTERS}",
                    file.transmitters.len()
                ),
            );
        }
        let floor_ok = |f: i32| site.floor(f).is_some();
        let mut total_cells = 0usize;
        let mut tx = Vec::with_capacity(file.transmitters.len());
        let mut entries = Vec::with_capacity(file.transmitters.len());
        for (ti, t) in file.transmitters.into_iter().enumerate() {
            let at = format!("transmitters[{ti}]");
            let kind = kind_of(t.kind);
            let id = match kind {
                TxKind::Ble => match normalize_beacon_id(&t.id) {
                    Ok(id) => id,
                    Err(e) => return bad(format!("{at}.id"), e),
                },
                TxKind::Wifi if crate::wifi::is_bssid(&t.id) => t.id.to_ascii_lowercase(),
                TxKind::Wifi => {
                    return bad(
                        format!("{at}.id"),
                        format!("`{}` is not a BSSID", crate::bounds::echo(&t.id)),
                    );
                }
            };
            if !floor_ok(t.floor) {
                return bad(
                    format!("{at}.floor"),
                    format!("floor {} is not in the site", t.floor),
                );
            }
            for (f, v) in [("x_m", t.x_m), ("y_m", t.y_m)] {
                if !v.is_finite() {
                    return bad(format!("{at}.{f}"), "must be finite".into());
                }
            }
            let (dz_m, model) = match t.pathloss {
                Some(p) => {
                    for (f, v) in [
                        ("dz_m", p.dz_m),
                        ("rssi_1m_dbm", p.rssi_1m_dbm),
                        ("exponent", p.exponent),
                    ] {
                        if !v.is_finite() {
                            return bad(format!("{at}.pathloss.{f}"), "must be finite".into());
                        }
                    }
                    if p.exponent <= 0.0 {
                        return bad(format!("{at}.pathloss.exponent"), "must be > 0".into());
                    }
                    (
                        p.dz_m,
                        PathLoss {
                            rssi_1m_dbm: p.rssi_1m_dbm,
                            exponent: p.exponent,
                        },
                    )
                }
                None => (
                    0.0,
                    PathLoss {
                        rssi_1m_dbm: file.fallback.prior_dbm,
                        exponent: 2.0,
                    },
                ),
            };
            let has_pathloss = t.pathloss.is_some();
            let grids = check_grids(&at, t.grids, &floor_ok, RSSI_RANGE, &mut total_cells)?;
            tx.push(Transmitter {
                id,
                kind,
                floor: t.floor,
                pos: Vec2::new(t.x_m, t.y_m),
                dz_m,
                model,
            });
            entries.push(MapEntry {
                has_pathloss,
                samples: t.samples,
                walks: t.walks,
                grids,
            });
        }
        let mut map = RadioMap::assemble(site, tx, entries, file.fallback)?;
        if let Some(r) = file.reference_scans {
            map.set_reference_scans(reference_scans_of(r, &floor_ok)?);
        }
        if let Some(m) = file.magnetic {
            let grids = check_grids(
                "magnetic",
                m.grids,
                &floor_ok,
                MAGNETIC_RANGE,
                &mut total_cells,
            )?;
            map.set_magnetic(Some(MagneticMap::new(grids)));
        }
        map.set_device_offsets(device_offsets_of(file.device_offsets)?);
        Ok(map)
    }
}

/// The checked `device_offsets` section: at most
/// [`device_offsets::MAX_DEVICES`] models with valid names and finite
/// offsets within +-60 dB.
fn device_offsets_of(d: BTreeMap<String, DeviceOffset>) -> Result<device_offsets::DeviceOffsets> {
    if d.len() > device_offsets::MAX_DEVICES {
        return bad(
            "device_offsets".into(),
            format!(
                "{} phone models, at most {}",
                d.len(),
                device_offsets::MAX_DEVICES
            ),
        );
    }
    for (name, o) in &d {
        if !device_offsets::valid_name(name) {
            return bad(
                "device_offsets".into(),
                format!(
                    "`{}` is not a phone model name (1-{} characters, no control characters)",
                    crate::bounds::echo(name),
                    device_offsets::MAX_DEVICE_CHARS
                ),
            );
        }
        for (f, v) in [("ble_db", o.ble_db), ("wifi_db", o.wifi_db)] {
            if let Some(v) = v
                && !(v.is_finite() && v.abs() <= 60.0)
            {
                return bad(
                    format!("device_offsets.{}.{f}", crate::bounds::echo(name)),
                    format!("must be finite and within +-60 dB, got {v}"),
                );
            }
        }
    }
    Ok(d)
}

/// The checked [`ReferenceScans`] of a file section.
fn reference_scans_of(
    r: ReferenceScansFile,
    floor_ok: &dyn Fn(i32) -> bool,
) -> Result<ReferenceScans> {
    if r.ids.len() > super::reference_scans::MAX_REFERENCE_IDS {
        return bad(
            "reference_scans.ids".into(),
            format!("over {} entries", super::reference_scans::MAX_REFERENCE_IDS),
        );
    }
    let mut ids = Vec::with_capacity(r.ids.len());
    for (i, t) in r.ids.iter().enumerate() {
        let kind = kind_of(t.kind);
        let id = match kind {
            TxKind::Ble => match normalize_beacon_id(&t.id) {
                Ok(id) => id,
                Err(e) => return bad(format!("reference_scans.ids[{i}].id"), e),
            },
            TxKind::Wifi if t.id.len() <= 64 => t.id.to_ascii_lowercase(),
            TxKind::Wifi => {
                return bad(
                    format!("reference_scans.ids[{i}].id"),
                    "longer than 64 characters".into(),
                );
            }
        };
        ids.push((kind, id));
    }
    if let Some(i) = r.scans.iter().position(|s| !floor_ok(s.floor)) {
        return bad(
            format!("reference_scans.scans[{i}].floor"),
            format!("floor {} is not in the site", r.scans[i].floor),
        );
    }
    ReferenceScans::new(r.config, ids, r.scans)
}

/// The checked `grids` of the section at `at` (`at.grids[i]`): each by
/// [`check_grid`], at most one per floor, and their cells added to
/// `total_cells`, which may not pass [`MAX_RADIO_MAP_CELLS`].
fn check_grids(
    at: &str,
    grids: Vec<Grid>,
    floor_ok: &dyn Fn(i32) -> bool,
    range: (i16, i16, &str),
    total_cells: &mut usize,
) -> Result<Vec<Grid>> {
    let mut out: Vec<Grid> = Vec::with_capacity(grids.len());
    for (gi, g) in grids.into_iter().enumerate() {
        let at = format!("{at}.grids[{gi}]");
        *total_cells = total_cells.saturating_add(g.mean_dbm_x10.len());
        if *total_cells > MAX_RADIO_MAP_CELLS {
            return bad(
                format!("{at}.mean_dbm_x10"),
                format!("the map holds over {MAX_RADIO_MAP_CELLS} cells"),
            );
        }
        check_grid(&at, &g, floor_ok, range)?;
        if out.iter().any(|o| o.floor == g.floor) {
            return bad(
                format!("{at}.floor"),
                format!("a second grid for floor {}", g.floor),
            );
        }
        out.push(g);
    }
    Ok(out)
}

/// Range of a transmitter grid's means (0.1 dBm) and of a magnetic one's
/// (0.1 uT), with the unit for messages.
const RSSI_RANGE: (i16, i16, &str) = (-2000, 200, "0.1 dBm");
const MAGNETIC_RANGE: (i16, i16, &str) = (
    0,
    (super::magnetic_map::MAX_FIELD_UT * 10.0) as i16,
    "0.1 uT",
);

fn check_grid(
    at: &str,
    g: &Grid,
    floor_ok: &dyn Fn(i32) -> bool,
    (lo, hi, unit): (i16, i16, &str),
) -> Result<()> {
    if !floor_ok(g.floor) {
        return bad(
            format!("{at}.floor"),
            format!("floor {} is not in the site", g.floor),
        );
    }
    for (f, v) in [("x0_m", g.x0_m), ("y0_m", g.y0_m)] {
        if !(v.is_finite() && v.abs() <= crate::bounds::MAX_FLOOR_SIDE_M) {
            return bad(
                format!("{at}.{f}"),
                format!(
                    "must be finite and within +-{} m",
                    crate::bounds::MAX_FLOOR_SIDE_M
                ),
            );
        }
    }
    if !(g.cell_m.is_finite() && (0.05..=1000.0).contains(&g.cell_m)) {
        return bad(
            format!("{at}.cell_m"),
            format!(
                "must be in [0.05, 1000], got {}",
                crate::bounds::show(g.cell_m)
            ),
        );
    }
    if g.nx == 0 || g.ny == 0 {
        return bad(format!("{at}.nx"), "nx and ny must be >= 1".into());
    }
    let n = match g.nx.checked_mul(g.ny) {
        Some(n) if n <= MAX_RADIO_MAP_GRID_CELLS => n,
        _ => {
            return bad(
                format!("{at}.nx"),
                format!(
                    "nx x ny = {} x {} is over the limit of {MAX_RADIO_MAP_GRID_CELLS} cells",
                    g.nx, g.ny
                ),
            );
        }
    };
    for (f, v) in [
        ("mean_dbm_x10", &g.mean_dbm_x10),
        ("sd_dbm_x10", &g.sd_dbm_x10),
    ] {
        if v.len() != n {
            return bad(
                format!("{at}.{f}"),
                format!("has {} values, nx x ny = {n}", v.len()),
            );
        }
    }
    for (k, (&m, &s)) in g.mean_dbm_x10.iter().zip(&g.sd_dbm_x10).enumerate() {
        if (m == NO_VALUE) != (s == NO_VALUE) {
            return bad(
                format!("{at}.sd_dbm_x10[{k}]"),
                "no value (-32768) in one array but not in the other".into(),
            );
        }
        if m != NO_VALUE && !(lo..=hi).contains(&m) {
            return bad(
                format!("{at}.mean_dbm_x10[{k}]"),
                format!("{m} is outside [{lo}, {hi}] ({unit})"),
            );
        }
        if s != NO_VALUE && s < 1 {
            return bad(
                format!("{at}.sd_dbm_x10[{k}]"),
                format!("{s} must be >= 1 (0.1 units)"),
            );
        }
    }
    Ok(())
}
