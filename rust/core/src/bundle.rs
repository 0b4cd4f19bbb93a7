//! Site bundles: one versioned file holding everything a phone needs to
//! position on a site (site.json with its beacons and access points, the
//! plan images, the radio map), with a manifest of sizes and SHA-256
//! hashes. Written by `fpbp bundle`, read by the JNI `startBundle` from a
//! memory-mapped file or a direct buffer. Layout (docs/formats.md,
//! "Site bundle"):
//!
//! ```text
//! offset  size  field
//! 0       8     magic "FPBPBNDL"
//! 8       4     container version, u32 little-endian (1)
//! 12      4     manifest length M, u32 little-endian (1 ..= MAX_MANIFEST_BYTES)
//! 16      M     manifest, UTF-8 JSON (Manifest)
//! 16 + M  ...   the entries' bytes in manifest order, back to back; the file
//!               ends with the last entry
//! ```
//!
//! Parsing works on a borrowed `&[u8]` (the core does no I/O): entries are
//! slices of the input, never copied; every length is checked against the
//! input and the bounds below before anything is allocated; every entry's
//! hash is checked; unknown versions, kinds and fields are refused. The
//! radio map entry is the gzip of its JSON (docs/formats.md "Radio map"),
//! decoded while it is parsed: no string of the whole map is ever built,
//! not even for an error's message. Every collection, string and number of
//! the content is bounded as it streams (`bounds::json`; the limits and
//! why: docs/formats.md "Site bundle"), so a small file of bad bytes is
//! refused without asking for much memory or time.
//!
//! Why SHA-256 (the `sha2` crate of RustCrypto, pure Rust, no_std, no
//! default features): the manifest's hash is also the content's identity (a
//! tool or a person checks an entry with `sha256sum`, an app can log which
//! map it runs), and a truncated or patched file must never parse; a CRC
//! detects accidents only. The cost is a few small crates and ~10 ms per
//! 20 MB on a phone core.

use std::io::Read;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::bounds::json::JsonLimits;
use crate::radio::RadioMap;
use crate::radio::radio_map_file::RadioMapFile;
use crate::site::json_path::Scanner;
use crate::site::{Site, SiteSpec};
use crate::{Error, Result};

/// First eight bytes of every bundle.
pub const MAGIC: &[u8; 8] = b"FPBPBNDL";
/// Container version this build writes and reads.
pub const VERSION: u32 = 1;
/// `format` of the manifest.
pub const FORMAT: &str = "fpbp-bundle";
/// Bytes before the manifest: magic, version, manifest length.
pub const HEADER_BYTES: usize = 16;

/// Largest bundle, bytes (a mall floor's is ~2 MB).
pub const MAX_BUNDLE_BYTES: u64 = 1 << 30;
/// Largest manifest, bytes.
pub const MAX_MANIFEST_BYTES: u32 = 1 << 20;
/// Most entries in one bundle.
pub const MAX_ENTRIES: usize = 256;
/// Longest entry name, bytes.
pub const MAX_NAME_BYTES: usize = 255;
/// Largest site.json entry, bytes (ILC F1's with 554 access points: 131
/// kB; a site at the transmitter limits, ~8 MB).
pub const MAX_SITE_JSON_BYTES: u64 = 16 << 20;
/// Largest radio map once decompressed (`raw_size`), bytes: a gzip bomb
/// stops here. The parsed map takes at most about twice its text (a grid
/// value "0," is 2 bytes of text and 2 in memory; a scan entry "[0,0]," 6
/// and 8, plus 6 in the query's index), so 64 MiB keeps a refused map under
/// ~150 MB and ~1.5 s; ILC F1's map (554 transmitters, 1 766 scans) is
/// 18.7 MB (docs/formats.md "Site bundle").
pub const MAX_RADIO_MAP_RAW_BYTES: u64 = 64 << 20;

/// Name of the site entry.
pub const SITE_ENTRY: &str = "site.json";
/// Name of the radio map entry.
pub const RADIO_MAP_ENTRY: &str = "radio-map.json.gz";

/// What an entry holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EntryKind {
    /// site.json (`fpbp-site`), exactly one, named [`SITE_ENTRY`].
    Site,
    /// A plan image (PNG), named by the path `floors[k].plan` gives.
    Plan,
    /// The radio map (`fpbp-radio-map` JSON, gzip), at most one.
    RadioMap,
}

impl EntryKind {
    /// The encoding an entry of this kind must have.
    pub fn encoding(self) -> Encoding {
        match self {
            EntryKind::Site | EntryKind::Plan => Encoding::Identity,
            EntryKind::RadioMap => Encoding::Gzip,
        }
    }
}

/// How an entry's bytes are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Encoding {
    /// As they are.
    #[default]
    Identity,
    /// gzip (RFC 1952); `raw_size` gives the decompressed length.
    Gzip,
}

/// One entry of the manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EntryInfo {
    /// Entry name (the site's plan path for plans).
    pub name: String,
    pub kind: EntryKind,
    #[serde(default)]
    pub encoding: Encoding,
    /// Stored bytes.
    pub size: u64,
    /// Decompressed bytes (gzip entries only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw_size: Option<u64>,
    /// SHA-256 of the stored bytes, 64 lower-case hex digits.
    pub sha256: String,
}

/// The manifest: what the bundle holds and how to check it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Always [`FORMAT`].
    pub format: String,
    /// The container version (the header's).
    pub version: u32,
    /// The site's `name` (informative).
    pub site: String,
    /// The `fpbp` build that wrote it (informative).
    #[serde(default)]
    pub writer: String,
    pub entries: Vec<EntryInfo>,
}

/// A parsed, checked bundle: its manifest and each entry's stored bytes
/// (slices of the input).
#[derive(Debug, Clone)]
pub struct Bundle<'a> {
    manifest: Manifest,
    data: Vec<&'a [u8]>,
}

fn bad<T>(at: impl Into<String>, msg: impl Into<String>) -> Result<T> {
    Err(Error::Bundle {
        at: at.into(),
        msg: msg.into(),
    })
}

/// SHA-256 of `bytes` in lower-case hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use std::fmt::Write;
    let d = Sha256::digest(bytes);
    let mut s = String::with_capacity(64);
    for b in d.iter() {
        let _ = write!(s, "{b:02x}");
    }
    s
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    let mut b = [0u8; 4];
    b.copy_from_slice(&bytes[at..at + 4]);
    u32::from_le_bytes(b)
}

/// The header's container version, when `bytes` starts like a bundle
/// (magic and version readable), else `None`.
pub fn sniff(bytes: &[u8]) -> Option<u32> {
    (bytes.len() >= 12 && &bytes[..8] == MAGIC).then(|| u32_at(bytes, 8))
}

impl<'a> Bundle<'a> {
    /// Parses and checks a bundle: header, manifest, every entry's size,
    /// encoding and hash, the required entries. Errors name the header
    /// field, manifest field or entry at fault.
    pub fn parse(bytes: &'a [u8]) -> Result<Bundle<'a>> {
        if bytes.len() as u64 > MAX_BUNDLE_BYTES {
            return bad(
                "size",
                format!(
                    "{} bytes, over the limit of {MAX_BUNDLE_BYTES}",
                    bytes.len()
                ),
            );
        }
        if bytes.len() < HEADER_BYTES {
            return bad(
                "header",
                format!(
                    "{} bytes, shorter than the {HEADER_BYTES}-byte header",
                    bytes.len()
                ),
            );
        }
        if &bytes[..8] != MAGIC {
            return bad(
                "header.magic",
                "not an fpbp bundle (the file does not start with FPBPBNDL)",
            );
        }
        let version = u32_at(bytes, 8);
        if version != VERSION {
            return bad(
                "header.version",
                format!("is {version}, this build reads version {VERSION}"),
            );
        }
        let m = u32_at(bytes, 12);
        if m == 0 || m > MAX_MANIFEST_BYTES {
            return bad(
                "header.manifest_length",
                format!("is {m}, expected 1 to {MAX_MANIFEST_BYTES}"),
            );
        }
        let m = m as usize;
        let Some(text) = bytes.get(HEADER_BYTES..HEADER_BYTES + m) else {
            return bad(
                "header.manifest_length",
                format!("is {m}, past the end of the {}-byte file", bytes.len()),
            );
        };
        let manifest: Manifest = serde_json::from_slice(text).map_err(|e| {
            let (field, msg) = crate::site::json_path::describe(text, &e);
            Error::Bundle {
                at: format!("manifest.{field}"),
                msg,
            }
        })?;
        if manifest.format != FORMAT {
            return bad(
                "manifest.format",
                format!(
                    "is `{}`, expected `{FORMAT}`",
                    crate::bounds::echo(&manifest.format)
                ),
            );
        }
        if manifest.version != version {
            return bad(
                "manifest.version",
                format!("is {}, the header says {version}", manifest.version),
            );
        }
        if manifest.entries.len() > MAX_ENTRIES {
            return bad(
                "manifest.entries",
                format!(
                    "{} entries, over the limit of {MAX_ENTRIES}",
                    manifest.entries.len()
                ),
            );
        }
        let mut data = Vec::with_capacity(manifest.entries.len());
        let mut at = HEADER_BYTES + m;
        let mut seen = std::collections::BTreeSet::new();
        let (mut sites, mut maps) = (0, 0);
        for (i, e) in manifest.entries.iter().enumerate() {
            let f = |field: &str| format!("manifest.entries[{i}].{field}");
            if e.name.is_empty()
                || e.name.len() > MAX_NAME_BYTES
                || e.name.chars().any(char::is_control)
            {
                return bad(
                    f("name"),
                    format!(
                        "`{}`: 1 to {MAX_NAME_BYTES} bytes without control characters",
                        crate::bounds::echo(&e.name)
                    ),
                );
            }
            if !seen.insert(e.name.as_str()) {
                return bad(f("name"), format!("`{}` appears twice", e.name));
            }
            if e.encoding != e.kind.encoding() {
                return bad(
                    f("encoding"),
                    format!(
                        "is {:?}, a {:?} entry is {:?}",
                        e.encoding,
                        e.kind,
                        e.kind.encoding()
                    ),
                );
            }
            match e.kind {
                EntryKind::Site => {
                    sites += 1;
                    if e.name != SITE_ENTRY {
                        return bad(f("name"), format!("the site entry is named `{SITE_ENTRY}`"));
                    }
                    if e.size > MAX_SITE_JSON_BYTES {
                        return bad(
                            f("size"),
                            format!("{} bytes, over the limit of {MAX_SITE_JSON_BYTES}", e.size),
                        );
                    }
                }
                EntryKind::Plan if e.size > crate::bounds::MAX_PLAN_FILE_BYTES => {
                    return bad(
                        f("size"),
                        format!(
                            "{} bytes, over the plan limit of {}",
                            e.size,
                            crate::bounds::MAX_PLAN_FILE_BYTES
                        ),
                    );
                }
                EntryKind::Plan => {}
                EntryKind::RadioMap => {
                    maps += 1;
                    match e.raw_size {
                        Some(r) if r <= MAX_RADIO_MAP_RAW_BYTES => {}
                        Some(r) => {
                            return bad(
                                f("raw_size"),
                                format!("{r} bytes, over the limit of {MAX_RADIO_MAP_RAW_BYTES}"),
                            );
                        }
                        None => return bad(f("raw_size"), "missing (a gzip entry gives it)"),
                    }
                }
            }
            if e.kind.encoding() == Encoding::Identity && e.raw_size.is_some() {
                return bad(f("raw_size"), "only gzip entries have one");
            }
            let left = (bytes.len() - at) as u64;
            if e.size > left {
                return bad(
                    f("size"),
                    format!(
                        "entry `{}` needs {} bytes, only {left} are left in the file",
                        e.name, e.size
                    ),
                );
            }
            let slice = &bytes[at..at + e.size as usize];
            at += e.size as usize;
            if !(e.sha256.len() == 64
                && e.sha256
                    .bytes()
                    .all(|c| c.is_ascii_digit() || (b'a'..=b'f').contains(&c)))
            {
                return bad(f("sha256"), "expected 64 lower-case hex digits");
            }
            let got = sha256_hex(slice);
            if got != e.sha256 {
                return bad(
                    format!("entry {}", e.name),
                    format!(
                        "SHA-256 is {got}, the manifest says {} (the file is damaged or was edited)",
                        e.sha256
                    ),
                );
            }
            data.push(slice);
        }
        if sites != 1 {
            return bad(
                "manifest.entries",
                format!("{sites} site entries, expected exactly one (`{SITE_ENTRY}`)"),
            );
        }
        if maps > 1 {
            return bad(
                "manifest.entries",
                format!("{maps} radio map entries, expected at most one"),
            );
        }
        if at != bytes.len() {
            return bad(
                "size",
                format!(
                    "{} bytes after the last entry (the file is longer than its manifest says)",
                    bytes.len() - at
                ),
            );
        }
        Ok(Bundle { manifest, data })
    }

    /// The manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The stored bytes of entry `name`.
    pub fn entry(&self, name: &str) -> Option<&'a [u8]> {
        self.manifest
            .entries
            .iter()
            .position(|e| e.name == name)
            .map(|i| self.data[i])
    }

    fn of_kind(&self, kind: EntryKind) -> Option<(&EntryInfo, &'a [u8])> {
        self.manifest
            .entries
            .iter()
            .zip(&self.data)
            .find(|(e, _)| e.kind == kind)
            .map(|(e, d)| (e, *d))
    }

    /// The bytes of site.json.
    pub fn site_json(&self) -> &'a [u8] {
        // parse checked there is exactly one
        self.of_kind(EntryKind::Site).map_or(&[], |(_, d)| d)
    }

    /// Whether the bundle holds a radio map.
    pub fn has_radio_map(&self) -> bool {
        self.of_kind(EntryKind::RadioMap).is_some()
    }

    /// Name of the site in error messages: `bundle:site.json`.
    pub const SITE_FILE: &'static str = "bundle:site.json";

    /// Parses site.json and builds the site with the bundle's plan entries
    /// (a plan path the bundle lacks is an error naming `floors[k].plan`).
    pub fn build_site(&self) -> Result<Site> {
        let spec = SiteSpec::from_json(self.site_json(), Self::SITE_FILE)?;
        Site::build(spec, Self::SITE_FILE, &mut |path: &str| {
            self.manifest
                .entries
                .iter()
                .zip(&self.data)
                .find(|(e, _)| e.kind == EntryKind::Plan && e.name == path)
                .map(|(_, d)| d.to_vec())
                .ok_or_else(|| {
                    std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        format!("the bundle has no plan entry `{path}`"),
                    )
                })
        })
    }

    /// The radio map resolved against `site` (built from this bundle), or
    /// `None` when the bundle has none. The gzip stream is decoded while
    /// the JSON is parsed (no text of the whole map is built); its length
    /// must be the manifest's `raw_size`. Errors name the entry and, for
    /// JSON errors, the field.
    pub fn radio_map(&self, site: &Site) -> Result<Option<RadioMap>> {
        let Some((info, gz)) = self.of_kind(EntryKind::RadioMap) else {
            return Ok(None);
        };
        let at = format!("entry {}", info.name);
        let raw = info.raw_size.unwrap_or(0);
        let mut reader = std::io::BufReader::with_capacity(
            64 * 1024,
            JsonLimits::new(
                flate2::read::GzDecoder::new(gz),
                raw,
                crate::bounds::MAX_RADIO_MAP_STRING_BYTES,
                crate::bounds::MAX_JSON_NUMBER_CHARS,
            ),
        );
        let parsed = serde_json::from_reader::<_, RadioMapFile>(&mut reader);
        let limits = reader.get_ref();
        let file = match parsed {
            Ok(f) => f,
            Err(e) if e.is_io() => {
                return bad(
                    at,
                    match limits.violation() {
                        Some(v) if v.offset >= raw => format!(
                            "decompresses to more than the manifest's raw_size of {raw} bytes"
                        ),
                        Some(v) => format!(
                            "radio map: field `{}`: {}",
                            scan_path(gz, Scanner::at_offset(v.offset), raw).path(""),
                            v.msg
                        ),
                        None => format!("gzip: {e}"),
                    },
                );
            }
            Err(e) => {
                let (field, msg) = scan_path(gz, Scanner::at_error(&e), raw).describe(&e);
                return bad(at, format!("radio map: field `{field}`: {msg}"));
            }
        };
        if limits.bytes_read() != raw {
            return bad(
                at,
                format!(
                    "decompresses to {} bytes, the manifest's raw_size is {raw}",
                    limits.bytes_read()
                ),
            );
        }
        let map = RadioMap::from_file_owned(file, site).map_err(|e| Error::Bundle {
            at: at.clone(),
            msg: e.to_string(),
        })?;
        Ok(Some(map))
    }
}

/// The JSON path scan `scanner` run over the decompressed text of `gz` (at
/// most `raw` bytes, read in chunks: no text of the map is held), for the
/// message of an error found while parsing it. Only on error paths.
fn scan_path(gz: &[u8], mut scanner: Scanner, raw: u64) -> Scanner {
    let mut text = flate2::read::GzDecoder::new(gz).take(raw);
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        match text.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(k) => {
                if scanner.feed(&buf[..k]) {
                    break;
                }
            }
        }
    }
    scanner
}

/// Whether `name` is a path relative to the bundle, as [`write`] names plan
/// entries: not absolute (`/x`, `\\x`, `C:x`), no `..` component. Bundles
/// written before this check may hold absolute names; they still read.
pub fn is_bundle_relative(name: &str) -> bool {
    let b = name.as_bytes();
    let drive = b.len() >= 2 && b[1] == b':' && b[0].is_ascii_alphabetic();
    !(name.starts_with('/')
        || name.starts_with('\\')
        || drive
        || name.split(['/', '\\']).any(|c| c == ".."))
}

/// What [`write`] puts in a bundle.
#[derive(Debug, Clone, Copy)]
pub struct BundleInput<'a> {
    /// site.json as it is (its plan paths name the plan entries).
    pub site_json: &'a [u8],
    /// Each plan path of the site and the image's bytes; the paths name
    /// the entries and must be relative ([`is_bundle_relative`]).
    pub plans: &'a [(&'a str, &'a [u8])],
    /// The radio map's JSON, or none (the engines use the site's path-loss
    /// models).
    pub radio_map_json: Option<&'a [u8]>,
    /// Written into the manifest's `writer`.
    pub writer: &'a str,
}

/// Writes a bundle: the site, its plans and the radio map (gzip, default
/// level). Checks only what the container needs (names, sizes); callers
/// check the content by parsing the result back ([`Bundle::parse`],
/// [`Bundle::build_site`], [`Bundle::radio_map`]), as `fpbp bundle` does.
pub fn write(input: &BundleInput<'_>) -> Result<Vec<u8>> {
    use std::io::Write;
    let spec = SiteSpec::from_json(input.site_json, SITE_ENTRY)?;
    let gz = match input.radio_map_json {
        None => None,
        Some(j) => {
            let mut enc = flate2::write::GzEncoder::new(
                Vec::with_capacity(j.len() / 8),
                flate2::Compression::default(),
            );
            enc.write_all(j)
                .and_then(|()| enc.finish())
                .map(|v| Some((v, j.len() as u64)))
                .or_else(|e| bad(RADIO_MAP_ENTRY, format!("gzip: {e}")))?
        }
    };
    let mut parts: Vec<(EntryInfo, &[u8])> = Vec::new();
    let info = |name: &str, kind: EntryKind, data: &[u8], raw_size: Option<u64>| EntryInfo {
        name: name.to_string(),
        kind,
        encoding: kind.encoding(),
        size: data.len() as u64,
        raw_size,
        sha256: sha256_hex(data),
    };
    parts.push((
        info(SITE_ENTRY, EntryKind::Site, input.site_json, None),
        input.site_json,
    ));
    for (name, data) in input.plans {
        if !is_bundle_relative(name) {
            return bad(
                format!("entry {}", crate::bounds::echo(name)),
                "a plan entry is named by a path relative to the bundle \
                 (no leading `/` or drive, no `..`): rewrite floors[].plan",
            );
        }
        parts.push((info(name, EntryKind::Plan, data, None), data));
    }
    if let Some((g, raw)) = &gz {
        parts.push((
            info(RADIO_MAP_ENTRY, EntryKind::RadioMap, g, Some(*raw)),
            g.as_slice(),
        ));
    }
    let manifest = Manifest {
        format: FORMAT.into(),
        version: VERSION,
        site: spec.name.clone(),
        writer: input.writer.to_string(),
        entries: parts.iter().map(|(e, _)| e.clone()).collect(),
    };
    let m = serde_json::to_vec_pretty(&manifest)
        .or_else(|e| bad("manifest", format!("cannot serialise: {e}")))?;
    let m_len = u32::try_from(m.len())
        .ok()
        .filter(|&n| n <= MAX_MANIFEST_BYTES)
        .map_or_else(
            || bad("manifest", format!("{} bytes, over the limit", m.len())),
            Ok,
        )?;
    let total: usize = HEADER_BYTES + m.len() + parts.iter().map(|(_, d)| d.len()).sum::<usize>();
    if total as u64 > MAX_BUNDLE_BYTES {
        return bad(
            "size",
            format!("{total} bytes, over the limit of {MAX_BUNDLE_BYTES}"),
        );
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&m_len.to_le_bytes());
    out.extend_from_slice(&m);
    for (_, d) in &parts {
        out.extend_from_slice(d);
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
