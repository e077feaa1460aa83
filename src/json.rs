//! JSON trees of the core's serde types, for EXR headers, reports and the Python package.

use serde::Serialize;
use serde_json::Value;

/// `value` as a JSON tree with every f32 as its shortest decimal (0.8, not the
/// 0.800000011920929 that widening to f64 first would give). Values JSON cannot hold (NaN,
/// infinities) become null, as serde_json writes them.
pub fn tree<T: Serialize + ?Sized>(value: &T) -> Value {
    serde_json::to_string(value)
        .ok()
        .and_then(|text| serde_json::from_str(&text).ok())
        .unwrap_or(Value::Null)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_keeps_its_shortest_decimal() {
        assert_eq!(tree(&[0.8f32, 1e-3]).to_string(), "[0.8,0.001]");
        assert_eq!(tree(&f32::NAN), Value::Null);
    }
}
