//! Pixel classification of a stylized plan PNG (FP-BP Sec. IV-A1/2): each
//! pixel takes the legend class whose colour is nearest in RGB; a pixel
//! farther than the tolerance from every legend colour is *unclassified*,
//! counted, and still given its nearest class. Above the legend's
//! `max_unclassified_fraction` the plan is rejected.

use super::Feature;
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

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

/// The classified pixels of one plan image.
#[derive(Debug, Clone)]
pub struct ClassifiedPlan {
    pub width_px: usize,
    pub height_px: usize,
    /// Row-major, row 0 at the top of the image.
    pub features: Vec<Feature>,
    /// Pixels farther than the tolerance from every legend colour.
    pub unclassified_count: usize,
}

impl ClassifiedPlan {
    /// Unclassified pixels over all pixels.
    pub fn unclassified_fraction(&self) -> f64 {
        let n = self.width_px * self.height_px;
        if n == 0 {
            0.0
        } else {
            self.unclassified_count as f64 / n as f64
        }
    }
}

fn dist2(a: [u8; 3], b: [u8; 3]) -> f64 {
    a.iter()
        .zip(b.iter())
        .map(|(&x, &y)| {
            let d = x as f64 - y as f64;
            d * d
        })
        .sum()
}

/// Classifies one RGB colour: the nearest legend class and whether it lies
/// within the tolerance. Ties go to the more restrictive class (Wall, Door).
pub fn classify_rgb(rgb: [u8; 3], legend: &Legend) -> (Feature, bool) {
    let cands = [
        (Feature::Wall, legend.wall),
        (Feature::Door, legend.door),
        (Feature::Walkable, legend.walkable),
    ];
    let mut best = (Feature::Wall, f64::INFINITY);
    for (f, c) in cands {
        let d = dist2(rgb, c);
        if d < best.1 {
            best = (f, d);
        }
    }
    (best.0, best.1.sqrt() <= legend.tolerance)
}

/// Width and height of a PNG, from its header (nothing is decoded). `file`
/// names the plan in errors.
pub fn png_dimensions(png_bytes: &[u8], file: &str) -> Result<(usize, usize)> {
    let (w, h) = png_reader(png_bytes)
        .into_dimensions()
        .map_err(|e| Error::Plan {
            file: file.to_string(),
            msg: format!("not a decodable PNG: {e}"),
        })?;
    Ok((w as usize, h as usize))
}

fn png_reader(png_bytes: &[u8]) -> image::ImageReader<std::io::Cursor<&[u8]>> {
    image::ImageReader::with_format(std::io::Cursor::new(png_bytes), image::ImageFormat::Png)
}

/// Decodes `png_bytes` and classifies every pixel with `legend`. Alpha is
/// ignored (the plan is expected opaque). `file` names the plan in errors.
/// The header's size and colour type are checked before anything is
/// decoded: at most [`MAX_PLAN_SIDE_PX`] a side, [`MAX_PLAN_PIXELS`] pixels
/// and [`MAX_PLAN_DECODED_BYTES`] decoded; the decoded image is classified
/// in place (no second copy of it).
///
/// [`MAX_PLAN_SIDE_PX`]: crate::bounds::MAX_PLAN_SIDE_PX
/// [`MAX_PLAN_PIXELS`]: crate::bounds::MAX_PLAN_PIXELS
/// [`MAX_PLAN_DECODED_BYTES`]: crate::bounds::MAX_PLAN_DECODED_BYTES
pub fn classify_png(png_bytes: &[u8], legend: &Legend, file: &str) -> Result<ClassifiedPlan> {
    use crate::bounds::{MAX_PLAN_DECODED_BYTES, MAX_PLAN_PIXELS, MAX_PLAN_SIDE_PX};
    use image::ImageDecoder;
    let plan_err = |msg: String| Error::Plan {
        file: file.to_string(),
        msg,
    };
    let not_png = |e: image::ImageError| plan_err(format!("not a decodable PNG: {e}"));
    // The size is read from the header and checked before anything is decoded.
    let mut decoder = png_reader(png_bytes).into_decoder().map_err(not_png)?;
    let (w, h) = decoder.dimensions();
    let (w, h) = (w as usize, h as usize);
    if w == 0 || h == 0 {
        return Err(plan_err("image has zero size".into()));
    }
    if w > MAX_PLAN_SIDE_PX || h > MAX_PLAN_SIDE_PX || w * h > MAX_PLAN_PIXELS {
        return Err(plan_err(format!(
            "image is {w} x {h} px, over the limit of {MAX_PLAN_SIDE_PX} px a side and \
             {MAX_PLAN_PIXELS} px in all"
        )));
    }
    let decoded = decoder.total_bytes();
    if decoded > MAX_PLAN_DECODED_BYTES {
        return Err(plan_err(format!(
            "image is {w} x {h} px of {:?}: {decoded} bytes decoded, over the limit of \
             {MAX_PLAN_DECODED_BYTES} (save it as 8-bit RGB or with fewer pixels)",
            decoder.color_type()
        )));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_PLAN_SIDE_PX as u32);
    limits.max_image_height = Some(MAX_PLAN_SIDE_PX as u32);
    limits.max_alloc = Some(MAX_PLAN_DECODED_BYTES + (1 << 20));
    decoder.set_limits(limits).map_err(not_png)?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(not_png)?;
    let mut features = Vec::new();
    features
        .try_reserve_exact(w * h)
        .map_err(|e| plan_err(format!("cannot allocate {w} x {h} classified pixels: {e}")))?;
    let mut unclassified = 0usize;
    let mut push = |rgb: [u8; 3]| {
        let (f, ok) = classify_rgb(rgb, legend);
        if !ok {
            unclassified += 1;
        }
        features.push(f);
    };
    match &img {
        image::DynamicImage::ImageRgb8(b) => b.pixels().for_each(|p| push(p.0)),
        image::DynamicImage::ImageRgba8(b) => {
            b.pixels().for_each(|p| push([p.0[0], p.0[1], p.0[2]]))
        }
        image::DynamicImage::ImageLuma8(b) => b.pixels().for_each(|p| push([p.0[0]; 3])),
        image::DynamicImage::ImageLumaA8(b) => b.pixels().for_each(|p| push([p.0[0]; 3])),
        // 16-bit plans (rare): converted pixel by pixel as `to_rgb8` does
        other => {
            use image::GenericImageView;
            for (_, _, p) in other.pixels() {
                push([p.0[0], p.0[1], p.0[2]]);
            }
        }
    }
    drop(img);
    let plan = ClassifiedPlan {
        width_px: w,
        height_px: h,
        features,
        unclassified_count: unclassified,
    };
    let frac = plan.unclassified_fraction();
    if frac > legend.max_unclassified_fraction {
        return Err(Error::Plan {
            file: file.to_string(),
            msg: format!(
                "{unclassified} of {} pixels ({:.2}%) match no legend colour within tolerance {} \
                 (limit legend.max_unclassified_fraction = {})",
                w * h,
                frac * 100.0,
                legend.tolerance,
                legend.max_unclassified_fraction
            ),
        });
    }
    Ok(plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
        let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn classifies_legend_colours_with_tolerance() {
        let bytes = png(4, 1, |x, _| match x {
            0 => [10, 10, 10],
            1 => [240, 20, 20],
            2 => [250, 250, 250],
            _ => [128, 128, 128],
        });
        let legend = Legend {
            max_unclassified_fraction: 0.5,
            ..Legend::default()
        };
        let p = classify_png(&bytes, &legend, "t.png").unwrap();
        assert_eq!(
            &p.features[..3],
            &[Feature::Wall, Feature::Door, Feature::Walkable]
        );
        assert_eq!(p.unclassified_count, 1);
        assert!((p.unclassified_fraction() - 0.25).abs() < 1e-12);
    }

    #[test]
    fn sixteen_bit_and_grey_plans_classify_as_their_rgb8_copy() {
        let legend = Legend {
            max_unclassified_fraction: 1.0,
            ..Legend::default()
        };
        let rgb16 = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(7, 5, |x, y| {
            image::Rgb([x as u16 * 9000, y as u16 * 16000, 65535 - x as u16 * 5000])
        });
        let grey = image::GrayImage::from_fn(7, 5, |x, y| image::Luma([(x * 30 + y * 7) as u8]));
        for img in [
            image::DynamicImage::ImageRgb16(rgb16),
            image::DynamicImage::ImageLuma8(grey),
        ] {
            let mut bytes = std::io::Cursor::new(Vec::new());
            img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
            let got = classify_png(bytes.get_ref(), &legend, "p.png").unwrap();
            let want: Vec<Feature> = img
                .to_rgb8()
                .pixels()
                .map(|p| classify_rgb(p.0, &legend).0)
                .collect();
            assert_eq!(got.features, want);
        }
    }

    #[test]
    fn too_many_unclassified_is_an_error_naming_the_file() {
        let bytes = png(4, 4, |_, _| [0, 200, 0]);
        let e = classify_png(&bytes, &Legend::default(), "green.png").unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("green.png") && s.contains("max_unclassified_fraction"),
            "{s}"
        );
    }

    fn crc32(data: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in data {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }

    #[test]
    fn oversized_png_header_is_refused_before_decoding() {
        // A valid 1 x 1 PNG whose IHDR claims 30000 x 30000: refused from the
        // header (the pixel data is never decoded, so nothing is allocated).
        let mut bytes = png(1, 1, |_, _| [255, 255, 255]);
        bytes[16..20].copy_from_slice(&30_000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&30_000u32.to_be_bytes());
        // IHDR's CRC covers its type and data (bytes 12..29)
        let crc = crc32(&bytes[12..29]);
        bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = classify_png(&bytes, &Legend::default(), "big.png").unwrap_err();
        let s = e.to_string();
        assert!(s.contains("big.png") && s.contains("over the limit"), "{s}");
    }

    #[test]
    fn non_png_is_an_error() {
        let e = classify_png(b"GIF89a not a png", &Legend::default(), "x.png").unwrap_err();
        assert!(e.to_string().contains("x.png"));
    }
}
