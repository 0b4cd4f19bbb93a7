//! Values derived from a radio model that every engine built on it would
//! compute alike (grids over the survey's reference scans): built once
//! per model at the first use and shared after, so that a replay of many
//! logs on one radio map, or a phone that rebuilds its engine, does not
//! build them again for each engine.

use std::any::{Any, TypeId};
use std::fmt;
use std::sync::{Arc, Mutex, PoisonError};

/// At most this many derived values per model; beyond, a value is built
/// for its caller and not kept (many parameter sets on one map).
const MAX_VALUES: usize = 16;

/// A derived value, by its type and the parameters it was built with.
struct Slot {
    ty: TypeId,
    key: Vec<u64>,
    value: Arc<dyn Any + Send + Sync>,
}

/// The derived values of one model. A clone starts empty (the clone may
/// be changed before it is used).
#[derive(Default)]
pub struct DerivedCache {
    slots: Mutex<Vec<Slot>>,
}

impl DerivedCache {
    /// The value of type `T` built with the parameters `key`: the kept one,
    /// or `build()`'s, kept for the next caller. `build` runs without the
    /// lock held (two threads may both build; the first kept wins, and
    /// both values are equal, as `build` must depend only on the model and
    /// `key`).
    pub fn get_or_build<T: Any + Send + Sync>(
        &self,
        key: &[f64],
        build: impl FnOnce() -> T,
    ) -> Arc<T> {
        let key: Vec<u64> = key.iter().map(|k| k.to_bits()).collect();
        if let Some(v) = self.find::<T>(&key) {
            return v;
        }
        let built = Arc::new(build());
        let mut slots = self.slots.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(v) = find_in::<T>(&slots, &key) {
            return v;
        }
        if slots.len() < MAX_VALUES {
            slots.push(Slot {
                ty: TypeId::of::<T>(),
                key,
                value: built.clone(),
            });
        }
        built
    }

    fn find<T: Any + Send + Sync>(&self, key: &[u64]) -> Option<Arc<T>> {
        let slots = self.slots.lock().unwrap_or_else(PoisonError::into_inner);
        find_in::<T>(&slots, key)
    }

    /// How many values are kept.
    pub fn len(&self) -> usize {
        self.slots
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .len()
    }

    /// Whether no value is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// [`DerivedCache::get_or_build`] in `cache` when the model has one
/// ([`super::RadioModel::derived`]), else `build()` for this caller alone.
pub fn get_or_build_in<T: Any + Send + Sync>(
    cache: Option<&DerivedCache>,
    key: &[f64],
    build: impl FnOnce() -> T,
) -> Arc<T> {
    match cache {
        Some(c) => c.get_or_build(key, build),
        None => Arc::new(build()),
    }
}

fn find_in<T: Any + Send + Sync>(slots: &[Slot], key: &[u64]) -> Option<Arc<T>> {
    slots
        .iter()
        .find(|s| s.ty == TypeId::of::<T>() && s.key == key)
        .and_then(|s| s.value.clone().downcast::<T>().ok())
}

impl Clone for DerivedCache {
    fn clone(&self) -> Self {
        DerivedCache::default()
    }
}

impl fmt::Debug for DerivedCache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "DerivedCache({} values)", self.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_is_built_once_per_type_and_key() {
        let c = DerivedCache::default();
        let mut builds = 0;
        let a = c.get_or_build(&[1.0, 4.0], || {
            builds += 1;
            7u32
        });
        let b = c.get_or_build(&[1.0, 4.0], || {
            builds += 1;
            8u32
        });
        assert_eq!((*a, *b, builds), (7, 7, 1));
        // another key, another type: built anew
        assert_eq!(*c.get_or_build(&[1.0, 5.0], || 9u32), 9);
        assert_eq!(*c.get_or_build(&[1.0, 4.0], || 10u64), 10);
        assert_eq!(c.len(), 3);
        // a clone starts empty
        assert!(c.clone().is_empty());
    }

    #[test]
    fn values_beyond_the_bound_are_built_but_not_kept() {
        let c = DerivedCache::default();
        for i in 0..(MAX_VALUES + 5) {
            assert_eq!(*c.get_or_build(&[i as f64], || i), i);
        }
        assert_eq!(c.len(), MAX_VALUES);
        assert_eq!(*c.get_or_build(&[(MAX_VALUES + 1) as f64], || 0usize), 0);
    }
}
