//! How a log is read: strictness, georeference, reorder window, gap threshold.

use fpbp_core::site::GeoRef;
use serde::{Deserialize, Serialize};

/// The log formats this crate reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum LogFormat {
    /// fpbp native log v1 (docs/formats.md "Native log v1").
    Native,
    /// Microsoft Indoor Location Competition 2.0 trace.
    Ilc,
    /// IPIN GetSensorData logfile.
    Ipin,
}

impl LogFormat {
    /// Short lowercase name ("native", "ilc", "ipin").
    pub fn name(self) -> &'static str {
        match self {
            LogFormat::Native => "native",
            LogFormat::Ilc => "ilc",
            LogFormat::Ipin => "ipin",
        }
    }
}

/// Options of [`crate::open_log`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Fail on the first malformed line (file and line in the error) instead of
    /// skipping and counting it. Default false.
    pub strict: bool,
    /// The site's georeference and ENU -> MCS rotation (radians): needed to put
    /// lat/lon truth (IPIN POSI) into the MCS. Without it such truth points are
    /// skipped and counted in `ReadReport::truth_without_georef`. Default None.
    pub site_georef: Option<(GeoRef, f64)>,
    /// Floor given to truth points whose log does not say (ILC waypoints,
    /// native truth lines with `-`). Default None.
    pub default_floor: Option<i32>,
    /// Reorder window, seconds: rows that arrive out of order by up to this much
    /// are put back in time order; later ones are dropped and counted
    /// (`late_dropped`). Default 3.0 (ILC BLE batches and waypoints step back by
    /// well under 3 s; see docs/formats.md).
    pub reorder_window_s: f64,
    /// A gap between consecutive events longer than this, seconds, is counted in
    /// `ReadReport::gaps_over_threshold`. Default 1.0.
    pub gap_threshold_s: f64,
    /// Force a format instead of detecting it from the content. Default None.
    pub format: Option<LogFormat>,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            strict: false,
            site_georef: None,
            default_floor: None,
            reorder_window_s: 15.0,
            gap_threshold_s: 1.0,
            format: None,
        }
    }
}
