//! The two model traits of a particle filter over a [`Cloud`]: how the
//! particles move between measurements, and how a measurement weighs them.
//!
//! A filter owns its cloud, its seeded RNG and its models; one cycle is
//! [`MotionModel::propagate`], [`MeasurementModel::update`], an estimate
//! and resampling (the [`Cloud`]'s operations). Models draw every random
//! number from the RNG they are handed, in an order they document: the
//! engines' tracks depend on it.

use rand_pcg::Pcg64;

use super::cloud::Cloud;

/// Moves every particle for one control input `U` (a PDR step, the steps
/// of an interval), drawing its noise from `rng`. It may also keep
/// per-particle state in the cloud's columns.
pub trait MotionModel<U: ?Sized> {
    /// Propagates `cloud` by `control`.
    fn propagate(&mut self, cloud: &mut Cloud, rng: &mut Pcg64, control: &U);
}

/// Weighs every particle by one measurement `Z` (a position fix, the
/// beacons heard): sets, multiplies or adds to the weights as the model's
/// paper says.
pub trait MeasurementModel<Z: ?Sized> {
    /// Updates the weights of `cloud` by `z`.
    fn update(&mut self, cloud: &mut Cloud, z: &Z);
}
