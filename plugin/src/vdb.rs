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
/// with each volume's spacing and origin as the grid transform. `compression` is "zip" or
/// "none"; `half` stores values as float16: True for every grid, or the names of the grids to
/// store so (a name that is not a grid is an error). The GIL is released while it writes.
#[pyfunction]
#[pyo3(signature = (path, grids, compression = "zip", half = None))]
pub fn write_vdb(
    py: Python<'_>,
    path: PathBuf,
    grids: &Bound<'_, PyDict>,
    compression: &str,
    half: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let compression = compression.parse::<Compression>().map_err(py_err)?;
    let named = grids
        .iter()
        .map(|(name, volume)| Ok((name.extract::<String>()?, volume.cast_into::<PyVolume>()?)))
        .collect::<PyResult<Vec<_>>>()?;
    let halves = half_grids(half, named.iter().map(|(name, _)| name.as_str()))?;
    let grids: Vec<(VdbGrid, VdbOptions)> = named
        .iter()
        .map(|(name, volume)| {
            let options = VdbOptions {
                compression,
                half: halves.contains(name),
            };
            (vdb_grid(name, &volume.get().inner), options)
        })
        .collect();
    py.detach(|| vdb::write_vdb_each(&path, &grids))
        .map_err(py_err)
}

/// The names of the grids `half` stores as float16: all of `names` for True, none for False
/// or None, else the names it lists, each of which must be one of `names`.
fn half_grids<'a>(
    half: Option<&Bound<'_, PyAny>>,
    names: impl Iterator<Item = &'a str> + Clone,
) -> PyResult<Vec<String>> {
    let Some(half) = half else {
        return Ok(Vec::new());
    };
    if let Ok(all) = half.extract::<bool>() {
        return Ok(if all {
            names.map(str::to_string).collect()
        } else {
            Vec::new()
        });
    }
    let listed = half
        .try_iter()?
        .map(|name| name?.extract::<String>())
        .collect::<PyResult<Vec<_>>>()?;
    if let Some(unknown) = listed
        .iter()
        .find(|n| !names.clone().any(|m| m == n.as_str()))
    {
        return Err(py_err(occlux::Error::param(
            "half",
            format!(
                "no grid '{unknown}' to store as float16 (the grids: {})",
                names.collect::<Vec<_>>().join(", ")
            ),
        )));
    }
    Ok(listed)
}
