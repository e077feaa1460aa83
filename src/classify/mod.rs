//! Classification: transfer functions map a value (and optionally the gradient magnitude) to the
//! optical properties of the model in DESIGN.md: an achromatic extinction sigma_t per world unit,
//! an RGB single-scattering albedo and an optional RGB emission.
//!
//! A transfer function is baked into a [`Lut`] over the volume's value range (and gradient
//! range) that the CPU and GPU renderers both read with the same linear interpolation, so the
//! twins classify identically.

mod lut;
pub mod presets;
mod tf1d;
mod tf2d;

pub use lut::{Lut, Optical, LUT_STRIDE};
pub use tf1d::{ControlPoint, TransferFunction1D};
pub use tf2d::{TransferFunction2D, Widget, WidgetShape};

use crate::error::{Error, Result};
use crate::volume::Volume;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How control-point and widget value positions are expressed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ValueUnits {
    /// 0 is the volume's minimum value, 1 its maximum (presets use this).
    #[default]
    Normalized,
    /// The volume's own values.
    Raw,
}

/// A 1D or 2D transfer function; as JSON `{"points": [...]}` or `{"widgets": [...]}`, the
/// scene file's keys.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum TransferFunction {
    #[serde(rename = "points")]
    OneD(TransferFunction1D),
    #[serde(rename = "widgets")]
    TwoD(TransferFunction2D),
}

/// A transfer function with its value units and a global density scale on sigma_t.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Classification {
    #[serde(flatten)]
    pub tf: TransferFunction,
    pub units: ValueUnits,
    /// Multiplies sigma_t everywhere (not the albedo, not the emission).
    pub density_scale: f32,
    /// Entries of the baked table along the value axis.
    pub lut_size: usize,
}

/// Default number of LUT entries along the value axis (and 1/16 of it along the gradient axis).
pub const DEFAULT_LUT_SIZE: usize = 4096;

impl Classification {
    pub fn new(tf: TransferFunction, units: ValueUnits, density_scale: f32) -> Result<Self> {
        let c = Self {
            tf,
            units,
            density_scale,
            lut_size: DEFAULT_LUT_SIZE,
        };
        c.validate()?;
        Ok(c)
    }

    pub fn validate(&self) -> Result<()> {
        if !self.density_scale.is_finite() || self.density_scale < 0.0 {
            return Err(Error::param(
                "classification.density_scale",
                format!("must be finite and >= 0, got {}", self.density_scale),
            ));
        }
        if !(2..=65536).contains(&self.lut_size) {
            return Err(Error::param(
                "classification.lut_size",
                format!("must be in 2..=65536, got {}", self.lut_size),
            ));
        }
        match &self.tf {
            TransferFunction::OneD(tf) => tf.validate(),
            TransferFunction::TwoD(tf) => tf.validate(),
        }
    }

    /// Whether classification needs the gradient magnitude (a 2D transfer function).
    pub fn uses_gradient(&self) -> bool {
        matches!(self.tf, TransferFunction::TwoD(_))
    }

    /// Bakes the table for `volume`: the value axis spans its value range, the gradient axis
    /// (2D only) spans [0, max gradient magnitude].
    pub fn bake(&self, volume: &Volume) -> Lut {
        let (vmin, vmax) = volume.value_range();
        let gmax = if self.uses_gradient() {
            volume.max_gradient_magnitude()
        } else {
            0.0
        };
        self.bake_over(vmin, vmax, gmax)
    }

    /// Extinction (sigma_t per world unit) at every voxel centre, as a volume on the same grid:
    /// the density grid that other renderers read. Classifying voxels before interpolation
    /// differs from Occlux's renders (which interpolate values, then classify) where the
    /// transfer function changes quickly between neighbouring voxel values.
    pub fn extinction(&self, volume: &Volume) -> Result<Volume> {
        let lut = self.bake(volume);
        let uses_gradient = self.uses_gradient();
        if !uses_gradient {
            // A 1D table needs only each voxel's own value: one contiguous, parallel map.
            let values = volume
                .values()
                .par_iter()
                .map(|&v| lut.lookup(v, 0.0).sigma_t)
                .collect();
            return Volume::new(volume.dims(), volume.spacing(), volume.origin(), values);
        }
        let (origin, spacing) = (volume.origin(), volume.spacing());
        Volume::from_fn(volume.dims(), spacing, origin, |p| {
            let c = ((p - origin) / spacing).round();
            let v = volume.at(c.x as usize, c.y as usize, c.z as usize);
            let g = if uses_gradient {
                volume.gradient(p).length()
            } else {
                0.0
            };
            lut.lookup(v, g).sigma_t
        })
    }

    /// The control points of a 1D transfer function placed on the raw values of a volume whose
    /// values span `value_range`, sorted, with the density scale applied to sigma_t: the
    /// function the baked table holds, for renderers that take a ramp (Cycles). None for a 2D
    /// transfer function.
    pub fn raw_points(&self, value_range: (f32, f32)) -> Option<Vec<ControlPoint>> {
        let TransferFunction::OneD(tf) = &self.tf else {
            return None;
        };
        let (vmin, vmax) = value_axis(value_range.0, value_range.1);
        let to_raw = |x: f32| match self.units {
            ValueUnits::Normalized => vmin + x * (vmax - vmin),
            ValueUnits::Raw => x,
        };
        Some(
            tf.points()
                .iter()
                .map(|p| ControlPoint {
                    value: to_raw(p.value),
                    sigma_t: p.sigma_t * self.density_scale,
                    ..p.clone()
                })
                .collect(),
        )
    }

    /// Bakes the table over an explicit value range and gradient-magnitude maximum.
    pub fn bake_over(&self, vmin: f32, vmax: f32, gmax: f32) -> Lut {
        let (vmin, vmax) = value_axis(vmin, vmax);
        let to_tf = |v: f32| match self.units {
            ValueUnits::Normalized => (v - vmin) / (vmax - vmin),
            ValueUnits::Raw => v,
        };
        let nv = self.lut_size;
        let value_at = |i: usize| vmin + (vmax - vmin) * i as f32 / (nv - 1) as f32;
        let scale = self.density_scale;
        match &self.tf {
            TransferFunction::OneD(tf) => {
                let entries = (0..nv)
                    .map(|i| tf.eval(to_tf(value_at(i))).scaled(scale))
                    .collect();
                Lut::new([vmin, vmax], None, [nv, 1], entries)
            }
            TransferFunction::TwoD(tf) => {
                let ng = (nv / 16).max(2);
                let gmax_axis = if gmax > 0.0 { gmax } else { 1.0 };
                let mut entries = Vec::with_capacity(nv * ng);
                for gi in 0..ng {
                    // Widgets place gradient magnitudes normalised by the volume's maximum.
                    let g = gi as f32 / (ng - 1) as f32;
                    for vi in 0..nv {
                        entries.push(tf.eval(to_tf(value_at(vi)), g).scaled(scale));
                    }
                }
                Lut::new([vmin, vmax], Some(gmax_axis), [nv, ng], entries)
            }
        }
    }
}

/// The table's value axis for values in [vmin, vmax]: a constant volume still needs a non-empty
/// axis for interpolation.
fn value_axis(vmin: f32, vmax: f32) -> (f32, f32) {
    (vmin, if vmax > vmin { vmax } else { vmin + 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn density_scale_multiplies_extinction_only() {
        let tf = TransferFunction1D::new(vec![
            ControlPoint::new(0.0, 0.0, [0.5; 3], [0.0; 3]),
            ControlPoint::new(1.0, 2.0, [0.5; 3], [1.0; 3]),
        ])
        .unwrap();
        let c =
            Classification::new(TransferFunction::OneD(tf), ValueUnits::Normalized, 3.0).unwrap();
        let lut = c.bake_over(10.0, 20.0, 0.0);
        let o = lut.lookup(15.0, 0.0);
        assert!((o.sigma_t - 3.0).abs() < 1e-5);
        assert!((o.albedo - Vec3::splat(0.5)).length() < 1e-6);
        assert!((o.emission - Vec3::splat(0.5)).length() < 1e-5);
    }

    #[test]
    fn raw_units_place_points_on_raw_values() {
        // sigma_t = 20 * clip((v - 60) / 60, 0, 1): the benchmark scene's density.
        let tf = TransferFunction1D::new(vec![
            ControlPoint::new(60.0, 0.0, [0.8; 3], [0.0; 3]),
            ControlPoint::new(120.0, 20.0, [0.8; 3], [0.0; 3]),
        ])
        .unwrap();
        let c = Classification::new(TransferFunction::OneD(tf), ValueUnits::Raw, 1.0).unwrap();
        let lut = c.bake_over(0.0, 255.0, 0.0);
        for v in [0.0f32, 59.0, 75.0, 90.0, 119.0, 200.0] {
            let want = 20.0 * ((v - 60.0) / 60.0).clamp(0.0, 1.0);
            assert!((lut.lookup(v, 0.0).sigma_t - want).abs() < 0.02, "v={v}");
        }
    }

    #[test]
    fn raw_points_are_where_the_table_puts_them() {
        let c = presets::preset("ct-soft-tissue").unwrap();
        let c = Classification {
            density_scale: 2.5,
            ..c
        };
        let lut = c.bake_over(-1000.0, 3000.0, 0.0);
        let points = c.raw_points((-1000.0, 3000.0)).unwrap();
        assert!(points.len() >= 2);
        for p in &points {
            let o = lut.lookup(p.value, 0.0);
            assert!(
                (o.sigma_t - p.sigma_t).abs() <= 1e-2 * p.sigma_t.max(1.0),
                "{p:?}"
            );
        }
        let widgets = presets::preset("boundary-2d").unwrap();
        assert!(widgets.raw_points((0.0, 1.0)).is_none());
    }

    #[test]
    fn rejects_negative_density_scale() {
        let tf = presets::preset("ct-bone").unwrap();
        let err = Classification::new(tf.tf, ValueUnits::Normalized, -1.0).unwrap_err();
        assert!(err.to_string().contains("density_scale"));
    }
}
