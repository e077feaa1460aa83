//! Core errors as Python exceptions.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::PyErr;

create_exception!(
    occlux,
    OccluxError,
    PyException,
    "An error reported by the Occlux core. The message is the core's, verbatim: it names the \
     file, field or parameter at fault and the expected form."
);

/// A core error as an `OccluxError` (`.map_err(py_err)?`; `From` cannot be implemented here
/// because neither type is this crate's).
pub(crate) fn py_err(error: occlux::Error) -> PyErr {
    OccluxError::new_err(error.to_string())
}

/// A Python argument that is not one of a fixed set of choices fails like the core's own
/// choices (e.g. `compression`): as a core parameter error.
pub(crate) fn unknown_choice(key: &str, got: &str, known: &[&str]) -> PyErr {
    py_err(occlux::Error::param(
        key,
        format!("'{got}' is not one of {}", known.join(", ")),
    ))
}
