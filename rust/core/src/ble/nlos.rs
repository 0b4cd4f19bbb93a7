//! NLOS identification from RSSI and a predicted position (PPSA paper,
//! Sec. 3.2, eqs. 1-10), as a reusable BLE component.
//!
//! For a beacon with model R0, n and a predicted phone position x^ (the last
//! position moved by PDR, eq. 1), the RSSI expected under LOS is
//! RSSI^ = R0 - 10 n log10 d^ (eqs. 2, 3, 5). The identification value is
//!
//!   delta = RSSI^ - RSSI_k   (dB of excess attenuation)
//!
//! i.e. the paper's eq. 7 with the sign turned so that NLOS attenuation
//! (the received signal is *weaker* than predicted) is positive. With the
//! paper's own sign the NLOS mean mu_NLOS would be negative, and eq. 9 then
//! has no interior minimum and eq. 10 (delta >= TH_best -> NLOS) would mark
//! the *strongest* beacons as NLOS. Under LOS delta ~ N(0, sigma_1^2),
//! under NLOS delta ~ N(mu_NLOS, sigma_2^2) with sigma_1 = sigma_LOS +
//! sigma_p and sigma_2 = sigma_NLOS + sigma_p (as printed under eq. 7).
//!
//! TH_best minimises the misclassification sum r(th) of eq. 9
//! (P(LOS delta >= th) + P(NLOS delta < th)); [`th_best`] finds it in closed
//! form from r'(th) = 0 (equal densities: a quadratic in th).

use serde::{Deserialize, Serialize};

use super::frontend::FilteredBeacon;
use super::pathloss::range_m;
use crate::{Error, Result, Vec2};

/// How GML (and the other BLE-only positioners) use NLOS identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NlosGmlMode {
    /// No identification (the FP-BP paper's GML).
    Off,
    /// Drop beacons identified as NLOS, keeping at least `min_beacons`
    /// (the least attenuated NLOS beacons are kept when needed).
    Drop,
    /// Keep NLOS beacons but add mu_NLOS back to their RSSI (bias correction).
    Correct,
}

/// Parameters of NLOS identification (`ble.nlos`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NlosConfig {
    /// sigma_LOS of eq. 4, dB. Default 1.9 (PPSA Table 2, Huawei Mate 9).
    pub sigma_los_dbm: f64,
    /// sigma_NLOS of eq. 4, dB. Default 4.25 (PPSA Table 2, Huawei Mate 9).
    pub sigma_nlos_dbm: f64,
    /// mu_NLOS: mean extra attenuation of an NLOS path, dB (> 0). The paper
    /// does not print its value; default 10 (a typical single interior wall
    /// at 2.4 GHz; see docs/engines-nlos.md).
    pub mu_nlos_dbm: f64,
    /// sigma_p of eq. 5: RSSI error caused by the error of the predicted
    /// position, dB. Default 0 (the paper neglects it, Sec. 4.2).
    pub sigma_p_dbm: f64,
    /// Use in the BLE-only positioners (GML etc.). Default `off`.
    pub gml_mode: NlosGmlMode,
    /// `drop` keeps at least this many beacons. Default 3.
    pub min_beacons: usize,
}

impl Default for NlosConfig {
    fn default() -> Self {
        NlosConfig {
            sigma_los_dbm: 1.9,
            sigma_nlos_dbm: 4.25,
            mu_nlos_dbm: 10.0,
            sigma_p_dbm: 0.0,
            gml_mode: NlosGmlMode::Off,
            min_beacons: 3,
        }
    }
}

impl NlosConfig {
    /// Checks every field; errors name the field (prefix `prefix`, e.g. `ble.nlos`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let pos = |f: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::config(
                    format!("{prefix}.{f}"),
                    format!("must be finite and > 0, got {v}"),
                ))
            }
        };
        pos("sigma_los_dbm", self.sigma_los_dbm)?;
        pos("sigma_nlos_dbm", self.sigma_nlos_dbm)?;
        pos("mu_nlos_dbm", self.mu_nlos_dbm)?;
        if !(self.sigma_p_dbm.is_finite() && self.sigma_p_dbm >= 0.0) {
            return Err(Error::config(
                format!("{prefix}.sigma_p_dbm"),
                "must be finite and >= 0",
            ));
        }
        if self.min_beacons < 3 {
            return Err(Error::config(
                format!("{prefix}.min_beacons"),
                "must be >= 3",
            ));
        }
        Ok(())
    }

    /// sigma_1 = sigma_LOS + sigma_p (eq. 9).
    pub fn sigma1(&self) -> f64 {
        self.sigma_los_dbm + self.sigma_p_dbm
    }

    /// sigma_2 = sigma_NLOS + sigma_p (eq. 9).
    pub fn sigma2(&self) -> f64 {
        self.sigma_nlos_dbm + self.sigma_p_dbm
    }

    /// TH_best for this configuration (eq. 8).
    pub fn th_best(&self) -> f64 {
        th_best(self.sigma1(), self.sigma2(), self.mu_nlos_dbm)
    }
}

/// Complementary error function (Numerical Recipes `erfcc`, fractional
/// error below 1.2e-7 everywhere).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Standard normal CDF.
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// Normal density (MATLAB `normpdf(x, mu, sigma)`).
pub fn normpdf(x: f64, mu: f64, sigma: f64) -> f64 {
    let z = (x - mu) / sigma;
    (-0.5 * z * z).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt())
}

/// r(th) of eq. 9: P(N(0, s1^2) >= th) + P(N(mu, s2^2) < th).
pub fn misclassification(th: f64, sigma1: f64, sigma2: f64, mu_nlos: f64) -> f64 {
    (1.0 - normal_cdf(th / sigma1)) + normal_cdf((th - mu_nlos) / sigma2)
}

/// TH_best of eq. 8: the minimiser of r(th) (eq. 9), from r'(th) = 0, i.e.
/// the points where the two densities are equal:
/// th^2 (1/s1^2 - 1/s2^2) + 2 mu th / s2^2 - mu^2 / s2^2 + 2 ln(s1/s2) = 0.
/// Of the real roots the one with the smallest r is returned (equal sigmas:
/// mu / 2). Requires s1, s2 > 0 and mu > 0 (checked by [`NlosConfig::validate`]);
/// without a real root (cannot happen then) it falls back to mu / 2.
pub fn th_best(sigma1: f64, sigma2: f64, mu_nlos: f64) -> f64 {
    let s1sq = sigma1 * sigma1;
    let s2sq = sigma2 * sigma2;
    let a = 1.0 / s1sq - 1.0 / s2sq;
    let b = 2.0 * mu_nlos / s2sq;
    let c = -mu_nlos * mu_nlos / s2sq + 2.0 * (sigma1 / sigma2).ln();
    let mut roots = Vec::with_capacity(2);
    if a.abs() < 1e-12 * (1.0 / s1sq) {
        if b != 0.0 {
            roots.push(-c / b);
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            // numerically stable pair
            let q = -0.5 * (b + b.signum() * sq);
            if q != 0.0 {
                roots.push(q / a);
                roots.push(c / q);
            } else {
                roots.push(-b / (2.0 * a));
            }
        }
    }
    roots
        .into_iter()
        .filter(|r| r.is_finite())
        .min_by(|x, y| {
            misclassification(*x, sigma1, sigma2, mu_nlos)
                .total_cmp(&misclassification(*y, sigma1, sigma2, mu_nlos))
        })
        .unwrap_or(0.5 * mu_nlos)
}

/// The condition of one propagation path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PathCondition {
    Los,
    Nlos,
}

/// Identification of one beacon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NlosVerdict {
    /// delta = predicted - measured RSSI, dB (eq. 7, sign as in the module doc).
    pub delta_db: f64,
    pub condition: PathCondition,
}

/// RSSI-based NLOS identification against a predicted position.
#[derive(Debug, Clone, PartialEq)]
pub struct NlosIdentifier {
    cfg: NlosConfig,
    th_best: f64,
    min_distance_m: f64,
}

impl NlosIdentifier {
    /// `min_distance_m` floors the predicted range (as the front end's path-loss use).
    pub fn new(cfg: &NlosConfig, min_distance_m: f64) -> Self {
        NlosIdentifier {
            th_best: cfg.th_best(),
            cfg: cfg.clone(),
            min_distance_m,
        }
    }

    pub fn config(&self) -> &NlosConfig {
        &self.cfg
    }

    /// TH_best in dB.
    pub fn th_best(&self) -> f64 {
        self.th_best
    }

    /// Classifies a delta (eq. 10): delta >= TH_best is NLOS.
    pub fn classify_delta(&self, delta_db: f64) -> PathCondition {
        if delta_db >= self.th_best {
            PathCondition::Nlos
        } else {
            PathCondition::Los
        }
    }

    /// Identifies beacon `b` (measured RSSI `rssi_dbm`) from the predicted
    /// position `predicted` (eqs. 2, 5, 7, 10). `None` on non-finite input.
    pub fn identify(
        &self,
        b: &FilteredBeacon,
        rssi_dbm: f64,
        predicted: Vec2,
    ) -> Option<NlosVerdict> {
        let d = range_m(predicted, b.pos, b.dz_m, self.min_distance_m);
        let expected = b.model.rssi_at(d, self.min_distance_m);
        let delta_db = expected - rssi_dbm;
        delta_db.is_finite().then(|| NlosVerdict {
            delta_db,
            condition: self.classify_delta(delta_db),
        })
    }

    /// Applies `gml_mode` to a filtered set (strongest first) given the
    /// previous/predicted position. Returns the set to hand to the positioner
    /// and how many beacons were identified as NLOS.
    pub fn apply_to_set(
        &self,
        beacons: &[FilteredBeacon],
        predicted: Vec2,
    ) -> (Vec<FilteredBeacon>, usize) {
        let verdicts: Vec<Option<NlosVerdict>> = beacons
            .iter()
            .map(|b| self.identify(b, b.rssi_dbm, predicted))
            .collect();
        let nlos = verdicts
            .iter()
            .filter(|v| v.is_some_and(|v| v.condition == PathCondition::Nlos))
            .count();
        match self.cfg.gml_mode {
            NlosGmlMode::Off => (beacons.to_vec(), nlos),
            NlosGmlMode::Correct => {
                let out = beacons
                    .iter()
                    .zip(&verdicts)
                    .map(|(b, v)| {
                        let mut b = *b;
                        if v.is_some_and(|v| v.condition == PathCondition::Nlos) {
                            b.rssi_dbm += self.cfg.mu_nlos_dbm;
                        }
                        b
                    })
                    .collect::<Vec<_>>();
                let mut out = out;
                out.sort_by(|a, b| b.rssi_dbm.total_cmp(&a.rssi_dbm));
                (out, nlos)
            }
            NlosGmlMode::Drop => {
                let los: Vec<FilteredBeacon> = beacons
                    .iter()
                    .zip(&verdicts)
                    .filter(|(_, v)| v.is_none_or(|v| v.condition == PathCondition::Los))
                    .map(|(b, _)| *b)
                    .collect();
                if los.len() >= self.cfg.min_beacons {
                    return (los, nlos);
                }
                // keep the least attenuated NLOS beacons to reach min_beacons
                let mut extra: Vec<(f64, usize)> = verdicts
                    .iter()
                    .enumerate()
                    .filter_map(|(i, v)| {
                        v.filter(|v| v.condition == PathCondition::Nlos)
                            .map(|v| (v.delta_db, i))
                    })
                    .collect();
                extra.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let need = self.cfg.min_beacons - los.len();
                let mut keep: Vec<usize> = extra.iter().take(need).map(|&(_, i)| i).collect();
                keep.sort_unstable();
                let out = beacons
                    .iter()
                    .zip(&verdicts)
                    .enumerate()
                    .filter(|(i, (_, v))| {
                        v.is_none_or(|v| v.condition == PathCondition::Los) || keep.contains(i)
                    })
                    .map(|(_, (b, _))| *b)
                    .collect();
                (out, nlos)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::PathLoss;
    use proptest::prelude::*;

    /// Golden-section minimisation of r(th) after a coarse scan (independent
    /// of the closed form).
    fn numeric_min(s1: f64, s2: f64, mu: f64) -> f64 {
        let r = |t: f64| misclassification(t, s1, s2, mu);
        let (lo, hi) = (-5.0 * s1 - 5.0 * s2, mu + 5.0 * s2 + 5.0 * s1);
        let n = 20_000;
        let mut best = lo;
        for k in 0..=n {
            let t = lo + (hi - lo) * k as f64 / n as f64;
            if r(t) < r(best) {
                best = t;
            }
        }
        let h = (hi - lo) / n as f64;
        let (mut a, mut b) = (best - h, best + h);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..100 {
            let c = b - g * (b - a);
            let d = a + g * (b - a);
            if r(c) < r(d) {
                b = d;
            } else {
                a = c;
            }
        }
        0.5 * (a + b)
    }

    #[test]
    fn erfc_matches_known_values() {
        for (x, v) in [
            (0.0, 1.0),
            (0.5, 0.479_500_122_186_953_5),
            (1.0, 0.157_299_207_050_285_1),
            (2.0, 0.004_677_734_981_047_266),
            (-1.0, 1.842_700_792_949_715),
        ] {
            assert!((erfc(x) - v).abs() < 2e-7 * v.max(1e-3), "erfc({x})");
        }
        assert!((normal_cdf(1.959_963_985) - 0.975).abs() < 1e-6);
    }

    #[test]
    fn th_best_of_the_paper_parameters_matches_numeric_minimisation() {
        let c = NlosConfig::default();
        let th = c.th_best();
        let num = numeric_min(c.sigma1(), c.sigma2(), c.mu_nlos_dbm);
        assert!((th - num).abs() < 1e-3, "closed {th} numeric {num}");
        // sigma 1.9 / 4.25, mu 10: the quadratic's roots are 3.7056 and -8.7012
        assert!((th - 3.7056).abs() < 1e-3, "{th}");
        // strictly between the two means, nearer the narrower LOS one
        assert!(th > 0.0 && th < c.mu_nlos_dbm / 2.0 + 1.0, "{th}");
        // equal sigmas: midway
        assert!((th_best(3.0, 3.0, 8.0) - 4.0).abs() < 1e-9);
    }

    proptest! {
        #[test]
        fn th_best_minimises_eq_9(s1 in 0.5f64..6.0, s2 in 0.5f64..8.0, mu in 1.0f64..20.0) {
            let th = th_best(s1, s2, mu);
            let num = numeric_min(s1, s2, mu);
            let (rt, rn) = (misclassification(th, s1, s2, mu), misclassification(num, s1, s2, mu));
            // the closed form is never worse than the numeric search
            prop_assert!(rt <= rn + 1e-7, "th {th} r {rt} / numeric {num} r {rn}");
            prop_assert!((th - num).abs() < 1e-2 || (rt - rn).abs() < 1e-7);
        }
    }

    fn beacon(x: f64, rssi: f64) -> FilteredBeacon {
        FilteredBeacon {
            index: 0,
            floor: 0,
            pos: Vec2::new(x, 0.0),
            dz_m: 0.0,
            model: PathLoss {
                rssi_1m_dbm: -59.0,
                exponent: 2.0,
            },
            rssi_dbm: rssi,
            var_dbm2: 1.0,
            samples: 5,
            last_t_ns: 0,
        }
    }

    #[test]
    fn identifies_attenuated_paths_as_nlos() {
        let id = NlosIdentifier::new(&NlosConfig::default(), 0.5);
        let p = Vec2::new(0.0, 0.0);
        // 10 m: LOS model RSSI -79
        let los = id.identify(&beacon(10.0, -80.0), -80.0, p).unwrap();
        assert_eq!(los.condition, PathCondition::Los);
        assert!((los.delta_db - 1.0).abs() < 1e-9);
        let nlos = id.identify(&beacon(10.0, -90.0), -90.0, p).unwrap();
        assert_eq!(nlos.condition, PathCondition::Nlos);
        assert!(id.identify(&beacon(10.0, f64::NAN), f64::NAN, p).is_none());
    }

    #[test]
    fn drop_mode_keeps_min_beacons_and_correct_mode_shifts() {
        let mut cfg = NlosConfig {
            gml_mode: NlosGmlMode::Drop,
            ..NlosConfig::default()
        };
        let p = Vec2::new(0.0, 0.0);
        // model RSSI at 5, 10, 20, 30 m: -73, -79, -85, -88.5
        let set = [
            beacon(5.0, -73.0),
            beacon(10.0, -79.5),
            beacon(20.0, -97.0),
            beacon(30.0, -100.0),
        ];
        let id = NlosIdentifier::new(&cfg, 0.5);
        let (out, n) = id.apply_to_set(&set, p);
        assert_eq!(n, 2);
        // 2 LOS + the least attenuated NLOS beacon (30 m: delta 11.5 < 12 at 20 m)
        assert_eq!(out.len(), 3);
        assert!(out.iter().any(|b| b.pos.x == 30.0));
        assert!(!out.iter().any(|b| b.pos.x == 20.0));
        cfg.gml_mode = NlosGmlMode::Correct;
        let id = NlosIdentifier::new(&cfg, 0.5);
        let (out, _) = id.apply_to_set(&set, p);
        assert_eq!(out.len(), 4);
        assert!(
            out.iter()
                .any(|b| b.pos.x == 20.0 && (b.rssi_dbm + 87.0).abs() < 1e-9)
        );
        cfg.gml_mode = NlosGmlMode::Off;
        let id = NlosIdentifier::new(&cfg, 0.5);
        assert_eq!(id.apply_to_set(&set, p).0, set.to_vec());
    }

    #[test]
    fn bad_config_names_the_field() {
        let c = NlosConfig {
            mu_nlos_dbm: -1.0,
            ..NlosConfig::default()
        };
        let e = c.validate("ble.nlos").unwrap_err().to_string();
        assert!(e.contains("ble.nlos.mu_nlos_dbm"), "{e}");
    }
}
