//! The BLE task (the paper's GML Runnable): front end + one positioner + the
//! eq. 22 mean filter. Each run picks the floor most of the strongest beacons
//! are on, estimates y* on that floor's grid and returns x_B.

use std::collections::BTreeMap;

use super::config::BleConfig;
use super::frontend::{BleFrontEnd, FilteredBeacon};
use super::mean_filter::MeanFilter;
use super::positioner::{BlePositioner, PositionerKind};
use crate::Vec2;
use crate::events::BleObservation;
use crate::site::Site;

/// One BLE position x_B.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BleFix {
    pub t_ns: i64,
    /// x_B after the mean filter, MCS metres.
    pub pos: Vec2,
    /// y* before the mean filter.
    pub raw: Vec2,
    pub floor: i32,
    /// Beacons the filtered set held on `floor`.
    pub beacons: usize,
}

/// Front end + positioner + mean filter.
pub struct BleTask {
    cfg: BleConfig,
    front: BleFrontEnd,
    positioner: Box<dyn BlePositioner>,
    mean: MeanFilter,
    grids: BTreeMap<i32, Vec<Vec2>>,
    last: Option<BleFix>,
    /// NLOS identification, when `ble.nlos.gml_mode` is not `off`.
    nlos: Option<super::nlos::NlosIdentifier>,
    /// RSSI-bias estimate when `estimate_rssi_bias` is on.
    bias: Option<super::rssi_bias::RssiBiasEstimator>,
    /// Floor tracker (`ble.floor_tracker`): barometer + likely-floor votes.
    floors: Option<crate::floor::FloorTracker>,
    /// Runs that produced no position.
    pub no_fix: u64,
}

impl BleTask {
    /// A task on `site` with the positioner `kind` (GML searches each floor's
    /// `FloorMap::grid()`).
    pub fn new(kind: PositionerKind, cfg: &BleConfig, site: &Site) -> Self {
        let mut grids = BTreeMap::new();
        if kind == PositionerKind::Gml {
            for (spec, map) in site.spec.floors.iter().zip(&site.floors) {
                grids.insert(spec.id, map.grid().to_vec());
            }
        }
        let mut task = Self::with_parts(cfg, BleFrontEnd::new(cfg, site), kind.build(cfg), grids);
        task.floors = cfg.floor_tracker.then(|| {
            crate::floor::FloorTracker::new(&cfg.floor, &site.floor_heights(), site.default_floor())
        });
        task
    }

    /// One sensor sample: pressure goes to the floor tracker (if any).
    pub fn on_sensor(&mut self, event: &crate::events::SensorEvent) {
        if let (Some(ft), crate::events::SensorData::Pressure(p)) =
            (self.floors.as_mut(), event.data)
        {
            ft.on_pressure(event.t_ns, p);
        }
    }

    /// The floor tracker's rejected pressure samples.
    pub fn floor_rejected(&self) -> u64 {
        self.floors.as_ref().map_or(0, |f| f.rejected)
    }

    /// A task from explicit parts (tests, benches, other engines).
    pub fn with_parts(
        cfg: &BleConfig,
        front: BleFrontEnd,
        positioner: Box<dyn BlePositioner>,
        grids: BTreeMap<i32, Vec<Vec2>>,
    ) -> Self {
        BleTask {
            cfg: cfg.clone(),
            front,
            positioner,
            mean: MeanFilter::with_mode(cfg.mean_window_n, cfg.mean_reset_s, cfg.mean_mode),
            grids,
            last: None,
            nlos: (cfg.nlos.gml_mode != super::nlos::NlosGmlMode::Off)
                .then(|| super::nlos::NlosIdentifier::new(&cfg.nlos, cfg.min_distance_m)),
            bias: cfg
                .estimate_rssi_bias
                .then(|| super::rssi_bias::RssiBiasEstimator::new(6.0, 0.01, 5.0)),
            floors: None,
            no_fix: 0,
        }
    }

    pub fn front(&self) -> &BleFrontEnd {
        &self.front
    }

    pub fn positioner_name(&self) -> &'static str {
        self.positioner.name()
    }

    /// Hands one observation to the front end; true when it was used.
    pub fn on_observation(&mut self, obs: &BleObservation) -> bool {
        self.front.on_observation(obs)
    }

    /// The current filtered set on the likely floor, strongest first.
    pub fn beacons_on_floor(&self, t_ns: i64) -> (Option<i32>, Vec<FilteredBeacon>) {
        let all = self.front.current(t_ns);
        let floor = BleFrontEnd::likely_floor(&all, self.cfg.gml.top_n);
        let on = all.into_iter().filter(|b| Some(b.floor) == floor).collect();
        (floor, on)
    }

    /// One run at `t_ns`. `prev` is the previous position on the floor (the
    /// fused one for FP-BP); `None` uses this task's own last x_B when it is on
    /// the same floor. Returns x_B, or `None` (counted in `no_fix`).
    pub fn run(&mut self, t_ns: i64, prev: Option<Vec2>) -> Option<BleFix> {
        let (floor, beacons) = self.beacons_on_floor(t_ns);
        let Some(likely) = floor else {
            self.no_fix += 1;
            return None;
        };
        // with pressure, the floor tracker decides the floor; its beacons are
        // used when at least 3 are heard, else every heard beacon (a floor
        // with few or no beacons, e.g. a mezzanine)
        let (floor, beacons) = match self.floors.as_mut() {
            Some(ft) if ft.has_pressure() => {
                if let Some(v) = BleFrontEnd::floor_vote(
                    ft.config(),
                    &self.front.current(t_ns),
                    self.cfg.gml.top_n,
                ) {
                    ft.on_ble_floor(t_ns, v);
                }
                match ft.floor() {
                    Some(f) if f != likely => {
                        let all = self.front.current(t_ns);
                        let on: Vec<FilteredBeacon> =
                            all.iter().filter(|b| b.floor == f).copied().collect();
                        (f, if on.len() >= 3 { on } else { all })
                    }
                    _ => (likely, beacons),
                }
            }
            _ => (likely, beacons),
        };
        let same_floor_last = self.last.filter(|l| l.floor == floor);
        if same_floor_last.is_none() {
            self.mean.clear();
        }
        let prev = prev.or(same_floor_last.map(|l| l.pos));
        let grid: &[Vec2] = self.grids.get(&floor).map(|g| g.as_slice()).unwrap_or(&[]);
        // RSSI-bias correction (ble.estimate_rssi_bias), then NLOS identification
        // against the previous position (ble.nlos.gml_mode)
        let corrected: Vec<FilteredBeacon> = match &self.bias {
            Some(b) => beacons
                .iter()
                .map(|f| FilteredBeacon {
                    rssi_dbm: f.rssi_dbm - b.bias_db(),
                    ..*f
                })
                .collect(),
            None => beacons.clone(),
        };
        let corrected = match (&self.nlos, prev) {
            (Some(id), Some(p)) => id.apply_to_set(&corrected, p).0,
            _ => corrected,
        };
        let Some(raw) = self.positioner.locate(&corrected, grid, prev) else {
            self.no_fix += 1;
            return None;
        };
        if let Some(b) = self.bias.as_mut() {
            b.update_at(t_ns, raw, &beacons, self.cfg.min_distance_m);
        }
        let pos = self.mean.push(t_ns, raw);
        if !(pos.x.is_finite() && pos.y.is_finite()) {
            self.mean.clear();
            self.no_fix += 1;
            return None;
        }
        let fix = BleFix {
            t_ns,
            pos,
            raw,
            floor,
            beacons: beacons.len(),
        };
        self.last = Some(fix);
        Some(fix)
    }

    /// Forgets the mean filter's history and the last x_B (the caller moved
    /// the user to a known point: positions from before must not be averaged
    /// into the next x_B). The front end's RSSI windows are kept.
    pub fn reset_position(&mut self) {
        self.mean.clear();
        self.last = None;
    }

    /// The last x_B.
    pub fn last(&self) -> Option<BleFix> {
        self.last
    }
}
