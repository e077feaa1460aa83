//! `occlux.ao_volume`: VAO volumes (Ruiz, Szirmay-Kalos et al.) of a scene's classified volume,
//! as a dict of grids ready for `occlux.write_vdb`.

use crate::py_err;
use crate::render::{compute, scene_volume, with_progress};
use crate::scene::PyScene;
use crate::volume::PyVolume;
use occlux::ao::{self, AoVolumeParams};
use occlux::render::ao_shaded::{AO_GRID, AO_VARIANCE_GRID};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Computes the AO volume of `scene` (its own volume, or `volume`) classified by its
/// classification: `method` "cdf", "gauss", "gauss-exact", "penner" or "exact" (VAO; the
/// voxel count is slow and always on the CPU) with tangent-sphere `radius` in voxels and
/// `field` "extinction" or "value", or "sweep" (the visibility, the mean transmittance of the
/// extinction over all directions). Returns {"ao": Volume (openness, 1 = unoccluded)} plus "ao_variance" when
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
    let params = AoVolumeParams {
        method: method.parse().map_err(py_err)?,
        radius,
        field: field.parse().map_err(py_err)?,
        variance,
    };
    params.validate().map_err(py_err)?;
    let compute = compute(py, device)?;
    let scene = &scene.inner;
    let volume = scene_volume(py, scene, volume)?;
    let ao = with_progress(py, progress, |report| {
        ao::ao_volume(&compute, &volume, &scene.classification, &params, report)
    })?;
    let grids = PyDict::new(py);
    grids.set_item(AO_GRID, PyVolume::from(ao.openness))?;
    if let Some(v) = ao.variance {
        grids.set_item(AO_VARIANCE_GRID, PyVolume::from(v))?;
    }
    Ok(grids)
}
