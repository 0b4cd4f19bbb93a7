//! The magnetic field's magnitude learned from survey walks: a second map
//! signal beside the radio. A building's steel bends the earth's field
//! into a pattern fixed in place; the magnitude |B| does not depend on how
//! the phone is held. On the shared ILC site1/F1 traces the walks' mean
//! |B| in a 2 m cell agrees across walkers and phones to about 1.9 uT while
//! the cell means vary about 6 uT over the floor (`cargo run --release -p
//! fpbp-cli --example magnetic_map_check`, docs/lab/tcpf-history.md "Stop 32").
//!
//! [`MagneticMapBuilder`] bins the placed samples of every survey log
//! ([`super::survey::magnetic_samples`]) per floor in `bin_m` squares and
//! smooths them onto one grid per floor with the radio map's kernel
//! ([`super::radio_map_build`], `prior_weight` 0: no model to lean on),
//! values in 0.1 uT in the radio map's [`Grid`] layout. Cells further than
//! `max_distance_m` from every bin have no value: there the field is
//! unknown and the engine takes no evidence from it. The map travels in the
//! radio map file's optional `magnetic` section (docs/formats.md).
//!
//! Pure: events in, the map out.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::radio_map::{Grid, NO_VALUE};
use super::radio_map_build::{BinStat, SmoothParams, smooth_grid};
use super::survey::{SurveyOptions, magnetic_samples};
use crate::Vec2;
use crate::bounds::{MAX_RADIO_MAP_CELLS, check_count, check_range};
use crate::events::LogEvent;
use crate::{Error, Result};

/// The strongest field a survey sample may read, uT: the earth's is
/// 25-65 uT and a building's steel bends it by tens; a phone beside a
/// magnet reads more, and such samples are left out of the map (its file
/// refuses means beyond this, `radio_map_file`).
pub const MAX_FIELD_UT: f64 = 200.0;

/// The field's magnitude |B| of a magnetometer sample, uT.
pub fn magnitude_ut(b: crate::events::Vec3) -> f64 {
    (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt()
}

/// Settings of [`MagneticMapBuilder`] (the `magnetic` section of the radio
/// map settings, `fpbp calibrate --radio-map-config`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MagneticMapConfig {
    /// Build the magnetic grids at all.
    pub enabled: bool,
    /// Bin side for the samples, metres.
    pub bin_m: f64,
    /// Grid cell side, metres.
    pub cell_m: f64,
    /// Gaussian kernel bandwidth (sd), metres.
    pub bandwidth_m: f64,
    /// No value further than this from every bin, metres.
    pub max_distance_m: f64,
    /// Cell spread bounds and its growth with the distance to the nearest
    /// bin, uT and uT per metre.
    pub min_sd_ut: f64,
    pub max_sd_ut: f64,
    pub sd_growth_ut_per_m: f64,
    /// A floor needs this many placed samples for a grid.
    pub min_samples: usize,
    /// Cells per floor's grid at most (the cell is coarsened to fit).
    pub max_cells_per_grid: usize,
}

impl Default for MagneticMapConfig {
    fn default() -> Self {
        MagneticMapConfig {
            enabled: true,
            bin_m: 1.0,
            cell_m: 1.0,
            bandwidth_m: 1.0,
            max_distance_m: 2.0,
            min_sd_ut: 1.5,
            max_sd_ut: 10.0,
            sd_growth_ut_per_m: 1.0,
            min_samples: 500,
            max_cells_per_grid: 250_000,
        }
    }
}

impl MagneticMapConfig {
    /// Checks every field; errors name `<prefix>.<field>`.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        for (f, v, lo, hi) in [
            ("bin_m", self.bin_m, 0.1, 20.0),
            ("cell_m", self.cell_m, 0.1, 20.0),
            ("bandwidth_m", self.bandwidth_m, 0.1, 20.0),
            ("max_distance_m", self.max_distance_m, 0.0, 50.0),
            ("min_sd_ut", self.min_sd_ut, 0.1, 50.0),
            ("max_sd_ut", self.max_sd_ut, self.min_sd_ut, 100.0),
            ("sd_growth_ut_per_m", self.sd_growth_ut_per_m, 0.0, 50.0),
        ] {
            check_range(&format!("{prefix}.{f}"), v, lo, hi)?;
        }
        check_count(
            &format!("{prefix}.max_cells_per_grid"),
            self.max_cells_per_grid,
            1,
            1 << 20,
        )?;
        Ok(())
    }
}

/// One grid per floor of |B| (mean and spread, 0.1 uT).
#[derive(Debug, Clone, PartialEq)]
pub struct MagneticMap {
    grids: Vec<Grid>,
}

impl MagneticMap {
    /// A map of the given grids (at most one per floor; checked by the
    /// file reader).
    pub fn new(grids: Vec<Grid>) -> Self {
        MagneticMap { grids }
    }

    pub fn grids(&self) -> &[Grid] {
        &self.grids
    }

    /// The grid of `floor`, if the survey gave it one.
    pub fn grid(&self, floor: i32) -> Option<&Grid> {
        self.grids.iter().find(|g| g.floor == floor)
    }

    /// (mean, sd) of |B| at `p` on `floor`, uT; `None` where the survey
    /// says nothing.
    pub fn sample(&self, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        self.grid(floor).and_then(|g| g.sample(p))
    }
}

#[derive(Default)]
struct Bin {
    n: f64,
    sum: f64,
    sum2: f64,
    pos_sum: Vec2,
}

/// Accumulates survey logs into a [`MagneticMap`].
pub struct MagneticMapBuilder {
    cfg: MagneticMapConfig,
    bins: BTreeMap<i32, BTreeMap<(i64, i64), Bin>>,
    samples: BTreeMap<i32, usize>,
}

impl MagneticMapBuilder {
    pub fn new(cfg: &MagneticMapConfig) -> Result<Self> {
        cfg.validate("magnetic")?;
        Ok(MagneticMapBuilder {
            cfg: cfg.clone(),
            bins: BTreeMap::new(),
            samples: BTreeMap::new(),
        })
    }

    /// Adds one log's magnetometer samples; returns (seen, placed).
    pub fn add_log(&mut self, events: &[LogEvent], opts: &SurveyOptions) -> (usize, usize) {
        let bin = self.cfg.bin_m;
        let (bins, samples) = (&mut self.bins, &mut self.samples);
        magnetic_samples(events, opts, |floor, pos, ut| {
            let key = ((pos.x / bin).floor() as i64, (pos.y / bin).floor() as i64);
            let b = bins.entry(floor).or_default().entry(key).or_default();
            b.n += 1.0;
            b.sum += ut;
            b.sum2 += ut * ut;
            b.pos_sum += pos;
            *samples.entry(floor).or_default() += 1;
        })
    }

    /// The map (`None` when no floor has `min_samples`), with the samples
    /// per floor.
    pub fn finish(self) -> Result<(Option<MagneticMap>, BTreeMap<i32, usize>)> {
        let c = &self.cfg;
        let p = SmoothParams {
            cell_m: c.cell_m,
            bandwidth_m: c.bandwidth_m,
            max_distance_m: c.max_distance_m,
            prior_weight: 0.0,
            min_sd: c.min_sd_ut,
            max_sd: c.max_sd_ut,
            sd_growth_per_m: c.sd_growth_ut_per_m,
            max_cells_per_grid: c.max_cells_per_grid,
            sd_at: None,
            base_at: None,
        };
        let mut grids = Vec::new();
        let mut cells = 0usize;
        for (floor, bins) in &self.bins {
            if self.samples.get(floor).copied().unwrap_or(0) < c.min_samples {
                continue;
            }
            let stats: Vec<BinStat> = bins
                .values()
                .map(|b| BinStat::of(b.n, b.sum, b.sum2, b.pos_sum))
                .collect();
            let (n, s1) = stats
                .iter()
                .fold((0.0, 0.0), |a, s| (a.0 + s.n, a.1 + s.sum));
            let floor_mean = s1 / n.max(1.0);
            let fallback = move |_: Vec2| (floor_mean, p.max_sd);
            if let Some(g) = smooth_grid(*floor, &stats, &p, &fallback)? {
                cells = cells.saturating_add(g.mean_dbm_x10.len());
                if cells > MAX_RADIO_MAP_CELLS {
                    return Err(Error::Input(format!(
                        "magnetic map: over {MAX_RADIO_MAP_CELLS} cells"
                    )));
                }
                grids.push(g);
            }
        }
        let map = (!grids.is_empty()).then(|| MagneticMap::new(grids));
        Ok((map, self.samples))
    }
}

/// Cells of `g` with a value.
pub fn valued_cells(g: &Grid) -> usize {
    g.mean_dbm_x10.iter().filter(|m| **m != NO_VALUE).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::{SensorData, SensorEvent, TruthPoint};

    /// A walk along y = 0 from x = 0 to x = 40 m in 40 s with |B| = 40 +
    /// 10 sin(x / 3) (a fixed pattern along the corridor), 10 Hz.
    fn walk(offset_ut: f64) -> Vec<LogEvent> {
        let mut ev = Vec::new();
        for k in 0..=40 {
            ev.push(LogEvent::Truth(TruthPoint {
                t_ns: k * 1_000_000_000,
                x_m: k as f64,
                y_m: 0.0,
                floor: Some(0),
            }));
        }
        for k in 0..400 {
            let x = k as f64 * 0.1;
            let b = 40.0 + 10.0 * (x / 3.0).sin() + offset_ut;
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns: k * 100_000_000,
                data: SensorData::Magnetometer([0.0, b * 0.6, -b * 0.8]),
            }));
        }
        ev.sort_by_key(LogEvent::t_ns);
        ev
    }

    fn opts() -> SurveyOptions {
        SurveyOptions {
            default_floor: None,
            max_truth_gap_ns: 20_000_000_000,
            wifi_max_age_ns: 4_000_000_000,
            min_rssi_dbm: -100.0,
        }
    }

    #[test]
    fn the_map_holds_the_walked_pattern_and_nothing_far_from_it() {
        let cfg = MagneticMapConfig {
            min_samples: 10,
            ..MagneticMapConfig::default()
        };
        let mut b = MagneticMapBuilder::new(&cfg).unwrap();
        assert_eq!(b.add_log(&walk(0.0), &opts()), (400, 400));
        let (map, samples) = b.finish().unwrap();
        let map = map.expect("a grid for floor 0");
        assert_eq!(samples[&0], 400);
        for x in [5.0, 12.5, 20.0, 31.0] {
            let (m, sd) = map.sample(0, Vec2::new(x, 0.0)).expect("on the walk");
            let truth = 40.0 + 10.0 * (x / 3.0).sin();
            // the 1 m kernel smooths a 19 m wavelength only a little
            assert!((m - truth).abs() < 1.5, "x {x}: {m} vs {truth}");
            assert!((1.5..4.0).contains(&sd), "x {x}: sd {sd}");
        }
        // 5 m beside the walk: no value; another floor: none
        assert!(map.sample(0, Vec2::new(20.0, 5.0)).is_none());
        assert!(map.sample(1, Vec2::new(20.0, 0.0)).is_none());
    }

    #[test]
    fn a_phone_beside_a_magnet_cannot_push_the_map_out_of_the_files_range() {
        // two seconds of 900 uT at x = 20 m (a phone held to a speaker)
        let mut ev = walk(0.0);
        ev.extend((0..20).map(|k| {
            LogEvent::Sensor(SensorEvent {
                t_ns: 20_000_000_000 + k * 100_000_000,
                data: SensorData::Magnetometer([900.0, 0.0, 0.0]),
            })
        }));
        ev.sort_by_key(LogEvent::t_ns);
        let cfg = MagneticMapConfig {
            min_samples: 10,
            ..MagneticMapConfig::default()
        };
        let mut b = MagneticMapBuilder::new(&cfg).unwrap();
        assert_eq!(
            b.add_log(&ev, &opts()),
            (420, 400),
            "the 20 are seen, not placed"
        );
        let map = b.finish().unwrap().0.unwrap();
        let hi = (MAX_FIELD_UT * 10.0) as i16;
        for g in map.grids() {
            assert!(
                g.mean_dbm_x10
                    .iter()
                    .all(|m| *m == NO_VALUE || (0..=hi).contains(m)),
                "a mean beyond {MAX_FIELD_UT} uT: the radio map reader refuses it"
            );
        }
    }

    #[test]
    fn too_few_samples_give_no_map_and_bad_settings_are_named() {
        let mut b = MagneticMapBuilder::new(&MagneticMapConfig::default()).unwrap();
        b.add_log(&walk(0.0), &opts());
        assert!(b.finish().unwrap().0.is_none(), "400 < 500 samples");
        let bad = MagneticMapConfig {
            bandwidth_m: -1.0,
            ..MagneticMapConfig::default()
        };
        let e = MagneticMapBuilder::new(&bad).err().unwrap().to_string();
        assert!(e.contains("magnetic.bandwidth_m"), "{e}");
    }
}
