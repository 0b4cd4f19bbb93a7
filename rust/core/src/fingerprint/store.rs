//! Fingerprint databases of every floor of a site, ready for matching
//! ([`FingerprintSet`]: clustered once when built or loaded, never on first
//! use), and their serialisable form ([`FingerprintFile`], JSON format
//! `fpbp-fingerprints` version 1, documented in docs/fingerprints.md).
//!
//! The file names beacons by id, not by registry index, so it stays valid
//! when the site's beacon list is reordered; it is resolved against a site
//! (positions and path-loss models from site.json) with
//! [`FingerprintSet::from_file`]. The core does no I/O: callers hand the
//! JSON text (CLI: a file; app: bytes through JNI).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::FingerprintConfig;
use super::cluster::SubDatabases;
use super::db::{DbBeacon, Fingerprint, FingerprintDb};
use crate::Vec2;
use crate::ble::BleConfig;
use crate::ble::grid::rect_grid;
use crate::ble::registry::BeaconRegistry;
use crate::map::FloorMap;
use crate::site::Site;
use crate::{Error, Result};

/// `format` of a fingerprint file.
pub const FORMAT: &str = "fpbp-fingerprints";
/// Current `version` of a fingerprint file.
pub const VERSION: u32 = 1;

/// One floor's database and its sub-databases (Table 1).
#[derive(Debug, Clone, PartialEq)]
pub struct FloorDb {
    pub db: FingerprintDb,
    pub sub: SubDatabases,
}

impl FloorDb {
    /// Clusters `db` (AP + relative-density outliers, `cfg`).
    pub fn cluster(db: FingerprintDb, cfg: &FingerprintConfig) -> Self {
        let vecs: Vec<Vec<f64>> = db.points.iter().map(|p| p.rssi_dbm.clone()).collect();
        let sub = SubDatabases::build(
            &vecs,
            cfg.ap_damping,
            cfg.ap_iterations,
            cfg.density_k,
            cfg.outlier_relative_density,
        );
        FloorDb { db, sub }
    }
}

/// Where a set's reference points came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// Path-loss models at walkable grid points (eq. 6 everywhere).
    Model,
    /// Walked survey logs (eq. 3 with start/end compensation, eqs. 4-6 fill).
    Survey,
}

/// The clustered databases of a site's floors.
#[derive(Debug, Clone, PartialEq)]
pub struct FingerprintSet {
    pub source: Source,
    pub floors: BTreeMap<i32, FloorDb>,
}

/// The beacons of `floor` in `registry` as database beacons.
pub fn floor_beacons(registry: &BeaconRegistry, ble: &BleConfig, floor: i32) -> Vec<DbBeacon> {
    registry
        .beacons()
        .iter()
        .enumerate()
        .filter(|(_, b)| b.floor == floor)
        .map(|(i, b)| DbBeacon {
            registry_index: i,
            pos: b.pos,
            dz_m: b.z_m - ble.phone_height_m,
            model: b.model,
        })
        .collect()
}

/// The walkable points of a rectangular grid over `map` at `interval_m`.
pub fn walkable_grid(map: &FloorMap, interval_m: f64) -> Vec<Vec2> {
    rect_grid(map.width_m(), map.height_m(), interval_m)
        .into_iter()
        .filter(|p| map.is_walkable(*p))
        .collect()
}

/// The model database of `floor`: the beacons' path-loss models at walkable
/// grid points (`grid_step_m`, coarsened by 1.25x until at most
/// `max_points_per_floor`). None without beacons or walkable points.
pub fn model_floor_database(
    site: &Site,
    registry: &BeaconRegistry,
    ble: &BleConfig,
    cfg: &FingerprintConfig,
    floor: i32,
) -> Option<FingerprintDb> {
    let map = site.floor(floor)?;
    let beacons = floor_beacons(registry, ble, floor);
    if beacons.is_empty() {
        return None;
    }
    let mut step = cfg.grid_step_m;
    let mut grid = walkable_grid(map, step);
    while grid.len() > cfg.max_points_per_floor {
        step *= 1.25;
        grid = walkable_grid(map, step);
    }
    if grid.is_empty() {
        return None;
    }
    Some(FingerprintDb::from_model(
        beacons,
        &grid,
        cfg.missing_rssi_dbm,
        ble.min_distance_m,
    ))
}

impl FingerprintSet {
    /// The model databases of every floor of `site`, clustered now.
    pub fn model(site: &Site, ble: &BleConfig, cfg: &FingerprintConfig) -> Self {
        let registry = BeaconRegistry::new(&site.spec.beacons);
        let floors = site
            .spec
            .floors
            .iter()
            .filter_map(|f| {
                model_floor_database(site, &registry, ble, cfg, f.id)
                    .map(|db| (f.id, FloorDb::cluster(db, cfg)))
            })
            .collect();
        FingerprintSet {
            source: Source::Model,
            floors,
        }
    }

    /// Total reference points over all floors.
    pub fn points(&self) -> usize {
        self.floors.values().map(|f| f.db.points.len()).sum()
    }

    /// The serialisable form (beacons by id, RSSI rounded to 0.01 dB).
    pub fn to_file(&self, site: &Site) -> FingerprintFile {
        let registry = BeaconRegistry::new(&site.spec.beacons);
        let r2 = |v: f64| (v * 100.0).round() / 100.0;
        FingerprintFile {
            format: FORMAT.to_string(),
            version: VERSION,
            site: site.spec.name.clone(),
            source: self.source,
            floors: self
                .floors
                .iter()
                .map(|(&floor, f)| FloorFile {
                    floor,
                    missing_rssi_dbm: f.db.missing_rssi_dbm,
                    beacons: f
                        .db
                        .beacons
                        .iter()
                        .map(|b| {
                            registry
                                .get(b.registry_index)
                                .map_or_else(String::new, |r| r.id.clone())
                        })
                        .collect(),
                    clusters: f.sub.members.len(),
                    reassigned: f.sub.reassigned,
                    points: f
                        .db
                        .points
                        .iter()
                        .zip(&f.sub.label)
                        .map(|(p, &c)| PointFile {
                            x_m: r2(p.pos.x),
                            y_m: r2(p.pos.y),
                            cluster: c,
                            rssi_dbm: p.rssi_dbm.iter().map(|&v| r2(v)).collect(),
                        })
                        .collect(),
                })
                .collect(),
        }
    }

    /// Resolves a file against `site`: every beacon id must be a beacon of
    /// that floor in site.json (positions and models come from the site),
    /// every RSSI vector as long as the beacon list and finite, every
    /// cluster label below `clusters`. Errors name the field at fault.
    pub fn from_file(file: &FingerprintFile, site: &Site, ble: &BleConfig) -> Result<Self> {
        let bad = |field: String, msg: String| {
            Err(Error::Input(format!(
                "fingerprint database: field `{field}`: {msg}"
            )))
        };
        if file.format != FORMAT {
            return bad(
                "format".into(),
                format!("is `{}`, expected `{FORMAT}`", file.format),
            );
        }
        if file.version != VERSION {
            return bad(
                "version".into(),
                format!("is {}, this build reads {VERSION}", file.version),
            );
        }
        let registry = BeaconRegistry::new(&site.spec.beacons);
        let mut floors = BTreeMap::new();
        for (fi, f) in file.floors.iter().enumerate() {
            if site.floor(f.floor).is_none() {
                return bad(
                    format!("floors[{fi}].floor"),
                    format!("floor {} is not in the site", f.floor),
                );
            }
            if floors.contains_key(&f.floor) {
                return bad(
                    format!("floors[{fi}].floor"),
                    format!("floor {} appears twice", f.floor),
                );
            }
            if !f.missing_rssi_dbm.is_finite() {
                return bad(
                    format!("floors[{fi}].missing_rssi_dbm"),
                    "must be finite".into(),
                );
            }
            let mut beacons = Vec::with_capacity(f.beacons.len());
            for (bi, id) in f.beacons.iter().enumerate() {
                let Some(i) = registry.lookup(id) else {
                    return bad(
                        format!("floors[{fi}].beacons[{bi}]"),
                        format!("beacon `{id}` is not in the site"),
                    );
                };
                let Some(b) = registry.get(i).filter(|b| b.floor == f.floor) else {
                    return bad(
                        format!("floors[{fi}].beacons[{bi}]"),
                        format!("beacon `{id}` is not on floor {}", f.floor),
                    );
                };
                beacons.push(DbBeacon {
                    registry_index: i,
                    pos: b.pos,
                    dz_m: b.z_m - ble.phone_height_m,
                    model: b.model,
                });
            }
            if f.clusters == 0 && !f.points.is_empty() {
                return bad(
                    format!("floors[{fi}].clusters"),
                    "must be >= 1 when the floor has points".into(),
                );
            }
            let mut db = FingerprintDb::new(beacons, f.missing_rssi_dbm);
            let mut label = Vec::with_capacity(f.points.len());
            for (pi, p) in f.points.iter().enumerate() {
                let at = format!("floors[{fi}].points[{pi}]");
                if !(p.x_m.is_finite() && p.y_m.is_finite()) {
                    return bad(format!("{at}.x_m/y_m"), "must be finite".into());
                }
                if p.rssi_dbm.len() != db.beacons.len() {
                    return bad(
                        format!("{at}.rssi_dbm"),
                        format!(
                            "has {} values for {} beacons",
                            p.rssi_dbm.len(),
                            db.beacons.len()
                        ),
                    );
                }
                if p.rssi_dbm.iter().any(|v| !v.is_finite()) {
                    return bad(format!("{at}.rssi_dbm"), "must be finite".into());
                }
                if p.cluster >= f.clusters {
                    return bad(
                        format!("{at}.cluster"),
                        format!("is {}, the floor has {} clusters", p.cluster, f.clusters),
                    );
                }
                label.push(p.cluster);
                db.points.push(Fingerprint {
                    pos: Vec2::new(p.x_m, p.y_m),
                    rssi_dbm: p.rssi_dbm.clone(),
                });
            }
            let vecs: Vec<Vec<f64>> = db.points.iter().map(|p| p.rssi_dbm.clone()).collect();
            let Some(sub) = SubDatabases::from_labels(&vecs, label, f.clusters, f.reassigned)
            else {
                return bad(format!("floors[{fi}].points"), "bad cluster labels".into());
            };
            if !db.points.is_empty() {
                floors.insert(f.floor, FloorDb { db, sub });
            }
        }
        Ok(FingerprintSet {
            source: file.source,
            floors,
        })
    }

    /// Parses and resolves JSON text (see [`FingerprintSet::from_file`]);
    /// syntax errors name the line and column.
    pub fn from_json(text: &str, site: &Site, ble: &BleConfig) -> Result<Self> {
        let file: FingerprintFile = serde_json::from_str(text).map_err(|e| {
            Error::Input(format!(
                "fingerprint database: line {}, column {}: {e}",
                e.line(),
                e.column()
            ))
        })?;
        Self::from_file(&file, site, ble)
    }
}

/// The JSON form of a [`FingerprintSet`] (format `fpbp-fingerprints`, version 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FingerprintFile {
    /// Always `fpbp-fingerprints`.
    pub format: String,
    /// Format version, 1.
    pub version: u32,
    /// Name of the site it was built for (informative).
    pub site: String,
    /// `survey` or `model`.
    pub source: Source,
    pub floors: Vec<FloorFile>,
}

/// One floor of a [`FingerprintFile`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorFile {
    /// Floor id as in site.json.
    pub floor: i32,
    /// RSSI floor of the values, dBm.
    pub missing_rssi_dbm: f64,
    /// Beacon ids (site.json spelling or canonical), the order of every `rssi_dbm` vector.
    pub beacons: Vec<String>,
    /// Number of sub-databases (AP clusters after the outlier rule).
    pub clusters: usize,
    /// Points the relative-density rule moved to another cluster.
    pub reassigned: usize,
    pub points: Vec<PointFile>,
}

/// One reference point of a [`FloorFile`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointFile {
    /// Position in the floor's MCS, metres.
    pub x_m: f64,
    pub y_m: f64,
    /// Sub-database (cluster) index, < `clusters`.
    pub cluster: usize,
    /// RSSI per beacon of the floor, dBm (missing values filled).
    pub rssi_dbm: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fingerprint::survey::SurveyBuilder;
    use crate::fingerprint::survey::tests::{rv_pdr, site, straight_walk};

    fn survey_set() -> FingerprintSet {
        let site = site();
        let mut b = SurveyBuilder::new(
            &site,
            &BleConfig::default(),
            &rv_pdr(),
            &FingerprintConfig::default(),
        );
        b.add_log(&straight_walk(1.4, 20.0).0);
        b.finish()
    }

    #[test]
    fn json_round_trip_keeps_points_beacons_and_clusters() {
        let site = site();
        let set = survey_set();
        let text = serde_json::to_string(&set.to_file(&site)).unwrap();
        let back = FingerprintSet::from_json(&text, &site, &BleConfig::default()).unwrap();
        assert_eq!(back.source, Source::Survey);
        assert_eq!(back.floors.len(), set.floors.len());
        for (f, a) in &set.floors {
            let b = &back.floors[f];
            assert_eq!(a.db.beacons, b.db.beacons);
            assert_eq!(a.sub.label, b.sub.label);
            assert_eq!(a.sub.members, b.sub.members);
            assert_eq!(a.db.points.len(), b.db.points.len());
            for (p, q) in a.db.points.iter().zip(&b.db.points) {
                assert!((p.pos - q.pos).norm() < 0.01);
                for (x, y) in p.rssi_dbm.iter().zip(&q.rssi_dbm) {
                    assert!((x - y).abs() <= 0.005 + 1e-9);
                }
            }
        }
        // model sets round-trip too
        let m = FingerprintSet::model(&site, &BleConfig::default(), &FingerprintConfig::default());
        assert_eq!(m.source, Source::Model);
        let text = serde_json::to_string(&m.to_file(&site)).unwrap();
        let back = FingerprintSet::from_json(&text, &site, &BleConfig::default()).unwrap();
        assert_eq!(back.points(), m.points());
    }

    #[test]
    fn bad_files_are_errors_naming_the_field() {
        let site = site();
        let file = survey_set().to_file(&site);
        let ble = BleConfig::default();
        let check = |f: &FingerprintFile, needle: &str| {
            let e = FingerprintSet::from_file(f, &site, &ble)
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{e}");
        };
        let mut f = file.clone();
        f.format = "x".into();
        check(&f, "`format`");
        let mut f = file.clone();
        f.version = 9;
        check(&f, "`version`");
        let mut f = file.clone();
        f.floors[0].beacons[2] = "mac:11:22:33:44:55:66".into();
        check(&f, "floors[0].beacons[2]");
        let mut f = file.clone();
        f.floors[0].points[3].rssi_dbm.pop();
        check(&f, "floors[0].points[3].rssi_dbm");
        let mut f = file.clone();
        f.floors[0].points[1].cluster = 999;
        check(&f, "floors[0].points[1].cluster");
        let mut f = file.clone();
        f.floors[0].floor = 7;
        check(&f, "floors[0].floor");
        let mut f = file.clone();
        f.floors[0].points[0].x_m = f64::NAN;
        check(&f, "floors[0].points[0].x_m");
        let e = FingerprintSet::from_json("{\"format\": 1", &site, &ble)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1"), "{e}");
        let e = FingerprintSet::from_json("{\"format\":\"fpbp-fingerprints\",\"version\":1,\"site\":\"\",\"source\":\"survey\",\"floors\":[],\"extra\":1}", &site, &ble)
            .unwrap_err()
            .to_string();
        assert!(e.contains("extra"), "{e}");
    }
}
