//! Structured data across the boundary as JSON: the core's serde trees become Python dicts and
//! lists (through the standard `json` module), and back.

use crate::py_err;
use pyo3::prelude::*;
use serde_json::Value;

/// A JSON tree as Python objects (dict, list, str, float, int, bool, None).
pub(crate) fn to_python<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?
        .call_method1("loads", (value.to_string(),))
}

/// Python objects as a JSON tree; what `json.dumps` refuses is an `OccluxError` naming `what`.
pub(crate) fn from_python(value: &Bound<'_, PyAny>, what: &str) -> PyResult<Value> {
    let text: String = value
        .py()
        .import("json")?
        .call_method1("dumps", (value,))?
        .extract()?;
    serde_json::from_str(&text)
        .map_err(|e| py_err(occlux::Error::param(what, format!("not plain data: {e}"))))
}
