//! `occlux.reference`: the Monte Carlo references, mean and standard error as numpy arrays.

use crate::arrays::readonly_view;
use crate::render::{scene_volume, with_progress};
use crate::scene::PyScene;
use crate::unknown_choice;
use crate::volume::PyVolume;
use numpy::PyArray3;
use occlux::render::reference::{
    render as render_reference, Estimator, ReferenceImage, ReferenceInput, ReferenceParams,
};
use pyo3::prelude::*;

/// A Monte Carlo reference: `mean` (height, width, 4: RGB radiance and the fraction of camera
/// paths that met the volume) and `stderr` (height, width, 3: the standard error of the mean's
/// RGB), read-only views.
#[pyclass(name = "ReferenceResult", module = "occlux", frozen)]
pub struct PyReferenceResult {
    image: ReferenceImage,
}

#[pymethods]
impl PyReferenceResult {
    #[getter]
    fn mean<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let image = &this.get().image;
        let shape = (image.height as usize, image.width as usize, 4);
        // SAFETY: the pixels belong to this frozen ReferenceResult, which never changes them.
        unsafe { readonly_view(this.clone().into_any(), image.mean.as_flattened(), shape) }
    }

    #[getter]
    fn stderr<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let image = &this.get().image;
        let shape = (image.height as usize, image.width as usize, 3);
        // SAFETY: as for `mean`.
        unsafe { readonly_view(this.clone().into_any(), image.stderr.as_flattened(), shape) }
    }

    #[getter]
    fn spp(&self) -> u32 {
        self.image.spp
    }

    fn __repr__(&self) -> String {
        format!(
            "ReferenceResult({}x{}, spp={})",
            self.image.width, self.image.height, self.image.spp
        )
    }
}

/// Renders a Monte Carlo reference of `scene` (its own volume, or `volume`) on the CPU:
/// `estimator` "ambient", "cone" (half-angle `aperture_deg`), "single" or "multiple"
/// (`bounces` scatterings after the first), Henyey-Greenstein `g` for single and multiple.
/// Same seed, same image. The GIL is released while it samples.
#[pyfunction]
#[pyo3(signature = (
    scene, estimator = "single", spp = 64, seed = 1, bounces = 8, g = 0.0, aperture_deg = 30.0,
    volume = None, progress = None
))]
#[allow(clippy::too_many_arguments)] // Python keyword arguments, all with defaults
pub fn reference(
    py: Python<'_>,
    scene: &PyScene,
    estimator: &str,
    spp: u32,
    seed: u64,
    bounces: u32,
    g: f32,
    aperture_deg: f32,
    volume: Option<&PyVolume>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyReferenceResult> {
    let estimator = estimator_named(estimator, bounces, aperture_deg)?;
    let params = ReferenceParams {
        estimator,
        spp,
        seed,
        g,
    };
    let (scene, volume) = scene_volume(py, &scene.inner, volume)?;
    let scene = &*scene;
    let image = with_progress(py, progress, |report| {
        let lut = scene.classification.bake(&volume);
        let input = ReferenceInput {
            volume: &volume,
            lut: &lut,
            camera: &scene.camera,
            lighting: &scene.lighting,
            params: &params,
        };
        render_reference(&input, report)
    })?;
    Ok(PyReferenceResult { image })
}

/// The estimator called `name` ("ambient", "cone", "single", "multiple") with its own
/// parameter: `bounces` for "multiple", the cone's half-angle for "cone".
pub(crate) fn estimator_named(name: &str, bounces: u32, aperture_deg: f32) -> PyResult<Estimator> {
    Ok(match name {
        "ambient" => Estimator::Ambient,
        "cone" => Estimator::Cone {
            aperture: aperture_deg.to_radians(),
        },
        "single" => Estimator::Single,
        "multiple" => Estimator::Multiple { bounces },
        other => {
            return Err(unknown_choice(
                "estimator",
                other,
                &["ambient", "cone", "single", "multiple"],
            ))
        }
    })
}
