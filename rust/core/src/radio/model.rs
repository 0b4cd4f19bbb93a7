//! What RSSI a transmitter should give at a position: the [`RadioModel`]
//! trait and its path-loss implementation.

use std::collections::BTreeMap;

use super::fast_ln::ln_normal;
use crate::Vec2;
use crate::ble::pathloss::PathLoss;
use crate::radio_id::normalize_beacon_id;
use crate::site::{BeaconSpec, Site};

/// The two radios a transmitter can belong to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TxKind {
    Ble,
    Wifi,
}

/// One transmitter the model knows.
#[derive(Debug, Clone, PartialEq)]
pub struct Transmitter {
    /// Canonical id: a beacon id (`ibeacon:...`) or a lower-case BSSID.
    pub id: String,
    pub kind: TxKind,
    pub floor: i32,
    /// Position in the MCS, metres.
    pub pos: Vec2,
    /// Mounting height minus phone height, metres.
    pub dz_m: f64,
    pub model: PathLoss,
}

/// Transmitter indices by kind and canonical id, looked up by `&str`
/// without allocating a key (one map per kind).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct IdIndex {
    ble: BTreeMap<String, usize>,
    wifi: BTreeMap<String, usize>,
}

impl IdIndex {
    fn map(&self, kind: TxKind) -> &BTreeMap<String, usize> {
        match kind {
            TxKind::Ble => &self.ble,
            TxKind::Wifi => &self.wifi,
        }
    }

    /// The index of `id` of `kind`, as stored.
    pub(crate) fn get(&self, kind: TxKind, id: &str) -> Option<usize> {
        self.map(kind).get(id).copied()
    }

    pub(crate) fn contains(&self, kind: TxKind, id: &str) -> bool {
        self.map(kind).contains_key(id)
    }

    /// Adds `id` of `kind` at `i`; false (and nothing changed) when it is
    /// already there.
    pub(crate) fn insert(&mut self, kind: TxKind, id: String, i: usize) -> bool {
        let m = match kind {
            TxKind::Ble => &mut self.ble,
            TxKind::Wifi => &mut self.wifi,
        };
        match m.entry(id) {
            std::collections::btree_map::Entry::Occupied(_) => false,
            std::collections::btree_map::Entry::Vacant(v) => {
                v.insert(i);
                true
            }
        }
    }
}

/// The index of `id` of `kind` in `by_id`, trying the id as given, then
/// its canonical spelling (beacon ids normalised, BSSIDs lower-case): the
/// lookup every [`RadioModel`] shares.
pub(crate) fn lookup_in(by_id: &IdIndex, kind: TxKind, id: &str) -> Option<usize> {
    if let Some(i) = by_id.get(kind, id) {
        return Some(i);
    }
    let canon = match kind {
        TxKind::Ble => normalize_beacon_id(id).ok()?,
        TxKind::Wifi => match crate::wifi::canonical_bssid(id) {
            // its own canonical form: already looked up (most BSSIDs a
            // phone hears are not in the model)
            std::borrow::Cow::Borrowed(_) => return None,
            std::borrow::Cow::Owned(c) => c,
        },
    };
    by_id.get(kind, &canon)
}

/// The path-loss curve of `t` at a phone at `p`: the 3-D range (floored at
/// `min_range_m`, `ble::pathloss::range_m`) through `t`'s R0 and exponent.
pub(crate) fn pathloss_mean(t: &Transmitter, p: Vec2, min_range_m: f64) -> f64 {
    let d = crate::ble::pathloss::range_m(p, t.pos, t.dz_m, min_range_m);
    t.model.rssi_at(d, min_range_m)
}

/// (mean, sd) of a transmitter `apart` floors from the phone: `loss_db`
/// less per floor, `extra_sd_db` more spread (added in quadrature); as is
/// on the same floor.
pub(crate) fn across_floors(
    (mean, sd): (f64, f64),
    apart: i32,
    loss_db: f64,
    extra_sd_db: f64,
) -> (f64, f64) {
    if apart > 0 {
        (
            mean - loss_db * f64::from(apart),
            (sd * sd + extra_sd_db * extra_sd_db).sqrt(),
        )
    } else {
        (mean, sd)
    }
}

/// Expected RSSI of a transmitter at a position and the spread around it.
pub trait RadioModel: Send + Sync {
    /// Every transmitter, indexed as [`RadioModel::lookup`] returns.
    fn transmitters(&self) -> &[Transmitter];
    /// Index of the transmitter with id `id` of kind `kind` (any spelling
    /// of a beacon id; BSSIDs lower-case).
    fn lookup(&self, kind: TxKind, id: &str) -> Option<usize>;
    /// (mean dBm, standard deviation dB) of transmitter `tx` for a phone at
    /// `p` on floor `floor`; `None` for an unknown index.
    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)>;
    /// [`RadioModel::expected`] of transmitter `tx` at every point of `ps`
    /// into `mean` and `sd` (each at least `ps.len()` long); `false` (the
    /// outputs unspecified) for an unknown index. The values of `expected`
    /// point by point (within 1e-6 dB: an override may use a faster
    /// logarithm); models override it to hoist the per-transmitter work out
    /// of the loop over particles.
    fn expected_many(
        &self,
        tx: usize,
        floor: i32,
        ps: &[Vec2],
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> bool {
        for ((p, m), s) in ps.iter().zip(mean.iter_mut()).zip(sd.iter_mut()) {
            let Some((a, b)) = self.expected(tx, floor, *p) else {
                return false;
            };
            (*m, *s) = (a, b);
        }
        true
    }
    /// Whether the model was learned per floor (a radio map), so that its
    /// likelihood can tell floors apart; a path-loss model with one
    /// attenuation per floor cannot (APs carry through floors).
    fn learned_per_floor(&self) -> bool {
        false
    }
    /// The survey's reference scans (fingerprints), when the model has them.
    fn reference_scans(&self) -> Option<&super::reference_scans::ReferenceScans> {
        None
    }
    /// Where values derived from the model are kept for every engine on
    /// it ([`super::derived`]); `None`: each engine builds its own.
    fn derived(&self) -> Option<&super::derived::DerivedCache> {
        None
    }
    /// The survey's magnetic field, when the model has it.
    fn magnetic(&self) -> Option<&super::magnetic_map::MagneticMap> {
        None
    }
    /// Phone model `device`'s offset of radio `kind` from the model's
    /// level, dB (to subtract from its readings), when the survey
    /// recorded walks with it ([`super::device_offsets`]).
    fn device_offset_db(&self, _device: &str, _kind: TxKind) -> Option<f64> {
        None
    }
}

/// Settings of [`PathLossModel`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathLossParams {
    /// Spread of a BLE reading around the path-loss curve, dB.
    pub ble_sd_db: f64,
    /// Spread of a WiFi reading around the path-loss curve, dB.
    pub wifi_sd_db: f64,
    /// Extra loss per floor between phone and transmitter, dB.
    pub floor_loss_db: f64,
    /// Extra spread for a transmitter on another floor, dB.
    pub other_floor_sd_db: f64,
    /// Ranges are floored at this, metres.
    pub min_range_m: f64,
    /// Height of the phone above the floor, metres.
    pub phone_height_m: f64,
}

/// The log-distance model of every beacon and access point of a site.
#[derive(Debug, Clone)]
pub struct PathLossModel {
    tx: Vec<Transmitter>,
    by_id: IdIndex,
    /// Floor index (position in the site's floor list) by floor id: floors
    /// apart are counted by list position.
    floor_rank: BTreeMap<i32, i32>,
    params: PathLossParams,
}

impl PathLossModel {
    /// The model of `site`'s beacons and access points. Entries with an
    /// unparsable id, non-finite values or a non-positive exponent are left
    /// out (site validation reports them first).
    pub fn for_site(site: &Site, params: PathLossParams) -> Self {
        let mut m = PathLossModel {
            tx: Vec::new(),
            by_id: IdIndex::default(),
            floor_rank: site
                .spec
                .floors
                .iter()
                .enumerate()
                .map(|(i, f)| (f.id, i as i32))
                .collect(),
            params,
        };
        for b in &site.spec.beacons {
            if let Ok(id) = normalize_beacon_id(&b.id) {
                m.push(TxKind::Ble, id, b);
            }
        }
        for a in &site.spec.access_points {
            m.push(TxKind::Wifi, a.id.to_ascii_lowercase(), a);
        }
        m
    }

    /// A model of the given transmitters on a one-floor site (benches,
    /// tests, models built elsewhere). Later duplicates of an id are dropped.
    pub fn from_transmitters(tx: Vec<Transmitter>, params: PathLossParams) -> Self {
        let mut m = PathLossModel {
            tx: Vec::new(),
            by_id: IdIndex::default(),
            floor_rank: BTreeMap::new(),
            params,
        };
        for t in tx {
            if m.by_id.insert(t.kind, t.id.clone(), m.tx.len()) {
                m.tx.push(t);
            }
        }
        m
    }

    fn push(&mut self, kind: TxKind, id: String, b: &BeaconSpec) {
        let ok = [b.x_m, b.y_m, b.z_m, b.rssi_1m_dbm, b.path_loss_exponent]
            .iter()
            .all(|v| v.is_finite())
            && b.path_loss_exponent > 0.0;
        if !ok || self.by_id.contains(kind, &id) {
            return;
        }
        self.by_id.insert(kind, id.clone(), self.tx.len());
        self.tx.push(Transmitter {
            id,
            kind,
            floor: b.floor,
            pos: Vec2::new(b.x_m, b.y_m),
            dz_m: b.z_m - self.params.phone_height_m,
            model: PathLoss {
                rssi_1m_dbm: b.rssi_1m_dbm,
                exponent: b.path_loss_exponent,
            },
        });
    }

    /// How many floors lie between floor ids `a` and `b` (by the site's
    /// floor order; 1 for an unknown floor).
    pub fn floors_apart(&self, a: i32, b: i32) -> i32 {
        match (self.floor_rank.get(&a), self.floor_rank.get(&b)) {
            (Some(x), Some(y)) => (x - y).abs(),
            _ => i32::from(a != b),
        }
    }

    /// The model's settings.
    pub fn params(&self) -> &PathLossParams {
        &self.params
    }
}

impl RadioModel for PathLossModel {
    fn transmitters(&self) -> &[Transmitter] {
        &self.tx
    }

    fn lookup(&self, kind: TxKind, id: &str) -> Option<usize> {
        lookup_in(&self.by_id, kind, id)
    }

    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        let t = self.tx.get(tx)?;
        let pr = &self.params;
        let sd = match t.kind {
            TxKind::Ble => pr.ble_sd_db,
            TxKind::Wifi => pr.wifi_sd_db,
        };
        Some(across_floors(
            (pathloss_mean(t, p, pr.min_range_m), sd),
            self.floors_apart(floor, t.floor),
            pr.floor_loss_db,
            pr.other_floor_sd_db,
        ))
    }

    fn expected_many(
        &self,
        tx: usize,
        floor: i32,
        ps: &[Vec2],
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> bool {
        let Some(t) = self.tx.get(tx) else {
            return false;
        };
        let pr = &self.params;
        let sd0 = match t.kind {
            TxKind::Ble => pr.ble_sd_db,
            TxKind::Wifi => pr.wifi_sd_db,
        };
        pathloss_many(
            t,
            ps,
            pr.min_range_m,
            sd0,
            self.floors_apart(floor, t.floor),
            pr.floor_loss_db,
            pr.other_floor_sd_db,
            mean,
            sd,
        );
        true
    }
}

/// [`pathloss_mean`] of `t` at every point of `ps` with spread `sd0`, both
/// through [`across_floors`] for `apart` floors, into `mean` and `sd` (at
/// least `ps.len()` long): the one-point functions' values within 1e-8 dB
/// (the logarithm by [`ln_normal`] of the squared range; unit test).
#[allow(clippy::too_many_arguments)]
pub(crate) fn pathloss_many(
    t: &Transmitter,
    ps: &[Vec2],
    min_range_m: f64,
    sd0: f64,
    apart: i32,
    loss_db: f64,
    extra_sd_db: f64,
    mean: &mut [f64],
    sd: &mut [f64],
) {
    let (_, s) = across_floors((0.0, sd0), apart, loss_db, extra_sd_db);
    let loss = if apart > 0 {
        loss_db * f64::from(apart)
    } else {
        0.0
    };
    // R0 - 10 n log10(max(d, min)) as R0 - 5 n / ln 10 * ln max(d^2, min^2)
    let r0 = t.model.rssi_1m_dbm - loss;
    let k = 5.0 * t.model.exponent / std::f64::consts::LN_10;
    let (dz2, min2) = (t.dz_m * t.dz_m, min_range_m * min_range_m);
    // NaN positions count at the floored range as in `range_m`, infinite
    // ones at the largest finite range
    let lo = min2.max(f64::MIN_POSITIVE);
    pathloss_loop(ps, t.pos, dz2, lo, r0, k, mean);
    let n = ps.len().min(sd.len());
    sd[..n].fill(s);
}

crate::simd::avx2_dispatch! {
    /// `mean[i]` = `r0` - `k` ln clamp(|ps[i] - tx|^2 + `dz2`, `lo`, MAX):
    /// [`pathloss_many`]'s loop.
    pub(crate) fn pathloss_loop(ps: &[Vec2], tx: Vec2, dz2: f64, lo: f64, r0: f64, k: f64, mean: &mut [f64]) {
        for (p, m) in ps.iter().zip(mean.iter_mut()) {
            let (dx, dy) = (p.x - tx.x, p.y - tx.y);
            let d2 = (dx * dx + dy * dy + dz2).max(lo).min(f64::MAX);
            *m = r0 - k * ln_normal(d2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::site::testkit;

    fn params() -> PathLossParams {
        PathLossParams {
            ble_sd_db: 6.0,
            wifi_sd_db: 7.0,
            floor_loss_db: 15.0,
            other_floor_sd_db: 4.0,
            min_range_m: 0.5,
            phone_height_m: 1.2,
        }
    }

    #[test]
    fn lookup_tries_the_canonical_spelling() {
        let mut by_id = IdIndex::default();
        by_id.insert(TxKind::Wifi, "aa:bb:cc:dd:ee:0f".to_string(), 3);
        by_id.insert(TxKind::Ble, "AA:BB:CC:DD:EE:0F".to_string(), 4);
        assert_eq!(
            lookup_in(&by_id, TxKind::Wifi, "aa:bb:cc:dd:ee:0f"),
            Some(3)
        );
        assert_eq!(
            lookup_in(&by_id, TxKind::Wifi, "AA:BB:cc:DD:EE:0F"),
            Some(3)
        );
        assert_eq!(lookup_in(&by_id, TxKind::Wifi, "aa:bb:cc:dd:ee:00"), None);
        assert_eq!(lookup_in(&by_id, TxKind::Wifi, "AA:BB:CC:DD:EE:00"), None);
        assert_eq!(lookup_in(&by_id, TxKind::Ble, "AA:BB:CC:DD:EE:0F"), Some(4));
    }

    #[test]
    fn expected_rssi_falls_with_range_and_floors() {
        let model = PathLoss {
            rssi_1m_dbm: -60.0,
            exponent: 2.0,
        };
        let maps = vec![testkit::open_map(20, 20), testkit::open_map(20, 20)];
        let site = testkit::beacon_site("radio", maps, &[(5.0, 5.0)], model);
        let m = PathLossModel::for_site(&site, params());
        assert!(!m.transmitters().is_empty());
        let i = 0;
        let t = m.transmitters()[i].clone();
        let near = m.expected(i, t.floor, t.pos).unwrap();
        let far = m
            .expected(i, t.floor, t.pos + Vec2::new(10.0, 0.0))
            .unwrap();
        assert!(near.0 > far.0 + 10.0, "{near:?} {far:?}");
        let other = site
            .spec
            .floors
            .iter()
            .find(|f| f.id != t.floor)
            .unwrap()
            .id;
        let up = m.expected(i, other, t.pos + Vec2::new(10.0, 0.0)).unwrap();
        assert!((far.0 - up.0 - 15.0).abs() < 1e-9);
        assert!(up.1 > far.1);
        assert_eq!(m.lookup(TxKind::Ble, &t.id), Some(i));
        assert_eq!(m.lookup(TxKind::Wifi, &t.id), None);
        assert!(m.expected(m.transmitters().len(), 0, t.pos).is_none());
    }

    #[test]
    fn expected_many_is_expected_point_by_point() {
        let model = PathLoss {
            rssi_1m_dbm: -58.0,
            exponent: 2.7,
        };
        let maps = vec![testkit::open_map(30, 30), testkit::open_map(30, 30)];
        let bs = [(5.0, 5.0), (20.0, 12.0), (0.0, 30.0)];
        let site = testkit::beacon_site("many", maps, &bs, model);
        let mut pr = params();
        pr.phone_height_m = 0.2;
        let m = PathLossModel::for_site(&site, pr);
        // on and around the beacons (the range floor), near and far
        let ps: Vec<Vec2> = (0..900)
            .map(|i| Vec2::new(f64::from(i % 30) * 1.01, f64::from(i / 30) * 0.99))
            .chain(bs.iter().map(|b| Vec2::new(b.0, b.1)))
            .chain([Vec2::new(5.3, 5.2), Vec2::new(-400.0, 900.0)])
            .collect();
        let (mut mean, mut sd) = (vec![0.0; ps.len()], vec![0.0; ps.len()]);
        for floor in [0, 1, 7] {
            for tx in 0..m.transmitters().len() {
                assert!(m.expected_many(tx, floor, &ps, &mut mean, &mut sd));
                for (i, p) in ps.iter().enumerate() {
                    let (a, b) = m.expected(tx, floor, *p).unwrap();
                    assert!((mean[i] - a).abs() < 1e-8, "{p:?}: {} {a}", mean[i]);
                    assert_eq!(sd[i], b);
                }
            }
        }
        assert!(!m.expected_many(3, 0, &ps, &mut mean, &mut sd));
    }
}
