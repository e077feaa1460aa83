//! Classification: transfer functions map a value (and optionally the gradient magnitude) to the
//! optical properties of the model of docs/architecture.md#optical-model: an achromatic extinction
//! sigma_t per world unit, an RGB single-scattering albedo and an optional RGB emission.
//!
//! A transfer function is baked into a [`Lut`] over the volume's value range (and gradient
//! range) that the CPU and GPU renderers both read with the same linear interpolation, so the
//! twins classify identically.

mod lut;
pub mod presets;
mod tf1d;
mod tf2d;
pub mod window;

pub use lut::{Lut, Optical, LUT_STRIDE};
pub use tf1d::{ControlPoint, TransferFunction1D};
pub use tf2d::{TransferFunction2D, Widget, WidgetShape};
pub use window::{histogram, ValueRange, Window, WindowReport, MAX_HISTOGRAM_BINS};

use crate::error::{Error, Result};
use crate::volume::Volume;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// How control-point and widget value positions are expressed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ValueUnits {
    /// Positions on the classification's `range` (by default the robust window of
    /// [`window`]: 0 near the background, 1 at the top of the object's values); presets use
    /// this unless the values are Hounsfield units.
    #[default]
    Normalized,
    /// The volume's own values.
    Raw,
    /// Hounsfield units: the volume's own values, which the file says (or the scene states)
    /// are a CT's HU; the CT presets have HU forms.
    Hu,
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
    /// What normalised 0 and 1 are on the volume's values (normalised units only).
    pub range: ValueRange,
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
            range: ValueRange::default(),
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
        self.range.validate()?;
        match &self.tf {
            TransferFunction::OneD(tf) => tf.validate(),
            TransferFunction::TwoD(tf) => tf.validate(),
        }
    }

    /// Whether classification needs the gradient magnitude (a 2D transfer function).
    pub fn uses_gradient(&self) -> bool {
        matches!(self.tf, TransferFunction::TwoD(_))
    }

    /// Bakes the table for `volume`: the value axis spans its value range (for normalised
    /// units, what of it the window's ends and cut leave distinct), the gradient axis (2D only)
    /// spans [0, max gradient magnitude].
    pub fn bake(&self, volume: &Volume) -> Lut {
        let (vmin, vmax) = volume.value_range();
        let gmax = if self.uses_gradient() {
            volume.max_gradient_magnitude()
        } else {
            0.0
        };
        self.bake_over(vmin, vmax, self.window(volume), gmax)
    }

    /// The window normalised positions are read on for `volume`; None for raw and HU units.
    pub fn window(&self, volume: &Volume) -> Option<Window> {
        (self.units == ValueUnits::Normalized).then(|| self.range.window(volume))
    }

    /// This classification with its window resolved for `volume`, so that it classifies the
    /// same without the statistics (and says which values it used); unchanged for raw and HU
    /// units.
    pub fn resolved_for(&self, volume: &Volume) -> Self {
        Self {
            range: self.window(volume).map_or(self.range, ValueRange::Window),
            ..self.clone()
        }
    }

    /// Extinction (sigma_t per world unit) at every voxel centre, as a volume on the same grid:
    /// the density grid that other renderers read. Classifying voxels before interpolation
    /// differs from Occlux's renders (which interpolate values, then classify) where the
    /// transfer function changes quickly between neighbouring voxel values.
    pub fn extinction(&self, volume: &Volume) -> Result<Volume> {
        self.into_extinction(Cow::Borrowed(volume))
    }

    /// [`Self::extinction`] of a volume that may be given away: an owned volume under a 1D table
    /// becomes its extinction in place, so the two are never held at once (the AO volumes'
    /// peak memory); a borrowed one, or any under a 2D table (which reads neighbours for the
    /// gradient), is classified into a new grid.
    pub fn into_extinction(&self, volume: Cow<'_, Volume>) -> Result<Volume> {
        let lut = self.bake(&volume);
        let (dims, spacing, origin) = (volume.dims(), volume.spacing(), volume.origin());
        if !self.uses_gradient() {
            // A 1D table needs only each voxel's own value: one contiguous, parallel map.
            let sigma_t = |v: f32| lut.lookup(v, 0.0).sigma_t;
            let values = match volume {
                Cow::Owned(volume) => {
                    let mut values = volume.into_values();
                    values.par_iter_mut().for_each(|v| *v = sigma_t(*v));
                    values
                }
                Cow::Borrowed(volume) => volume.values().par_iter().map(|&v| sigma_t(v)).collect(),
            };
            return Volume::new(dims, spacing, origin, values);
        }
        Volume::from_fn(dims, spacing, origin, |p| {
            let c = ((p - origin) / spacing).round();
            let v = volume.at(c.x as usize, c.y as usize, c.z as usize);
            lut.lookup(v, volume.gradient(p).length()).sigma_t
        })
    }

    /// The control points of a 1D transfer function placed on `volume`'s raw values, sorted,
    /// with the density scale applied to sigma_t: the function the baked table holds, for
    /// renderers that take a ramp (Cycles). A window's cut becomes a step back to the first
    /// point. None for a 2D transfer function.
    pub fn raw_points(&self, volume: &Volume) -> Option<Vec<ControlPoint>> {
        let TransferFunction::OneD(tf) = &self.tf else {
            return None;
        };
        let window = self.window(volume);
        let to_raw = |x: f32| window.map_or(x, |w| w.raw(x));
        let scaled = |p: &ControlPoint, value: f32| ControlPoint {
            value,
            sigma_t: p.sigma_t * self.density_scale,
            ..p.clone()
        };
        let mut points: Vec<ControlPoint> = tf
            .points()
            .iter()
            .map(|p| scaled(p, to_raw(p.value)))
            .collect();
        if let Some(cut) = window.and_then(|w| w.cut) {
            let (first, last) = (&tf.points()[0], &tf.points()[tf.points().len() - 1]);
            points.retain(|p| p.value < cut);
            points.push(scaled(last, cut));
            points.push(scaled(first, above(cut)));
        }
        Some(points)
    }

    /// Bakes the table for values in [vmin, vmax] read on `window` (normalised units; None
    /// for raw and HU), and gradient magnitudes up to `gmax`.
    pub fn bake_over(&self, vmin: f32, vmax: f32, window: Option<Window>, gmax: f32) -> Lut {
        let nv = self.lut_size;
        let (vmin, vmax) = match window {
            // The table spans what the window leaves distinct: beyond a quarter of its width
            // past either end every value classifies as that end (lookups clamp), so far
            // outliers cost the data no resolution. Above a cut every value classifies as
            // the bottom, so the table ends one entry past the cut: the step is one entry
            // of the data's own range wide, not one of the range the wrapped values stretch.
            Some(w) => {
                let margin = 0.25 * (w.hi - w.lo);
                let lo = vmin.max(w.lo - margin);
                let hi = match w.cut {
                    Some(cut) if nv > 2 && cut > lo => vmax.min(cut + (cut - lo) / (nv - 2) as f32),
                    Some(_) => vmax,
                    None => vmax.min(w.hi + margin),
                };
                value_axis(lo, hi)
            }
            None => value_axis(vmin, vmax),
        };
        let to_tf = |v: f32| match window {
            Some(w) if w.cut.is_some_and(|cut| v > cut) => w.normalise(w.lo),
            Some(w) => w.normalise(v),
            None => v,
        };
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

/// The next f32 above `x` (what `f32::next_up` gives, which is newer than the crate's MSRV).
pub(crate) fn above(x: f32) -> f32 {
    if x.is_nan() || x == f32::INFINITY {
        return x;
    }
    if x == 0.0 {
        return f32::from_bits(1);
    }
    let bits = x.to_bits();
    f32::from_bits(if x > 0.0 { bits + 1 } else { bits - 1 })
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
        let window = Window {
            lo: 10.0,
            hi: 20.0,
            cut: None,
        };
        let lut = c.bake_over(10.0, 20.0, Some(window), 0.0);
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
        let lut = c.bake_over(0.0, 255.0, None, 0.0);
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
        // A CT-like ramp with one far outlier, and the same ramp with wrapped negative values.
        let ramp = |n: usize| (0..n).map(|i| (i % 4000) as f32 - 1000.0);
        let outlier: Vec<f32> = ramp(40_000).chain([1e6]).collect();
        let wrapped: Vec<f32> = ramp(40_000)
            .map(|v| v + 1000.0)
            .chain((0..4000).map(|i| 64_000.0 + (i % 100) as f32))
            .collect();
        for values in [outlier, wrapped] {
            let volume = Volume::new([values.len(), 1, 1], Vec3::ONE, Vec3::ZERO, values).unwrap();
            let lut = c.bake(&volume);
            let points = c.raw_points(&volume).unwrap();
            assert!(points.len() >= 2);
            // The ramp's points, the cut's included, are exact in the table.
            let cut = c.window(&volume).and_then(|w| w.cut);
            for p in points
                .iter()
                .filter(|p| !cut.is_some_and(|cut| p.value > cut))
            {
                let o = lut.lookup(p.value, 0.0);
                assert!(
                    (o.sigma_t - p.sigma_t).abs() <= 1e-2 * p.sigma_t.max(1.0),
                    "{p:?}"
                );
            }
            // The step at a cut is one table entry of the data's range wide: 1 % of the range
            // past the cut already reads as the bottom.
            if let Some(cut) = cut {
                let past = lut.lookup(cut * 1.01, 0.0).sigma_t;
                assert_eq!(past, points[0].sigma_t, "{cut}");
            }
            // Between points the table follows the ramp the points describe.
            for v in [-500.0f32, 0.0, 700.0, 1500.0, 2999.0, 64_050.0] {
                let after = points.partition_point(|p| p.value <= v);
                let want = match after {
                    0 => points[0].sigma_t,
                    n if n == points.len() => points[n - 1].sigma_t,
                    n => {
                        let (a, b) = (&points[n - 1], &points[n]);
                        a.sigma_t + (b.sigma_t - a.sigma_t) * (v - a.value) / (b.value - a.value)
                    }
                };
                let got = lut.lookup(v, 0.0).sigma_t;
                assert!(
                    (got - want).abs() <= 0.05 * want.max(1.0),
                    "v={v}: {got} vs {want}"
                );
            }
        }
        let widgets = presets::preset("boundary-2d").unwrap();
        let volume = Volume::new([2, 1, 1], Vec3::ONE, Vec3::ZERO, vec![0.0, 1.0]).unwrap();
        assert!(widgets.raw_points(&volume).is_none());
    }

    #[test]
    fn rejects_negative_density_scale() {
        let tf = presets::preset("ct-bone").unwrap();
        let err = Classification::new(tf.tf, ValueUnits::Normalized, -1.0).unwrap_err();
        assert!(err.to_string().contains("density_scale"));
    }
}
