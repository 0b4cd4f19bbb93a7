//! Reading an ILC `geojson_map.json` (WGS-84 lon/lat polygons) and projecting
//! it into the ILC floor frame: the local equirectangular projection whose
//! origin is the south-west corner of the bounding box of all coordinates
//! (../shared/datasets/README.md "Coordinate frame (checked)"):
//! x = (lon - lon_min) k cos((lat_min + lat_max) / 2), y = (lat - lat_min) k,
//! with k = pi / 180 * 6378137 m.

use crate::raster::Polygon;
use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::geo::EARTH_RADIUS_M;
use serde_json::Value;

/// One GeoJSON feature: its polygons in lon/lat degrees and its name.
#[derive(Debug, Clone)]
pub struct GeoFeature {
    /// Polygons, each a list of rings of [lon, lat] degrees.
    pub polygons: Vec<Vec<Vec<[f64; 2]>>>,
    /// `properties.name` ("" when absent).
    pub name: String,
}

/// Parses a FeatureCollection of Polygon / MultiPolygon features. `file`
/// names the source in error messages.
pub fn parse_features(bytes: &[u8], file: &str) -> Result<Vec<GeoFeature>> {
    let v: Value = serde_json::from_slice(bytes).with_context(|| format!("{file}: not JSON"))?;
    let feats = v
        .get("features")
        .and_then(Value::as_array)
        .with_context(|| format!("{file}: no `features` array"))?;
    let mut out = Vec::with_capacity(feats.len());
    for (n, f) in feats.iter().enumerate() {
        let at = || format!("{file}: features[{n}]");
        let geom = f
            .get("geometry")
            .with_context(|| format!("{}: no `geometry`", at()))?;
        let ty = geom.get("type").and_then(Value::as_str).unwrap_or("");
        let coords = geom
            .get("coordinates")
            .with_context(|| format!("{}: no `geometry.coordinates`", at()))?;
        let polygons = match ty {
            "Polygon" => vec![parse_polygon(coords).with_context(at)?],
            "MultiPolygon" => coords
                .as_array()
                .with_context(|| format!("{}: MultiPolygon coordinates not an array", at()))?
                .iter()
                .map(parse_polygon)
                .collect::<Result<Vec<_>>>()
                .with_context(at)?,
            other => bail!(
                "{}: geometry type `{other}` (want Polygon or MultiPolygon)",
                at()
            ),
        };
        let name = f
            .get("properties")
            .and_then(|p| p.get("name"))
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string();
        out.push(GeoFeature { polygons, name });
    }
    if out.is_empty() {
        bail!("{file}: the FeatureCollection is empty");
    }
    Ok(out)
}

fn parse_polygon(v: &Value) -> Result<Vec<Vec<[f64; 2]>>> {
    let rings = v.as_array().context("polygon is not an array of rings")?;
    let mut out = Vec::with_capacity(rings.len());
    for (r, ring) in rings.iter().enumerate() {
        let pts = ring
            .as_array()
            .with_context(|| format!("ring {r} is not an array"))?;
        let mut ring_out = Vec::with_capacity(pts.len());
        for (k, p) in pts.iter().enumerate() {
            let lon = p.get(0).and_then(Value::as_f64);
            let lat = p.get(1).and_then(Value::as_f64);
            match (lon, lat) {
                (Some(lon), Some(lat))
                    if lon.is_finite()
                        && lat.is_finite()
                        && lat.abs() <= 90.0
                        && lon.abs() <= 180.0 =>
                {
                    ring_out.push([lon, lat])
                }
                _ => bail!("ring {r} point {k}: not a [lon, lat] pair in degrees"),
            }
        }
        if ring_out.len() < 3 {
            bail!("ring {r} has {} points (need 3)", ring_out.len());
        }
        out.push(ring_out);
    }
    if out.is_empty() {
        bail!("polygon has no ring");
    }
    Ok(out)
}

/// The ILC floor frame of a GeoJSON: see the module doc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IlcFrame {
    pub lon_min_deg: f64,
    pub lat_min_deg: f64,
    pub lat_max_deg: f64,
    /// Largest x, metres (the floor's width when the image covers the bbox).
    pub width_m: f64,
    /// Largest y, metres.
    pub height_m: f64,
}

impl IlcFrame {
    /// The frame spanned by the bounding box of all coordinates of `feats`.
    pub fn of(feats: &[GeoFeature]) -> IlcFrame {
        let (mut lon_min, mut lon_max) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut lat_min, mut lat_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in feats
            .iter()
            .flat_map(|f| f.polygons.iter().flatten().flatten())
        {
            lon_min = lon_min.min(p[0]);
            lon_max = lon_max.max(p[0]);
            lat_min = lat_min.min(p[1]);
            lat_max = lat_max.max(p[1]);
        }
        let mut f = IlcFrame {
            lon_min_deg: lon_min,
            lat_min_deg: lat_min,
            lat_max_deg: lat_max,
            width_m: 0.0,
            height_m: 0.0,
        };
        let top_right = f.project([lon_max, lat_max]);
        f.width_m = top_right.x;
        f.height_m = top_right.y;
        f
    }

    /// Latitude at which longitudes are scaled, degrees.
    pub fn lat_mid_deg(&self) -> f64 {
        0.5 * (self.lat_min_deg + self.lat_max_deg)
    }

    /// [lon, lat] degrees -> floor metres.
    pub fn project(&self, p: [f64; 2]) -> Vec2 {
        let k = std::f64::consts::PI / 180.0 * EARTH_RADIUS_M;
        Vec2::new(
            (p[0] - self.lon_min_deg) * k * self.lat_mid_deg().to_radians().cos(),
            (p[1] - self.lat_min_deg) * k,
        )
    }

    /// A GeoJSON polygon list in floor metres.
    pub fn project_feature(&self, f: &GeoFeature) -> Vec<Polygon> {
        f.polygons
            .iter()
            .map(|poly| {
                poly.iter()
                    .map(|ring| ring.iter().map(|p| self.project(*p)).collect())
                    .collect()
            })
            .collect()
    }

    /// The site georeference that reproduces this projection exactly through
    /// `fpbp_core::geo` (reference at the mid latitude, rotation 0).
    pub fn georef(&self) -> fpbp_core::site::GeoRef {
        let k = std::f64::consts::PI / 180.0 * EARTH_RADIUS_M;
        fpbp_core::site::GeoRef {
            lat_deg: self.lat_mid_deg(),
            lon_deg: self.lon_min_deg,
            x_m: 0.0,
            y_m: (self.lat_mid_deg() - self.lat_min_deg) * k,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO: &str = r#"{"type":"FeatureCollection","features":[
      {"type":"Feature","properties":{},"geometry":{"type":"MultiPolygon","coordinates":[[[[120.0,30.0],[120.001,30.0],[120.001,30.001],[120.0,30.001],[120.0,30.0]]]]}},
      {"type":"Feature","properties":{"name":"shop"},"geometry":{"type":"Polygon","coordinates":[[[120.0002,30.0002],[120.0004,30.0002],[120.0004,30.0004],[120.0002,30.0004]]]}}
    ]}"#;

    #[test]
    fn parses_and_projects() {
        let f = parse_features(TWO.as_bytes(), "t.json").unwrap();
        assert_eq!(f.len(), 2);
        assert_eq!(f[1].name, "shop");
        let fr = IlcFrame::of(&f);
        let k = std::f64::consts::PI / 180.0 * EARTH_RADIUS_M;
        assert!((fr.height_m - 0.001 * k).abs() < 1e-6);
        assert!((fr.width_m - 0.001 * k * 30.0005f64.to_radians().cos()).abs() < 1e-6);
        let p = fr.project([120.0, 30.0]);
        assert!(p.norm() < 1e-9);
        // The georef reproduces the projection through fpbp_core::geo.
        let g = fr.georef();
        for q in [[120.0004, 30.0002], [120.001, 30.001], [120.0, 30.0]] {
            let a = fr.project(q);
            let b = fpbp_core::geo::mcs_from_wgs84(&g, 0.0, q[1], q[0]);
            assert!((a - b).norm() < 1e-6, "{a:?} {b:?}");
        }
    }

    #[test]
    fn bad_input_names_the_feature() {
        let bad = r#"{"features":[{"geometry":{"type":"Polygon","coordinates":[[[1,2],[3]]]}}]}"#;
        let e = parse_features(bad.as_bytes(), "x.json").unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("x.json: features[0]") && msg.contains("point 1"),
            "{msg}"
        );
        assert!(parse_features(b"{}", "y.json").is_err());
        let line = r#"{"features":[{"geometry":{"type":"LineString","coordinates":[]}}]}"#;
        assert!(
            format!("{:#}", parse_features(line.as_bytes(), "z").unwrap_err())
                .contains("LineString")
        );
    }
}
