//! `occlux.Volume`: the core volume, built from numpy, loaded from a file or generated.

use crate::arrays::{readonly_view, volume_values};
use crate::py_err;
use glam::Vec3;
use numpy::{PyArray1, PyArray3};
use occlux::classify::{histogram, Window};
use occlux::volume::info::suggested_points;
use occlux::volume::{self, phantom, LoadOptions, Volume};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A dense scalar volume in world units: voxel (i, j, k) is `values[k, j, i]` and has its centre
/// at `origin + (i, j, k) * spacing`. Immutable: `values` is a read-only view of its memory.
#[pyclass(name = "Volume", module = "occlux", frozen)]
pub struct PyVolume {
    pub(crate) inner: Volume,
}

impl From<Volume> for PyVolume {
    fn from(inner: Volume) -> Self {
        Self { inner }
    }
}

type Triple = (f32, f32, f32);

fn triple(v: Vec3) -> Triple {
    (v.x, v.y, v.z)
}

#[pymethods]
impl PyVolume {
    /// Builds a volume from a numpy array of shape (nz, ny, nx) and any real dtype (converted to
    /// float32, one copy). Raises OccluxError for NaN or infinite values, non-positive spacing or
    /// a non-finite origin.
    #[new]
    #[pyo3(
        signature = (values, spacing = [1.0; 3], origin = [0.0; 3]),
        text_signature = "(values, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0))"
    )]
    fn new(
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        spacing: [f32; 3],
        origin: [f32; 3],
    ) -> PyResult<Self> {
        let (dims, values) = volume_values(values)?;
        let (spacing, origin) = (Vec3::from(spacing), Vec3::from(origin));
        py.detach(|| Volume::new(dims, spacing, origin, values))
            .map_err(py_err)
            .map(Self::from)
    }

    /// Loads a volume file (.nrrd, .nhdr, .nii, .nii.gz, .vdb, .npy); `grid` picks a VDB grid
    /// (default: the only or first float grid).
    #[staticmethod]
    #[pyo3(signature = (path, grid = None))]
    fn load(py: Python<'_>, path: PathBuf, grid: Option<String>) -> PyResult<Self> {
        let options = LoadOptions {
            grid,
            ..LoadOptions::default()
        };
        py.detach(|| volume::load(&path, &options))
            .map_err(py_err)
            .map(Self::from)
    }

    /// A built-in phantom (see `occlux.PHANTOMS`) filling [-1, 1]^3 with `size`^3 voxels.
    #[staticmethod]
    #[pyo3(signature = (name, size = 64))]
    fn phantom(py: Python<'_>, name: &str, size: usize) -> PyResult<Self> {
        py.detach(|| phantom::by_name(name, size))
            .map_err(py_err)
            .map(Self::from)
    }

    /// Voxels along x, y, z: (nx, ny, nz).
    #[getter]
    fn dims(&self) -> (usize, usize, usize) {
        let [nx, ny, nz] = self.inner.dims();
        (nx, ny, nz)
    }

    /// Distance between voxel centres along x, y, z, in world units.
    #[getter]
    fn spacing(&self) -> Triple {
        triple(self.inner.spacing())
    }

    /// World position of the centre of voxel (0, 0, 0).
    #[getter]
    fn origin(&self) -> Triple {
        triple(self.inner.origin())
    }

    /// World-space bounding box of the voxels' cells: ((min x, y, z), (max x, y, z)).
    #[getter]
    fn bounds(&self) -> (Triple, Triple) {
        let (lo, hi) = self.inner.bounds();
        (triple(lo), triple(hi))
    }

    /// Smallest and largest value.
    #[getter]
    fn value_range(&self) -> (f32, f32) {
        self.inner.value_range()
    }

    /// The values as a read-only float32 array of shape (nz, ny, nx) that views the volume's
    /// memory (no copy; the array keeps the volume alive).
    #[getter]
    fn values<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let [nx, ny, nz] = this.get().inner.dims();
        let owner = this.clone().into_any();
        // SAFETY: the values belong to this frozen Volume, which never changes them.
        unsafe { readonly_view(owner, this.get().inner.values(), (nz, ny, nx)) }
    }

    /// The robust window of the values, on which normalised transfer functions (the presets)
    /// read 0 and 1, as `occlux info` prints it: a dict with `lo` and `hi`, `cut` (the value
    /// above which wrapped negative numbers are classified as `lo`; None when there are none),
    /// `background` (the centre of the most common value band) and the shares of the sampled
    /// voxels `above` the window's top and `wrapped` (cut away); `points`, the ramp `occlux info
    /// --suggest` suggests on it, as `(value, sigma_t, albedo, emission)` in the file's values.
    fn robust_window<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let report = py.detach(|| Window::robust(&self.inner));
        let window = PyDict::new(py);
        window.set_item("lo", report.window.lo)?;
        window.set_item("hi", report.window.hi)?;
        window.set_item("cut", report.window.cut)?;
        window.set_item("background", report.background)?;
        window.set_item("above", report.above)?;
        window.set_item("wrapped", report.wrapped)?;
        let points: Vec<_> = suggested_points(&report)
            .into_iter()
            .map(|p| (p.value, p.sigma_t, p.albedo, p.emission))
            .collect();
        window.set_item("points", points)?;
        Ok(window)
    }

    /// Voxels in `bins` equal bins over [lo, hi] (uint64), binned as numpy's
    /// `histogram(values, bins, range=(lo, hi))` bins them in float64; values outside are not
    /// counted. Counted in parallel over the volume's own memory (no copy). Raises OccluxError
    /// naming `histogram.bins` (1 to 65536) or `histogram.range` (finite lo < hi).
    #[pyo3(signature = (lo, hi, bins = 64))]
    fn histogram<'py>(
        &self,
        py: Python<'py>,
        lo: f32,
        hi: f32,
        bins: i64,
    ) -> PyResult<Bound<'py, PyArray1<u64>>> {
        // A negative count would fail pyo3's unsigned conversion without naming the argument.
        let bins = usize::try_from(bins).map_err(|_| {
            py_err(occlux::Error::param(
                "histogram.bins",
                format!("must be positive, got {bins}"),
            ))
        })?;
        let counts = py
            .detach(|| histogram(self.inner.values(), lo, hi, bins))
            .map_err(py_err)?;
        Ok(PyArray1::from_vec(py, counts))
    }

    fn __repr__(&self) -> String {
        let [nx, ny, nz] = self.inner.dims();
        let (lo, hi) = self.inner.value_range();
        format!(
            "Volume(dims=({nx}, {ny}, {nz}), spacing={:?}, origin={:?}, value_range=({lo}, {hi}))",
            self.spacing(),
            self.origin()
        )
    }
}
