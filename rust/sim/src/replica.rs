//! Simulator profiles of the papers' replica testbeds (issue 18; sites in
//! maps/replica-<paper>/, drawn by crate::replica_sites). Each walk is a
//! fixed route (`walk.waypoints_m`) on its replica with the radio channel,
//! advertising rate, phone height and walking speed the paper states; the
//! choices where it is silent are listed, with reasons, in
//! docs/reproduction.md. Pinned by `replica_profiles_are_pinned` below: a
//! change to a replica walk fails that test.

use fpbp_core::{Error, Result};

use crate::profile::SimProfile;

/// One replica walk: a named profile and the length simulated.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplicaWalk {
    /// Profile name (`replica-<paper>-<walk>`), accepted by [`SimProfile::named`].
    pub name: &'static str,
    /// What the walk stands for in the paper.
    pub paper_walk: &'static str,
    pub duration_s: f64,
    pub profile: SimProfile,
}

/// Names of every replica walk profile.
pub const REPLICA_PROFILE_NAMES: &[&str] = &[
    "replica-fpbp-1",
    "replica-fpbp-2",
    "replica-fpbp-3",
    "replica-prox-pf-1",
    "replica-ppsa-1",
    "replica-bmw-1",
    "replica-bmw-survey",
    "replica-tc-1",
    "replica-tc-2",
];

/// A replica profile: the default simulator with no pauses (the papers walk
/// their courses without stopping) and the given route.
fn course(name: &str, waypoints: &[[f64; 2]]) -> SimProfile {
    let mut p = SimProfile {
        name: name.to_string(),
        ..SimProfile::default()
    };
    p.walk.pause_probability = 0.0;
    p.walk.waypoints_m = waypoints.to_vec();
    p
}

/// The FP-BP replica's channel, calibrated on the paper's BLE-only
/// baselines (docs/reproduction.md "FP-BP channel"): every advert inside the
/// scan window is reported, 10 % burst loss, shadowing 3 dB, fast fading 3
/// dB, 0.5 dB per wall.
fn fpbp_channel(p: &mut SimProfile) {
    p.ble.reception_probability = 1.0;
    p.ble.burst_loss_fraction = 0.1;
    p.ble.shadowing_sigma_db = 3.0;
    p.ble.fast_fading_sigma_db = 3.0;
    p.ble.wall_attenuation_db = 0.5;
}

/// The FP-BP replica's walker, calibrated on the paper's PDR-only baseline
/// (docs/reproduction.md "FP-BP channel"): half the simulator's default
/// heading offset, walker step-length spread and yaw drift rate (the
/// defaults were measured on ILC and IPIN phones; the paper's PDR drifts
/// less).
fn fpbp_pdr(p: &mut SimProfile) {
    p.imu.yaw_offset_rad *= 0.5;
    p.imu.walker_step_length_sd_rel *= 0.5;
    p.imu.yaw_drift_rate_rad_s *= 0.5;
}

/// The walks of replica `paper` (`fpbp`, `prox-pf`, `ppsa`, `bmw`, `tc`).
pub fn replica_walks(paper: &str) -> Result<Vec<ReplicaWalk>> {
    let walks = match paper {
        "fpbp" => {
            // Table II's trajectories 1-3 (528, 229, 313 steps), shortened to
            // about half (CI time): 150, 65, 90 s through rooms and doors.
            let mut t1 = course(
                "replica-fpbp-1",
                &[
                    [3.0, 24.0],
                    [10.0, 10.0],
                    [27.0, 8.0],
                    [42.0, 5.0],
                    [47.0, 5.0],
                    [56.0, 8.0],
                    [85.0, 10.0],
                    [92.0, 24.0],
                    [92.0, 40.0],
                    [62.0, 40.0],
                    [20.0, 40.0],
                    [5.0, 30.0],
                ],
            );
            let mut t2 = course(
                "replica-fpbp-2",
                &[[95.0, 24.0], [78.0, 38.0], [48.0, 38.0], [47.0, 3.0]],
            );
            let mut t3 = course(
                "replica-fpbp-3",
                &[
                    [20.0, 44.0],
                    [35.0, 30.0],
                    [24.0, 24.0],
                    [10.0, 5.0],
                    [28.0, 12.0],
                    [47.0, 18.0],
                ],
            );
            // Sec. V-A (the channel) is missing from the paper: the channel
            // is the grid point whose BLE-only baselines come closest to
            // Fig. 11(b) (GML 2.01, FRBW 2.55, ML 2.63, trilateration 9.39 m
            // on trajectory 1), chosen on those four alone, never on fpbp or
            // bp (docs/reproduction.md "FP-BP channel").
            // The walker's PDR errors likewise on the PDR-only baseline
            // (Fig. 11(e): 7.41 m on trajectory 1, from the truth).
            for p in [&mut t1, &mut t2, &mut t3] {
                fpbp_channel(p);
                fpbp_pdr(p);
            }
            vec![
                ReplicaWalk {
                    name: "replica-fpbp-1",
                    paper_walk: "trajectory 1",
                    duration_s: 150.0,
                    profile: t1,
                },
                ReplicaWalk {
                    name: "replica-fpbp-2",
                    paper_walk: "trajectory 2",
                    duration_s: 65.0,
                    profile: t2,
                },
                ReplicaWalk {
                    name: "replica-fpbp-3",
                    paper_walk: "trajectory 3",
                    duration_s: 90.0,
                    profile: t3,
                },
            ]
        }
        "prox-pf" => {
            // The 70 m course with six turns; phone at breast height (1 m);
            // the channel fitted to the paper's P(d) (eq. 5): total RSSI
            // sigma 4 dB and the phone 3 dB below the beacons' model.
            let mut p = course(
                "replica-prox-pf-1",
                &[
                    [3.0, 15.0],
                    [3.0, 3.0],
                    [14.0, 3.0],
                    [14.0, 12.0],
                    [25.0, 12.0],
                    [25.0, 3.0],
                    [36.0, 3.0],
                    [36.0, 10.0],
                ],
            );
            p.walk.phone_height_m = 1.0;
            p.walk.step_freq_min_hz = 1.7;
            p.walk.step_freq_max_hz = 2.0;
            p.walk.step_len_at_min_freq_m = 0.62;
            p.walk.step_len_at_max_freq_m = 0.68;
            p.ble.shadowing_sigma_db = 2.8;
            p.ble.fast_fading_sigma_db = 2.8;
            p.ble.device_bias_dbm = -3.0;
            vec![ReplicaWalk {
                name: "replica-prox-pf-1",
                paper_walk: "the 70 m course (one of five trials)",
                duration_s: 70.0,
                profile: p,
            }]
        }
        "ppsa" => {
            // Along the corridor x = 63.8 (Table 4's points), 1.2 m/s (Table
            // 3), 10 BLE reports per beacon and second (Sec. 2), sigma_LOS
            // 1.9 dB and sigma_NLOS 4.25 dB (Table 2, Mate 9), a fifth of the
            // adverts NLOS with mu_NLOS 10 dB (not printed).
            let mut p = course("replica-ppsa-1", &[[63.8, 30.5], [63.8, 88.5]]);
            p.walk.step_freq_min_hz = 1.7;
            p.walk.step_freq_max_hz = 1.9;
            p.walk.step_len_at_min_freq_m = 0.66;
            p.walk.step_len_at_max_freq_m = 0.72;
            p.ble.advert_interval_s = 0.1;
            p.ble.reception_probability = 0.9;
            p.ble.burst_loss_fraction = 0.1;
            p.ble.shadowing_sigma_db = 1.3;
            p.ble.fast_fading_sigma_db = 1.4;
            p.ble.nlos_rate = 0.2;
            p.ble.nlos_mean_db = 10.0;
            p.ble.nlos_sigma_db = 3.8;
            vec![ReplicaWalk {
                name: "replica-ppsa-1",
                paper_walk: "the corridor walk of Sec. 4.1.1 (61 points, 1.2 m apart)",
                duration_s: 60.0,
                profile: p,
            }]
        }
        "bmw" => {
            // A loop of the lower floor's corridor (point A, along the
            // anchors and back to A, Fig. 25); anchors advertise at 10 Hz.
            let mut p = course(
                "replica-bmw-1",
                &[[3.0, 3.0], [31.0, 3.0], [31.0, 13.0], [3.0, 13.0]],
            );
            p.ble.advert_interval_s = 0.1;
            vec![ReplicaWalk {
                name: "replica-bmw-1",
                paper_walk: "the one-floor loop of Fig. 25",
                duration_s: 90.0,
                profile: p,
            }]
        }
        "tc" => {
            // 210 m of the 380 m route, transmitters at 2.5 Hz (Sec. IV-B),
            // the phone hears down to -94 dBm (weak transmitters within about
            // 5 m, strong ones within 100 m, Sec. III). Walk 2: a phone 3 dB
            // below the calibration phone (Mate 20 Pro, Table II).
            // along the walkway between the kerb and the columns, 1.8 m
            // from either row of posts
            let route = [[4.0, 3.8], [214.0, 3.8]];
            let mut p = course("replica-tc-1", &route);
            p.ble.advert_interval_s = 0.4;
            p.ble.sensitivity_dbm = -94.0;
            let mut q = p.clone();
            q.name = "replica-tc-2".into();
            q.ble.device_bias_dbm = -3.0;
            vec![
                ReplicaWalk {
                    name: "replica-tc-1",
                    paper_walk: "Pixel 7 Pro, no RSSI bias (Table III)",
                    duration_s: 170.0,
                    profile: p,
                },
                ReplicaWalk {
                    name: "replica-tc-2",
                    paper_walk: "Mate 20 Pro, 3 dB RSSI bias (Table IV)",
                    duration_s: 170.0,
                    profile: q,
                },
            ]
        }
        other => {
            return Err(Error::config(
                "replica",
                format!("unknown replica `{other}` (known: fpbp, prox-pf, ppsa, bmw, tc)"),
            ));
        }
    };
    Ok(walks)
}

/// The direction of a survey's lines relative to the replica's test walk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurveyPattern {
    /// Every other line in the test walk's direction (a surveyor walking the
    /// lines back and forth; the replica's survey).
    Alternate,
    /// Every line in the test walk's direction.
    WithTest,
    /// Every line against it.
    AgainstTest,
}

/// One survey walk of a replica: a profile walked on `floor`.
#[derive(Debug, Clone, PartialEq)]
pub struct SurveyWalk {
    /// Profile name (`replica-<paper>-survey`), accepted by [`SimProfile::named`].
    pub name: &'static str,
    pub floor: i32,
    pub duration_s: f64,
    pub profile: SimProfile,
}

/// The BMW survey walker's gait: one step frequency, 1.8 Hz, and the
/// simulator's step length at it (0.65 m), i.e. about 1.17 m/s, so that the
/// walk's length in time is known.
const SURVEY_STEP_HZ: f64 = 1.8;

/// The walked fingerprint survey of replica `paper` (BMW Sec. 3.2.1: the
/// surveyor walks straight lines between labelled start and end points; the
/// reference points are 0.6 m apart, Sec. 4), one walk per floor, or
/// nothing when the paper surveyed no fingerprints. BMW: the corridor loop
/// (2.4 m wide) walked as four rings 0.6 m apart (0.3, 0.9, 1.5 and 2.1 m
/// from the outer wall, i.e. the centre lines of the 0.6 m reference-point
/// rows), each ring four straight lines, on both floors, the rings' direction
/// by `pattern`; the same phone and anchors as the test walk; no dwell (the
/// paper's survey is walked). Choices where the paper is silent:
/// docs/reproduction.md "robust-ekf (BMW)".
pub fn survey_walks(paper: &str, pattern: SurveyPattern) -> Result<Vec<SurveyWalk>> {
    if paper != "bmw" {
        replica_walks(paper)?;
        return Ok(Vec::new());
    }
    let test = replica_walks("bmw")?.remove(0).profile;
    let (x0, y0, x1, y1) = (1.8, 1.8, 32.2, 14.2);
    let mut route: Vec<[f64; 2]> = Vec::new();
    for (k, d) in [0.3, 0.9, 1.5, 2.1].into_iter().enumerate() {
        let (a, b, c, e) = (x0 + d, y0 + d, x1 - d, y1 - d);
        // the test walk's direction: east along the lower corridor, north, west
        let with = [[a, b], [c, b], [c, e], [a, e], [a, b]];
        let against = [[a, b], [a, e], [c, e], [c, b], [a, b]];
        let along = match pattern {
            SurveyPattern::Alternate => k % 2 == 0,
            SurveyPattern::WithTest => true,
            SurveyPattern::AgainstTest => false,
        };
        route.extend_from_slice(if along { &with } else { &against });
    }
    let length_m: f64 = route
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let mut p = course("replica-bmw-survey", &route);
    p.ble = test.ble.clone();
    p.walk.step_freq_min_hz = SURVEY_STEP_HZ;
    p.walk.step_freq_max_hz = SURVEY_STEP_HZ;
    let step_m = 0.5 * (p.walk.step_len_at_min_freq_m + p.walk.step_len_at_max_freq_m);
    // one pass: the corners are cut (the walk is a little shorter), so stop at 98 %
    let duration_s = p.walk.initial_still_s + 0.98 * length_m / (SURVEY_STEP_HZ * step_m);
    Ok([0, 1]
        .into_iter()
        .map(|floor| SurveyWalk {
            name: "replica-bmw-survey",
            floor,
            duration_s,
            profile: p.clone(),
        })
        .collect())
}

/// The profile of replica walk `name` (one of [`REPLICA_PROFILE_NAMES`]).
pub fn replica_profile(name: &str) -> Option<SimProfile> {
    let rest = name.strip_prefix("replica-")?;
    let (paper, _) = rest.rsplit_once('-')?;
    let walk = replica_walks(paper)
        .ok()?
        .into_iter()
        .find(|w| w.name == name)
        .map(|w| w.profile);
    walk.or_else(|| {
        survey_walks(paper, SurveyPattern::Alternate)
            .ok()?
            .into_iter()
            .find(|w| w.name == name)
            .map(|w| w.profile)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// FNV-1a of the profile's JSON: a change to any replica walk (route,
    /// channel, gait, length) changes it. Update the pins deliberately, with
    /// the new figures in docs/reproduction.md.
    fn fnv(s: &str) -> u64 {
        s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        })
    }

    #[test]
    fn every_name_resolves_and_validates() {
        for n in REPLICA_PROFILE_NAMES {
            let p = replica_profile(n).unwrap_or_else(|| panic!("{n}"));
            p.validate().unwrap();
            assert_eq!(p.name, *n);
            assert_eq!(SimProfile::named(n).unwrap(), p);
        }
        assert!(replica_profile("replica-nope-1").is_none());
        assert!(replica_walks("nope").is_err());
    }

    #[test]
    fn replica_profiles_are_pinned() {
        let mut lines = Vec::new();
        for paper in ["fpbp", "prox-pf", "ppsa", "bmw", "tc"] {
            for w in replica_walks(paper).unwrap() {
                let json = serde_json::to_string(&w.profile).unwrap();
                lines.push(format!("{} {} {:016x}", w.name, w.duration_s, fnv(&json)));
            }
            for w in survey_walks(paper, SurveyPattern::Alternate).unwrap() {
                let json = serde_json::to_string(&w.profile).unwrap();
                lines.push(format!(
                    "{} floor {} {:.1} {:016x}",
                    w.name,
                    w.floor,
                    w.duration_s,
                    fnv(&json)
                ));
            }
        }
        let got = lines.join("\n");
        let want = "\
replica-fpbp-1 150 8731092fe6afbbcf
replica-fpbp-2 65 739360e91366f349
replica-fpbp-3 90 61492a3dca43f739
replica-prox-pf-1 70 737df03a7edd4ca5
replica-ppsa-1 60 b2707769aca87b4b
replica-bmw-1 90 a90c81baf8c119a8
replica-bmw-survey floor 0 259.8 a457cca25969e50a
replica-bmw-survey floor 1 259.8 a457cca25969e50a
replica-tc-1 170 af7afc4b5160c74d
replica-tc-2 170 a8b138230a11bc00";
        assert_eq!(got, want, "a replica walk changed:\n{got}");
    }
}
