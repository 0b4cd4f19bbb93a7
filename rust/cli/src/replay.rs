//! `fpbp replay`: one log through one engine -> track.csv, metrics.json,
//! track.png; the work is `fpbp_eval::replay`, this prints the summary.

use fpbp_eval::replay::{ReplayOptions, run_checked};
use fpbp_eval::{metrics, radio_map, runner};

pub fn run(args: ReplayOptions) -> anyhow::Result<()> {
    let data = fpbp_core::engines::EngineData {
        radio_map: match &args.radio_map {
            Some(p) => Some(radio_map::load(p, runner::load_site(&args.site)?.as_ref())?),
            None => None,
        },
        ..Default::default()
    };
    let build = runner::builder_with(data);
    let (m, empty) = run_checked(&args, &build)?;
    let e = &m.errors;
    println!(
        "{} ({} start): {} truth points, {} without a pose (coverage {}), mean {} m, p50 {} m, p80 {} m, \
         max {} m (over the points with a pose); {} jumps, {} wall crossings per 100 m; realtime x{}",
        m.engine,
        m.start.name(),
        e.points,
        e.no_fix,
        fpbp_eval::eval::fmt_pct(e.coverage),
        metrics::fmt_opt(e.mpe_m, 2),
        metrics::fmt_opt(e.p50_m, 2),
        metrics::fmt_opt(e.p80_m, 2),
        metrics::fmt_opt(e.max_m, 2),
        m.track.jumps,
        metrics::fmt_opt(m.track.wall_crossings_per_100m, 1),
        metrics::fmt_opt(m.realtime_factor, 0)
    );
    println!(
        "wrote {}/{{track.csv,metrics.json,track.png}}",
        args.out.display()
    );
    empty
}
