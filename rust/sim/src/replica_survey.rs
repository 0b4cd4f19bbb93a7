//! The walked fingerprint survey of a replica testbed (BMW Sec. 3.2.1,
//! docs/reproduction.md "robust-ekf (BMW)"): the replica's survey walks
//! (`crate::replica::survey_walks`) simulated and turned into a
//! fingerprint database by the same builder as `fpbp fingerprint build`
//! (`fpbp_core::fingerprint::SurveyBuilder`). Shared by `fpbp reproduce`
//! and the `trace_replica` example.

use crate::SimRequest;
use crate::replica::{SurveyPattern, survey_walks};
use anyhow::Context;
use fpbp_core::engines::EngineConfig;
use fpbp_core::fingerprint::{FingerprintSet, SurveyBuilder};
use fpbp_core::site::Site;

/// The BMW replica's survey settings (engine config JSON): reference points
/// 0.6 m apart (Sec. 4: 514 RPs at 0.6 m), known points only at the ends of
/// each straight survey line (Fig. 3, eq. 3; the truth track simplified
/// within 0.3 m), one RSSI sample every 0.5 s (one per 0.6 m at the
/// surveyor's 1.17 m/s).
pub const BMW_SURVEY_CONFIG: &str = r#"{"ekf":{"fingerprint":{"survey_cell_m":0.6,"survey_line_tolerance_m":0.3,"survey_sample_interval_s":0.5}}}"#;

/// The survey of test seed `s` is simulated with seed `SURVEY_SEED_OFFSET + s`
/// (its own random draws, not the test walk's).
pub const SURVEY_SEED_OFFSET: u64 = 1000;

/// The survey database of replica `paper` for test seed `seed`, built with
/// `cfg`'s `ble`, `pdr` and `ekf.fingerprint` sections; None when the paper
/// surveyed nothing. Also returns the survey's (known points, samples).
pub fn survey_db(
    paper: &str,
    site: &Site,
    cfg: &EngineConfig,
    seed: u64,
    pattern: SurveyPattern,
) -> anyhow::Result<Option<(FingerprintSet, usize, usize)>> {
    let walks = survey_walks(paper, pattern)?;
    if walks.is_empty() {
        return Ok(None);
    }
    let mut b = SurveyBuilder::new(site, &cfg.ble, &cfg.pdr, &cfg.ekf.fingerprint);
    let (mut known, mut samples) = (0, 0);
    for w in &walks {
        let req = SimRequest {
            duration_s: w.duration_s,
            seed: SURVEY_SEED_OFFSET + seed,
            floor: Some(w.floor),
            t0_ns: crate::DEFAULT_T0_NS,
            profile: w.profile.clone(),
        };
        let sim = crate::simulate(site, &req)
            .with_context(|| format!("simulating {} floor {} seed {seed}", w.name, w.floor))?;
        let rep = b.add_log(&sim.events);
        known += rep.known_points;
        samples += rep.samples;
    }
    Ok(Some((b.finish(), known, samples)))
}

/// `--survey` of `reproduce` and `trace_replica`: `alternate` (the replica's),
/// `with` or `against` the test walk's direction.
pub fn parse_pattern(s: &str) -> anyhow::Result<SurveyPattern> {
    Ok(match s {
        "alternate" => SurveyPattern::Alternate,
        "with" => SurveyPattern::WithTest,
        "against" => SurveyPattern::AgainstTest,
        other => anyhow::bail!("unknown survey pattern `{other}` (alternate, with, against)"),
    })
}
