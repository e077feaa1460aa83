//! `occlux.Classification`: a transfer function with its value units and density scale.

use crate::volume::PyVolume;
use crate::{py_err, unknown_choice};
use occlux::classify::{
    presets, Classification, ControlPoint, TransferFunction, TransferFunction1D, ValueUnits,
};
use pyo3::prelude::*;

/// A control point as Python gives it: (value, sigma_t, (r, g, b) albedo, (r, g, b) emission).
type PointArg = (f32, f32, [f32; 3], [f32; 3]);

/// Maps the value (and for 2D presets the gradient magnitude) to extinction sigma_t per world
/// unit, an RGB albedo and an RGB emission.
#[pyclass(name = "Classification", module = "occlux", frozen)]
pub struct PyClassification {
    pub(crate) inner: Classification,
}

impl From<Classification> for PyClassification {
    fn from(inner: Classification) -> Self {
        Self { inner }
    }
}

fn parse_units(units: &str) -> PyResult<ValueUnits> {
    match units {
        "normalized" => Ok(ValueUnits::Normalized),
        "raw" => Ok(ValueUnits::Raw),
        "hu" => Ok(ValueUnits::Hu),
        other => Err(unknown_choice("units", other, &["normalized", "raw", "hu"])),
    }
}

fn units_name(units: ValueUnits) -> &'static str {
    match units {
        ValueUnits::Normalized => "normalized",
        ValueUnits::Raw => "raw",
        ValueUnits::Hu => "hu",
    }
}

#[pymethods]
impl PyClassification {
    /// A built-in classification (see `occlux.PRESETS`). `units` says how its value positions
    /// are read: "normalized" (on the robust window of the volume's values: 0 near the
    /// background, 1 at the top of the object's values) or "hu" (the CT presets' forms in
    /// Hounsfield units). `density_scale` multiplies sigma_t.
    #[staticmethod]
    #[pyo3(signature = (name, density_scale = 1.0, units = "normalized"))]
    fn preset(name: &str, density_scale: f32, units: &str) -> PyResult<Self> {
        let mut c = presets::preset_in(name, parse_units(units)?).map_err(py_err)?;
        c.density_scale = density_scale;
        c.validate().map_err(py_err)?;
        Ok(c.into())
    }

    /// A piecewise-linear 1D transfer function through control points
    /// `(value, sigma_t, (r, g, b) albedo, (r, g, b) emission)`.
    #[staticmethod]
    #[pyo3(signature = (points, units = "normalized", density_scale = 1.0))]
    fn from_points(points: Vec<PointArg>, units: &str, density_scale: f32) -> PyResult<Self> {
        let points = points
            .into_iter()
            .map(|(value, sigma_t, albedo, emission)| {
                ControlPoint::new(value, sigma_t, albedo, emission)
            })
            .collect();
        let tf = TransferFunction1D::new(points).map_err(py_err)?;
        Classification::new(
            TransferFunction::OneD(tf),
            parse_units(units)?,
            density_scale,
        )
        .map_err(py_err)
        .map(Self::from)
    }

    /// The control points `(value, sigma_t, (r, g, b) albedo, (r, g, b) emission)` of a 1D
    /// transfer function (before `density_scale`); None for a 2D one.
    #[getter]
    fn points(&self) -> Option<Vec<PointArg>> {
        match &self.inner.tf {
            TransferFunction::OneD(tf) => Some(
                tf.points()
                    .iter()
                    .map(|p| (p.value, p.sigma_t, p.albedo, p.emission))
                    .collect(),
            ),
            TransferFunction::TwoD(_) => None,
        }
    }

    /// The control points of a 1D transfer function on `volume`'s raw values, sorted, with
    /// `density_scale` applied: the function Occlux's table holds for that volume, as
    /// `(value, sigma_t, albedo, emission)`; None for a 2D transfer function.
    fn raw_points(&self, volume: &PyVolume) -> Option<Vec<PointArg>> {
        self.inner.raw_points(&volume.inner).map(|points| {
            points
                .into_iter()
                .map(|p| (p.value, p.sigma_t, p.albedo, p.emission))
                .collect()
        })
    }

    /// Extinction (sigma_t per world unit) at every voxel centre of `volume`, as a volume on
    /// the same grid: the `density` grid that `export` writes.
    fn extinction(&self, py: Python<'_>, volume: &PyVolume) -> PyResult<PyVolume> {
        py.detach(|| self.inner.extinction(&volume.inner))
            .map(PyVolume::from)
            .map_err(py_err)
    }

    /// "normalized", "raw" or "hu".
    #[getter]
    fn units(&self) -> &'static str {
        units_name(self.inner.units)
    }

    /// Multiplier on sigma_t.
    #[getter]
    fn density_scale(&self) -> f32 {
        self.inner.density_scale
    }

    fn __repr__(&self) -> String {
        let kind = match &self.inner.tf {
            TransferFunction::OneD(tf) => format!("1D, {} points", tf.points().len()),
            TransferFunction::TwoD(_) => "2D".into(),
        };
        format!(
            "Classification({kind}, units='{}', density_scale={})",
            self.units(),
            self.inner.density_scale
        )
    }
}
