//! The site file (site.json, format version 1): floors with their stylized
//! plans, beacons, the colour legend and the frames. Documented in
//! docs/formats.md. This module holds the serde schema and its validation;
//! `Site::build` turns a validated spec plus the plan bytes into maps.

use serde::{Deserialize, Serialize};

use crate::bounds::{
    MAX_FLOOR_SIDE_M, MAX_GRID_CELLS, MAX_MAP_PIXELS, MAX_PIXELS_PER_METER, MAX_PLAN_SIDE_PX,
    MIN_GRID_STEP_M, MIN_PIXELS_PER_METER, show,
};
pub use crate::map::Legend;
use crate::map::{DEFAULT_GRID_INTERVAL_M, Feature, FloorMap, classify_png, png_dimensions};
use crate::{Error, Result};

/// The `format` value of a site file.
pub const SITE_FORMAT: &str = "fpbp-site";
/// The site-file version this reader knows.
pub const SITE_VERSION: u32 = 1;
/// Resolution of an open floor's generated plan when the floor gives none, px/m.
pub const OPEN_FLOOR_PIXELS_PER_METER: f64 = 10.0;

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
    /// A geometric rotation (it also places lat/lon truth and GNSS).
    #[serde(default)]
    pub map_from_enu_rad: f64,
    /// Added to every phone's heading on top of `map_from_enu_rad`,
    /// radians, counter-clockwise: magnetic declination and whatever else
    /// turns the phones' heading away from the map in this building, as
    /// `fpbp calibrate` measures it on survey walks with truth
    /// ([`crate::pdr::heading_bias`]). Left out of the file when 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub heading_bias_rad: f64,
    /// Colour legend of the stylized plans.
    #[serde(default)]
    pub legend: Legend,
    /// GML grid interval I_M, metres (FP-BP Sec. IV-A4).
    #[serde(default = "default_grid_interval_m")]
    pub grid_interval_m: f64,
    /// Floors, at least one, at most [`crate::bounds::MAX_FLOORS`]
    /// (counted while parsing).
    #[serde(deserialize_with = "floors")]
    pub floors: Vec<FloorSpec>,
    /// Beacons; may be empty (PDR-only sites, or before `fpbp calibrate`).
    /// At most [`crate::bounds::MAX_SITE_TRANSMITTERS`].
    #[serde(default, deserialize_with = "transmitters")]
    pub beacons: Vec<BeaconSpec>,
    /// WiFi access points, one entry per BSSID (`id` = lower-case
    /// `aa:bb:cc:dd:ee:ff`), with the same fields and model as beacons
    /// (docs/formats.md says why a parallel list). Left out of the file when
    /// empty. At most [`crate::bounds::MAX_SITE_TRANSMITTERS`].
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "transmitters"
    )]
    pub access_points: Vec<BeaconSpec>,
    /// Optional WGS-84 georeference of the MCS (for GNSS and lat/lon truth).
    #[serde(default)]
    pub georef: Option<GeoRef>,
}

fn floors<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Vec<FloorSpec>, D::Error> {
    crate::bounds::json::vec(d, crate::bounds::MAX_FLOORS)
}

fn transmitters<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<BeaconSpec>, D::Error> {
    crate::bounds::json::vec(d, crate::bounds::MAX_SITE_TRANSMITTERS)
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn default_grid_interval_m() -> f64 {
    DEFAULT_GRID_INTERVAL_M
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
    /// Each floor's id and height (m), in the site file's order: what a
    /// [`crate::floor::FloorTracker`] is built over.
    pub fn floor_heights(&self) -> Vec<(i32, f64)> {
        self.spec
            .floors
            .iter()
            .map(|f| (f.id, f.height_m))
            .collect()
    }

    /// The map of floor `id`, if the site has it.
    pub fn floor(&self, id: i32) -> Option<&FloorMap> {
        self.spec
            .floors
            .iter()
            .position(|f| f.id == id)
            .and_then(|i| self.floors.get(i))
    }

    /// The first floor's id (the default floor of single-floor engines).
    pub fn default_floor(&self) -> i32 {
        self.spec.floors.first().map(|f| f.id).unwrap_or(0)
    }
}

fn site_err(file: &str, field: impl Into<String>, msg: impl Into<String>) -> Error {
    Error::Site {
        file: file.to_string(),
        field: field.into(),
        msg: msg.into(),
    }
}

impl SiteSpec {
    /// The rotation the PDR applies to the phone's east-north heading to
    /// walk in the MCS: the map's rotation plus the site's heading bias.
    pub fn pdr_rotation_rad(&self) -> f64 {
        self.map_from_enu_rad + self.heading_bias_rad
    }

    /// Parses site.json bytes. Syntax errors, unknown and missing fields and
    /// wrong types become [`Error::Site`] naming `file_name`, the JSON path of
    /// the field (e.g. `floors[0].pixels_per_meter`) and the line/column.
    /// Does not validate ranges: [`Site::build`] does.
    pub fn from_json(bytes: &[u8], file_name: &str) -> Result<SiteSpec> {
        serde_json::from_slice(bytes).map_err(|e| {
            let (field, msg) = json_path::describe(bytes, &e);
            site_err(file_name, field, msg)
        })
    }

    /// Serializes as pretty JSON (what the generators write).
    pub fn to_json_pretty(&self) -> String {
        // Serializing plain data with finite or non-finite f64 cannot fail
        // except on non-finite floats, which serde_json writes as null.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Checks every field that does not need the plan images. `file` names
    /// the site file in errors.
    pub fn validate(&self, file: &str) -> Result<()> {
        if self.format != SITE_FORMAT {
            return Err(site_err(
                file,
                "format",
                format!("must be \"{SITE_FORMAT}\", got \"{}\"", self.format),
            ));
        }
        if self.version != SITE_VERSION {
            return Err(site_err(
                file,
                "version",
                format!(
                    "this reader knows version {SITE_VERSION}, got {}",
                    self.version
                ),
            ));
        }
        if !self.map_from_enu_rad.is_finite() {
            return Err(site_err(file, "map_from_enu_rad", "must be finite"));
        }
        if !self.heading_bias_rad.is_finite() || self.heading_bias_rad.abs() > std::f64::consts::PI
        {
            return Err(site_err(
                file,
                "heading_bias_rad",
                format!("must be within [-pi, pi], got {}", self.heading_bias_rad),
            ));
        }
        let l = &self.legend;
        if !(l.tolerance >= 0.0 && l.tolerance.is_finite()) {
            return Err(site_err(
                file,
                "legend.tolerance",
                "must be >= 0 and finite",
            ));
        }
        if !(0.0..=1.0).contains(&l.max_unclassified_fraction) {
            return Err(site_err(
                file,
                "legend.max_unclassified_fraction",
                "must be in [0, 1]",
            ));
        }
        if l.wall == l.door || l.wall == l.walkable || l.door == l.walkable {
            return Err(site_err(
                file,
                "legend",
                "wall, door and walkable colours must differ",
            ));
        }
        if !(self.grid_interval_m.is_finite() && self.grid_interval_m >= MIN_GRID_STEP_M) {
            return Err(site_err(
                file,
                "grid_interval_m",
                format!(
                    "must be finite and >= {MIN_GRID_STEP_M} m, got {}",
                    show(self.grid_interval_m)
                ),
            ));
        }
        if self.floors.is_empty() {
            return Err(site_err(file, "floors", "at least one floor is required"));
        }
        for (k, f) in self.floors.iter().enumerate() {
            let at = |name: &str| format!("floors[{k}].{name}");
            if self.floors[..k].iter().any(|g| g.id == f.id) {
                return Err(site_err(
                    file,
                    at("id"),
                    format!("duplicate floor id {}", f.id),
                ));
            }
            for (name, v) in [
                ("pixels_per_meter", f.pixels_per_meter),
                ("target_pixels_per_meter", f.target_pixels_per_meter),
            ] {
                if let Some(r) = v
                    && !(r.is_finite()
                        && (MIN_PIXELS_PER_METER..=MAX_PIXELS_PER_METER).contains(&r))
                {
                    return Err(site_err(
                        file,
                        at(name),
                        format!(
                            "must be in [{MIN_PIXELS_PER_METER}, {MAX_PIXELS_PER_METER}] px/m, got {}",
                            show(r)
                        ),
                    ));
                }
            }
            if !f.height_m.is_finite() {
                return Err(site_err(file, at("height_m"), "must be finite"));
            }
            match (&f.plan, f.open_area_m) {
                (Some(p), None) => {
                    if p.trim().is_empty() {
                        return Err(site_err(file, at("plan"), "empty path"));
                    }
                    if f.pixels_per_meter.is_none() {
                        return Err(site_err(
                            file,
                            at("pixels_per_meter"),
                            "required when `plan` is given",
                        ));
                    }
                }
                (None, Some([w, h])) => {
                    if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
                        return Err(site_err(
                            file,
                            at("open_area_m"),
                            format!("must be > 0, got [{w}, {h}]"),
                        ));
                    }
                    let r = f.pixels_per_meter.unwrap_or(OPEN_FLOOR_PIXELS_PER_METER);
                    let (wp, hp) = open_floor_px(w, h, r);
                    check_floor_size(wp, hp, r, self.grid_interval_m)
                        .map_err(|msg| site_err(file, at("open_area_m"), msg))?;
                }
                (Some(_), Some(_)) => {
                    return Err(site_err(
                        file,
                        at("open_area_m"),
                        "give either `plan` or `open_area_m`, not both",
                    ));
                }
                (None, None) => {
                    return Err(site_err(
                        file,
                        at("plan"),
                        "missing: give `plan` (a PNG) or `open_area_m`",
                    ));
                }
            }
        }
        self.validate_transmitters(file, "beacons", &self.beacons)?;
        self.validate_transmitters(file, "access_points", &self.access_points)?;
        for (k, a) in self.access_points.iter().enumerate() {
            if !crate::radio_id::is_bssid(&a.id) {
                return Err(site_err(
                    file,
                    format!("access_points[{k}].id"),
                    format!("`{}` is not a lower-case BSSID aa:bb:cc:dd:ee:ff", a.id),
                ));
            }
        }
        if let Some(g) = &self.georef {
            if !(-90.0..=90.0).contains(&g.lat_deg) {
                return Err(site_err(file, "georef.lat_deg", "must be in [-90, 90]"));
            }
            if !(-180.0..=180.0).contains(&g.lon_deg) {
                return Err(site_err(file, "georef.lon_deg", "must be in [-180, 180]"));
            }
            if !(g.x_m.is_finite() && g.y_m.is_finite()) {
                return Err(site_err(file, "georef.x_m", "x_m and y_m must be finite"));
            }
        }
        Ok(())
    }
}

impl SiteSpec {
    /// Checks one list of transmitters (`beacons` or `access_points`): ids
    /// non-empty and unique, floors known, finite positions, a negative R0
    /// and a positive exponent.
    fn validate_transmitters(&self, file: &str, list: &str, items: &[BeaconSpec]) -> Result<()> {
        let mut seen = std::collections::BTreeSet::new();
        for (k, b) in items.iter().enumerate() {
            let at = |name: &str| format!("{list}[{k}].{name}");
            if b.id.trim().is_empty() {
                return Err(site_err(file, at("id"), "empty id"));
            }
            if !seen.insert(b.id.as_str()) {
                return Err(site_err(file, at("id"), format!("duplicate id {}", b.id)));
            }
            if !self.floors.iter().any(|f| f.id == b.floor) {
                return Err(site_err(
                    file,
                    at("floor"),
                    format!("no floor with id {}", b.floor),
                ));
            }
            for (name, v) in [("x_m", b.x_m), ("y_m", b.y_m), ("z_m", b.z_m)] {
                if !v.is_finite() {
                    return Err(site_err(file, at(name), "must be finite"));
                }
            }
            if !(b.rssi_1m_dbm.is_finite() && b.rssi_1m_dbm < 0.0) {
                return Err(site_err(
                    file,
                    at("rssi_1m_dbm"),
                    format!("must be a negative dBm value, got {}", b.rssi_1m_dbm),
                ));
            }
            if !(b.path_loss_exponent > 0.0 && b.path_loss_exponent.is_finite()) {
                return Err(site_err(
                    file,
                    at("path_loss_exponent"),
                    format!("must be > 0, got {}", b.path_loss_exponent),
                ));
            }
        }
        Ok(())
    }
}

/// Pixel size of an open floor's generated plan (at least 3 x 3), as f64 so
/// that a huge input cannot overflow before it is checked.
fn open_floor_px(w_m: f64, h_m: f64, r: f64) -> (f64, f64) {
    ((w_m * r).round().max(3.0), (h_m * r).round().max(3.0))
}

/// Checks a floor map's size before it is built: each side at most
/// [`MAX_PLAN_SIDE_PX`] pixels and [`MAX_FLOOR_SIDE_M`] metres, at most
/// [`MAX_MAP_PIXELS`] pixels, a grid of at most [`MAX_GRID_CELLS`] cells.
/// The message says the value and the limit.
pub fn check_floor_size(
    w_px: f64,
    h_px: f64,
    r: f64,
    grid_interval_m: f64,
) -> std::result::Result<(), String> {
    let (w_m, h_m) = (w_px / r, h_px / r);
    if !(w_m <= MAX_FLOOR_SIDE_M && h_m <= MAX_FLOOR_SIDE_M) {
        return Err(format!(
            "floor is {} x {} m, over the limit of {MAX_FLOOR_SIDE_M} m a side",
            show(w_m),
            show(h_m)
        ));
    }
    if !(w_px <= MAX_PLAN_SIDE_PX as f64 && h_px <= MAX_PLAN_SIDE_PX as f64) {
        return Err(format!(
            "plan is {} x {} px at {} px/m, over the limit of {MAX_PLAN_SIDE_PX} px a side",
            show(w_px),
            show(h_px),
            show(r)
        ));
    }
    let px = w_px * h_px;
    if px > MAX_MAP_PIXELS as f64 {
        return Err(format!(
            "plan is {w_px} x {h_px} = {} px at {} px/m, over the limit of {MAX_MAP_PIXELS} px \
             (lower pixels_per_meter or set target_pixels_per_meter)",
            show(px),
            show(r)
        ));
    }
    let cells = crate::bounds::grid_cells(w_m, h_m, grid_interval_m);
    if cells > MAX_GRID_CELLS as f64 {
        return Err(format!(
            "grid_interval_m {} on a {w_m:.1} x {h_m:.1} m floor gives {} grid cells, \
             over the limit of {MAX_GRID_CELLS} (raise grid_interval_m)",
            show(grid_interval_m),
            show(cells)
        ));
    }
    Ok(())
}

/// The map of an open floor: a walkable `w` x `h` m rectangle at `r` px/m
/// whose outermost pixel ring is Wall. Sizes must have passed
/// [`check_floor_size`] ([`SiteSpec::validate`] does it); memory that cannot
/// be had is an error, not an abort.
pub fn open_floor_map(w_m: f64, h_m: f64, r: f64, grid_interval_m: f64) -> Result<FloorMap> {
    let (wf, hf) = open_floor_px(w_m, h_m, r);
    check_floor_size(wf, hf, r, grid_interval_m).map_err(Error::Input)?;
    let (w, h) = (wf as usize, hf as usize);
    let mut f = crate::bounds::try_filled(w * h, Feature::Walkable, "open floor plan")?;
    for j in 0..h {
        for i in 0..w {
            if i == 0 || j == 0 || i == w - 1 || j == h - 1 {
                f[j * w + i] = Feature::Wall;
            }
        }
    }
    Ok(FloorMap::from_features_with_grid(
        w,
        h,
        r,
        f,
        grid_interval_m,
    ))
}

impl Site {
    /// Validates `spec` and builds one map per floor. `site_file` names the
    /// site in errors; `load_plan` returns the bytes of a plan path as written
    /// in the spec (the caller resolves it relative to the site file).
    /// Checks: format/version, ranges ([`SiteSpec::validate`]), each plan
    /// readable and a PNG with few unclassified pixels and some Walkable
    /// pixels, each beacon inside its floor's plan and not inside a Wall.
    pub fn build(
        spec: SiteSpec,
        site_file: &str,
        load_plan: &mut dyn FnMut(&str) -> std::io::Result<Vec<u8>>,
    ) -> Result<Site> {
        spec.validate(site_file)?;
        let mut floors = Vec::with_capacity(spec.floors.len());
        // map pixels of the floors so far: the site's floors together hold
        // at most MAX_MAP_PIXELS (checked before each floor is built, so
        // many floors of one plan cannot multiply the map's memory)
        let mut site_px = 0.0;
        let mut add_px = |px: f64, field: &str| {
            site_px += px;
            if site_px > MAX_MAP_PIXELS as f64 {
                return Err(site_err(
                    site_file,
                    field,
                    format!(
                        "the floors hold {} map pixels together up to this one, over the \
                         limit of {MAX_MAP_PIXELS} for a site (lower pixels_per_meter or set \
                         target_pixels_per_meter)",
                        show(site_px)
                    ),
                ));
            }
            Ok(())
        };
        for (k, f) in spec.floors.iter().enumerate() {
            let map = match (&f.plan, f.open_area_m) {
                (Some(path), _) => {
                    let field = format!("floors[{k}].plan");
                    let bytes = load_plan(path).map_err(|e| {
                        site_err(site_file, &field, format!("cannot read plan {path}: {e}"))
                    })?;
                    let r = f.pixels_per_meter.unwrap_or(OPEN_FLOOR_PIXELS_PER_METER);
                    let kf = f
                        .target_pixels_per_meter
                        .map(|t| FloorMap::downsample_factor(r, t))
                        .unwrap_or(1);
                    // the downsampled size (blocks of kf, partial blocks
                    // kept), checked from the PNG header before decoding
                    let (w_px, h_px) = png_dimensions(&bytes, path)
                        .map_err(|e| site_err(site_file, &field, e.to_string()))?;
                    let (wk, hk) = (
                        w_px.div_ceil(kf.max(1)) as f64,
                        h_px.div_ceil(kf.max(1)) as f64,
                    );
                    check_floor_size(wk, hk, r / kf.max(1) as f64, spec.grid_interval_m).map_err(
                        |msg| site_err(site_file, &field, format!("plan {path}: {msg}")),
                    )?;
                    add_px(wk * hk, &field)?;
                    let plan = classify_png(&bytes, &spec.legend, path)
                        .map_err(|e| site_err(site_file, &field, e.to_string()))?;
                    let map = FloorMap::from_classified_plan(plan, r, kf, spec.grid_interval_m);
                    if map.walkable_pixel_count() == 0 {
                        return Err(site_err(
                            site_file,
                            field,
                            format!(
                                "plan {path} has no Walkable pixels (legend.walkable = {:?})",
                                spec.legend.walkable
                            ),
                        ));
                    }
                    map
                }
                (None, Some([w, h])) => {
                    let r = f.pixels_per_meter.unwrap_or(OPEN_FLOOR_PIXELS_PER_METER);
                    let (wp, hp) = open_floor_px(w, h, r);
                    let field = format!("floors[{k}].open_area_m");
                    add_px(wp * hp, &field)?;
                    open_floor_map(w, h, r, spec.grid_interval_m)
                        .map_err(|e| site_err(site_file, &field, e.to_string()))?
                }
                (None, None) => {
                    return Err(site_err(site_file, format!("floors[{k}].plan"), "missing"));
                }
            };
            floors.push(map);
        }
        for (list, items) in [
            ("beacons", &spec.beacons),
            ("access_points", &spec.access_points),
        ] {
            check_on_plan(site_file, list, items, &spec, &floors)?;
        }
        Ok(Site { spec, floors })
    }
}

/// Each transmitter of `items` lies inside its floor's plan and not on a
/// Wall pixel (a Door pixel is allowed).
fn check_on_plan(
    site_file: &str,
    list: &str,
    items: &[BeaconSpec],
    spec: &SiteSpec,
    floors: &[FloorMap],
) -> Result<()> {
    for (k, b) in items.iter().enumerate() {
        let Some(fi) = spec.floors.iter().position(|f| f.id == b.floor) else {
            return Err(site_err(
                site_file,
                format!("{list}[{k}].floor"),
                "unknown floor",
            ));
        };
        let map = &floors[fi];
        let p = crate::Vec2::new(b.x_m, b.y_m);
        if map.pixel_of(p).is_none() {
            return Err(site_err(
                site_file,
                format!("{list}[{k}]"),
                format!(
                    "{} at ({}, {}) m lies outside floor {}'s plan [0, {:.2}] x [0, {:.2}] m",
                    b.id,
                    b.x_m,
                    b.y_m,
                    b.floor,
                    map.width_m(),
                    map.height_m()
                ),
            ));
        }
        if map.feature(p) == Feature::Wall {
            return Err(site_err(
                site_file,
                format!("{list}[{k}]"),
                format!("{} at ({}, {}) m lies inside a Wall", b.id, b.x_m, b.y_m),
            ));
        }
    }
    Ok(())
}

pub(crate) mod json_path {
    //! The JSON path (`floors[0].pixels_per_meter`) at a serde_json error
    //! position, by scanning the text up to it: from a slice, or from a
    //! stream fed in chunks ([`Scanner`]; memory bounded by the nesting
    //! depth, not by the text).

    /// The path of the field at fault and a message for a serde_json error
    /// on `bytes`: NaN / Infinity (not JSON) are said as such, and a message
    /// echoing input is cut to [`crate::bounds::MAX_MESSAGE_CHARS`].
    pub(crate) fn describe(bytes: &[u8], e: &serde_json::Error) -> (String, String) {
        let mut s = Scanner::at_error(e);
        s.feed(bytes);
        s.describe(e)
    }

    /// Longest object key kept for a path, bytes (a longer key is cut).
    const MAX_KEY_BYTES: usize = 256;
    /// A cut key is shown as its first this many characters and its whole
    /// length (within the JNI layer's echo limit, so the length survives).
    const CUT_KEY_SHOWN_CHARS: usize = 100;
    /// Bytes kept from the error position on (to tell NaN / Infinity).
    const TAIL_BYTES: usize = 11;

    enum Frame {
        Object { key: Option<String>, want_key: bool },
        Array { index: usize },
    }

    fn backticked(msg: &str, prefix: &str) -> Option<String> {
        let rest = &msg[msg.find(prefix)? + prefix.len()..];
        let end = rest.find('`')?;
        Some(rest[..end].to_string())
    }

    /// Where a scan stops.
    #[derive(Clone, Copy)]
    enum Target {
        /// serde_json's (line, column), 1-based, bytes: the value being
        /// read there (a string begun before it is read to its end).
        LineColumn(usize, usize),
        /// The byte at this offset (0-based): the value holding it.
        Offset(u64),
    }

    /// The JSON path at a position of a text fed in chunks ([`feed`]),
    /// keeping only the open objects and arrays (serde_json refuses nesting
    /// deeper than 128) and keys of at most [`MAX_KEY_BYTES`].
    ///
    /// [`feed`]: Scanner::feed
    pub(crate) struct Scanner {
        target: Target,
        /// Offset of the next byte.
        pos: u64,
        /// Line of the next byte (1-based).
        line: usize,
        /// Offset where the scan of structure ends (exclusive), once known.
        end: Option<u64>,
        /// Offset of the error (the tail's start), once known.
        at: Option<u64>,
        stack: Vec<Frame>,
        /// Inside a string: its bytes so far (when it is a key), whether
        /// the next byte is escaped.
        string: Option<(Option<Vec<u8>>, bool)>,
        /// Characters of the key being read (all of them, kept or not).
        key_chars: usize,
        /// The structure scan is over.
        done: bool,
        tail: Vec<u8>,
    }

    impl Scanner {
        /// A scan to the position of serde_json error `e`.
        pub(crate) fn at_error(e: &serde_json::Error) -> Scanner {
            Self::new(Target::LineColumn(e.line(), e.column()))
        }

        /// A scan to the byte at `offset` (0-based).
        pub(crate) fn at_offset(offset: u64) -> Scanner {
            Self::new(Target::Offset(offset))
        }

        fn new(target: Target) -> Scanner {
            let mut s = Scanner {
                target,
                pos: 0,
                line: 1,
                end: None,
                at: None,
                stack: Vec::new(),
                string: None,
                key_chars: 0,
                done: false,
                tail: Vec::new(),
            };
            s.line_started(0);
            s
        }

        /// Line `self.line` starts at `offset`: the end is known when it is
        /// the target's.
        fn line_started(&mut self, offset: u64) {
            match self.target {
                Target::LineColumn(l, c) if l == self.line => {
                    self.end = Some(offset + c as u64);
                    self.at = Some(offset + c.saturating_sub(1) as u64);
                }
                Target::Offset(o) if self.end.is_none() => {
                    self.end = Some(o + 1);
                    self.at = Some(o);
                }
                _ => {}
            }
        }

        /// Whether the scan needs no more bytes.
        pub(crate) fn finished(&self) -> bool {
            self.done && self.tail.len() >= TAIL_BYTES
        }

        /// Feeds the next bytes of the text; returns whether the scan is
        /// finished (later bytes change nothing).
        pub(crate) fn feed(&mut self, bytes: &[u8]) -> bool {
            for &b in bytes {
                if self.finished() {
                    return true;
                }
                let p = self.pos;
                self.pos += 1;
                if self.at.is_some_and(|a| p >= a) && self.tail.len() < TAIL_BYTES {
                    self.tail.push(b);
                }
                if b == b'\n'
                    && let Target::LineColumn(l, _) = self.target
                    && self.line < l
                {
                    self.line += 1;
                    self.line_started(p + 1);
                }
                if self.done {
                    continue;
                }
                let past_end = self.end.is_some_and(|e| p >= e);
                if let Some((key, escaped)) = &mut self.string {
                    // a string begun before the end is read to its close
                    // (a key), except when the target is a byte offset
                    if past_end && matches!(self.target, Target::Offset(_)) {
                        self.done = true;
                        continue;
                    }
                    if *escaped {
                        *escaped = false;
                    } else if b == b'\\' {
                        *escaped = true;
                    } else if b == b'"' {
                        let key = key.take();
                        self.string = None;
                        let n = self.key_chars;
                        if let (Some(k), Some(Frame::Object { key, want_key })) =
                            (key, self.stack.last_mut())
                        {
                            let text = String::from_utf8_lossy(&k);
                            *key = Some(if text.chars().count() == n {
                                text.into_owned()
                            } else {
                                let head: String = text.chars().take(CUT_KEY_SHOWN_CHARS).collect();
                                format!("{head}... ({n} chars)")
                            });
                            *want_key = false;
                        }
                        if past_end {
                            self.done = true;
                        }
                        continue;
                    }
                    if let Some(k) = key {
                        if b & 0xC0 != 0x80 {
                            self.key_chars += 1;
                        }
                        if k.len() < MAX_KEY_BYTES {
                            k.push(b);
                        }
                    }
                    continue;
                }
                if past_end {
                    self.done = true;
                    continue;
                }
                let last = self.end.is_some_and(|e| p + 1 >= e);
                match b {
                    b'{' => self.stack.push(Frame::Object {
                        key: None,
                        want_key: true,
                    }),
                    b'[' => self.stack.push(Frame::Array { index: 0 }),
                    // The error of a missing field is reported at the
                    // closing brace: keep that object on the stack.
                    b'}' | b']' if !last => {
                        self.stack.pop();
                    }
                    b',' => match self.stack.last_mut() {
                        Some(Frame::Object { want_key, .. }) => *want_key = true,
                        Some(Frame::Array { index }) => *index += 1,
                        None => {}
                    },
                    b'"' => {
                        let is_key = matches!(
                            self.stack.last(),
                            Some(Frame::Object { want_key: true, .. })
                        );
                        self.string = Some((is_key.then(Vec::new), false));
                        self.key_chars = 0;
                    }
                    _ => {}
                }
            }
            self.finished()
        }

        /// The path at the target (`(top level)` when empty); `msg` is the
        /// error's message (a missing field is named in it).
        pub(crate) fn path(&self, msg: &str) -> String {
            let missing = backticked(msg, "missing field `");
            let mut path = String::new();
            let n = self.stack.len();
            for (k, f) in self.stack.iter().enumerate() {
                match f {
                    Frame::Object { key, .. } => {
                        if k + 1 == n && missing.is_some() {
                            break;
                        }
                        if let Some(key) = key {
                            if !path.is_empty() {
                                path.push('.');
                            }
                            path.push_str(key);
                        }
                    }
                    Frame::Array { index } => path.push_str(&format!("[{index}]")),
                }
            }
            if let Some(m) = missing {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(&m);
            }
            if path.is_empty() {
                path = "(top level)".into();
            }
            path
        }

        /// The path and message of serde_json error `e` (the scan was made
        /// [`Scanner::at_error`]): NaN / Infinity (not JSON) are said as
        /// such, and a message echoing input is cut to
        /// [`crate::bounds::MAX_MESSAGE_CHARS`].
        pub(crate) fn describe(&self, e: &serde_json::Error) -> (String, String) {
            let msg = e.to_string();
            let path = self.path(&msg);
            let rest = self.tail.as_slice();
            let word =
                |w: &[u8]| rest.starts_with(w) || rest.get(1..).is_some_and(|r| r.starts_with(w));
            let msg = if word(b"NaN") || word(b"Infinity") || word(b"-Infinity") {
                format!(
                    "NaN and Infinity are not allowed (JSON numbers are finite) at line {}, column {}",
                    e.line(),
                    e.column()
                )
            } else {
                crate::bounds::cut(&msg, crate::bounds::MAX_MESSAGE_CHARS)
            };
            (path, msg)
        }
    }
}

#[cfg(feature = "fs")]
pub mod files;

#[cfg(test)]
mod tests;

#[cfg(test)]
pub(crate) mod testkit;
