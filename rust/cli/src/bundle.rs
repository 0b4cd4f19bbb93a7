//! `fpbp bundle`: one file with a site, its plans and its radio map for the
//! phone (`fpbp_core::bundle`, docs/formats.md "Site bundle"), and
//! `--check`: load a bundle (or the site and map files) as the library
//! does and print how long each step took and the peak memory. File glue
//! only.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use fpbp_core::bundle::{self, Bundle, BundleInput};
use fpbp_core::site::SiteSpec;

/// Arguments of `fpbp bundle`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Site file (site.json; its plans are read relative to it), or with
    /// `--check` a bundle or a site file.
    pub input: PathBuf,
    /// Radio map (`fpbp calibrate --radio-map`); without it the bundle has
    /// none and tcpf uses the site's path-loss models.
    #[arg(long)]
    pub radio_map: Option<PathBuf>,
    /// Bundle to write (e.g. site.fpbp).
    #[arg(long, required_unless_present = "check")]
    pub out: Option<PathBuf>,
    /// Load INPUT (a bundle, or a site file with its `--radio-map`) as the
    /// library does and print the time of each step and the peak memory.
    #[arg(long, conflicts_with = "out")]
    pub check: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.check {
        return check(&args);
    }
    let out = args.out.as_deref().context("--out is required")?;
    let started = Instant::now();
    let site_path = &args.input;
    let mut site_json = std::fs::read(site_path)
        .with_context(|| format!("cannot read site file {}", site_path.display()))?;
    let mut spec = SiteSpec::from_json(&site_json, &site_path.display().to_string())?;
    let dir = site_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    // (path in the site file, name in the bundle, bytes)
    let mut plans: Vec<(String, String, Vec<u8>)> = Vec::new();
    let kept: Vec<&str> = spec
        .floors
        .iter()
        .filter_map(|f| f.plan.as_deref())
        .filter(|p| bundle::is_bundle_relative(p))
        .collect();
    for f in &spec.floors {
        let Some(p) = &f.plan else { continue };
        if plans.iter().any(|(q, _, _)| q == p) {
            continue;
        }
        let taken = plans
            .iter()
            .map(|(_, n, _)| n.as_str())
            .chain(kept.iter().copied());
        let name = entry_name(p, taken);
        plans.push((
            p.clone(),
            name,
            fpbp_core::site::files::read_plan_file(&dir.join(p))?,
        ));
    }
    // a plan path that is absolute or leaves the site's directory names no
    // entry of a bundle (its path on this machine): the bundle's site.json
    // names that plan by its file name instead
    if plans.iter().any(|(p, n, _)| p != n) {
        for (k, f) in spec.floors.iter_mut().enumerate() {
            if let Some(p) = &mut f.plan
                && let Some((_, n, _)) = plans.iter().find(|(q, _, _)| q == p)
                && p != n
            {
                println!("floors[{k}].plan {p} is entry `{n}` of the bundle");
                *p = n.clone();
            }
        }
        site_json = spec.to_json_pretty().into_bytes();
    }
    let map_json = match &args.radio_map {
        Some(p) => Some(std::fs::read(p).with_context(|| format!("cannot read {}", p.display()))?),
        None => None,
    };
    let plan_refs: Vec<(&str, &[u8])> = plans
        .iter()
        .map(|(_, n, d)| (n.as_str(), d.as_slice()))
        .collect();
    let bytes = bundle::write(&BundleInput {
        site_json: &site_json,
        plans: &plan_refs,
        radio_map_json: map_json.as_deref(),
        writer: concat!("fpbp ", env!("CARGO_PKG_VERSION")),
    })?;
    // never write a bundle the library would refuse: parse it back in full
    let b = Bundle::parse(&bytes).context("the bundle just written does not parse")?;
    let site = b.build_site().context("the bundle's site does not build")?;
    if let Some(p) = &args.radio_map {
        b.radio_map(&site)
            .with_context(|| format!("radio map {}", p.display()))?;
    }
    std::fs::write(out, &bytes).with_context(|| format!("cannot write {}", out.display()))?;
    print_manifest(b.manifest(), bytes.len());
    if let Some(raw) = map_json.as_ref().map(Vec::len) {
        println!(
            "bundle {} bytes = {:.1} % of site.json + plans + radio map JSON ({} bytes)",
            bytes.len(),
            100.0 * bytes.len() as f64
                / (site_json.len() + plan_refs.iter().map(|p| p.1.len()).sum::<usize>() + raw)
                    as f64,
            site_json.len() + plan_refs.iter().map(|p| p.1.len()).sum::<usize>() + raw
        );
    }
    println!(
        "wrote {} ({:.1} s)",
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The entry name of plan path `path`: the path itself when it is relative
/// to the bundle ([`bundle::is_bundle_relative`]), else its file name, made
/// unique among `taken` (`plan-2.png`).
fn entry_name<'a>(path: &str, taken: impl Iterator<Item = &'a str> + Clone) -> String {
    if bundle::is_bundle_relative(path) {
        return path.to_string();
    }
    let p = Path::new(path);
    let stem = p
        .file_stem()
        .map_or("plan".into(), |s| s.to_string_lossy().into_owned());
    let ext = p
        .extension()
        .map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
    (1..)
        .map(|k| {
            if k == 1 {
                format!("{stem}{ext}")
            } else {
                format!("{stem}-{k}{ext}")
            }
        })
        .find(|n| taken.clone().all(|t| t != n))
        .unwrap_or_default()
}

fn print_manifest(m: &bundle::Manifest, total: usize) {
    println!(
        "{} v{} `{}`: {total} bytes, {} entries",
        m.format,
        m.version,
        m.site,
        m.entries.len()
    );
    for e in &m.entries {
        let raw = e
            .raw_size
            .map_or(String::new(), |r| format!(" ({r} bytes decompressed)"));
        println!(
            "  {:<10} {:<28} {:>10} bytes{raw}  sha256 {}",
            serde_json::to_value(e.kind)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default(),
            e.name,
            e.size,
            e.sha256
        );
    }
}

/// Peak resident set size of this process so far, bytes (Linux: VmHWM).
fn peak_rss() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn mb(b: Option<u64>) -> String {
    b.map_or("n/a".into(), |b| format!("{:.1} MB", b as f64 / 1e6))
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// `--check`: load INPUT as the library does, with figures.
fn check(args: &Args) -> anyhow::Result<()> {
    let rss0 = peak_rss();
    let t = Instant::now();
    let bytes = std::fs::read(&args.input)
        .with_context(|| format!("cannot read {}", args.input.display()))?;
    let read_ms = ms(t);
    if bundle::sniff(&bytes).is_some() {
        if args.radio_map.is_some() {
            bail!("--radio-map: a bundle carries its own radio map");
        }
        let t = Instant::now();
        let b = Bundle::parse(&bytes)?;
        let parse_ms = ms(t);
        let t = Instant::now();
        let site = b.build_site()?;
        let site_ms = ms(t);
        let t = Instant::now();
        let map = b.radio_map(&site)?;
        let map_ms = ms(t);
        print_manifest(b.manifest(), bytes.len());
        println!(
            "load: read {read_ms:.1} ms, manifest + SHA-256 {parse_ms:.1} ms, site {site_ms:.1} ms, \
             radio map (gunzip + parse + resolve) {map_ms:.1} ms{}; total {:.1} ms",
            if map.is_none() { " (none)" } else { "" },
            read_ms + parse_ms + site_ms + map_ms
        );
    } else {
        let t = Instant::now();
        let site = fpbp_core::site::files::load_site(&args.input)?;
        let site_ms = ms(t);
        let t = Instant::now();
        let mut text_bytes = 0;
        if let Some(p) = &args.radio_map {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read {}", p.display()))?;
            text_bytes = text.len();
            fpbp_core::radio::RadioMap::from_json(&text, &site)
                .with_context(|| p.display().to_string())?;
        }
        let map_ms = ms(t);
        println!(
            "load (files, as `fpbp eval` does): site {site_ms:.1} ms (incl. reading {} bytes), \
             radio map (read {text_bytes} bytes + parse + resolve) {map_ms:.1} ms; total {:.1} ms",
            bytes.len(),
            site_ms + map_ms
        );
    }
    println!(
        "peak RSS: {} (before loading: {})",
        mb(peak_rss()),
        mb(rss0)
    );
    Ok(())
}
