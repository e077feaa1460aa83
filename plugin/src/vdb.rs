//! `occlux.write_vdb`: volumes as OpenVDB float grids.

use crate::py_err;
use crate::volume::PyVolume;
use occlux::export::vdb::{self, Compression, VdbGrid, VdbOptions};
use occlux::pipeline::vdb_grid;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Writes `grids` ({name: Volume}, in the dict's order) into one OpenVDB file, atomically:
/// sparse fog-volume float grids (voxels equal to 0 are inactive), except `sdf`, a level set,
/// with each volume's spacing and origin as the grid transform. `compression` is "zip" or "none"; `half` stores values as
/// float16. The GIL is released while it writes.
#[pyfunction]
#[pyo3(signature = (path, grids, compression = "zip", half = false))]
pub fn write_vdb(
    py: Python<'_>,
    path: PathBuf,
    grids: &Bound<'_, PyDict>,
    compression: &str,
    half: bool,
) -> PyResult<()> {
    let options = VdbOptions {
        compression: compression.parse::<Compression>().map_err(py_err)?,
        half,
    };
    let named = grids
        .iter()
        .map(|(name, volume)| Ok((name.extract::<String>()?, volume.cast_into::<PyVolume>()?)))
        .collect::<PyResult<Vec<_>>>()?;
    let grids: Vec<VdbGrid> = named
        .iter()
        .map(|(name, volume)| vdb_grid(name, &volume.get().inner))
        .collect();
    py.detach(|| vdb::write_vdb(&path, &grids, &options))
        .map_err(py_err)
}
