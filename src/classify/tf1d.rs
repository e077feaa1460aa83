//! Piecewise-linear 1D transfer functions over the value.

use super::lut::Optical;
use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// One control point: at `value`, extinction `sigma_t` per world unit, `albedo` and `emission`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlPoint {
    pub value: f32,
    pub sigma_t: f32,
    #[serde(default = "default_albedo")]
    pub albedo: [f32; 3],
    #[serde(default)]
    pub emission: [f32; 3],
}

pub(super) fn default_albedo() -> [f32; 3] {
    [1.0; 3]
}

impl ControlPoint {
    pub fn new(value: f32, sigma_t: f32, albedo: [f32; 3], emission: [f32; 3]) -> Self {
        Self {
            value,
            sigma_t,
            albedo,
            emission,
        }
    }

    fn optical(&self) -> Optical {
        Optical {
            sigma_t: self.sigma_t,
            albedo: Vec3::from(self.albedo),
            emission: Vec3::from(self.emission),
        }
    }
}

/// Checks the optical fields shared by control points and 2D widgets; `key` names the entry.
pub(super) fn validate_optics(
    key: &str,
    sigma_t: f32,
    albedo: [f32; 3],
    emission: [f32; 3],
) -> Result<()> {
    if !sigma_t.is_finite() || sigma_t < 0.0 {
        return Err(Error::param(
            format!("{key}.sigma_t"),
            format!("must be finite and >= 0, got {sigma_t}"),
        ));
    }
    if albedo.iter().any(|a| !(0.0..=1.0).contains(a)) {
        return Err(Error::param(
            format!("{key}.albedo"),
            format!("each channel must be in [0, 1], got {albedo:?}"),
        ));
    }
    if emission.iter().any(|e| !e.is_finite() || *e < 0.0) {
        return Err(Error::param(
            format!("{key}.emission"),
            format!("each channel must be finite and >= 0, got {emission:?}"),
        ));
    }
    Ok(())
}

/// Control points sorted by value; linear in between, constant beyond the ends.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct TransferFunction1D {
    points: Vec<ControlPoint>,
}

impl TransferFunction1D {
    /// Sorts the points by value and validates them.
    pub fn new(mut points: Vec<ControlPoint>) -> Result<Self> {
        points.sort_by(|a, b| a.value.total_cmp(&b.value));
        let tf = Self { points };
        tf.validate()?;
        Ok(tf)
    }

    pub fn points(&self) -> &[ControlPoint] {
        &self.points
    }

    pub fn validate(&self) -> Result<()> {
        if self.points.is_empty() {
            return Err(Error::param(
                "classification.points",
                "needs at least one control point",
            ));
        }
        for (i, p) in self.points.iter().enumerate() {
            let key = format!("classification.points[{i}]");
            if !p.value.is_finite() {
                return Err(Error::param(
                    format!("{key}.value"),
                    format!("must be finite, got {}", p.value),
                ));
            }
            validate_optics(&key, p.sigma_t, p.albedo, p.emission)?;
        }
        Ok(())
    }

    /// Optical properties at value `x` (in the transfer function's units).
    pub fn eval(&self, x: f32) -> Optical {
        let pts = &self.points;
        let after = pts.partition_point(|p| p.value <= x);
        if after == 0 {
            return pts[0].optical();
        }
        if after == pts.len() {
            return pts[pts.len() - 1].optical();
        }
        let (a, b) = (&pts[after - 1], &pts[after]);
        let t = (x - a.value) / (b.value - a.value);
        let (oa, ob) = (a.optical(), b.optical());
        Optical {
            sigma_t: oa.sigma_t + (ob.sigma_t - oa.sigma_t) * t,
            albedo: oa.albedo.lerp(ob.albedo, t),
            emission: oa.emission.lerp(ob.emission, t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_clamps() {
        let tf = TransferFunction1D::new(vec![
            ControlPoint::new(1.0, 4.0, [1.0, 0.0, 0.0], [0.0; 3]),
            ControlPoint::new(0.0, 0.0, [0.0, 0.0, 1.0], [0.0; 3]),
        ])
        .unwrap();
        assert_eq!(tf.eval(-1.0).sigma_t, 0.0);
        assert_eq!(tf.eval(2.0).sigma_t, 4.0);
        let mid = tf.eval(0.25);
        assert!((mid.sigma_t - 1.0).abs() < 1e-6);
        assert!((mid.albedo - Vec3::new(0.25, 0.0, 0.75)).length() < 1e-6);
    }

    #[test]
    fn rejects_bad_points() {
        let bad = |p: ControlPoint| TransferFunction1D::new(vec![p]).unwrap_err().to_string();
        assert!(bad(ControlPoint::new(0.0, -1.0, [1.0; 3], [0.0; 3])).contains("sigma_t"));
        assert!(bad(ControlPoint::new(0.0, 1.0, [1.5, 0.0, 0.0], [0.0; 3])).contains("albedo"));
        assert!(bad(ControlPoint::new(f32::NAN, 1.0, [1.0; 3], [0.0; 3])).contains("value"));
        assert!(TransferFunction1D::new(vec![]).is_err());
    }
}
