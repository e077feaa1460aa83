//! Lights of the optical model: a uniform ambient environment, directional and point lights,
//! and the background radiance seen where rays leave the volume.

use crate::error::{Error, Result};
use glam::Vec3;
use serde::Serialize;

/// One light. Radiometric quantities are RGB. As JSON: `{"type": "directional", "to_light":
/// [x, y, z], "irradiance": [r, g, b]}` and so on.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Light {
    /// Uniform environment radiance from every direction.
    Ambient { radiance: Vec3 },
    /// A distant light: `to_light` is the unit direction from the scene towards the light
    /// (Blender's sun sits that way); `irradiance` on a surface facing it.
    Directional { to_light: Vec3, irradiance: Vec3 },
    /// A point light of radiant `intensity` (irradiance intensity / r^2 at distance r).
    Point { position: Vec3, intensity: Vec3 },
}

/// The kinds of light in the optical model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(into = "&'static str")]
pub enum LightKind {
    Ambient,
    Directional,
    Point,
}

impl LightKind {
    pub fn name(self) -> &'static str {
        match self {
            LightKind::Ambient => "ambient",
            LightKind::Directional => "directional",
            LightKind::Point => "point",
        }
    }
}

impl From<LightKind> for &'static str {
    fn from(kind: LightKind) -> Self {
        kind.name()
    }
}

impl Light {
    pub fn kind(&self) -> LightKind {
        match self {
            Light::Ambient { .. } => LightKind::Ambient,
            Light::Directional { .. } => LightKind::Directional,
            Light::Point { .. } => LightKind::Point,
        }
    }
}

/// Most lights a scene may hold (the GPU kernels keep them in a fixed uniform array).
pub const MAX_LIGHTS: usize = 8;

/// The lights of a scene and its background radiance.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Lighting {
    pub lights: Vec<Light>,
    pub background: Vec3,
}

impl Lighting {
    pub fn validate(&self) -> Result<()> {
        if self.lights.len() > MAX_LIGHTS {
            return Err(Error::param(
                "lights",
                format!("at most {MAX_LIGHTS} lights, got {}", self.lights.len()),
            ));
        }
        let non_negative = |v: Vec3| v.is_finite() && v.min_element() >= 0.0;
        if !non_negative(self.background) {
            return Err(Error::param("background", "must be finite and >= 0"));
        }
        for (i, light) in self.lights.iter().enumerate() {
            let ok = match *light {
                Light::Ambient { radiance } => non_negative(radiance),
                Light::Directional {
                    to_light,
                    irradiance,
                } => to_light.is_normalized() && non_negative(irradiance),
                Light::Point {
                    position,
                    intensity,
                } => position.is_finite() && non_negative(intensity),
            };
            if !ok {
                return Err(Error::param(
                    format!("lights[{i}]"),
                    "radiometric values must be finite and >= 0 and directions non-zero",
                ));
            }
        }
        Ok(())
    }

    /// Total ambient radiance.
    pub fn ambient(&self) -> Vec3 {
        self.lights
            .iter()
            .map(|l| match l {
                Light::Ambient { radiance } => *radiance,
                _ => Vec3::ZERO,
            })
            .sum()
    }
}

/// The unit direction towards a (non-ambient) light and the irradiance it delivers at `p`.
#[inline]
pub fn incident(light: &Light, p: Vec3) -> Option<(Vec3, Vec3)> {
    match *light {
        Light::Ambient { .. } => None,
        Light::Directional {
            to_light,
            irradiance,
        } => Some((to_light, irradiance)),
        Light::Point {
            position,
            intensity,
        } => {
            let d = position - p;
            // A point light inside a sample's own position delivers nothing finite: skip it.
            let r2 = d.length_squared().max(1e-12);
            Some((d / r2.sqrt(), intensity / r2))
        }
    }
}
