//! Each survey phone model's RSSI offsets, per radio, from the survey's
//! walk offsets.
//!
//! Phone models read the same transmitter several dB apart, and not by
//! the same amount on both radios: on IPIN 2023 the SM-G930F reads 8.7 dB
//! weaker than the SM-A520F on the beacons and 6.4 dB on the access points,
//! while two walks of one model at the same place differ by 0.1 +- 1.6 /
//! 2.2 dB (docs/lab/tcpf-radio-trust.md "Two phone models, two radios").
//! [`super::walk_offsets`] already learns each survey walk's offset per
//! radio; grouped by the phone model that recorded the walk they give the
//! model's offsets from the map's level. A phone of a surveyed model then
//! starts with its readings corrected by them (`EngineConfig::device`),
//! rather than learning one offset for both radios while it walks.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::TxKind;

/// At least this many survey walks of a model with an offset of a radio
/// give that model's offset of that radio.
pub const MIN_WALKS: usize = 2;
/// At most this many phone models are kept (the survey's phones).
pub const MAX_DEVICES: usize = 64;
/// A phone model's name is at most this many characters.
pub const MAX_DEVICE_CHARS: usize = 64;

/// One phone model's offsets from the map's level, dB (to subtract from
/// its readings); `None` where fewer than [`MIN_WALKS`] walks had one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceOffset {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ble_db: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wifi_db: Option<f64>,
    /// Survey walks recorded with the model.
    pub walks: usize,
}

impl DeviceOffset {
    /// The offset of radio `kind`, dB.
    pub fn of(&self, kind: TxKind) -> Option<f64> {
        match kind {
            TxKind::Ble => self.ble_db,
            TxKind::Wifi => self.wifi_db,
        }
    }
}

/// The phone models' offsets by name (at most [`MAX_DEVICES`]).
pub type DeviceOffsets = BTreeMap<String, DeviceOffset>;

/// The offsets of each model in `device_of_walk` (walk index -> model,
/// `None` unknown): per radio, the median of its walks' offsets in
/// `ble` / `wifi` (walk -> dB). Models with no radio's offset are left
/// out; past [`MAX_DEVICES`] the models with the fewest walks are. A
/// survey of one model gives none: the map's level is that model's (the
/// walks' offsets are centred on the survey), and the median of its
/// walks' would only shift it by their scatter.
pub fn from_walks(
    device_of_walk: &[Option<String>],
    ble: &BTreeMap<usize, f64>,
    wifi: &BTreeMap<usize, f64>,
) -> DeviceOffsets {
    let mut walks: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (w, d) in device_of_walk.iter().enumerate() {
        if let Some(d) = d.as_deref().filter(|d| valid_name(d)) {
            walks.entry(d).or_default().push(w);
        }
    }
    let median_of = |ws: &[usize], of: &BTreeMap<usize, f64>| {
        let v: Vec<f64> = ws.iter().filter_map(|w| of.get(w).copied()).collect();
        if v.len() < MIN_WALKS {
            return None;
        }
        crate::stats::median(&v)
    };
    let mut out: Vec<(String, DeviceOffset)> = walks
        .into_iter()
        .filter_map(|(d, ws)| {
            let o = DeviceOffset {
                ble_db: median_of(&ws, ble),
                wifi_db: median_of(&ws, wifi),
                walks: ws.len(),
            };
            (o.ble_db.is_some() || o.wifi_db.is_some()).then(|| (d.to_string(), o))
        })
        .collect();
    if out.len() < 2 {
        return DeviceOffsets::new();
    }
    out.sort_by(|a, b| b.1.walks.cmp(&a.1.walks).then_with(|| a.0.cmp(&b.0)));
    out.truncate(MAX_DEVICES);
    out.into_iter().collect()
}

/// The offsets of phone model `name` in `offsets`. Phones name their model
/// `<manufacturer> <model>` (Android's `Build.MANUFACTURER` and
/// `Build.MODEL`, e.g. `Google Pixel 7`: the library's `DeviceModel`);
/// surveys recorded before that name by the library's survey recorder
/// carry the model alone (`Pixel 7`). So: the entry of `name` itself,
/// else, for a name of more than one word, the entry of `name` without
/// its first word (a map calibrated from such surveys). Nothing else is
/// tried: no case folding, no partial match.
pub fn lookup<'a>(offsets: &'a DeviceOffsets, name: &str) -> Option<&'a DeviceOffset> {
    offsets.get(name).or_else(|| {
        let (_, model) = name.trim().split_once(' ')?;
        offsets.get(model.trim_start())
    })
}

/// Whether `name` can name a phone model: 1 to [`MAX_DEVICE_CHARS`]
/// characters, no control characters.
pub fn valid_name(name: &str) -> bool {
    !name.trim().is_empty()
        && name.chars().count() <= MAX_DEVICE_CHARS
        && !name.chars().any(char::is_control)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_model_gets_the_median_of_its_walks_per_radio() {
        let devices = [
            Some("SM-A520F".to_string()),
            Some("SM-G930F".to_string()),
            Some("SM-A520F".to_string()),
            Some("SM-G930F".to_string()),
            None,
            Some("SM-A520F".to_string()),
            Some("one walk".to_string()),
        ];
        let ble = BTreeMap::from([(0, 4.0), (1, -4.5), (2, 5.0), (3, -4.0), (4, 9.0), (5, 4.5)]);
        let wifi = BTreeMap::from([(0, 3.0), (1, -3.0), (3, -3.5), (6, 1.0)]);
        let d = from_walks(&devices, &ble, &wifi);
        assert_eq!(d.len(), 2, "{d:?}");
        let a = d["SM-A520F"];
        assert_eq!((a.ble_db, a.wifi_db, a.walks), (Some(4.5), None, 3));
        let g = d["SM-G930F"];
        assert_eq!(
            (g.of(TxKind::Ble), g.of(TxKind::Wifi)),
            (Some(-4.25), Some(-3.25))
        );
        // names that cannot name a model are not kept
        let bad = [Some(" ".to_string()), Some("x\ny".to_string())];
        let ble = BTreeMap::from([(0, 1.0), (1, 1.0)]);
        assert!(from_walks(&bad, &ble, &ble).is_empty());
        // one model alone: the map's level is its own
        let one = [Some("a".to_string()), Some("a".to_string())];
        assert!(from_walks(&one, &ble, &ble).is_empty());
        assert!(!valid_name(&"m".repeat(MAX_DEVICE_CHARS + 1)));
    }

    #[test]
    fn a_phone_finds_its_model_and_the_model_alone_of_older_surveys() {
        let o = |db| DeviceOffset {
            ble_db: Some(db),
            wifi_db: None,
            walks: 2,
        };
        let map = DeviceOffsets::from([
            ("Google Pixel 7".to_string(), o(1.0)),
            ("SM-G930F".to_string(), o(2.0)),
            ("Pixel 7".to_string(), o(3.0)),
        ]);
        let ble = |name: &str| lookup(&map, name).and_then(|d| d.of(TxKind::Ble));
        // the whole name first, even when the model alone is there too
        assert_eq!(ble("Google Pixel 7"), Some(1.0));
        // a legacy entry: the model alone
        assert_eq!(ble("samsung SM-G930F"), Some(2.0));
        assert_eq!(ble("SM-G930F"), Some(2.0));
        // nothing else matches
        assert_eq!(ble("samsung SM-G930"), None);
        assert_eq!(ble("SAMSUNG sm-g930f"), None);
        assert_eq!(ble("Google"), None);
        assert_eq!(ble(""), None);
        assert_eq!(ble("Pixel"), None);
    }

    #[test]
    fn past_the_bound_the_models_with_the_fewest_walks_are_left_out() {
        let n = MAX_DEVICES + 3;
        // model i recorded walks 2i, 2i+1, and model 0 two more
        let mut devices: Vec<Option<String>> =
            (0..2 * n).map(|w| Some(format!("m{:03}", w / 2))).collect();
        devices.extend([Some("m000".to_string()), Some("m000".to_string())]);
        let ble: BTreeMap<usize, f64> = (0..devices.len()).map(|w| (w, 1.0)).collect();
        let d = from_walks(&devices, &ble, &BTreeMap::new());
        assert_eq!(d.len(), MAX_DEVICES);
        assert_eq!(d["m000"].walks, 4);
        assert!(!d.contains_key(&format!("m{:03}", n - 1)));
    }
}
