//! The core's atomic writers for data made in Python: named float layers into a multilayer EXR
//! (`occlux.write_exr_layers`), an 8-bit RGB picture into a PNG (`occlux.write_png`), text
//! (`occlux.write_text`) and a Monte Carlo reference as `occlux reference` writes it
//! (`occlux.write_reference`). Each writes a temporary file beside the destination and renames
//! it into place (src/export/atomic.rs).

use crate::reference::estimator_named;
use crate::scene::PyScene;
use crate::{py_err, OccluxError};
use numpy::{PyReadonlyArray3, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use occlux::export::atomic::write_bytes_atomic;
use occlux::export::exr::{write_exr, ExrLayer, Precision};
use occlux::export::png::write_png_preview;
use occlux::pipeline;
use occlux::render::reference::{ReferenceImage, ReferenceParams};
use occlux::render::RenderImage;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Registers this file's functions in the native module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(write_exr_layers, m)?)?;
    m.add_function(wrap_pyfunction!(write_png, m)?)?;
    m.add_function(wrap_pyfunction!(write_text, m)?)?;
    m.add_function(wrap_pyfunction!(write_reference, m)?)?;
    Ok(())
}

/// Channel names by channel count: a grey layer is `Y`, colour `R, G, B` and `R, G, B, A`.
fn channel_names(count: usize) -> Option<&'static [&'static str]> {
    match count {
        1 => Some(&["Y"]),
        3 => Some(&["R", "G", "B"]),
        4 => Some(&["R", "G", "B", "A"]),
        _ => None,
    }
}

/// A value as a C-contiguous float32 (or uint8) numpy array, through numpy itself.
pub(crate) fn as_array<'py>(value: &Bound<'py, PyAny>, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    value
        .py()
        .import("numpy")?
        .call_method1("ascontiguousarray", (value, dtype))
}

/// Writes `layers` ({name: array}, in the dict's order) as one multilayer OpenEXR, atomically:
/// an array of shape (height, width) is a layer with channel `Y`, one of shape (height, width,
/// c) has channels Y (c = 1), R, G, B (3) or R, G, B, A (4); channels are named `layer.channel`
/// and row 0 is the top. `metadata` becomes text attributes of the header. Samples are float32,
/// or float16 unless `float32`; NaN or infinite samples are refused.
#[pyfunction]
#[pyo3(signature = (path, layers, metadata = None, float32 = true))]
pub fn write_exr_layers(
    py: Python<'_>,
    path: PathBuf,
    layers: &Bound<'_, PyDict>,
    metadata: Option<BTreeMap<String, String>>,
    float32: bool,
) -> PyResult<()> {
    let mut size: Option<(usize, usize)> = None;
    let mut exr_layers = Vec::with_capacity(layers.len());
    for (name, value) in layers.iter() {
        let name: String = name.extract()?;
        let array = as_array(&value, "float32")?;
        let array: PyReadonlyArrayDyn<f32> = array.extract()?;
        let shape = array.shape().to_vec();
        let (h, w, c) = match shape[..] {
            [h, w] => (h, w, 1),
            [h, w, c] => (h, w, c),
            _ => (0, 0, 0),
        };
        let channels = channel_names(c).filter(|_| h > 0 && w > 0).ok_or_else(|| {
            OccluxError::new_err(format!(
                "exr layer `{name}`: shape {shape:?} is not (height, width) or (height, width, \
                 c) with c = 1, 3 or 4"
            ))
        })?;
        if *size.get_or_insert((h, w)) != (h, w) {
            return Err(OccluxError::new_err(format!(
                "exr layer `{name}`: {w} x {h} pixels, unlike the layers before it ({} x {})",
                size.unwrap_or_default().1,
                size.unwrap_or_default().0
            )));
        }
        exr_layers.push(ExrLayer {
            name,
            channels: channels.iter().map(|c| c.to_string()).collect(),
            pixels: array.as_array().iter().copied().collect(),
        });
    }
    let (height, width) = size.unwrap_or_default();
    let metadata = metadata.unwrap_or_default();
    let precision = if float32 {
        Precision::Float
    } else {
        Precision::Half
    };
    py.detach(|| {
        write_exr(
            &path,
            width as u32,
            height as u32,
            &exr_layers,
            &metadata,
            precision,
        )
    })
    .map_err(py_err)
}

/// The linear value that the core's PNG tone mapping (exposure 1, sRGB) turns into `code`.
fn srgb_decode(code: u8) -> f32 {
    let x = f32::from(code) / 255.0;
    if x <= 0.040_45 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// Writes an 8-bit picture, shape (height, width, 3) and dtype uint8, row 0 at the top, as an
/// sRGB PNG, atomically; the codes are stored as they are.
#[pyfunction]
pub fn write_png(py: Python<'_>, path: PathBuf, rgb: &Bound<'_, PyAny>) -> PyResult<()> {
    let dtype: String = rgb
        .getattr("dtype")
        .and_then(|d| d.str()?.extract())
        .unwrap_or_default();
    if dtype != "uint8" {
        return Err(OccluxError::new_err(format!(
            "png: pixels must be a uint8 array of shape (height, width, 3), got dtype '{dtype}'"
        )));
    }
    let array = as_array(rgb, "uint8")?;
    let array: PyReadonlyArray3<u8> = array.extract().map_err(|_| {
        OccluxError::new_err("png: pixels must be a uint8 array of shape (height, width, 3)")
    })?;
    let shape = array.shape().to_vec();
    if shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(OccluxError::new_err(format!(
            "png: pixels must have shape (height, width, 3), got {shape:?}"
        )));
    }
    let mut image = RenderImage::new(shape[1] as u32, shape[0] as u32);
    let codes = array.as_slice()?;
    for (pixel, code) in image.rgba.iter_mut().zip(codes.chunks_exact(3)) {
        *pixel = [
            srgb_decode(code[0]),
            srgb_decode(code[1]),
            srgb_decode(code[2]),
            1.0,
        ];
    }
    py.detach(|| write_png_preview(&path, &image, 1.0))
        .map_err(py_err)
}

/// Writes `text` (UTF-8) to `path`, atomically.
#[pyfunction]
pub fn write_text(py: Python<'_>, path: PathBuf, text: &str) -> PyResult<()> {
    py.detach(|| write_bytes_atomic(&path, text.as_bytes()))
        .map_err(py_err)
}

/// Writes a Monte Carlo reference (`occlux.reference`'s result, made with these `estimator`,
/// `seed`, `bounces`, `g` and `aperture_deg`) as `occlux reference` does: OUT/STEM.exr (float32
/// layers `beauty` and `stderr`; the scene and the estimator as JSON in the header) and
/// OUT/STEM.png (a preview of the mean). Returns the paths written.
#[pyfunction]
#[pyo3(signature = (
    out_dir, result, scene, stem = "reference", estimator = "single", seed = 1, bounces = 8,
    g = 0.0, aperture_deg = 30.0, exposure = 1.0
))]
#[allow(clippy::too_many_arguments)] // Python keyword arguments, all with defaults
pub fn write_reference(
    py: Python<'_>,
    out_dir: PathBuf,
    result: &Bound<'_, PyAny>,
    scene: &PyScene,
    stem: &str,
    estimator: &str,
    seed: u64,
    bounces: u32,
    g: f32,
    aperture_deg: f32,
    exposure: f32,
) -> PyResult<Vec<PathBuf>> {
    if stem.is_empty() || stem.contains(['/', '\\']) {
        return Err(OccluxError::new_err(format!(
            "stem '{stem}' must be a plain file name"
        )));
    }
    let estimator = estimator_named(estimator, bounces, aperture_deg)?;
    let mean: PyReadonlyArray3<f32> = as_array(&result.getattr("mean")?, "float32")?.extract()?;
    let stderr: PyReadonlyArray3<f32> =
        as_array(&result.getattr("stderr")?, "float32")?.extract()?;
    let spp: u32 = result.getattr("spp")?.extract()?;
    let (height, width) = (mean.shape()[0], mean.shape()[1]);
    if mean.shape()[2] != 4 || stderr.shape() != [height, width, 3] {
        return Err(OccluxError::new_err(format!(
            "reference: mean {:?} and stderr {:?} are not (height, width, 4) and (height, \
             width, 3)",
            mean.shape(),
            stderr.shape()
        )));
    }
    let image = ReferenceImage {
        width: width as u32,
        height: height as u32,
        spp,
        mean: mean
            .as_slice()?
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect(),
        stderr: stderr
            .as_slice()?
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect(),
    };
    let params = ReferenceParams {
        estimator,
        spp,
        seed,
        g,
    };
    let scene = &scene.inner;
    py.detach(|| pipeline::write_reference(&image, scene, &params, &out_dir, stem, exposure))
        .map_err(py_err)
}
