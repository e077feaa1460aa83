//! A method's image against a reference image of the same scene (`occlux.image_error`,
//! `occlux.write_error_map`): docs/architecture.md#error-measure's error figures and the map of
//! where they differ, as the core computes them (src/metric/), for the add-on's Check Against
//! Cycles.

use crate::writers::as_array;
use crate::{py_err, OccluxError};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use occlux::metric::{self, error_map};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Registers this file's functions in the native module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(image_error, m)?)?;
    m.add_function(wrap_pyfunction!(write_error_map, m)?)?;
    Ok(())
}

/// Linear RGB pixels, row by row, and the image's (width, height).
type Pixels = (Vec<[f32; 3]>, (usize, usize));

/// An image argument (height, width, 3 or 4; alpha ignored) as RGB pixels and its size.
fn rgb_pixels(name: &str, value: &Bound<'_, PyAny>) -> PyResult<Pixels> {
    let array = as_array(value, "float32")?;
    let array: PyReadonlyArrayDyn<f32> = array.extract()?;
    let shape = array.shape().to_vec();
    let (h, w, c) = match shape[..] {
        [h, w, c] if h > 0 && w > 0 && (c == 3 || c == 4) => (h, w, c),
        _ => {
            return Err(OccluxError::new_err(format!(
                "{name}: shape {shape:?} is not (height, width, 3) or (height, width, 4)"
            )))
        }
    };
    let values: Vec<f32> = array.as_array().iter().copied().collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(OccluxError::new_err(format!(
            "{name}: pixel {} holds a non-finite value",
            i / c
        )));
    }
    let pixels = values.chunks_exact(c).map(|p| [p[0], p[1], p[2]]).collect();
    Ok((pixels, (w, h)))
}

/// An image and a reference of one size: their pixels and the size.
fn image_pair(
    image: &Bound<'_, PyAny>,
    reference: &Bound<'_, PyAny>,
) -> PyResult<(Vec<[f32; 3]>, Pixels)> {
    let (image, size) = rgb_pixels("image", image)?;
    let (reference, reference_size) = rgb_pixels("reference", reference)?;
    if size != reference_size {
        return Err(OccluxError::new_err(format!(
            "reference: {} x {} pixels, the image {} x {}",
            reference_size.0, reference_size.1, size.0, size.1
        )));
    }
    Ok((image, (reference, size)))
}

/// docs/architecture.md#error-measure's error of `image` against `reference` (arrays of shape
/// (height, width, 3 or 4), linear RGB; alpha ignored) over the volume's pixels, those where the
/// reference's grey differs from `background` (the background's grey) by more than 0.5 % of it: a
/// dict with `pixels`, `rel_rmse` (RMSE of the RGB difference / the reference's mean there), `bias`
/// (mean difference / that mean) and `noise` (the RMS of `stderr`, the reference's standard error
/// if given, / that mean; else 0).
#[pyfunction]
#[pyo3(signature = (image, reference, background, stderr = None))]
fn image_error<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    reference: &Bound<'py, PyAny>,
    background: f32,
    stderr: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (image, (reference, size)) = image_pair(image, reference)?;
    let stderr = match stderr {
        Some(e) => {
            let (e, e_size) = rgb_pixels("stderr", e)?;
            if e_size != size {
                return Err(OccluxError::new_err(
                    "stderr: its size differs from the reference's",
                ));
            }
            Some(e)
        }
        None => None,
    };
    let e =
        metric::image_error(&image, &reference, stderr.as_deref(), background).map_err(py_err)?;
    let figures = PyDict::new(py);
    figures.set_item("pixels", e.pixels)?;
    figures.set_item("rel_rmse", e.rel_rmse)?;
    figures.set_item("bias", e.bias)?;
    figures.set_item("noise", e.noise)?;
    Ok(figures)
}

/// Writes a PNG map of where `image` differs from `reference` (as for `image_error`): blue
/// where the image is darker, white where they agree, red where it is brighter, over the
/// volume's pixels (others mid grey), at least 256 pixels on its long side, with a colour key
/// below; atomically. Returns the key's range (the map saturates at +- range x the
/// reference's mean).
#[pyfunction]
fn write_error_map(
    py: Python<'_>,
    path: PathBuf,
    image: &Bound<'_, PyAny>,
    reference: &Bound<'_, PyAny>,
    background: f32,
) -> PyResult<f64> {
    let (image, (reference, size)) = image_pair(image, reference)?;
    py.detach(|| error_map::write_error_map(&path, &image, &reference, size, background))
        .map_err(py_err)
}
