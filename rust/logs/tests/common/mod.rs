//! Helpers shared by the dataset tests (each test file is its own crate).

use std::path::{Path, PathBuf};

/// `../shared/datasets`, or None (printing that the test is skipped).
pub fn datasets() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets");
    if d.is_dir() {
        Some(d)
    } else {
        println!(
            "skipped: ../shared/datasets not found (looked in {})",
            d.display()
        );
        None
    }
}

/// The `.gz` files of `dir`, sorted.
pub fn gz_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "gz"))
        .collect();
    v.sort();
    v
}
