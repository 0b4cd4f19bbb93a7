//! The interface shared by GML and its baselines.

use serde::{Deserialize, Serialize};

use super::baselines::{LlsTrilateration, MlContinuous, WeightedCentroid};
use super::config::BleConfig;
use super::frontend::FilteredBeacon;
use super::gml::Gml;
use crate::Vec2;

/// A BLE positioning algorithm: filtered beacons (one floor, strongest
/// first) -> one position estimate y* (before the mean filter).
pub trait BlePositioner: Send {
    /// Short name (the engine name).
    fn name(&self) -> &'static str;
    /// Estimates the position from `beacons`. `grid` is the floor's walkable
    /// grid (only GML uses it); `prev` the previous position, when known.
    /// Returns `None` when no position can be computed (too few beacons,
    /// degenerate geometry, empty grid); never a non-finite position.
    fn locate(
        &mut self,
        beacons: &[FilteredBeacon],
        grid: &[Vec2],
        prev: Option<Vec2>,
    ) -> Option<Vec2>;
}

/// The positioners the engines are built from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum PositionerKind {
    Gml,
    Trilat,
    Frbw,
    Ml,
    WeightedCentroid,
}

impl PositionerKind {
    pub const ALL: [PositionerKind; 5] = [
        PositionerKind::Gml,
        PositionerKind::Trilat,
        PositionerKind::Frbw,
        PositionerKind::Ml,
        PositionerKind::WeightedCentroid,
    ];

    /// Engine name.
    pub fn name(self) -> &'static str {
        match self {
            PositionerKind::Gml => "gml",
            PositionerKind::Trilat => "trilat",
            PositionerKind::Frbw => "frbw",
            PositionerKind::Ml => "ml",
            PositionerKind::WeightedCentroid => "wcentroid",
        }
    }

    pub fn from_name(name: &str) -> Option<PositionerKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Builds the positioner.
    pub fn build(self, cfg: &BleConfig) -> Box<dyn BlePositioner> {
        match self {
            PositionerKind::Gml => Box::new(Gml::new(cfg)),
            PositionerKind::Trilat => Box::new(LlsTrilateration::new(cfg)),
            PositionerKind::Frbw => Box::new(WeightedCentroid::frbw(cfg)),
            PositionerKind::Ml => Box::new(MlContinuous::new(cfg)),
            PositionerKind::WeightedCentroid => Box::new(WeightedCentroid::new(cfg)),
        }
    }
}

/// Whether a point is finite (positioners never return anything else).
pub(crate) fn finite(p: Vec2) -> Option<Vec2> {
    (p.x.is_finite() && p.y.is_finite()).then_some(p)
}
