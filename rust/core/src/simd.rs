//! Runtime dispatch of the particle loops to AVX2 or AVX-512.
//!
//! The crate is built for the x86-64 baseline (SSE2: two f64 lanes). The
//! per-particle loops (expected RSSI, likelihood products, exp, Box-Muller)
//! are vectorised by the compiler; a function defined by [`avx2_dispatch!`]
//! runs its loop compiled with AVX-512 (F, DQ, VL: eight f64 lanes) when
//! the CPU has it, else compiled with AVX2 (four lanes) when the CPU has
//! that, as built otherwise (and on every other architecture).
//!
//! The values are the same bits either way: Rust does not fuse a multiply
//! and an add into an FMA or reorder floating-point arithmetic unless told
//! to (enabling AVX-512 makes FMA instructions available, it does not make
//! the compiler contract `a * b + c` into one), and AVX2 and AVX-512 have
//! the same IEEE operations as SSE2, so wider lanes change how many
//! particles one instruction handles, not any result. The tests of the
//! callers pin that (`simd_paths_agree_to_the_bit` in each module).
//!
//! The macro holds the crate's one use of `unsafe`: calling a function
//! compiled for a CPU feature after checking at run time that the CPU has
//! it (the crate denies `unsafe` elsewhere).

use std::cell::Cell;

/// Whether this CPU has AVX2 (checked once by the standard library, then
/// a load).
#[inline]
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether this CPU has the AVX-512 subsets the wide build is compiled for
/// (F, DQ, VL; checked once by the standard library, then loads).
#[inline]
pub fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The widest build this thread may take: [`WIDEST`], or less inside
/// [`baseline`] / [`at_most_avx2`].
const WIDEST: u8 = 2;

thread_local! {
    /// Set by [`baseline`] (0) and [`at_most_avx2`] (1).
    static CAP: Cell<u8> = const { Cell::new(WIDEST) };
}

/// Whether the functions of [`avx2_dispatch!`] take their AVX-512 build
/// now: the CPU has it and this thread is not inside [`baseline`] or
/// [`at_most_avx2`].
#[inline]
pub fn use_avx512() -> bool {
    CAP.get() >= 2 && has_avx512()
}

/// Whether the functions of [`avx2_dispatch!`] take (at least) their AVX2
/// build now: the CPU has AVX2 and this thread is not inside [`baseline`].
#[inline]
pub fn use_avx2() -> bool {
    CAP.get() >= 1 && has_avx2()
}

fn capped<R>(cap: u8, f: impl FnOnce() -> R) -> R {
    let before = CAP.replace(cap);
    let r = f();
    CAP.set(before);
    r
}

/// Runs `f` with every function of [`avx2_dispatch!`] (on this thread)
/// taking its baseline build: the reference the tests compare with.
pub fn baseline<R>(f: impl FnOnce() -> R) -> R {
    capped(0, f)
}

/// Runs `f` with every function of [`avx2_dispatch!`] (on this thread)
/// taking its AVX2 build at most (the tests compare it with the others).
pub fn at_most_avx2<R>(f: impl FnOnce() -> R) -> R {
    capped(1, f)
}

/// Defines a function whose body is compiled three times, as built, with
/// AVX2 and with AVX-512 enabled, and runs the widest build the CPU has
/// ([`use_avx512`], [`use_avx2`]). The body should be a whole hot loop: it
/// is inlined into every build (and the `#[inline]` functions it calls
/// with it), so the check is paid once per call, not per particle.
/// Arguments are `name: Type` (no patterns).
macro_rules! avx2_dispatch {
    (
        $(#[$attr:meta])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block
    ) => {
        $(#[$attr])*
        #[allow(unsafe_code)]
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn kernel($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
                fn avx512($($arg: $ty),*) $(-> $ret)? {
                    kernel($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn avx2($($arg: $ty),*) $(-> $ret)? {
                    kernel($($arg),*)
                }
                if $crate::simd::use_avx512() {
                    // SAFETY: the CPU has AVX-512 F, DQ and VL
                    // (`use_avx512`), the features `avx512` was compiled
                    // for.
                    return unsafe { avx512($($arg),*) };
                }
                if $crate::simd::use_avx2() {
                    // SAFETY: the CPU has AVX2 (`use_avx2`), the one
                    // feature `avx2` was compiled for.
                    return unsafe { avx2($($arg),*) };
                }
            }
            kernel($($arg),*)
        }
    };
}
pub(crate) use avx2_dispatch;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec2;
    use crate::ble::pathloss::PathLoss;
    use crate::fast_math::exp_many;
    use crate::radio::likelihood::{CloudLikelihood, profiled_many};
    use crate::radio::model::{PathLossModel, PathLossParams, RadioModel};
    use crate::radio::{LikelihoodConfig, Measurement};
    use crate::site::testkit;

    /// What the dispatched loops compute for a cloud: the expected RSSI of
    /// every transmitter, the cloud's log-likelihood (one offset and one
    /// per particle), the residual sums, the profiled surface and exp of
    /// the log-likelihoods.
    fn cloud_values(m: &PathLossModel, ps: &[Vec2], meas: &[Measurement]) -> Vec<u64> {
        let cfg = LikelihoodConfig::default();
        let mut v = Vec::new();
        let (mut mean, mut sd) = (vec![0.0; ps.len()], vec![0.0; ps.len()]);
        for tx in 0..m.transmitters().len() {
            for floor in [0, 1] {
                assert!(m.expected_many(tx, floor, ps, &mut mean, &mut sd));
                v.extend(mean.iter().chain(&sd).map(|x| x.to_bits()));
            }
        }
        let mut cloud = CloudLikelihood::default();
        let mut out = Vec::new();
        let offs: Vec<f64> = (0..ps.len()).map(|i| -9.0 + (i % 7) as f64).collect();
        cloud.evaluate_each(m, &cfg, meas, 0, ps, &offs, &mut out);
        v.extend(out.iter().map(|x| x.to_bits()));
        cloud.evaluate(m, &cfg, meas, 0, ps, -4.0, &mut out);
        v.extend(out.iter().map(|x| x.to_bits()));
        let w: Vec<f64> = (0..ps.len()).map(|i| 0.5 + (i % 5) as f64 * 0.3).collect();
        for k in 0..meas.len() {
            let (a, b, c) = cloud.weighted_expected(k, &w).unwrap();
            v.extend([a.to_bits(), b.to_bits(), c.to_bits()]);
        }
        let (mut o, mut s, mut l) = (Vec::new(), Vec::new(), Vec::new());
        profiled_many(m, &cfg, meas, 0, ps, -2.0, 4.0, &mut o, &mut s, &mut l);
        v.extend(o.iter().chain(&s).chain(&l).map(|x| x.to_bits()));
        let xs: Vec<f64> = out.iter().map(|l| 0.3 * l).chain([-800.0, 710.0]).collect();
        let mut e = vec![0.0; xs.len()];
        exp_many(&xs, &mut e);
        v.extend(e.iter().map(|x| x.to_bits()));
        v
    }

    #[test]
    fn simd_paths_agree_to_the_bit() {
        let curve = PathLoss {
            rssi_1m_dbm: -59.0,
            exponent: 2.4,
        };
        let bs: Vec<(f64, f64)> = (0..12)
            .map(|k| (1.0 + (k % 4) as f64 * 6.1, 2.0 + (k / 4) as f64 * 7.3))
            .collect();
        let maps = vec![testkit::open_map(25, 25), testkit::open_map(25, 25)];
        let site = testkit::beacon_site("simd", maps, &bs, curve);
        let m = PathLossModel::for_site(
            &site,
            PathLossParams {
                ble_sd_db: 6.0,
                wifi_sd_db: 5.0,
                floor_loss_db: 15.0,
                other_floor_sd_db: 4.0,
                min_range_m: 0.5,
                phone_height_m: 1.2,
            },
        );
        // an odd count (the loops' tails), points on the beacons (range
        // floor) and far away
        let ps: Vec<Vec2> = (0..1003)
            .map(|i| Vec2::new((i % 31) as f64 * 0.83, (i / 31) as f64 * 0.77))
            .chain(bs.iter().map(|b| Vec2::new(b.0, b.1)))
            .chain([Vec2::new(-3e3, 5e4)])
            .collect();
        let meas: Vec<Measurement> = (0..bs.len())
            .map(|tx| Measurement {
                tx,
                rssi_dbm: -75.0 + (tx as f64 * 1.3).sin() * 12.0,
                readings: 1,
            })
            .collect();
        let fast = cloud_values(&m, &ps, &meas);
        let avx2 = at_most_avx2(|| cloud_values(&m, &ps, &meas));
        let reference = baseline(|| cloud_values(&m, &ps, &meas));
        assert_eq!(fast.len(), reference.len());
        assert!(avx2 == reference, "the AVX2 build changed a value");
        assert!(fast == reference, "the AVX-512 build changed a value");
    }
}
