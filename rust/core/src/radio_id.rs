//! Beacon identities: parsing and normalising the three id forms of site.json
//! and the logs. Canonical forms (what [`BeaconId`]'s `Display` writes):
//! `ibeacon:XXXXXXXX-XXXX-XXXX-XXXX-XXXXXXXXXXXX:major:minor` (uppercase UUID,
//! decimal major/minor without leading zeros), `mac:AA:BB:CC:DD:EE:FF`
//! (uppercase), `eddystone:NAMESPACE:INSTANCE` (uppercase hex, 20 and 12
//! digits). The prefix is case-insensitive; UUIDs may omit hyphens; MACs may
//! use `-` or no separator.
//!
//! WiFi access points are named by their BSSID, canonically lower-case
//! `aa:bb:cc:dd:ee:ff`: [`normalize_bssid`], [`is_bssid`] and
//! [`canonical_bssid`] are the one place that spelling is checked.

use std::fmt;

/// Whether `s` is a canonical BSSID: lower-case `aa:bb:cc:dd:ee:ff`.
pub fn is_bssid(s: &str) -> bool {
    s.len() == 17
        && s.split(':').count() == 6
        && s.split(':').all(|b| {
            b.len() == 2
                && b.bytes()
                    .all(|c| c.is_ascii_digit() || (b'a'..=b'f').contains(&c))
        })
}

/// A BSSID in its canonical (lower-case) spelling: `id` itself when it has
/// no upper case (no allocation: most BSSIDs a phone hears already are),
/// else a lower-cased copy.
pub fn canonical_bssid(id: &str) -> std::borrow::Cow<'_, str> {
    if id.bytes().any(|b| b.is_ascii_uppercase()) {
        std::borrow::Cow::Owned(id.to_ascii_lowercase())
    } else {
        std::borrow::Cow::Borrowed(id)
    }
}

/// `aa:bb:cc:dd:ee:ff` (lower case) from any case, with `:` or `-`; `None`
/// when it is not six hex pairs (the log readers and the JNI bridge).
pub fn normalize_bssid(s: &str) -> Option<String> {
    let mut parts = s.split([':', '-']);
    let mut out = String::with_capacity(17);
    for k in 0..6 {
        let p = parts.next()?;
        if p.len() != 2 || !p.bytes().all(|b| b.is_ascii_hexdigit()) {
            return None;
        }
        if k > 0 {
            out.push(':');
        }
        out.push_str(&p.to_ascii_lowercase());
    }
    parts.next().is_none().then_some(out)
}

/// A parsed beacon id.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BeaconId {
    IBeacon {
        uuid: [u8; 16],
        major: u16,
        minor: u16,
    },
    Mac([u8; 6]),
    Eddystone {
        namespace: [u8; 10],
        instance: [u8; 6],
    },
}

fn hex_bytes<const N: usize>(s: &str, what: &str) -> Result<[u8; N], String> {
    let digits: Vec<u8> = s.bytes().filter(|b| *b != b'-' && *b != b':').collect();
    if digits.len() != 2 * N {
        return Err(format!(
            "{what} `{s}`: expected {} hex digits, got {}",
            2 * N,
            digits.len()
        ));
    }
    let mut out = [0u8; N];
    for (i, pair) in digits.chunks(2).enumerate() {
        let hi = (pair[0] as char).to_digit(16);
        let lo = (pair[1] as char).to_digit(16);
        match (hi, lo) {
            (Some(h), Some(l)) => out[i] = (h * 16 + l) as u8,
            _ => return Err(format!("{what} `{s}`: not hexadecimal")),
        }
    }
    Ok(out)
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02X}")).collect()
}

impl BeaconId {
    /// Parses any accepted spelling; the error names the part at fault.
    pub fn parse(s: &str) -> Result<BeaconId, String> {
        let s = s.trim();
        let (prefix, rest) = s
            .split_once(':')
            .ok_or_else(|| format!("beacon id `{s}`: missing `kind:` prefix"))?;
        match prefix.to_ascii_lowercase().as_str() {
            "ibeacon" => {
                let mut parts = rest.rsplitn(3, ':');
                let minor = parts.next().unwrap_or("");
                let major = parts.next();
                let uuid = parts.next();
                let (Some(major), Some(uuid)) = (major, uuid) else {
                    return Err(format!(
                        "beacon id `{s}`: expected ibeacon:UUID:major:minor"
                    ));
                };
                let num = |v: &str, what: &str| {
                    v.trim()
                        .parse::<u16>()
                        .map_err(|_| format!("beacon id `{s}`: {what} `{v}` is not in 0..=65535"))
                };
                Ok(BeaconId::IBeacon {
                    uuid: hex_bytes::<16>(uuid, "iBeacon UUID")
                        .map_err(|e| format!("beacon id `{s}`: {e}"))?,
                    major: num(major, "major")?,
                    minor: num(minor, "minor")?,
                })
            }
            "mac" => Ok(BeaconId::Mac(
                hex_bytes::<6>(rest, "MAC").map_err(|e| format!("beacon id `{s}`: {e}"))?,
            )),
            "eddystone" => {
                let (ns, inst) = rest.split_once(':').ok_or_else(|| {
                    format!("beacon id `{s}`: expected eddystone:NAMESPACE:INSTANCE")
                })?;
                Ok(BeaconId::Eddystone {
                    namespace: hex_bytes::<10>(ns, "Eddystone namespace")
                        .map_err(|e| format!("beacon id `{s}`: {e}"))?,
                    instance: hex_bytes::<6>(inst, "Eddystone instance")
                        .map_err(|e| format!("beacon id `{s}`: {e}"))?,
                })
            }
            other => Err(format!(
                "beacon id `{s}`: unknown kind `{other}` (ibeacon, mac, eddystone)"
            )),
        }
    }
}

impl fmt::Display for BeaconId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BeaconId::IBeacon { uuid, major, minor } => write!(
                f,
                "ibeacon:{}-{}-{}-{}-{}:{major}:{minor}",
                hex(&uuid[0..4]),
                hex(&uuid[4..6]),
                hex(&uuid[6..8]),
                hex(&uuid[8..10]),
                hex(&uuid[10..16])
            ),
            BeaconId::Mac(m) => {
                let parts: Vec<String> = m.iter().map(|b| format!("{b:02X}")).collect();
                write!(f, "mac:{}", parts.join(":"))
            }
            BeaconId::Eddystone {
                namespace,
                instance,
            } => write!(f, "eddystone:{}:{}", hex(namespace), hex(instance)),
        }
    }
}

/// Canonical spelling of a beacon id, or an error naming what is wrong.
pub fn normalize_beacon_id(s: &str) -> Result<String, String> {
    BeaconId::parse(s).map(|id| id.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn normalises_the_three_forms() {
        assert_eq!(
            normalize_beacon_id("iBeacon:fda50693a4e24fb1afcfc6eb07647825:010073:61418").unwrap(),
            "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:10073:61418"
        );
        assert_eq!(
            normalize_beacon_id("mac:be:ac:20:23:00:0a").unwrap(),
            "mac:BE:AC:20:23:00:0A"
        );
        assert_eq!(
            normalize_beacon_id("MAC:beac-2023-000a").unwrap(),
            "mac:BE:AC:20:23:00:0A"
        );
        assert_eq!(
            normalize_beacon_id("eddystone:00112233445566778899:aabbccddeeff").unwrap(),
            "eddystone:00112233445566778899:AABBCCDDEEFF"
        );
    }

    #[test]
    fn rejects_bad_ids_with_a_reason() {
        for bad in [
            "",
            "foo",
            "wifi:AA:BB",
            "mac:AA:BB",
            "mac:GG:BB:CC:DD:EE:FF",
            "ibeacon:1234:1:2",
            "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:70000:1",
            "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1",
            "eddystone:0011",
            "mac:ÀÀ:BB:CC:DD:EE:FF",
        ] {
            let e = normalize_beacon_id(bad);
            assert!(e.is_err(), "{bad} accepted");
        }
    }

    proptest! {
        #[test]
        fn canonical_form_is_a_fixed_point(uuid in any::<[u8; 16]>(), major in any::<u16>(), minor in any::<u16>(), mac in any::<[u8; 6]>()) {
            for id in [BeaconId::IBeacon { uuid, major, minor }, BeaconId::Mac(mac)] {
                let s = id.to_string();
                prop_assert_eq!(BeaconId::parse(&s).unwrap(), id.clone());
                prop_assert_eq!(normalize_beacon_id(&s.to_lowercase()).unwrap(), s);
            }
        }

        #[test]
        fn never_panics(s in ".{0,60}") {
            let _ = normalize_beacon_id(&s);
        }
    }
}
