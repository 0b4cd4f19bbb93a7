//! Draws the five replica testbeds (issue 18):
//! `cargo run -p fpbp-cli --example make_replica_sites -- maps` writes
//! maps/replica-<paper>/plan.png and site.json (fpbp_sim::replica_sites;
//! deterministic, pinned by rust/cli/tests/replicas.rs).

use std::path::PathBuf;

use fpbp_eval::reproduce::write_replica as write;
use fpbp_sim::replica_sites::{REPLICAS, build};

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "maps".into()));
    for name in REPLICAS {
        let r = build(name)?;
        write(&r, &out)?;
        println!(
            "wrote {}/{} ({} x {} px, {} beacons)",
            out.display(),
            r.dir,
            r.plan.width(),
            r.plan.height(),
            r.spec.beacons.len()
        );
    }
    Ok(())
}
