//! numpy in and out: volume values into the core's `Vec<f32>` (one copy), and read-only numpy
//! views of memory that a frozen Python object owns (no copy).

use numpy::ndarray::{ArrayView, IntoDimension};
use numpy::prelude::*;
use numpy::{PyArray, PyArray3, PyUntypedArray};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// Dims (nx, ny, nz) and values (x fastest) of a numpy array of shape (nz, ny, nx) and any real
/// dtype, converted to f32 with one copy: a memcpy for C-contiguous float32, one strided pass
/// for the other native dtypes. Others (float16, longdouble, non-native byte order) go through
/// numpy's `astype` first.
pub(crate) fn volume_values(values: &Bound<'_, PyAny>) -> PyResult<([usize; 3], Vec<f32>)> {
    let array = values.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!(
            "values must be a numpy array of shape (nz, ny, nx), got {}",
            type_name(values)
        ))
    })?;
    if array.ndim() != 3 {
        return Err(PyValueError::new_err(format!(
            "values must have 3 dimensions (nz, ny, nx), got shape {:?}",
            array.shape()
        )));
    }
    let dtype = array.dtype();
    if !matches!(dtype.kind(), b'f' | b'i' | b'u') {
        return Err(PyTypeError::new_err(format!(
            "values must have a real dtype (float or integer), got {dtype}"
        )));
    }
    let [nz, ny, nx] = [array.shape()[0], array.shape()[1], array.shape()[2]];
    Ok(([nx, ny, nz], to_f32(array)?))
}

fn to_f32(array: &Bound<'_, PyUntypedArray>) -> PyResult<Vec<f32>> {
    if let Ok(a) = array.cast::<PyArray3<f32>>() {
        let a = a.try_readonly()?;
        let view = a.as_array();
        return Ok(view
            .as_slice()
            .map_or_else(|| view.iter().copied().collect(), <[f32]>::to_vec));
    }
    macro_rules! widen {
        ($($t:ty),*) => {$(
            if let Ok(a) = array.cast::<PyArray3<$t>>() {
                let a = a.try_readonly()?;
                return Ok(a.as_array().iter().map(|&v| v as f32).collect());
            }
        )*};
    }
    widen!(f64, u8, i8, u16, i16, u32, i32, u64, i64);
    let converted = array.call_method1("astype", ("float32",))?;
    to_f32(converted.cast::<PyUntypedArray>()?)
}

fn type_name(value: &Bound<'_, PyAny>) -> String {
    value
        .get_type()
        .name()
        .map_or_else(|_| "an unknown type".into(), |n| n.to_string())
}

/// A read-only numpy array of `shape` (C order) over `data`, with `owner` as its base object.
///
/// # Safety
/// `data` must belong to `owner` and never be mutated, moved or freed while `owner` lives:
/// `owner` is a frozen pyclass (no `&mut` access from Python or Rust) whose buffers are set once
/// at construction, and the array keeps `owner` alive.
pub(crate) unsafe fn readonly_view<'py, Sh: IntoDimension>(
    owner: Bound<'py, PyAny>,
    data: &[f32],
    shape: Sh,
) -> PyResult<Bound<'py, PyArray<f32, Sh::Dim>>> {
    let view = ArrayView::from_shape(shape, data)
        .map_err(|e| PyValueError::new_err(format!("array view: {e}")))?;
    // SAFETY: the caller's contract (above).
    let array = unsafe { PyArray::borrow_from_array(&view, owner) };
    array.try_readwrite()?.make_nonwriteable();
    Ok(array)
}
