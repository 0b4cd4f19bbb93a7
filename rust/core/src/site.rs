//! The site file (site.json, format version 1): floors with their stylized
//! plans, beacons, the colour legend and the frames. Documented in
//! docs/formats.md. This module holds the serde schema and its validation;
//! `Site::build` turns a validated spec plus the plan bytes into maps.

use serde::{Deserialize, Serialize};

use crate::map::FloorMap;

/// site.json as written on disk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SiteSpec {
    /// Always "fpbp-site".
    pub format: String,
    /// Format version; this reader knows 1.
    pub version: u32,
    /// Human-readable name of the site.
    pub name: String,
    /// Rotation from the east-north frame to the MCS, radians, counter-clockwise:
    /// a vector [e, n] in ENU is [x, y] = R(map_from_enu_rad) [e, n] in the MCS.
    /// Magnetic declination is folded in here.
    #[serde(default)]
    pub map_from_enu_rad: f64,
    /// Colour legend of the stylized plans.
    #[serde(default)]
    pub legend: Legend,
    /// GML grid interval I_M, metres (FP-BP Sec. IV-A4).
    #[serde(default = "default_grid_interval_m")]
    pub grid_interval_m: f64,
    /// Floors, at least one.
    pub floors: Vec<FloorSpec>,
    /// Beacons; may be empty (PDR-only sites, or before `fpbp calibrate`).
    #[serde(default)]
    pub beacons: Vec<BeaconSpec>,
    /// Optional WGS-84 georeference of the MCS (for GNSS and lat/lon truth).
    #[serde(default)]
    pub georef: Option<GeoRef>,
}

fn default_grid_interval_m() -> f64 {
    1.0
}

/// Colours (RGB) of the stylized plan and the tolerance of the classifier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Legend {
    pub wall: [u8; 3],
    pub door: [u8; 3],
    pub walkable: [u8; 3],
    /// Largest Euclidean RGB distance at which a pixel still takes a class.
    pub tolerance: f64,
    /// Above this fraction of unclassified pixels the plan is rejected.
    pub max_unclassified_fraction: f64,
}

impl Default for Legend {
    fn default() -> Self {
        Legend {
            wall: [0, 0, 0],
            door: [255, 0, 0],
            walkable: [255, 255, 255],
            tolerance: 60.0,
            max_unclassified_fraction: 0.01,
        }
    }
}

/// One floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorSpec {
    /// Floor id used by beacons, truth and poses (e.g. 0, -1, -2).
    pub id: i32,
    #[serde(default)]
    pub name: String,
    /// Path of the stylized plan PNG, relative to the site file. `None` means an
    /// open floor: a walkable rectangle of `open_area_m` with a wall border.
    #[serde(default)]
    pub plan: Option<String>,
    /// Resolution factor r of the plan, pixels per metre (eq. 23).
    #[serde(default)]
    pub pixels_per_meter: Option<f64>,
    /// Downsample the plan to about this r when building the map (optional).
    #[serde(default)]
    pub target_pixels_per_meter: Option<f64>,
    /// [width, height] in metres of an open floor (only when `plan` is None).
    #[serde(default)]
    pub open_area_m: Option<[f64; 2]>,
    /// Height of the floor above the site's reference, metres (barometric floors).
    #[serde(default)]
    pub height_m: f64,
}

/// One beacon with its log-distance model (FP-BP eq. 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeaconSpec {
    /// `ibeacon:UUID:major:minor`, `eddystone:NAMESPACE:INSTANCE` or `mac:AA:BB:CC:DD:EE:FF`.
    pub id: String,
    pub floor: i32,
    pub x_m: f64,
    pub y_m: f64,
    /// Mounting height above the floor, metres.
    #[serde(default)]
    pub z_m: f64,
    /// RSSI at 1 m, dBm (R_0 of eq. 1).
    pub rssi_1m_dbm: f64,
    /// Path-loss exponent n of eq. 1.
    pub path_loss_exponent: f64,
}

/// Ties the MCS to WGS-84: the MCS point (`x_m`, `y_m`) lies at (`lat_deg`,
/// `lon_deg`); local east/north offsets come from an equirectangular
/// projection at `lat_deg` (R = 6378137 m) and are rotated into the MCS by
/// `map_from_enu_rad`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeoRef {
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub x_m: f64,
    pub y_m: f64,
}

/// A site ready for the engines: the spec plus one built map per floor.
#[derive(Debug, Clone)]
pub struct Site {
    pub spec: SiteSpec,
    /// Same order as `spec.floors`.
    pub floors: Vec<FloorMap>,
}

impl Site {
    /// The map of floor `id`, if the site has it.
    pub fn floor(&self, id: i32) -> Option<&FloorMap> {
        self.spec
            .floors
            .iter()
            .position(|f| f.id == id)
            .map(|i| &self.floors[i])
    }

    /// The first floor's id (the default floor of single-floor engines).
    pub fn default_floor(&self) -> i32 {
        self.spec.floors.first().map(|f| f.id).unwrap_or(0)
    }
}
