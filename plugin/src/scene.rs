//! `occlux.Scene`: a validated scene file (volume source, classification, camera, lights, method).

use crate::classification::PyClassification;
use crate::json::{from_python, to_python};
use crate::py_err;
use crate::volume::PyVolume;
use occlux::camera::Camera;
use occlux::scene::Scene;
use pyo3::prelude::*;
use std::path::PathBuf;

/// A scene: where the volume comes from, its classification, the camera and image size, the
/// lights, the background and the rendering method.
#[pyclass(name = "Scene", module = "occlux")]
pub struct PyScene {
    pub(crate) inner: Scene,
}

#[pymethods]
impl PyScene {
    /// Reads a TOML scene file; relative volume paths are resolved against its folder.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let inner = Scene::from_file(&path).map_err(py_err)?;
        Ok(Self { inner })
    }

    /// Parses TOML scene text; relative volume paths are resolved against `base_dir`.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = PathBuf::from(".")), text_signature = "(text, base_dir='.')")]
    fn from_toml(text: &str, base_dir: PathBuf) -> PyResult<Self> {
        let inner = Scene::parse(text, &base_dir).map_err(py_err)?;
        Ok(Self { inner })
    }

    /// Builds a scene from the scene file's tree as Python data: a dict with the TOML file's
    /// sections and keys (`volume`, `classification`, `camera`, `lights`, `background`,
    /// `render`), validated as a file is; relative volume paths are resolved against `base_dir`.
    #[staticmethod]
    #[pyo3(signature = (tree, base_dir = PathBuf::from(".")), text_signature = "(tree, base_dir='.')")]
    fn from_dict(tree: &Bound<'_, PyAny>, base_dir: PathBuf) -> PyResult<Self> {
        let tree = from_python(tree, "scene")?;
        let inner = Scene::from_value(tree, &base_dir).map_err(py_err)?;
        Ok(Self { inner })
    }

    /// The scene as the core resolved it, as a dict: `volume` (source and placement),
    /// `classification`, `camera` (position, forward, right, up, projection with `fov_y` in
    /// radians or the orthographic `scale`, width, height, half_extent), `lighting` (`lights`
    /// and `background`) and `method` (its name under `method`, and every parameter).
    fn describe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.describe())
    }

    /// Loads (or generates) the scene's volume and settles what depends on the data, as
    /// `occlux render` does: Hounsfield presets when the file says its values are HU, the
    /// classification's window on the values, the content centre and the framed camera. The
    /// scene is updated; returns the volume and the notices, one line each.
    fn settle(&mut self, py: Python<'_>) -> PyResult<(PyVolume, Vec<String>)> {
        let scene = &self.inner;
        let loaded = py.detach(|| scene.load()).map_err(py_err)?;
        self.inner = loaded.scene;
        Ok((loaded.volume.into(), loaded.notices))
    }

    /// Loads (or generates) the scene's volume and places it in the world (`fit`, `centre`).
    fn load_volume(&self, py: Python<'_>) -> PyResult<PyVolume> {
        let scene = &self.inner;
        py.detach(|| scene.load_volume())
            .map_err(py_err)
            .map(PyVolume::from)
    }

    /// The classification; assign a `Classification` to replace it.
    #[getter]
    fn classification(&self) -> PyClassification {
        self.inner.classification.clone().into()
    }

    #[setter]
    fn set_classification(&mut self, value: PyRef<'_, PyClassification>) {
        self.inner.classification = value.inner.clone();
    }

    /// Image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.inner.camera.width
    }

    /// Image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.inner.camera.height
    }

    /// Changes the image size. The camera keeps its position, orientation and vertical field of
    /// view (perspective) or orthographic scale, so the same aspect ratio gives the same view
    /// at another resolution.
    fn set_size(&mut self, width: u32, height: u32) -> PyResult<()> {
        let cam = &self.inner.camera;
        self.inner.camera = Camera::look_at(
            cam.position,
            cam.position + cam.forward,
            cam.up,
            cam.projection,
            width,
            height,
        )
        .map_err(py_err)?;
        Ok(())
    }

    /// Background radiance (r, g, b) seen where rays leave the volume.
    #[getter]
    fn background(&self) -> (f32, f32, f32) {
        self.inner.lighting.background.into()
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(size=({}, {}), lights={}, background={:?})",
            self.width(),
            self.height(),
            self.inner.lighting.lights.len(),
            self.background()
        )
    }
}
