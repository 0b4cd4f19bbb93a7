//! Engine-config patches as JSON: a variant's settings laid over a base
//! config (`fpbp reproduce`, the `trace_replica` example).

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

#[cfg(test)]
mod tests {
    use super::merge;

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
