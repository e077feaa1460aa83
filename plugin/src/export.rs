//! Stages and whole exports: `occlux.stage_description` and `occlux.export`.

use crate::render::{compute, render_scene, scene_volume, settled};
use crate::scene::PyScene;
use crate::volume::PyVolume;
use crate::{py_err, OccluxError};
use occlux::export::exr::Precision;
use occlux::export::usd::StageDescription;
use occlux::export::vdb::{Compression, VdbOptions};
use occlux::pipeline::{self, OutputOptions};
use pyo3::prelude::*;
use std::path::PathBuf;

/// The USD stage for `volume`'s grids `grids`, stored in `vdb_file` (a path relative to the
/// stage), with `scene`'s camera and lights: a JSON string that `occlux.usd` authors with pxr.
/// With `frames` (VDB files relative to the stage), a series' stage: the fields read
/// `frames[i]` at time code i + 1, as `occlux series` writes it.
#[pyfunction]
#[pyo3(signature = (scene, volume, vdb_file, grids, frames = None))]
pub fn stage_description(
    scene: &PyScene,
    volume: &PyVolume,
    vdb_file: &str,
    grids: Vec<String>,
    frames: Option<Vec<String>>,
) -> PyResult<String> {
    let grids: Vec<&str> = grids.iter().map(String::as_str).collect();
    let scene = &scene.inner;
    let mut description = StageDescription::new(
        vdb_file,
        &grids,
        volume.inner.bounds(),
        &scene.camera,
        &scene.lighting.lights,
    )
    .map_err(py_err)?;
    if let Some(frames) = frames {
        description = description.with_time_samples(1, &frames).map_err(py_err)?;
    }
    Ok(description.to_json())
}

/// What `occlux export` does: renders `scene` (its own volume, or `volume`) and writes
/// OUT/STEM.exr and .png (the render), .vdb (grids `density`, extinction per scene unit, and
/// `value`) and .usda (a stage pointing at them, with the scene's camera and lights). Returns
/// the paths written.
#[pyfunction]
#[pyo3(signature = (
    scene, out_dir, stem = "scene", volume = None, device = "auto", compression = "zip",
    half = false, float32 = false, exposure = 1.0, progress = None
))]
#[allow(clippy::too_many_arguments)] // Python keyword arguments, all with defaults
pub fn export(
    py: Python<'_>,
    scene: &PyScene,
    out_dir: PathBuf,
    stem: &str,
    volume: Option<&PyVolume>,
    device: &str,
    compression: &str,
    half: bool,
    float32: bool,
    exposure: f32,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<PathBuf>> {
    if stem.is_empty() || stem.contains(['/', '\\']) {
        return Err(OccluxError::new_err(format!(
            "stem '{stem}' must be a plain file name"
        )));
    }
    let vdb = VdbOptions {
        compression: compression.parse::<Compression>().map_err(py_err)?,
        half,
    };
    let output = OutputOptions {
        precision: if float32 {
            Precision::Float
        } else {
            Precision::Half
        },
        exposure,
    };
    output.validate().map_err(py_err)?;
    let compute = compute(py, device)?;
    let (scene, volume) = scene_volume(py, &scene.inner, volume)?;
    let scene = &settled(py, scene, &volume, &compute)?;
    let rendered = render_scene(py, scene, &volume, &compute, progress)?;
    py.detach(|| pipeline::export(&rendered, scene, &volume, &out_dir, stem, &output, &vdb))
        .map_err(py_err)
}
