//! `occlux.bake`: the baked light grids of a scene (src/bake.rs), as a dict of grids ready for
//! `occlux.write_vdb`.

use crate::render::{compute, scene_volume, with_progress};
use crate::scene::PyScene;
use crate::volume::PyVolume;
use occlux::bake::{bake as bake_light, BakeParams};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Bakes the light of `scene` (its own volume, or `volume`) into grids any renderer can shade
/// with, without tracing shadows, each per unit strength of its light: {"ao": the ambient
/// visibility (`directions` discrete ordinates), with `multiple` "ao_multiple_r", "_g", "_b"
/// (uniform white ambient light's multiply scattered light per unit radiance), then per sun or
/// lamp i of the scene's lights
/// (in their order, ambient lights skipped) "light{i}": the irradiance reaching each voxel per
/// unit strength, and with `multiple` "light{i}_multiple_r", "_g", "_b": its multiply
/// scattered light per unit strength (Henyey-Greenstein `g`), on the solver's coarser grid}.
/// `device` and `progress` as for `render` (stages: the visibility and its multiple
/// scattering, then per light its light and its multiple scattering). The GIL is released while it computes.
#[pyfunction]
#[pyo3(signature = (
    scene, directions = occlux::transport::DEFAULT_DIRECTIONS, multiple = true, g = 0.0,
    device = "auto", volume = None, progress = None
))]
#[allow(clippy::too_many_arguments)] // Python keyword arguments, all with defaults
pub fn bake<'py>(
    py: Python<'py>,
    scene: &PyScene,
    directions: u32,
    multiple: bool,
    g: f32,
    device: &str,
    volume: Option<&PyVolume>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let params = BakeParams {
        directions,
        multiple,
        g,
    };
    let compute = compute(py, device)?;
    let (scene, volume) = scene_volume(py, &scene.inner, volume)?;
    let (scene, volume) = (&*scene, &*volume);
    let baked = with_progress(py, progress, |report| {
        bake_light(
            &compute,
            volume,
            &scene.classification,
            &scene.lighting,
            &params,
            report,
        )
    })?;
    let grids = PyDict::new(py);
    for (name, grid) in baked.into_grids() {
        grids.set_item(name, PyVolume::from(grid))?;
    }
    Ok(grids)
}
