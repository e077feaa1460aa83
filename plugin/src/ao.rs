//! `occlux.ao_volume`: AO volumes (VAO: Ruiz, Szirmay-Kalos et al.; occlusion sweeping) of a
//! scene's classified volume, as a dict of grids ready for `occlux.write_vdb`.

use crate::py_err;
use crate::render::{compute, scene_volume, with_progress};
use crate::scene::PyScene;
use crate::volume::PyVolume;
use occlux::ao::sweep::geometric::GeometricParams;
use occlux::ao::{self, AoVolumeParams};
use occlux::render::ao_shaded::{AO_GRID, AO_OCTANT_GRIDS, AO_VARIANCE_GRID, SDF_GRID};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Computes the AO volume of `scene` (its own volume, or `volume`) classified by its
/// classification: `method` "ordinates" (the default: the visibility, the mean transmittance
/// of the extinction over all directions, along straight paths in `directions` directions, by
/// discrete ordinates); "cdf", "gauss", "gauss-exact", "penner" or "exact" (VAO; the voxel
/// count is slow and always on the CPU) with tangent-sphere `radius` in voxels and `field`
/// "extinction" or "value"; "sweep" (occlusion sweeping: the AO of the iso-surface `iso` of
/// the raw values, or without it of the classified extinction at half its maximum, with
/// `gamma`, the eight `octant_intensities`, the surface's opacity `alpha` and, with
/// `combined`, the octants' plain mean); or "sweep-physical" (the visibility by a lattice
/// walk, which crosses about 19 % too much optical depth). Returns {"ao": Volume (openness, 1 =
/// unoccluded)} plus "ao_variance" when `variance` is true, "sdf" (the signed distance,
/// negative inside) for "sweep", and "ao_oct0".."ao_oct7" when `octants` is true, on the
/// volume's grid. `convention` "unoccluded" (1 in empty space and on an open flat surface, as
/// Blender shades) or "raw" (VAO only: the paper's openness, 1/2 in empty space and on a flat
/// interface). `device` and `progress` as for `render` (returning False from `progress`
/// cancels). The GIL is released while it computes.
#[pyfunction]
#[pyo3(signature = (
    scene, method = "ordinates", radius = 10, field = "extinction", variance = false, device = "auto",
    volume = None, progress = None, iso = None, gamma = 2.0, octant_intensities = None,
    alpha = 1.0, combined = false, octants = false, convention = "unoccluded",
    directions = occlux::transport::DEFAULT_DIRECTIONS
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
    iso: Option<f32>,
    gamma: f32,
    octant_intensities: Option<Vec<f32>>,
    alpha: f32,
    combined: bool,
    octants: bool,
    convention: &str,
    directions: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let intensities = match octant_intensities {
        Some(list) => GeometricParams::intensities_from(&list).map_err(py_err)?,
        None => [1.0; 8],
    };
    let params = AoVolumeParams {
        method: method.parse().map_err(py_err)?,
        radius,
        field: field.parse().map_err(py_err)?,
        variance,
        iso,
        geometric: GeometricParams {
            gamma,
            intensities,
            alpha,
            normal_weighted: !combined,
        },
        octants,
        convention: convention.parse().map_err(py_err)?,
        directions,
    };
    params.validate().map_err(py_err)?;
    let compute = compute(py, device)?;
    let (scene, volume) = scene_volume(py, &scene.inner, volume)?;
    let scene = &*scene;
    // A volume loaded here is given away to the method (classified in place where it can be).
    let ao = with_progress(py, progress, |report| {
        ao::ao_volume(&compute, volume, &scene.classification, &params, report)
    })?;
    let grids = PyDict::new(py);
    grids.set_item(AO_GRID, PyVolume::from(ao.openness))?;
    if let Some(v) = ao.variance {
        grids.set_item(AO_VARIANCE_GRID, PyVolume::from(v))?;
    }
    if let Some(sdf) = ao.sdf {
        grids.set_item(SDF_GRID, PyVolume::from(sdf))?;
    }
    for (name, octant) in AO_OCTANT_GRIDS.iter().zip(ao.octants) {
        grids.set_item(name, PyVolume::from(octant))?;
    }
    Ok(grids)
}
