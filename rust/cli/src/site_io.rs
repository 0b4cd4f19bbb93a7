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
        let p = dir.join(plan);
        std::fs::read(&p)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", p.display())))
    })?;
    Ok(Arc::new(site))
}
