//! `occlux.ao_volume`: VAO volumes (Ruiz, Szirmay-Kalos et al.) of a scene's classified volume,
//! as a dict of grids ready for `occlux.write_vdb`.

use crate::py_err;
use crate::render::{compute, scene_volume, with_progress};
use crate::scene::PyScene;
use crate::volume::PyVolume;
use occlux::ao::vao::{self, ScalarField, VaoParams};
use occlux::render::ao_shaded::{AO_GRID, AO_VARIANCE_GRID};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Computes the AO volume of `scene` (its own volume, or `volume`) classified by its
/// classification: `method` "cdf", "gauss", "gauss-exact", "penner" or "exact" (the voxel
/// count, slow, always on the CPU), tangent-sphere `radius` in voxels, `field` "extinction" or
/// "value". Returns {"ao": Volume (openness, 1 = unoccluded)} plus "ao_variance" when
/// `variance` is true, on the volume's grid. `device` and `progress` as for `render`
/// (returning False from `progress` cancels). The GIL is released while it computes.
#[pyfunction]
#[pyo3(signature = (
    scene, method = "cdf", radius = 10, field = "extinction", variance = false, device = "auto",
    volume = None, progress = None
))]
#[allow(clippy::too_many_arguments)] // Python keyword arguments, all with defaults
pub fn ao_volume<'py>(
    py: Python<'py>,
    scene: &PyScene,
    method: &str,
    radius: u32,
    field: &str,
    variance: bool,
    device: &str,
    volume: Option<&PyVolume>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let params = VaoParams {
        radius,
        estimator: method.parse().map_err(py_err)?,
        variance,
    };
    params.validate().map_err(py_err)?;
    let kind = field.parse().map_err(py_err)?;
    let compute = compute(py, device)?;
    let scene = &scene.inner;
    let volume = scene_volume(py, scene, volume)?;
    let ao = with_progress(py, progress, |report| {
        let scalar = ScalarField::new(&volume, &scene.classification, kind)?;
        vao::ao_volume(&compute, &scalar, &params, report)
    })?;
    let grids = PyDict::new(py);
    grids.set_item(AO_GRID, PyVolume::from(ao.openness))?;
    if let Some(v) = ao.variance {
        grids.set_item(AO_VARIANCE_GRID, PyVolume::from(v))?;
    }
    Ok(grids)
}
