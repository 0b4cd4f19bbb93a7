//! Tests of FP-BP's models: eq. 34's moves and draws (batched as the
//! per-particle loop), the per-particle biases, the extra noise and eq. 36.

use super::*;
use crate::fusion::ParticleFilter;
use crate::fusion::config::Resampling;
use crate::fusion::random::std_normal;
use rand::RngExt;
use rand::SeedableRng;

use crate::fusion::particle_filter::tests::{filter, filter_with_offsets};

/// Walks east 0.7 m per step while the PDR reports a yaw `bias_rad` off,
/// weighting against BLE fixes on the true path every step; returns the
/// final distance of the estimate from the truth and the weighted mean
/// heading offset of the particles.
fn walk_with_heading_bias(pf: &mut ParticleFilter, bias_rad: f64) -> (f64, f64) {
    pf.init_at(Vec2::zeros(), 0.0, |_| true);
    let mut truth = Vec2::zeros();
    for _ in 0..60 {
        truth += Vec2::new(0.7, 0.0);
        pf.predict(0.7, bias_rad);
        pf.weight(truth);
        pf.resample();
    }
    let off: f64 = pf
        .heading_offsets()
        .iter()
        .zip(pf.weights())
        .map(|(o, w)| o * w)
        .sum();
    ((pf.mean().unwrap() - truth).norm(), off)
}

#[test]
fn particle_heading_offsets_learn_a_constant_heading_error() {
    // 12 deg heading error, 42 m walk, BLE on the true path (sigma 3 m)
    let bias = 12f64.to_radians();
    let (err_on, off) = walk_with_heading_bias(&mut filter_with_offsets(1000, 0.15, 5), bias);
    let (err_off, _) = walk_with_heading_bias(&mut filter_with_offsets(1000, 0.0, 5), bias);
    assert!(
        (off + bias).abs() < 0.05,
        "learned offset {off}, expected {}",
        -bias
    );
    assert!(
        err_on < 0.5 * err_off,
        "error with offsets {err_on}, without {err_off}"
    );
}

fn offset_stats(pf: &ParticleFilter) -> (f64, Vec<f64>) {
    let o = pf.heading_offsets().to_vec();
    let sd = (o.iter().map(|x| x * x).sum::<f64>() / o.len() as f64).sqrt();
    (sd, o)
}

#[test]
fn gauss_markov_heading_offsets_keep_their_spread_and_decorrelate() {
    let (sd, corr) = (0.1, 10.0);
    let cfg = FusionConfig {
        particle_count: 2000,
        heading_offset_sd_rad: sd,
        heading_offset_corr_steps: corr,
        ..FusionConfig::default()
    };
    let mut pf = ParticleFilter::new(&cfg, 3);
    pf.init_at(Vec2::zeros(), 0.0, |_| true);
    let (_, start) = offset_stats(&pf);
    pf.predict(0.7, 0.0);
    let (_, next) = offset_stats(&pf);
    // lag-1 correlation a = exp(-1 / corr)
    let c1 = start.iter().zip(&next).map(|(a, b)| a * b).sum::<f64>()
        / start.iter().map(|a| a * a).sum::<f64>();
    assert!(
        (c1 - (-1.0 / corr).exp()).abs() < 0.03,
        "lag-1 correlation {c1}"
    );
    for _ in 0..199 {
        pf.predict(0.7, 0.0);
    }
    // stationary: the spread stays sd (a random walk with the same
    // per-step sd would have grown to ~0.6 rad, the clamp)
    let (sd_end, end) = offset_stats(&pf);
    assert!(
        (sd_end - sd).abs() < 0.015,
        "offset sd after 200 steps {sd_end}"
    );
    let c200 = start.iter().zip(&end).map(|(a, b)| a * b).sum::<f64>()
        / start.iter().map(|a| a * a).sum::<f64>();
    assert!(
        c200.abs() < 0.1,
        "offsets still correlated after 200 steps: {c200}"
    );
}

#[test]
fn gauss_markov_and_random_walk_offsets_are_exclusive() {
    let cfg = FusionConfig {
        heading_offset_sd_rad: 0.1,
        heading_offset_corr_steps: 10.0,
        heading_offset_walk_rad: 0.01,
        ..FusionConfig::default()
    };
    let e = cfg.validate().unwrap_err().to_string();
    assert!(e.contains("fusion.heading_offset_corr_steps"), "{e}");
}

#[test]
fn extra_noise_spreads_the_moves_and_zero_adds_none() {
    let mut a = filter(2000, Resampling::Systematic, 5);
    let mut b = filter(2000, Resampling::Systematic, 5);
    for pf in [&mut a, &mut b] {
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
    }
    // 0 (and garbage) adds nothing: the same draws as eq. 34 alone
    a.set_extra_noise(f64::NAN);
    a.predict(0.7, 0.3);
    b.predict(0.7, 0.3);
    assert_eq!(a.particles(), b.particles());
    let mut c = filter(2000, Resampling::Systematic, 5);
    c.init_at(Vec2::zeros(), 0.0, |_| true);
    c.set_extra_noise(0.5);
    c.predict(0.0, 0.0);
    // step 0 +- 0.15 m along x, N(0, 0.5^2) per axis on top: y shows it alone
    let sd_y = (c.particles().iter().map(|p| p.y * p.y).sum::<f64>() / 2000.0).sqrt();
    assert!((sd_y - 0.5).abs() < 0.03, "sd of y {sd_y}");
}

#[test]
fn predict_moves_mean_by_step() {
    let mut pf = filter(2000, Resampling::Systematic, 7);
    pf.init_at(Vec2::zeros(), 0.0, |_| true);
    for _ in 0..10 {
        pf.predict(0.7, std::f64::consts::FRAC_PI_2);
    }
    let m = pf.mean().unwrap();
    // 10 steps of 0.7 m north, shortened slightly by the heading noise (E cos nu ~ 0.98).
    assert!(m.x.abs() < 0.1, "{m:?}");
    assert!((m.y - 6.86).abs() < 0.15, "{m:?}");
}

#[test]
fn far_fix_does_not_underflow() {
    let mut pf = filter(50, Resampling::Systematic, 3);
    pf.init_at(Vec2::zeros(), 1.0, |_| true);
    pf.weight(Vec2::new(1e4, 0.0));
    let s: f64 = pf.weights().iter().sum();
    assert!((s - 1.0).abs() < 1e-9 && pf.weights().iter().all(|w| w.is_finite()));
}

#[test]
fn small_sin_cos_matches_libm() {
    for k in -1000..=1000 {
        let x = k as f64 * 0.5e-3;
        let (s, c) = small_sin_cos(x);
        assert!((s - x.sin()).abs() < 4e-16, "sin {x}");
        assert!((c - x.cos()).abs() < 4e-16, "cos {x}");
    }
}

#[test]
fn predict_fast_branch_matches_the_general_one() {
    // same seed, same draws: the angle-sum branch equals sin_cos(yaw + nu)
    // to rounding, and a wider noise takes the general branch
    for (dth, fast) in [(0.35, true), (0.5, true), (0.9, false)] {
        let cfg = FusionConfig {
            particle_count: 500,
            heading_noise_rad: dth,
            heading_offset_sd_rad: 0.0,
            ..FusionConfig::default()
        };
        let mut pf = ParticleFilter::new(&cfg, 11);
        pf.init_at(Vec2::zeros(), 0.0, |_| true);
        let mut rng = Pcg64::seed_from_u64(11);
        pf.predict(0.7, 2.0);
        for p in pf.particles() {
            let nu_s = cfg.step_noise_m * (2.0 * rng.random::<f64>() - 1.0);
            let nu_th = dth * (2.0 * rng.random::<f64>() - 1.0);
            let len = 0.7 + nu_s;
            let q = Vec2::new(len * (2.0 + nu_th).cos(), len * (2.0 + nu_th).sin());
            let tol = if fast { 1e-15 } else { 0.0 };
            assert!((p - q).norm() <= tol, "{dth}: {p:?} vs {q:?}");
        }
    }
}

#[test]
fn mean_likelihood_falls_with_distance() {
    let mut pf = filter(100, Resampling::Systematic, 1);
    pf.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
    assert!((pf.mean_likelihood(Vec2::new(0.0, 0.0), 3.0) - 1.0).abs() < 1e-12);
    let near = pf.mean_likelihood(Vec2::new(3.0, 0.0), 3.0);
    assert!((near - (-0.5f64).exp()).abs() < 1e-12);
    assert!(pf.mean_likelihood(Vec2::new(9.0, 0.0), 3.0) < near);
}

/// The biased propagation and the extra noise as they were before the
/// draws were batched: every draw inside the per-particle loop.
fn propagate_reference(
    mo: &Eq34Motion,
    cloud: &mut Cloud,
    rng: &mut Pcg64,
    step_length_m: f64,
    yaw_rad: f64,
) {
    let (ds, dth) = (mo.step_noise_m, mo.heading_noise_rad);
    let (walk_off, walk_scale) = (mo.heading_offset_walk_rad, mo.step_scale_walk);
    let a = mo.heading_offset_decay;
    let gm_sd = mo.heading_offset_sd_rad * (1.0 - a * a).sqrt();
    let (sy, cy) = yaw_rad.sin_cos();
    let (particles, [offsets, scales]) =
        cloud.positions_and_columns_mut([HEADING_OFFSET, STEP_SCALE]);
    for ((p, off), scale) in particles
        .iter_mut()
        .zip(offsets.iter_mut())
        .zip(scales.iter_mut())
    {
        if a > 0.0 {
            *off = (a * *off + gm_sd * std_normal(rng))
                .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD);
        } else if walk_off > 0.0 {
            *off = (*off + walk_off * std_normal(rng))
                .clamp(-MAX_HEADING_OFFSET_RAD, MAX_HEADING_OFFSET_RAD);
        }
        if walk_scale > 0.0 {
            *scale = (*scale + walk_scale * std_normal(rng))
                .clamp(1.0 - MAX_SCALE_DEVIATION, 1.0 + MAX_SCALE_DEVIATION);
        }
        let nu_s = ds * (2.0 * rng.random::<f64>() - 1.0);
        let nu_th = dth * (2.0 * rng.random::<f64>() - 1.0);
        let len = (step_length_m * *scale + nu_s).max(0.0);
        *p += step_vector(len, *off + nu_th, sy, cy);
    }
    let sd = mo.extra_noise_m;
    if sd > 0.0 {
        for p in particles.iter_mut() {
            let (a, b) = (std_normal(rng), std_normal(rng));
            *p += Vec2::new(sd * a, sd * b);
        }
    }
}

#[test]
fn batched_draws_match_the_per_particle_loop() {
    // offsets random-walking or Gauss-Markov, scales walking or not,
    // extra noise or not: the same positions, offsets, scales and
    // RNG state to the bit
    for (corr, walk_scale, noise) in [(0.0, 0.005, 0.3), (20.0, 0.0, 0.0), (0.0, 0.0, 0.2)] {
        let cfg = FusionConfig {
            particle_count: 257,
            heading_offset_sd_rad: 0.15,
            heading_offset_walk_rad: 0.01,
            heading_offset_corr_steps: corr,
            step_scale_sd: 0.1,
            step_scale_walk: walk_scale,
            ..FusionConfig::default()
        };
        let mut rng = Pcg64::seed_from_u64(5);
        let mut mo = Eq34Motion::new(&cfg, 257);
        let mut cloud = Cloud::new(257, 2);
        cloud.fill_disc(&mut rng, 257, Vec2::new(3.0, 4.0), 2.0, |_| true);
        mo.draw_biases(&mut cloud, &mut rng);
        mo.set_extra_noise(noise);
        let (mut rc, mut rr) = (cloud.clone(), rng.clone());
        for k in 0..6 {
            let yaw = 0.3 + 0.9 * f64::from(k);
            let step = PdrStep {
                length_m: 0.7,
                yaw_rad: yaw,
            };
            mo.propagate(&mut cloud, &mut rng, &step);
            propagate_reference(&mo, &mut rc, &mut rr, 0.7, yaw);
            assert_eq!(cloud.positions(), rc.positions());
            assert_eq!(cloud.column(HEADING_OFFSET), rc.column(HEADING_OFFSET));
            assert_eq!(cloud.column(STEP_SCALE), rc.column(STEP_SCALE));
            assert_eq!(rng, rr);
        }
    }
}
