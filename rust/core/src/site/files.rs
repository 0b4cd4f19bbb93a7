//! Loading a site from disk (feature `fs`): site.json and the plan images
//! next to it. The rest of the core takes bytes; this is the one reader the
//! CLI, the JNI bridge and the tests share.

use std::io::Read;
use std::path::Path;
use std::sync::Arc;

use crate::bounds::{MAX_PLAN_FILE_BYTES, check_plan_file};
use crate::site::{Site, SiteSpec};

/// Reads `path` (site.json), parses and validates it, reads each floor's plan
/// relative to the site file's folder and builds the maps. Errors name the
/// file and the field at fault.
pub fn load_site(path: &Path) -> crate::Result<Arc<Site>> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| crate::Error::Io {
        file: format!("cannot read site file {name}"),
        source,
    })?;
    let spec = SiteSpec::from_json(&bytes, &name)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let site = Site::build(spec, &name, &mut |plan: &str| {
        read_plan_file(&dir.join(plan))
    })?;
    Ok(Arc::new(site))
}

/// Parses site.json text whose plan paths are relative to `dir` (the JNI
/// bridge's `start`: the app hands the text and the folder) and builds the
/// site; `name` is the site's name in error messages.
pub fn load_site_text(json: &str, name: &str, dir: &Path) -> crate::Result<Site> {
    let spec = SiteSpec::from_json(json.as_bytes(), name)?;
    Site::build(spec, name, &mut |plan: &str| {
        read_plan_file(&dir.join(plan))
    })
}

/// Reads a plan file: only a regular file (a FIFO or device would block or
/// never end, a directory is no plan) of at most [`MAX_PLAN_FILE_BYTES`].
/// Errors name the path once.
pub fn read_plan_file(p: &Path) -> std::io::Result<Vec<u8>> {
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
