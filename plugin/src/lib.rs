//! Python bindings of Occlux: the native module `occlux._occlux`, re-exported by the `occlux`
//! package (plugin/python/occlux). Volumes and images cross the boundary as numpy arrays; core
//! errors become `occlux.OccluxError` with the core's message verbatim; long work (loading,
//! rendering, writing) runs with the GIL released.

mod ao;
mod arrays;
mod bake;
mod classification;
mod errors;
mod export;
mod json;
mod metrics;
mod reference;
mod render;
mod scene;
mod series;
mod vdb;
mod volume;
mod writers;

use errors::OccluxError;
pub(crate) use errors::{py_err, unknown_choice};
use pyo3::prelude::*;

/// The rendering methods a scene's `render.method` can name, from the core's registry: a list
/// of dicts with `name`, `summary`, `module`, `shaders`, `lights` (the kinds it renders),
/// `layers` (EXR), `grids` (VDB, beyond density and value) and `params`, each with `key`,
/// `doc`, `type` (float, int, bool, choice, planes), `default`, and `range` (`min`, `max`,
/// `min_inclusive`, `max_inclusive`; None for an unbounded side) or `options`.
#[pyfunction]
fn methods(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    json::to_python(py, &occlux::registry::describe())
}

#[pymodule]
fn _occlux(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("OccluxError", py.get_type::<OccluxError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("PHANTOMS", occlux::volume::phantom::PHANTOMS.to_vec())?;
    m.add("PRESETS", occlux::classify::presets::PRESETS.to_vec())?;
    m.add_class::<volume::PyVolume>()?;
    m.add_class::<classification::PyClassification>()?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<render::PyRenderResult>()?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(vdb::write_vdb, m)?)?;
    m.add_class::<reference::PyReferenceResult>()?;
    m.add_function(wrap_pyfunction!(reference::reference, m)?)?;
    m.add_function(wrap_pyfunction!(export::stage_description, m)?)?;
    m.add_function(wrap_pyfunction!(export::export, m)?)?;
    m.add_function(wrap_pyfunction!(ao::ao_volume, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(series::series_plan, m)?)?;
    m.add_function(wrap_pyfunction!(series::series_frame, m)?)?;
    m.add_function(wrap_pyfunction!(series::series_finish, m)?)?;
    writers::register(m)?;
    metrics::register(m)?;
    Ok(())
}
