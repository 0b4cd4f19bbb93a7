//! Settings of the radio map's builder ([`RadioMapConfig`]: `fpbp
//! calibrate --radio-map`, docs/parameters.md "Radio map").

use serde::{Deserialize, Serialize};

use super::magnetic_map::MagneticMapConfig;
use super::radio_map::FallbackParams;
use super::survey::SurveyOptions;
use super::wall_prior::WallPriorConfig;
use crate::Result;
use crate::bounds::{MAX_RADIO_MAP_GRID_CELLS, check_count};

/// Settings of [`super::radio_map_build::RadioMapBuilder`] (`fpbp
/// calibrate --radio-map`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioMapConfig {
    /// Grid cell side, metres. Default 2.
    pub cell_m: f64,
    /// Readings are binned in squares of this side before smoothing, m. Default 1.
    pub bin_m: f64,
    /// Gaussian kernel bandwidth (sd), metres. Default 2.5.
    pub bandwidth_m: f64,
    /// Cells farther than this from every bin hold no value, metres. Default 8.
    pub max_distance_m: f64,
    /// Pseudo-samples of the fallback mean/spread in every cell. Default 2.
    pub prior_weight: f64,
    /// Spread bounds of a cell, dB. Defaults 4.5 / 12.
    pub min_sd_db: f64,
    pub max_sd_db: f64,
    /// Spread added per metre of distance to the nearest bin (in
    /// quadrature), dB/m. Default 0.8.
    pub sd_growth_db_per_m: f64,
    /// A transmitter needs this many readings and walks. Defaults 20 / 2.
    pub min_samples: usize,
    pub min_walks: usize,
    /// Moving transmitter: RMS disagreement of walks in shared bins (each
    /// walk's median offset removed) above this, dB. Default 6.
    pub moving_max_db: f64,
    /// The moving test needs this many shared bins (fewer: not tested). Default 3.
    pub moving_min_bins: usize,
    /// Remove each survey walk's own RSSI offset (per radio kind, learned
    /// where walks share bins: [`super::walk_offsets`]) before smoothing.
    /// Default true (the folds of docs/lab/tcpf-history.md "Stop 33").
    pub walk_offsets: bool,
    /// A walk needs this many bins shared with other walks for an offset
    /// (fewer: none). Default 10.
    pub walk_offset_min_bins: usize,
    /// Estimate the walks' offsets against every walk's reading in a bin,
    /// the walk's own included, which converges to offsets whose
    /// differences are the walks' ([`super::walk_offsets::BinLevel`]).
    /// Default false: against the other walks' readings, 5 rounds, which
    /// leaves two walks that share bins twice their difference apart (the
    /// default the protocol was tuned with; docs/lab/tcpf-radio-trust.md
    /// "Two phone models, two radios").
    pub walk_offsets_converged: bool,
    /// With `walk_offsets`, remove them from the survey's reference scans
    /// too ([`super::radio_map_build::RadioMapBuilder::with_reference_scans`]). Default true.
    pub walk_offsets_in_scans: bool,
    /// Most cells of one grid (the cell is coarsened by 1.25x until it
    /// fits). Default 40000.
    pub max_cells_per_grid: usize,
    /// WiFi results older than this vs their scan are dropped, s. Default 4
    /// (tcpf's `wifi_max_age_s`).
    pub wifi_max_age_s: f64,
    /// Readings weaker than this are dropped, dBm. Default -100.
    pub min_rssi_dbm: f64,
    /// No position across truth points further apart, s. Default 20.
    pub max_truth_gap_s: f64,
    /// Phone height above the floor (path-loss fallback), m. Default 1.2.
    pub phone_height_m: f64,
    /// Only transmitters the site has (a path-loss model from `fpbp
    /// calibrate`, which rejects moving and non-log-distance ones) get
    /// grids; the others are left out. Default true: on ILC F1 (even
    /// half) every surveyed transmitter gave 16.7 m own start against 14.5
    /// m with the site's only (docs/parameters.md).
    pub site_transmitters_only: bool,
    /// Calibrate the cells' spread on the survey itself, leaving one walk
    /// out ([`super::radio_map_spread`]): per radio kind
    /// `sd(d) = sqrt(s0^2 + (k d)^2)` at distance d from the survey replaces the smoothed
    /// spread (and `sd_growth_db_per_m`, `min_sd_db`), and the residuals
    /// beyond `max_distance_m` set the fallback's path-loss spread.
    /// Default false (docs/tcpf.md "Radio map spread calibration").
    pub spread_calibration: bool,
    pub fallback: FallbackParams,
    /// The multi-wall prior under the map ([`super::wall_prior`]).
    pub wall_prior: WallPriorConfig,
    /// The magnetic field's map from the same walks
    /// ([`super::magnetic_map`]).
    pub magnetic: MagneticMapConfig,
}

impl Default for RadioMapConfig {
    fn default() -> Self {
        RadioMapConfig {
            cell_m: 2.0,
            bin_m: 1.0,
            bandwidth_m: 2.5,
            max_distance_m: 8.0,
            prior_weight: 2.0,
            min_sd_db: 4.5,
            max_sd_db: 12.0,
            sd_growth_db_per_m: 0.8,
            min_samples: 20,
            min_walks: 2,
            moving_max_db: 6.0,
            moving_min_bins: 3,
            walk_offsets: true,
            walk_offset_min_bins: 10,
            walk_offsets_converged: false,
            walk_offsets_in_scans: true,
            max_cells_per_grid: 40_000,
            wifi_max_age_s: 4.0,
            min_rssi_dbm: -100.0,
            max_truth_gap_s: 20.0,
            phone_height_m: 1.2,
            site_transmitters_only: true,
            spread_calibration: false,
            fallback: FallbackParams::default(),
            wall_prior: WallPriorConfig::default(),
            magnetic: MagneticMapConfig::default(),
        }
    }
}

impl RadioMapConfig {
    /// What a survey log's readings and magnetometer samples are placed
    /// with ([`survey_samples`], [`super::survey::magnetic_samples`]);
    /// `default_floor` for truth points without one.
    pub fn survey_options(&self, default_floor: Option<i32>) -> SurveyOptions {
        SurveyOptions {
            default_floor,
            max_truth_gap_ns: (self.max_truth_gap_s * 1e9) as i64,
            wifi_max_age_ns: (self.wifi_max_age_s * 1e9) as i64,
            min_rssi_dbm: self.min_rssi_dbm,
        }
    }

    /// Checks every field's range; errors name `radio_map.<field>`.
    pub fn validate(&self) -> Result<()> {
        use crate::bounds::{MIN_GRID_STEP_M, check_range};
        let p = "radio_map";
        self.magnetic.validate(&format!("{p}.magnetic"))?;
        check_range(&format!("{p}.cell_m"), self.cell_m, 0.25, 100.0)?;
        check_range(
            &format!("{p}.bin_m"),
            self.bin_m,
            MIN_GRID_STEP_M.max(0.1),
            100.0,
        )?;
        check_range(&format!("{p}.bandwidth_m"), self.bandwidth_m, 0.1, 50.0)?;
        check_range(
            &format!("{p}.max_distance_m"),
            self.max_distance_m,
            0.0,
            100.0,
        )?;
        check_range(&format!("{p}.prior_weight"), self.prior_weight, 0.0, 1e6)?;
        check_range(&format!("{p}.min_sd_db"), self.min_sd_db, 0.1, 50.0)?;
        check_range(
            &format!("{p}.max_sd_db"),
            self.max_sd_db,
            self.min_sd_db,
            50.0,
        )?;
        check_range(
            &format!("{p}.sd_growth_db_per_m"),
            self.sd_growth_db_per_m,
            0.0,
            50.0,
        )?;
        check_count(&format!("{p}.min_samples"), self.min_samples, 1, 1 << 30)?;
        check_count(&format!("{p}.min_walks"), self.min_walks, 1, 1 << 20)?;
        check_range(
            &format!("{p}.moving_max_db"),
            self.moving_max_db,
            0.0,
            200.0,
        )?;
        check_count(
            &format!("{p}.moving_min_bins"),
            self.moving_min_bins,
            1,
            1 << 20,
        )?;
        check_count(
            &format!("{p}.walk_offset_min_bins"),
            self.walk_offset_min_bins,
            1,
            1 << 30,
        )?;
        check_count(
            &format!("{p}.max_cells_per_grid"),
            self.max_cells_per_grid,
            1,
            MAX_RADIO_MAP_GRID_CELLS,
        )?;
        check_range(
            &format!("{p}.wifi_max_age_s"),
            self.wifi_max_age_s,
            0.0,
            3600.0,
        )?;
        check_range(&format!("{p}.min_rssi_dbm"), self.min_rssi_dbm, -200.0, 0.0)?;
        check_range(
            &format!("{p}.max_truth_gap_s"),
            self.max_truth_gap_s,
            0.0,
            86_400.0,
        )?;
        check_range(
            &format!("{p}.phone_height_m"),
            self.phone_height_m,
            -10.0,
            10.0,
        )?;
        self.wall_prior.validate(&format!("{p}.wall_prior"))?;
        self.fallback.validate(&format!("{p}.fallback"))
    }
}
