//! JSON patches: a variant's settings laid over a base engine config, a
//! channel laid over a simulator profile (`fpbp reproduce`, the
//! `trace_replica` example).

/// Merges JSON object `patch` into `base` (objects recursively; any other
/// value replaces what is there).
pub fn merge(base: &mut serde_json::Value, patch: &serde_json::Value) {
    match (base, patch) {
        (serde_json::Value::Object(b), serde_json::Value::Object(p)) => {
            for (k, v) in p {
                merge(b.entry(k.clone()).or_insert(serde_json::Value::Null), v);
            }
        }
        (b, p) => *b = p.clone(),
    }
}

/// `value` with JSON object `patch` [`merge`]d over it (a simulator
/// profile under a channel patch, `fpbp reproduce --profile-patch` and
/// `trace_replica`'s PROFILE_PATCH); an error when the result is no `T`.
pub fn patched<T: serde::Serialize + serde::de::DeserializeOwned>(
    value: &T,
    patch: &serde_json::Value,
) -> serde_json::Result<T> {
    let mut v = serde_json::to_value(value)?;
    merge(&mut v, patch);
    serde_json::from_value(v)
}

#[cfg(test)]
mod tests {
    use super::{merge, patched};

    #[test]
    fn a_patched_struct_keeps_what_the_patch_leaves() {
        #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
        struct S {
            a: f64,
            b: String,
        }
        let s = S {
            a: 1.0,
            b: "x".into(),
        };
        let p = patched(&s, &serde_json::json!({"a": 2.0})).unwrap();
        assert_eq!(
            p,
            S {
                a: 2.0,
                b: "x".into()
            }
        );
        assert!(patched(&s, &serde_json::json!({"a": "no"})).is_err());
    }

    #[test]
    fn objects_merge_and_values_replace() {
        let mut base = serde_json::json!({"a": {"x": 1, "y": 2}, "b": 3});
        merge(
            &mut base,
            &serde_json::json!({"a": {"y": 5}, "b": {"z": 1}}),
        );
        assert_eq!(
            base,
            serde_json::json!({"a": {"x": 1, "y": 5}, "b": {"z": 1}})
        );
    }
}
