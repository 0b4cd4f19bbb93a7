//! Tests of [`super::ParticleFilter`]: initialisation, weighting,
//! resampling, the columns travelling with their particles, penalties,
//! replacement, injection and estimates.

use super::*;
use proptest::prelude::*;
use rand::RngExt;

/// A filter of `m` particles with eq. 34 alone (shared with the models' tests).
pub(crate) fn filter(m: usize, resampling: Resampling, seed: u64) -> ParticleFilter {
    // eq. 34 alone: no per-particle heading offsets
    let cfg = FusionConfig {
        particle_count: m,
        resampling,
        heading_offset_sd_rad: 0.0,
        ..FusionConfig::default()
    };
    ParticleFilter::new(&cfg, seed)
}

/// A filter of `m` particles with per-particle heading offsets.
pub(crate) fn filter_with_offsets(m: usize, offset_sd_rad: f64, seed: u64) -> ParticleFilter {
    let cfg = FusionConfig {
        particle_count: m,
        heading_offset_sd_rad: offset_sd_rad,
        ..FusionConfig::default()
    };
    ParticleFilter::new(&cfg, seed)
}

#[test]
fn heading_offsets_stay_with_their_particles() {
    let mut pf = filter_with_offsets(500, 0.2, 9);
    pf.init_at(Vec2::zeros(), 0.0, |_| true);
    let sd = (pf.heading_offsets().iter().map(|o| o * o).sum::<f64>() / 500.0).sqrt();
    assert!((sd - 0.2).abs() < 0.03, "offset sd {sd}");
    pf.predict(1.0, 0.0);
    pf.weight(Vec2::new(1.0, 0.3));
    let pairs: Vec<(Vec2, f64)> = pf
        .particles()
        .iter()
        .copied()
        .zip(pf.heading_offsets().iter().copied())
        .collect();
    pf.resample();
    pf.replace_invalid(|p| p.y < 0.0, Vec2::zeros());
    for (p, o) in pf.particles().iter().zip(pf.heading_offsets()) {
        assert!(
            pairs.contains(&(*p, *o)),
            "{p:?} {o} is not a particle of before"
        );
    }
}

#[test]
fn the_owners_state_stays_with_its_particles_and_cell_draws_are_recorded() {
    let mut pf = filter(400, Resampling::Systematic, 3);
    let cells = [
        Vec2::new(0.0, 0.0),
        Vec2::new(10.0, 0.0),
        Vec2::new(0.0, 10.0),
    ];
    pf.init_from_cells(&cells, &[1.0, 2.0, 3.0], 1.0, |_| true);
    assert!(pf.state().is_empty());
    let draws = pf.cell_draws().to_vec();
    assert_eq!(draws.len(), 400);
    for (i, c) in &draws {
        assert!((pf.particles()[*i] - cells[*c]).norm() < 0.8);
    }
    // the state: the index of the cell each particle came from
    pf.set_state(draws.iter().map(|(_, c)| *c as f64).collect());
    pf.weight(Vec2::new(10.0, 0.0));
    pf.resample();
    pf.replace_invalid(|p| p.y > 5.0, Vec2::zeros());
    for (p, s) in pf.particles().iter().zip(pf.state()) {
        assert!((p - cells[*s as usize]).norm() < 0.8, "{p:?} {s}");
    }
    // re-seeding records its draws; a wrong length empties the state
    let n = pf.inject_from_cells(0.25, &cells[2..], &[1.0], 1.0, |_| true);
    assert_eq!(pf.cell_draws().len(), n);
    assert!(pf.cell_draws().iter().all(|(_, c)| *c == 0));
    pf.set_state(vec![0.0; 3]);
    assert!(pf.state().is_empty());
    pf.set_state(vec![1.0; 400]);
    pf.init_at(Vec2::zeros(), 1.0, |_| true);
    assert!(pf.state().is_empty() && pf.cell_draws().is_empty());
}

fn ess_filter(m: usize, fraction: f64) -> ParticleFilter {
    let cfg = FusionConfig {
        particle_count: m,
        resample_ess_fraction: fraction,
        sigma_x_m: 3.0,
        ..FusionConfig::default()
    };
    cfg.validate().unwrap();
    ParticleFilter::new(&cfg, 11)
}

#[test]
fn ess_resampling_waits_until_the_weights_degenerate() {
    let mut pf = ess_filter(1000, 0.5);
    pf.init_at(Vec2::zeros(), 2.0, |_| true);
    // a fix at the cloud's centre barely changes the weights: no resampling
    pf.weight(Vec2::zeros());
    let ess = pf.effective_sample_size();
    assert!(ess > 500.0, "ess {ess}");
    assert!(!pf.resample_if_degenerate());
    let w = pf.weights().to_vec();
    assert!(
        w.iter().any(|x| (x - 1e-3).abs() > 1e-5),
        "weights were reset"
    );
    // the next fix multiplies those weights: w_i ~ L_i^2 for the same fix
    pf.weight(Vec2::zeros());
    let inv = 1.0 / (2.0 * 9.0);
    let l: Vec<f64> = pf
        .particles()
        .iter()
        .map(|p| (-(p.norm_squared()) * inv).exp())
        .collect();
    let z: f64 = l.iter().map(|x| x * x).sum();
    for (wi, li) in pf.weights().iter().zip(&l) {
        assert!((wi - li * li / z).abs() < 1e-12, "{wi} vs {}", li * li / z);
    }
    // a far fix concentrates the weight: resampled, weights uniform
    pf.weight(Vec2::new(15.0, 0.0));
    assert!(
        pf.effective_sample_size() < 500.0,
        "ess {}",
        pf.effective_sample_size()
    );
    assert!(pf.resample_if_degenerate());
    assert!(pf.weights().iter().all(|x| (x - 1e-3).abs() < 1e-15));
}

#[test]
fn ess_fraction_one_resamples_every_step_like_the_paper() {
    let (mut a, mut b) = (ess_filter(300, 1.0), ess_filter(300, 1.0));
    for pf in [&mut a, &mut b] {
        pf.init_at(Vec2::zeros(), 2.0, |_| true);
    }
    for k in 0..20 {
        let x_b = Vec2::new(0.5 * k as f64, 0.3);
        a.predict(0.5, 0.0);
        b.predict(0.5, 0.0);
        a.weight(x_b);
        b.weight(x_b);
        assert!(a.resample_if_degenerate());
        b.resample();
        assert_eq!(a.particles(), b.particles());
    }
    let e = FusionConfig {
        resample_ess_fraction: 0.0,
        ..FusionConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("fusion.resample_ess_fraction"), "{e}");
}

#[test]
fn penalized_moves_keep_a_fraction_of_their_weight() {
    let mut pf = filter(4, Resampling::Systematic, 1);
    pf.init_at(Vec2::zeros(), 0.0, |_| true);
    let mut before = pf.particles().to_vec();
    // every particle "crossed": uniform again after normalising
    assert_eq!(pf.penalize_moves(&before, 0.1, |_, _| true), 4);
    assert!(pf.weights().iter().all(|w| (w - 0.25).abs() < 1e-12));
    // only the first particle's move (marked by its start) crossed
    before[0] = Vec2::new(-1.0, 0.0);
    let n = pf.penalize_moves(&before, 0.1, |a, _| a.x < 0.0);
    assert_eq!(n, 1);
    // 0.1 : 1 : 1 : 1
    assert!(
        (pf.weights()[0] - 0.1 / 3.1).abs() < 1e-12,
        "{:?}",
        pf.weights()
    );
    assert!((pf.weights()[1] - 1.0 / 3.1).abs() < 1e-12);
}

#[test]
fn penalize_flagged_equals_penalize_moves() {
    let mut a = filter(500, Resampling::Systematic, 4);
    a.init_at(Vec2::zeros(), 3.0, |_| true);
    a.weight(Vec2::new(1.0, 0.5));
    let mut b = a.clone();
    let before = vec![Vec2::zeros(); 500];
    let crossed = |_: Vec2, p: Vec2| p.x > 1.0 && p.y < 0.5;
    let flags: Vec<bool> = a
        .particles()
        .iter()
        .map(|p| crossed(Vec2::zeros(), *p))
        .collect();
    for factor in [0.01, 0.0, 1.0] {
        let n = a.penalize_moves(&before, factor, crossed);
        assert!(n > 0);
        assert_eq!(b.penalize_flagged(&flags, factor), n);
        assert_eq!(a.weights(), b.weights());
    }
}

#[test]
fn without_biases_offsets_and_scales_stay_0_and_1() {
    // resample and replace_invalid skip copying them then
    let mut pf = filter(300, Resampling::Stratified, 2);
    pf.init_at(Vec2::zeros(), 4.0, |_| true);
    for k in 0..5 {
        pf.predict(0.7, k as f64);
        pf.weight(Vec2::new(1.0, 1.0));
        pf.resample();
        pf.replace_invalid(|p| p.x < 0.0, Vec2::zeros());
        assert_eq!(pf.heading_offsets().len(), 300);
        assert!(pf.heading_offsets().iter().all(|o| *o == 0.0));
        assert!(pf.step_scales().iter().all(|s| *s == 1.0));
    }
}

#[test]
fn init_puts_all_particles_on_start() {
    let mut pf = filter(100, Resampling::Systematic, 1);
    pf.init_at(Vec2::new(3.0, 4.0), 0.0, |_| true);
    assert_eq!(pf.particles().len(), 100);
    assert!(pf.particles().iter().all(|p| *p == Vec2::new(3.0, 4.0)));
    assert!((pf.weights().iter().sum::<f64>() - 1.0).abs() < 1e-12);
}

#[test]
fn weighting_and_resampling_pull_towards_ble() {
    let mut pf = filter(1000, Resampling::Stratified, 3);
    pf.init_at(Vec2::zeros(), 5.0, |_| true);
    pf.weight(Vec2::new(3.0, 0.0));
    let m = pf.mean().unwrap();
    assert!(m.x > 1.0, "weighted mean moves towards x_B: {m:?}");
    pf.resample();
    let m2 = pf.mean().unwrap();
    assert!(
        (m2 - m).norm() < 0.5,
        "resampling keeps the mean: {m:?} {m2:?}"
    );
}

#[test]
fn same_seed_same_particles() {
    let run = |seed| {
        let mut pf = filter(200, Resampling::Systematic, seed);
        pf.init_at(Vec2::new(1.0, 1.0), 1.0, |_| true);
        for k in 0..20 {
            pf.predict(0.7, k as f64 * 0.1);
            pf.weight(Vec2::new(k as f64 * 0.5, 2.0));
            pf.resample();
        }
        pf.particles().to_vec()
    };
    assert_eq!(run(5), run(5));
    assert_ne!(run(5), run(6));
}

#[test]
fn replace_invalid_copies_good_particles_in_draw_order() {
    let mut pf = filter(300, Resampling::Systematic, 9);
    pf.init_at(Vec2::zeros(), 5.0, |_| true);
    let before = pf.particles().to_vec();
    let bad = |p: Vec2| p.x > 1.0;
    let n = pf.replace_invalid(bad, Vec2::new(9.0, 9.0));
    // reference: the former two-vector version with the same RNG stream
    let mut rng = Pcg64::seed_from_u64(9);
    for _ in 0..2 * 300 {
        let _: f64 = rng.random();
    }
    let good: Vec<usize> = (0..300).filter(|&i| !bad(before[i])).collect();
    let mut expect = before.clone();
    let mut count = 0;
    for i in 0..300 {
        if bad(before[i]) {
            count += 1;
            let k = ((rng.random::<f64>() * good.len() as f64) as usize).min(good.len() - 1);
            expect[i] = before[good[k]];
        }
    }
    assert!(count > 0);
    assert_eq!(n, count);
    assert_eq!(pf.particles(), &expect[..]);
    // all bad: the fallback
    assert_eq!(pf.replace_invalid(|_| true, Vec2::new(9.0, 9.0)), 300);
    assert!(pf.particles().iter().all(|p| *p == Vec2::new(9.0, 9.0)));
}

proptest! {
    #[test]
    fn weights_sum_to_one_and_resampling_keeps_count(
        m in 1usize..400,
        seed in 0u64..1000,
        stratified in any::<bool>(),
        bx in -50.0f64..50.0, by in -50.0f64..50.0,
        spread in 0.0f64..20.0,
    ) {
        let scheme = if stratified { Resampling::Stratified } else { Resampling::Systematic };
        let mut pf = filter(m, scheme, seed);
        pf.init_at(Vec2::zeros(), spread, |_| true);
        pf.predict(0.7, 0.3);
        pf.weight(Vec2::new(bx, by));
        let s: f64 = pf.weights().iter().sum();
        prop_assert!((s - 1.0).abs() < 1e-9);
        prop_assert!(pf.weights().iter().all(|w| *w >= 0.0));
        let before: Vec<Vec2> = pf.particles().to_vec();
        pf.resample();
        prop_assert_eq!(pf.particles().len(), m);
        let s: f64 = pf.weights().iter().sum();
        prop_assert!((s - 1.0).abs() < 1e-9);
        // Resampling only copies existing particles.
        prop_assert!(pf.particles().iter().all(|p| before.contains(p)));
    }
}

#[test]
fn inject_replaces_the_fraction_with_accepted_points_near_the_centre() {
    let mut pf = filter(1000, Resampling::Systematic, 3);
    pf.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
    let c = Vec2::new(20.0, 5.0);
    // Only the half-plane x >= 20 is accepted.
    let n = pf.inject(0.2, c, 1.0, |p| p.x >= 20.0);
    let moved: Vec<_> = pf.particles().iter().filter(|p| p.x != 0.0).collect();
    // Random indices may repeat: at most n distinct particles move.
    assert!(n > 150 && n <= 200, "{n}");
    assert!(moved.len() <= n && moved.len() > 150, "{}", moved.len());
    assert!(moved.iter().all(|p| p.x >= 20.0 && (**p - c).norm() < 6.0));
    let mut again = filter(1000, Resampling::Systematic, 3);
    again.init_at(Vec2::new(0.0, 0.0), 0.0, |_| true);
    again.inject(0.2, c, 1.0, |p| p.x >= 20.0);
    assert_eq!(pf.particles(), again.particles());
    assert_eq!(pf.inject(0.0, c, 1.0, |_| true), 0);
    assert_eq!(pf.inject(0.5, c, 1.0, |_| false), 0);
}
