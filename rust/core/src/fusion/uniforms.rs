//! Many uniform draws of the filter's PCG-64 at once, the same values as
//! drawing them one by one.
//!
//! `rng.random::<f64>()` on `Pcg64` steps a 128-bit LCG, s' = a s + c, and
//! outputs XSL-RR(s') >> 11 scaled by 2^-53. Drawn one by one, every draw
//! waits for the previous state's 128-bit multiply: a serial chain that
//! dominated the step's draws. The LCG jumps ahead in closed form (s_{k+4}
//! = a^4 s_k + c (a^3 + a^2 + a + 1)), so four interleaved chains compute
//! states k, k+1, k+2, k+3 independently and the CPU overlaps their
//! multiplies. Outputs and the final state are those of the serial stream
//! (unit test against `rand`'s draws, to the bit).

use rand_pcg::Pcg64;

/// PCG-64's LCG multiplier (`rand_pcg`'s `Lcg128Xsl64`).
const MULTIPLIER: u128 = 0x2360_ED05_1FC6_5DA4_4385_DF64_9FCC_F645;

/// Interleaved chains.
const LANES: usize = 4;

/// PCG's output function XSL RR (128-bit state, 64-bit output).
#[inline(always)]
fn xsl_rr(state: u128) -> u64 {
    let rot = (state >> 122) as u32;
    ((state >> 64) as u64 ^ state as u64).rotate_right(rot)
}

/// `rand`'s uniform f64 in [0, 1) from 64 random bits: the top 53 bits
/// times 2^-53.
#[inline(always)]
fn to_unit(bits: u64) -> f64 {
    const SCALE: f64 = 1.0 / (1u64 << 53) as f64;
    (bits >> 11) as f64 * SCALE
}

/// Fills `out` with `out.len()` draws of `rng.random::<f64>()`, in order,
/// and leaves `rng` where those draws would: the same values and state.
pub fn fill_uniform(rng: &mut Pcg64, out: &mut [f64]) {
    let stream = rng.stream();
    let inc = (stream << 1) | 1;
    let step = |s: u128| s.wrapping_mul(MULTIPLIER).wrapping_add(inc);
    // a^4 and c (a^3 + a^2 + a + 1): four steps in one
    let a2 = MULTIPLIER.wrapping_mul(MULTIPLIER);
    let a4 = a2.wrapping_mul(a2);
    let c4 = inc.wrapping_mul(
        a2.wrapping_mul(MULTIPLIER)
            .wrapping_add(a2)
            .wrapping_add(MULTIPLIER)
            .wrapping_add(1),
    );
    let mut s = rng.state();
    let mut chunks = out.chunks_exact_mut(LANES);
    if chunks.len() > 0 {
        // states of the next four draws
        let mut lane = [0u128; LANES];
        for l in &mut lane {
            s = step(s);
            *l = s;
        }
        for c in chunks.by_ref() {
            for (o, l) in c.iter_mut().zip(&lane) {
                *o = to_unit(xsl_rr(*l));
            }
            s = lane[LANES - 1];
            for l in &mut lane {
                *l = l.wrapping_mul(a4).wrapping_add(c4);
            }
        }
    }
    for o in chunks.into_remainder() {
        s = step(s);
        *o = to_unit(xsl_rr(s));
    }
    *rng = Pcg64::from_state(s, stream);
}

/// Draws `k = outs.len()` uniforms per particle for `m` particles, in the
/// order of a per-particle loop that takes `outs[0][i]`, `outs[1][i]`, ...
/// then moves to particle i + 1 (each of `outs` at least `m` long): one
/// [`fill_uniform`] into `buf`, then spread.
pub fn fill_interleaved(rng: &mut Pcg64, buf: &mut Vec<f64>, m: usize, outs: &mut [&mut [f64]]) {
    let k = outs.len();
    if k == 0 || m == 0 {
        return;
    }
    buf.resize(k * m, 0.0);
    fill_uniform(rng, buf);
    for (j, out) in outs.iter_mut().enumerate() {
        for (o, u) in out[..m].iter_mut().zip(buf[j..].iter().step_by(k)) {
            *o = *u;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn no_particles_draw_nothing() {
        let mut rng = Pcg64::seed_from_u64(3);
        let before = rng.clone();
        let (mut a, mut b): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
        let mut buf = Vec::new();
        // two outputs and no particles: spreading used to slice `buf[1..]`
        // of an empty buffer and panic
        fill_interleaved(&mut rng, &mut buf, 0, &mut [&mut a[..], &mut b[..]]);
        assert_eq!(rng, before, "no uniform taken for zero particles");
    }

    #[test]
    fn bulk_draws_are_the_serial_ones() {
        for seed in [0u64, 1, 7, 123_456_789] {
            let mut serial = Pcg64::seed_from_u64(seed);
            let mut bulk = serial.clone();
            // lengths around the lane count, and a long one
            for n in [0usize, 1, 2, 3, 4, 5, 7, 8, 9, 1000, 6001] {
                let want: Vec<f64> = (0..n).map(|_| serial.random::<f64>()).collect();
                let mut got = vec![0.0; n];
                fill_uniform(&mut bulk, &mut got);
                assert!(
                    want.iter()
                        .zip(&got)
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "seed {seed}, n {n}"
                );
                assert_eq!(bulk, serial, "state after {n}");
            }
            assert_eq!(bulk.random::<u64>(), serial.random::<u64>());
        }
    }
}
