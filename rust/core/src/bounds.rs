//! Resource bounds on inputs: the one place that says how large a site, a
//! grid or a config's work may get, and the checks that enforce them.
//!
//! Every size that comes from input (a floor's metric size, its pixel count,
//! a grid's cell count, a step that divides a length, an iteration count) is
//! checked against a limit here before anything is allocated or looped over,
//! so that no site file, config or start position can hang or abort the
//! process (an allocation failure aborts even under `catch_unwind`). The
//! limits and why they are what they are: docs/parameters.md, "Input bounds".

use crate::{Error, Result};

pub mod json;

/// Largest side of a floor, metres (a 10 km building does not exist; the
/// bound keeps metric loops such as the grid finite whatever the resolution).
pub const MAX_FLOOR_SIDE_M: f64 = 10_000.0;
/// Plan resolution range, pixels per metre (real plans: 1-50 px/m).
pub const MIN_PIXELS_PER_METER: f64 = 0.01;
pub const MAX_PIXELS_PER_METER: f64 = 1_000.0;
/// Largest side of a plan image or an open floor's generated plan, pixels.
pub const MAX_PLAN_SIDE_PX: usize = 20_000;
/// Most pixels of a decoded plan image (before downsampling): 1 byte per
/// classified pixel, plus the decoded image (below).
pub const MAX_PLAN_PIXELS: usize = 64 * 1024 * 1024;
/// Largest decoded plan image, bytes, as its PNG header declares it (width
/// x height x bytes per pixel of its colour type), checked before decoding:
/// with the classified pixels at most 128 MiB + 64 MiB. An 8-bit RGB plan
/// may have 44 M pixels, a 16-bit RGBA one 16 M.
pub const MAX_PLAN_DECODED_BYTES: u64 = 128 << 20;
/// Most floors of a site (each is a map; the tallest building has ~160).
pub const MAX_FLOORS: usize = 256;
/// Most beacons, and most access points, of a site (as many as a radio map
/// may have transmitters).
pub const MAX_SITE_TRANSMITTERS: usize = MAX_RADIO_MAP_TRANSMITTERS;
/// Most pixels of a built floor map (after downsampling). Room labelling,
/// the clearance tables and the features take about 20 bytes per pixel at
/// worst, so this caps one floor at about 340 MB; the largest real site
/// (IPIN 2023, docs/sites.md) is far below it.
pub const MAX_MAP_PIXELS: usize = 16 * 1024 * 1024;
/// Most cells of a GML grid before the Walkable filter (floor(W / I_M) x
/// floor(H / I_M)); the GML tables hold up to 512 f32 columns of the grid.
pub const MAX_GRID_CELLS: usize = 1 << 18;
/// Smallest grid interval / database grid step / survey cell, metres.
pub const MIN_GRID_STEP_M: f64 = 0.05;
/// Raycast and wall-check sampling steps, metres.
pub const MIN_RAY_STEP_M: f64 = 1e-3;
pub const MAX_RAY_STEP_M: f64 = 10.0;
/// Upper bound of iteration counts (affinity propagation, ML solver).
pub const MAX_ITERATIONS: usize = 10_000;
/// Affinity propagation does O(n^2) work per iteration on n points: the
/// product iterations x n^2 stays below this (default 200 x 900^2 = 1.6e8).
pub const MAX_AP_WORK: f64 = 2e10;
/// Most points of one floor's fingerprint database (AP keeps n x n matrices).
pub const MAX_FINGERPRINT_POINTS: usize = 5_000;
/// Most transmitters of a radio map (a large survey hears a few thousand
/// BSSIDs; the builder drops readings of any beyond this).
pub const MAX_RADIO_MAP_TRANSMITTERS: usize = 20_000;
/// Most cells of one radio-map grid (2 i16 per cell).
pub const MAX_RADIO_MAP_GRID_CELLS: usize = 1 << 20;
/// Most cells of all grids of a radio map together (4 bytes each: 64 MiB).
pub const MAX_RADIO_MAP_CELLS: usize = 1 << 24;
/// Most grids of one transmitter, or of the magnetic section (one per
/// floor).
pub const MAX_RADIO_MAP_GRIDS: usize = MAX_FLOORS;
/// Longest string of a radio map read as a stream (ids, names), bytes as
/// written (escapes included).
pub const MAX_RADIO_MAP_STRING_BYTES: usize = 1024;
/// Longest number token of a JSON stream, characters (an f64 written to
/// round-trip takes at most 24).
pub const MAX_JSON_NUMBER_CHARS: usize = 100;
/// Most particles / random candidates of a filter.
pub const MAX_PARTICLES: usize = 1_000_000;
/// Largest plan file read from disk, bytes (callers that read plans check it).
pub const MAX_PLAN_FILE_BYTES: u64 = 256 * 1024 * 1024;
/// Whether `meta` (of a plan file at `path`, before and after opening it)
/// may be read: a regular file (a FIFO or device would block or never end, a
/// directory is no plan) of at most [`MAX_PLAN_FILE_BYTES`]. The check
/// only; the callers that read plans (CLI, JNI) do the I/O.
pub fn check_plan_file(path: &std::path::Path, meta: &std::fs::Metadata) -> std::io::Result<()> {
    use std::io::{Error, ErrorKind};
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("{}: not a regular file", path.display()),
        ));
    }
    if meta.len() > MAX_PLAN_FILE_BYTES {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "{}: {} bytes, over the limit of {MAX_PLAN_FILE_BYTES}",
                path.display(),
                meta.len()
            ),
        ));
    }
    Ok(())
}

/// Longest an input value is echoed in an error message, characters.
pub const MAX_ECHO_CHARS: usize = 80;

/// `v` for a message: scientific notation for very small or large magnitudes
/// (`1e-300`, not 300 digits).
pub fn show(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// `v` finite and in `[min, max]`; the error names `field`, the value and the limits.
pub fn check_range(field: &str, v: f64, min: f64, max: f64) -> Result<()> {
    if v.is_finite() && v >= min && v <= max {
        Ok(())
    } else {
        Err(Error::config(
            field,
            format!(
                "must be finite and in [{}, {}], got {}",
                show(min),
                show(max),
                show(v)
            ),
        ))
    }
}

/// A raycast / wall-check sampling step, metres.
pub fn check_ray_step(field: &str, v: f64) -> Result<()> {
    check_range(field, v, MIN_RAY_STEP_M, MAX_RAY_STEP_M)
}

/// A grid interval or cell side, metres (no upper bound beyond finiteness:
/// a large interval gives a small grid).
pub fn check_grid_step(field: &str, v: f64) -> Result<()> {
    check_range(field, v, MIN_GRID_STEP_M, MAX_FLOOR_SIDE_M)
}

/// A count in `[min, max]`.
pub fn check_count(field: &str, v: usize, min: usize, max: usize) -> Result<()> {
    if (min..=max).contains(&v) {
        Ok(())
    } else {
        Err(Error::config(
            field,
            format!("must be in {min}..={max}, got {v}"),
        ))
    }
}

/// floor(w / step) x floor(h / step) computed without overflow (f64), the
/// cell count of a grid of interval `step` over a `w` x `h` m floor.
pub fn grid_cells(w_m: f64, h_m: f64, step_m: f64) -> f64 {
    (w_m / step_m).floor().max(0.0) * (h_m / step_m).floor().max(0.0)
}

/// `s` cut to [`MAX_ECHO_CHARS`] characters (with the total length said), for
/// echoing an input value in messages.
pub fn echo(s: &str) -> String {
    cut(s, MAX_ECHO_CHARS)
}

/// Longest message built around echoed input (a parser's), characters.
pub const MAX_MESSAGE_CHARS: usize = 400;

/// `s` cut to `max_chars` characters, with the total length said.
pub fn cut(s: &str, max_chars: usize) -> String {
    let n = s.chars().count();
    if n <= max_chars {
        s.to_string()
    } else {
        let head: String = s.chars().take(max_chars).collect();
        format!("{head}... ({n} characters)")
    }
}

/// A vector of `n` copies of `v`, or an error naming `what` when the memory
/// cannot be had (instead of the abort of `vec![v; n]`).
pub fn try_filled<T: Clone>(n: usize, v: T, what: &str) -> Result<Vec<T>> {
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|e| {
        Error::Input(format!(
            "{what}: cannot allocate {n} elements of {} bytes: {e}",
            std::mem::size_of::<T>()
        ))
    })?;
    out.resize(n, v);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_errors_name_field_value_and_limits() {
        let e = check_ray_step("prox_pf.raycast_step_m", 1e-300)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("prox_pf.raycast_step_m") && e.contains("1e-300") && e.contains("0.001"),
            "{e}"
        );
        assert!(check_ray_step("s", f64::NAN).is_err());
        assert!(check_ray_step("s", 0.05).is_ok());
        let e = check_count("ekf.fingerprint.ap_iterations", 1_000_000_000, 1, 10_000)
            .unwrap_err()
            .to_string();
        assert!(e.contains("1000000000") && e.contains("1..=10000"), "{e}");
    }

    #[test]
    fn grid_cells_do_not_overflow() {
        assert_eq!(grid_cells(20.0, 12.0, 1.0), 240.0);
        assert!(grid_cells(20.0, 12.0, 1e-300) > MAX_GRID_CELLS as f64);
        assert_eq!(grid_cells(20.0, 12.0, 1e6), 0.0);
    }

    #[test]
    fn echo_cuts_long_inputs() {
        assert_eq!(echo("abc"), "abc");
        let long = "x".repeat(10_000_000);
        let e = echo(&long);
        assert!(e.len() < 120 && e.contains("10000000 characters"), "{e}");
    }

    #[test]
    fn try_filled_refuses_impossible_sizes() {
        assert!(try_filled(usize::MAX / 2, 0u64, "test").is_err());
        assert_eq!(try_filled(3, 7u8, "test").unwrap(), vec![7, 7, 7]);
    }
}
