//! 2D transfer functions over (value, gradient magnitude), built from widgets as in Kniss,
//! Kindlmann and Hansen (2001): boxes, and trapezoids whose value width changes linearly with the
//! gradient magnitude (a triangle when the bottom width is 0, as in Kniss' boundary widget).

use super::lut::Optical;
use super::tf1d::{default_albedo, validate_optics};
use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The footprint of a widget in (value, gradient magnitude).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WidgetShape {
    /// Full strength inside the rectangle, nothing outside.
    #[default]
    Box,
    /// Strength falls linearly from 1 at `value` to 0 at the half width, which is
    /// `width_bottom / 2` at `gradient[0]` and `width_top / 2` at `gradient[1]`.
    Trapezoid,
}

/// One widget: gradient magnitudes are normalised to [0, 1] by the volume's largest one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Widget {
    #[serde(default)]
    pub shape: WidgetShape,
    /// Centre on the value axis.
    pub value: f32,
    /// Value width at `gradient[0]` (box: the width everywhere).
    pub width_bottom: f32,
    /// Value width at `gradient[1]` (box: ignored; defaults to width_bottom).
    #[serde(default)]
    pub width_top: Option<f32>,
    /// Normalised gradient-magnitude interval [low, high] the widget covers.
    #[serde(default = "full_gradient")]
    pub gradient: [f32; 2],
    pub sigma_t: f32,
    #[serde(default = "default_albedo")]
    pub albedo: [f32; 3],
    #[serde(default)]
    pub emission: [f32; 3],
}

fn full_gradient() -> [f32; 2] {
    [0.0, 1.0]
}

impl Widget {
    fn validate(&self, key: &str) -> Result<()> {
        let finite = [
            self.value,
            self.width_bottom,
            self.gradient[0],
            self.gradient[1],
        ]
        .iter()
        .all(|x| x.is_finite());
        if !finite {
            return Err(Error::param(
                key,
                "value, widths and gradient must be finite",
            ));
        }
        let top = self.width_top.unwrap_or(self.width_bottom);
        if self.width_bottom < 0.0
            || !top.is_finite()
            || top < 0.0
            || top + self.width_bottom <= 0.0
        {
            return Err(Error::param(
                format!("{key}.width_bottom"),
                "widths must be >= 0 and not both 0",
            ));
        }
        let [g0, g1] = self.gradient;
        if !(0.0..=1.0).contains(&g0) || !(0.0..=1.0).contains(&g1) || g0 >= g1 {
            return Err(Error::param(
                format!("{key}.gradient"),
                format!(
                    "must be [low, high] with 0 <= low < high <= 1, got {:?}",
                    self.gradient
                ),
            ));
        }
        validate_optics(key, self.sigma_t, self.albedo, self.emission)
    }

    /// Strength in [0, 1] at value `x` and normalised gradient magnitude `g`.
    fn weight(&self, x: f32, g: f32) -> f32 {
        let [g0, g1] = self.gradient;
        if g < g0 || g > g1 {
            return 0.0;
        }
        let t = (g - g0) / (g1 - g0);
        let top = self.width_top.unwrap_or(self.width_bottom);
        let d = (x - self.value).abs();
        match self.shape {
            WidgetShape::Box => f32::from(d <= 0.5 * self.width_bottom),
            WidgetShape::Trapezoid => {
                let half = 0.5 * (self.width_bottom + (top - self.width_bottom) * t);
                if half <= 0.0 {
                    0.0
                } else {
                    (1.0 - d / half).max(0.0)
                }
            }
        }
    }
}

/// Widgets add their extinction and emission; albedo is the extinction-weighted mean.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct TransferFunction2D {
    widgets: Vec<Widget>,
}

impl TransferFunction2D {
    pub fn new(widgets: Vec<Widget>) -> Result<Self> {
        let tf = Self { widgets };
        tf.validate()?;
        Ok(tf)
    }

    pub fn validate(&self) -> Result<()> {
        if self.widgets.is_empty() {
            return Err(Error::param(
                "classification.widgets",
                "needs at least one widget",
            ));
        }
        for (i, w) in self.widgets.iter().enumerate() {
            w.validate(&format!("classification.widgets[{i}]"))?;
        }
        Ok(())
    }

    /// Optical properties at value `x` (TF units) and normalised gradient magnitude `g`.
    pub fn eval(&self, x: f32, g: f32) -> Optical {
        let mut sigma = 0.0;
        let mut albedo_sum = Vec3::ZERO;
        let mut emission = Vec3::ZERO;
        for w in &self.widgets {
            let k = w.weight(x, g);
            sigma += k * w.sigma_t;
            albedo_sum += k * w.sigma_t * Vec3::from(w.albedo);
            emission += k * Vec3::from(w.emission);
        }
        let albedo = if sigma > 0.0 {
            albedo_sum / sigma
        } else {
            Vec3::from(self.widgets[0].albedo)
        };
        Optical {
            sigma_t: sigma,
            albedo,
            emission,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn widget(shape: WidgetShape) -> Widget {
        Widget {
            shape,
            value: 0.5,
            width_bottom: 0.0,
            width_top: Some(0.4),
            gradient: [0.0, 1.0],
            sigma_t: 10.0,
            albedo: [1.0, 0.5, 0.0],
            emission: [0.0; 3],
        }
    }

    #[test]
    fn trapezoid_widens_with_gradient() {
        let tf = TransferFunction2D::new(vec![widget(WidgetShape::Trapezoid)]).unwrap();
        // At g = 1 the half width is 0.2: at 0.6 the strength is 0.5.
        assert!((tf.eval(0.6, 1.0).sigma_t - 5.0).abs() < 1e-4);
        // At g = 0.5 the half width is 0.1: 0.6 is on the edge.
        assert!(tf.eval(0.6, 0.5).sigma_t.abs() < 1e-4);
        assert_eq!(tf.eval(0.5, 0.0).sigma_t, 0.0);
    }

    #[test]
    fn widgets_mix_albedo_by_extinction() {
        let mut a = widget(WidgetShape::Box);
        a.width_bottom = 1.0;
        let mut b = a.clone();
        b.sigma_t = 30.0;
        b.albedo = [0.0, 0.5, 1.0];
        let o = TransferFunction2D::new(vec![a, b]).unwrap().eval(0.5, 0.5);
        assert!((o.sigma_t - 40.0).abs() < 1e-4);
        assert!((o.albedo - Vec3::new(0.25, 0.5, 0.75)).length() < 1e-5);
    }

    #[test]
    fn rejects_bad_gradient_interval() {
        let mut w = widget(WidgetShape::Box);
        w.gradient = [0.6, 0.2];
        let err = TransferFunction2D::new(vec![w]).unwrap_err().to_string();
        assert!(err.contains("widgets[0].gradient"), "{err}");
    }
}
