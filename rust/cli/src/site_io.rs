//! Loading site files (site.json + plan PNGs) from disk.

use std::path::Path;
use std::sync::Arc;

use anyhow::Context;
use fpbp_core::site::{Site, SiteSpec};

/// Reads `path` (site.json), parses and validates it, reads each floor's plan
/// relative to the site file's folder and builds the maps. Errors name the
/// file and the field at fault.
pub fn load_site(path: &Path) -> anyhow::Result<Arc<Site>> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).with_context(|| format!("cannot read site file {name}"))?;
    let spec = SiteSpec::from_json(&bytes, &name)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let site = Site::build(spec, &name, &mut |plan: &str| {
        read_plan_file(&dir.join(plan))
    })?;
    Ok(Arc::new(site))
}

/// Reads a plan file: only a regular file (a FIFO or device would block or
/// never end, a directory is no plan) of at most
/// [`fpbp_core::bounds::MAX_PLAN_FILE_BYTES`]. Errors name the path once.
pub fn read_plan_file(p: &Path) -> std::io::Result<Vec<u8>> {
    use fpbp_core::bounds::{MAX_PLAN_FILE_BYTES, check_plan_file};
    use std::io::Read;
    let named = |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", p.display()));
    check_plan_file(p, &std::fs::metadata(p).map_err(named)?)?;
    let f = std::fs::File::open(p).map_err(named)?;
    check_plan_file(p, &f.metadata().map_err(named)?)?;
    let mut buf = Vec::new();
    f.take(MAX_PLAN_FILE_BYTES)
        .read_to_end(&mut buf)
        .map_err(named)?;
    Ok(buf)
}
