//! The beacon registry: the site's beacons by canonical id, with their
//! position and path-loss model. Ids not in the registry are ignored by the
//! front end and counted.

use std::collections::BTreeMap;

use super::pathloss::PathLoss;
use crate::Vec2;
use crate::radio_id::normalize_beacon_id;
use crate::site::BeaconSpec;

/// One registered beacon.
#[derive(Debug, Clone, PartialEq)]
pub struct RegisteredBeacon {
    /// Canonical id.
    pub id: String,
    pub floor: i32,
    /// Position in the MCS of `floor`, metres.
    pub pos: Vec2,
    /// Mounting height above the floor, metres.
    pub z_m: f64,
    pub model: PathLoss,
}

/// The site's beacons, indexed by canonical id.
#[derive(Debug, Clone, Default)]
pub struct BeaconRegistry {
    beacons: Vec<RegisteredBeacon>,
    by_id: BTreeMap<String, usize>,
    /// Specs left out: unparsable id, non-finite values, exponent <= 0, duplicates.
    pub skipped: Vec<String>,
}

impl BeaconRegistry {
    /// Builds the registry from site.json's beacons. Bad entries are skipped and
    /// described in `skipped` (site validation reports them as errors first).
    pub fn new(specs: &[BeaconSpec]) -> Self {
        let mut reg = BeaconRegistry::default();
        for (i, b) in specs.iter().enumerate() {
            let id = match normalize_beacon_id(&b.id) {
                Ok(id) => id,
                Err(e) => {
                    reg.skipped.push(format!("beacons[{i}]: {e}"));
                    continue;
                }
            };
            let finite = [b.x_m, b.y_m, b.z_m, b.rssi_1m_dbm, b.path_loss_exponent]
                .iter()
                .all(|v| v.is_finite());
            if !finite || b.path_loss_exponent <= 0.0 {
                reg.skipped.push(format!(
                    "beacons[{i}] ({id}): non-finite value or path_loss_exponent <= 0"
                ));
                continue;
            }
            if reg.by_id.contains_key(&id) {
                reg.skipped
                    .push(format!("beacons[{i}] ({id}): duplicate id"));
                continue;
            }
            reg.by_id.insert(id.clone(), reg.beacons.len());
            reg.beacons.push(RegisteredBeacon {
                id,
                floor: b.floor,
                pos: Vec2::new(b.x_m, b.y_m),
                z_m: b.z_m,
                model: PathLoss {
                    rssi_1m_dbm: b.rssi_1m_dbm,
                    exponent: b.path_loss_exponent,
                },
            });
        }
        reg
    }

    /// Index of a beacon by any spelling of its id.
    pub fn lookup(&self, raw_id: &str) -> Option<usize> {
        if let Some(i) = self.by_id.get(raw_id) {
            return Some(*i);
        }
        let id = normalize_beacon_id(raw_id).ok()?;
        self.by_id.get(&id).copied()
    }

    pub fn get(&self, index: usize) -> Option<&RegisteredBeacon> {
        self.beacons.get(index)
    }

    pub fn beacons(&self) -> &[RegisteredBeacon] {
        &self.beacons
    }

    pub fn len(&self) -> usize {
        self.beacons.len()
    }

    pub fn is_empty(&self) -> bool {
        self.beacons.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(id: &str, x: f64) -> BeaconSpec {
        BeaconSpec {
            id: id.into(),
            floor: 0,
            x_m: x,
            y_m: 0.0,
            z_m: 2.5,
            rssi_1m_dbm: -59.0,
            path_loss_exponent: 2.0,
        }
    }

    #[test]
    fn looks_up_any_spelling_and_skips_bad_entries() {
        let reg = BeaconRegistry::new(&[
            spec("mac:aa:bb:cc:dd:ee:01", 1.0),
            spec("mac:AA:BB:CC:DD:EE:01", 2.0),
            spec("nonsense", 3.0),
            BeaconSpec {
                path_loss_exponent: 0.0,
                ..spec("mac:AA:BB:CC:DD:EE:02", 4.0)
            },
            BeaconSpec {
                x_m: f64::NAN,
                ..spec("mac:AA:BB:CC:DD:EE:03", 4.0)
            },
        ]);
        assert_eq!(reg.len(), 1);
        assert_eq!(reg.skipped.len(), 4);
        assert_eq!(reg.lookup("MAC:aabbccddee01"), Some(0));
        assert_eq!(reg.lookup("mac:AA:BB:CC:DD:EE:02"), None);
        assert_eq!(reg.get(0).map(|b| b.pos.x), Some(1.0));
    }
}
