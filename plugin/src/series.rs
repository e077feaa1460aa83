//! `occlux.series`'s native steps (the Python module `occlux.series` runs them, on Dask workers
//! or here): plan a series and write its manifest, run one frame from the manifest with the
//! GIL released, and write the stage once every frame is there.

use crate::json::from_python;
use crate::py_err;
use crate::render::compute;
use occlux::scene::Scene;
use occlux::series::{self, FrameOutcome, FrameSpec, Manifest, Resume, SeriesOptions};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// Plans a series: reads every frame once (frames of other dims or spacing are refused before
/// any work), fixes the window and the camera across them, and writes `OUT/NAME.series.json`
/// (or checks the one there was made with the same settings). `scene`: a TOML scene file, or
/// its tree as a dict with `base_dir` resolving its relative paths; `frames`: a pattern or
/// folder (str), a list of files, or None for the scene's `volume.frames`; `options`: the
/// outputs (`render`, `export`, `ao`, `ao_radius`, `zip`, `half`, `float32`, `exposure`).
/// Returns the manifest's path and whether an earlier run's manifest was resumed.
#[pyfunction]
#[pyo3(signature = (scene, frames, out, name, options, base_dir = PathBuf::from(".")))]
pub fn series_plan(
    py: Python<'_>,
    scene: &Bound<'_, PyAny>,
    frames: Option<&Bound<'_, PyAny>>,
    out: PathBuf,
    name: &str,
    options: &Bound<'_, PyAny>,
    base_dir: PathBuf,
) -> PyResult<(PathBuf, bool)> {
    let (tree, base) = match scene.extract::<PathBuf>() {
        Ok(path) => Scene::file_tree(&path).map_err(py_err)?,
        Err(_) => (from_python(scene, "scene")?, base_dir),
    };
    let options: SeriesOptions = serde_json::from_value(from_python(options, "options")?)
        .map_err(|e| py_err(occlux::Error::param("options", e.to_string())))?;
    let spec = match frames {
        None => None,
        Some(f) => Some(match f.extract::<String>() {
            Ok(pattern) => FrameSpec::Pattern(pattern),
            Err(_) => FrameSpec::List(f.extract::<Vec<PathBuf>>()?),
        }),
    };
    py.detach(|| {
        let frames = spec.map(|s| s.resolve(Path::new(""))).transpose()?;
        let (manifest, resume) = series::plan(
            tree,
            &base,
            frames,
            name,
            &out,
            &options,
            &occlux::progress::Silent,
        )?;
        Ok((
            Manifest::path(&out, &manifest.name),
            resume == Resume::Resumed,
        ))
    })
    .map_err(py_err)
}

/// The folder a manifest lies in: the series' output folder.
fn series_folder(path: &Path) -> PathBuf {
    path.parent().unwrap_or(Path::new(".")).to_path_buf()
}

/// Runs frame `frame` of the series whose manifest is `manifest` on `device` ("cpu", "gpu" or
/// "auto"), writing its files as one set beside the manifest. Returns `("written", files)`,
/// or `("complete", [])` when an earlier run wrote them all.
#[pyfunction]
#[pyo3(signature = (manifest, frame, device = "cpu"))]
pub fn series_frame(
    py: Python<'_>,
    manifest: PathBuf,
    frame: u32,
    device: &str,
) -> PyResult<(&'static str, Vec<PathBuf>)> {
    let compute = compute(py, device)?;
    py.detach(|| {
        let plan = Manifest::read(&manifest)?;
        let out = series_folder(&manifest);
        series::run_frame(&plan, &out, frame, &compute, &occlux::progress::NoProgress)
    })
    .map(|outcome| match outcome {
        FrameOutcome::Written(files) => ("written", files),
        FrameOutcome::Complete => ("complete", Vec::new()),
    })
    .map_err(py_err)
}

/// Writes the series' USD stage once every frame's VDB is there; returns its path, or None
/// for a series without export.
#[pyfunction]
pub fn series_finish(py: Python<'_>, manifest: PathBuf) -> PyResult<Option<PathBuf>> {
    py.detach(|| {
        let plan = Manifest::read(&manifest)?;
        series::finish(&plan, &series_folder(&manifest))
    })
    .map_err(py_err)
}
