//! Reads a site for `start`: site.json text plus the directory its plan
//! paths are relative to. The only file I/O of the bridge (the core takes
//! bytes): `Site::build` asks for each plan by its path in the spec.

use std::path::Path;

use fpbp_core::site::Site;

use crate::error::BridgeError;

/// Name of the site in error messages (the JNI caller passes text, not a file).
pub const SITE_NAME: &str = "site.json";

/// Parses `site_json`, reads each floor's plan from `site_dir` and builds the
/// site (`fpbp_core::site::files`, the reader the CLI uses too). Errors name
/// the field (e.g. `floors[0].plan`) and, for plans, the path.
pub fn load_site(site_json: &str, site_dir: &Path) -> Result<Site, BridgeError> {
    Ok(fpbp_core::site::files::load_site_text(
        site_json, SITE_NAME, site_dir,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPEN: &str = r#"{"format": "fpbp-site", "version": 1, "name": "t",
        "floors": [{"id": 0, "open_area_m": [10.0, 8.0], "pixels_per_meter": 5.0}]}"#;

    #[test]
    fn open_floor_needs_no_file() {
        let site = load_site(OPEN, Path::new("/nonexistent")).expect("open site");
        assert_eq!(site.floors.len(), 1);
        assert_eq!(site.default_floor(), 0);
    }

    #[test]
    fn missing_plan_names_field_and_path() {
        let json = OPEN.replace(r#""open_area_m": [10.0, 8.0]"#, r#""plan": "nope.png""#);
        match load_site(&json, Path::new("/nonexistent")) {
            Err(BridgeError::IllegalArgument(m)) => {
                assert!(
                    m.contains("floors[0].plan") && m.contains("/nonexistent/nope.png"),
                    "{m}"
                )
            }
            other => panic!("unexpected {:?}", other.map(|_| ())),
        }
    }

    #[test]
    fn syntax_error_names_line() {
        match load_site("{\n \"format\": ", Path::new(".")) {
            Err(BridgeError::IllegalArgument(m)) => assert!(m.contains("line"), "{m}"),
            other => panic!("unexpected {:?}", other.map(|_| ())),
        }
    }

    #[test]
    fn demo_site_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
        let Ok(json) = std::fs::read_to_string(dir.join("site.json")) else {
            println!("skipped: maps/demo/site.json not found");
            return;
        };
        let site = load_site(&json, &dir).expect("demo site");
        assert!(!site.spec.beacons.is_empty());
    }
}
