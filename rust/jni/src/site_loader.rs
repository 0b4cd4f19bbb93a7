//! Reads a site for `start`: site.json text plus the directory its plan
//! paths are relative to. The only file I/O of the bridge (the core takes bytes).

use std::path::Path;

use fpbp_core::site::{Site, SiteSpec};

use crate::error::BridgeError;

/// Parses `site_json`, reads each floor's plan from `site_dir` and builds the site.
pub fn load_site(site_json: &str, site_dir: &Path) -> Result<Site, BridgeError> {
    let spec: SiteSpec = serde_json::from_str(site_json).map_err(|e| {
        BridgeError::IllegalArgument(format!(
            "site JSON (line {}, column {}): {e}",
            e.line(),
            e.column()
        ))
    })?;
    build_site(spec, site_dir)
}

fn build_site(spec: SiteSpec, site_dir: &Path) -> Result<Site, BridgeError> {
    // Interim until `Site::build` lands from the map helper: read every plan so
    // a missing one is reported, then refuse.
    for f in &spec.floors {
        if let Some(plan) = &f.plan {
            let path = site_dir.join(plan);
            std::fs::read(&path).map_err(|e| {
                BridgeError::IllegalArgument(format!(
                    "floor {}: plan {}: {e}",
                    f.id,
                    path.display()
                ))
            })?;
        }
    }
    Err(BridgeError::Internal(
        "site building is not available yet (Site::build)".into(),
    ))
}
