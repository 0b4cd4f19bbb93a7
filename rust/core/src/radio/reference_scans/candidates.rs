//! The candidates of a query, weighted, and where they point.

use std::collections::BTreeMap;

use crate::Vec2;

/// One candidate place of a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub floor: i32,
    pub pos: Vec2,
    /// RMS RSSI difference to the query, dB.
    pub dist_db: f64,
    /// The distance of the query's metric ([`super::ScanMetric`]): `dist_db`
    /// for [`super::ScanMetric::RmsDb`].
    pub score: f64,
}

/// A candidate weighted by its score: exp(-(s - s_best) / tau), the
/// weights of one query summing to 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightedCandidate {
    pub floor: i32,
    pub pos: Vec2,
    pub w: f64,
    /// The candidate's RSSI distance from the query, dB.
    pub dist_db: f64,
}

/// Where weighted candidates point: their heaviest floor (ties: the lower
/// id), its share of the weight, and the weighted mean and RMS spread of
/// the candidates on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateFix {
    pub floor: i32,
    pub share: f64,
    pub mean: Vec2,
    pub spread_m: f64,
}

/// The [`CandidateFix`] of `c`; `None` without weight.
pub fn candidate_fix(c: &[WeightedCandidate]) -> Option<CandidateFix> {
    let mut by_floor: BTreeMap<i32, f64> = BTreeMap::new();
    for a in c {
        *by_floor.entry(a.floor).or_insert(0.0) += a.w;
    }
    let (floor, share) = by_floor
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
    let (mut m, mut w) = (Vec2::zeros(), 0.0);
    for a in c.iter().filter(|a| a.floor == floor) {
        m += a.pos * a.w;
        w += a.w;
    }
    if w <= 0.0 {
        return None;
    }
    let mean = m / w;
    let spread_m = (c
        .iter()
        .filter(|a| a.floor == floor)
        .map(|a| a.w * (a.pos - mean).norm_squared())
        .sum::<f64>()
        / w)
        .sqrt();
    Some(CandidateFix {
        floor,
        share,
        mean,
        spread_m,
    })
}
