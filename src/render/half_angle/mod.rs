//! Half-angle slicing (Kniss, Premoze, Hansen, Shirley, McPherson 2003), the baseline IPSVI's
//! paper measures against: single scattering with shadows from suns and lamps, computed by
//! slicing the volume along the half vector between the view and the light so that one pass of
//! slices serves both the eye and a light buffer.
//!
//! With `v` the view direction (the camera's forward axis) and `w` the direction the light
//! travels (away from the sun; for a lamp, from the lamp towards the box's centre), the slices
//! are planes perpendicular to `h = normalize(v + w)` when the light comes from behind the
//! viewer (v . w >= 0), else to `h = normalize(w - v)`: either way moving along +h moves every
//! light ray away from the light, and every view ray away from the eye (the first case: the
//! eye composites front to back) or towards it (the second: back to front). Slab k lies
//! between the planes at h-coordinates c_k and c_k + d, and is sampled where each ray crosses
//! its middle plane; a view ray crosses it over `d / |dir . h|`, a light ray over
//! `d / (w_r . h)`, w_r that ray's direction.
//!
//! Per slab, first the eye: each pixel's sample at x takes the light's transmittance from the
//! light buffer (bilinear between its rays, as IPSVI's cache: the same light-space grid, a
//! sun's parallel rays or a lamp's perspective fan), and adds
//! `T alpha albedo p_HG(g) E(x) T_light` (plus emission) front to back, or composites it under
//! what lies in front (`L = alpha c + (1 - alpha) L`) back to front, E(x) the light's
//! irradiance there (a lamp's falls off as 1 / r^2); then the light: each ray of the light
//! buffer is attenuated by its own crossing of the slab, `exp(-sigma_t d_l)`.
//! The optical model is IPSVI's and the Monte Carlo `single` reference's; what differs is the
//! discretisation: the slab's material is sampled once per ray, and the light buffer holds the
//! light that passed the slabs before, so a sample is not shadowed by its own slab. Depth (where the
//! eye's transmittance falls through 0.5) is found front to back: for a back-to-front render by
//! a second, extinction-only pass over the same slabs. The `shadow` layer is IPSVI's
//! ([`crate::render::Factor`]): each light's transmittance at each sample composited with the
//! sample's weight as its colour is (front to back or back to front), the lights' weighted by
//! their irradiance composited the same way, beside the coverage.
//!
//! A lamp's rays fan out, and they cross the slices in order only if every one moves along +h
//! through the volume: the whole box must lie beyond the plane through the lamp across h. A
//! lamp closer than that (inside the box, or beside it at a wide angle to the view) is refused
//! by name; IPSVI takes lamps anywhere. Several lights are sliced one after the other (single
//! scattering is linear in the lights), emission and background added once.

pub mod cpu;
mod method;

use crate::camera::Camera;
use crate::classify::Lut;
use crate::error::{Error, Result};
use crate::lights::Lighting;
use crate::method::RenderMethod;
use crate::volume::Volume;
use serde::{Deserialize, Serialize};

/// Most slices a render may take (bounds the work of a tiny slice distance).
pub const MAX_SLICES: f32 = 1.0e5;

/// Parameters of half-angle slicing: `method = "half-angle"` in a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HalfAngleParams {
    /// Distance between slices along the half vector; None: the smallest voxel spacing.
    pub slice_distance: Option<f32>,
    /// Texels along the light buffer's longer side; None: as IPSVI's cache, half a pixel wide
    /// at the volume's centre, at most a voxel.
    pub light_buffer: Option<u32>,
    /// Henyey-Greenstein asymmetry, in (-1, 1).
    pub g: f32,
}

impl Default for HalfAngleParams {
    fn default() -> Self {
        Self {
            slice_distance: None,
            light_buffer: None,
            g: 0.0,
        }
    }
}

impl HalfAngleParams {
    pub fn validate(&self) -> Result<()> {
        method::SLICE_DISTANCE.check_optional(self.slice_distance)?;
        if let Some(size) = self.light_buffer {
            method::LIGHT_BUFFER.check(size as f64)?;
        }
        crate::optics::phase::G.check(self.g as f64)
    }
}

/// What half-angle slicing reads.
#[derive(Clone, Copy)]
pub struct HalfAngleInput<'a> {
    pub volume: &'a Volume,
    pub lut: &'a Lut,
    pub camera: &'a Camera,
    pub lighting: &'a Lighting,
    pub params: &'a HalfAngleParams,
}

impl HalfAngleInput<'_> {
    /// Validates the inputs; returns the slice distance.
    pub fn setup(&self) -> Result<f32> {
        self.params.validate()?;
        self.lighting.validate()?;
        HalfAngleParams::SPEC.check_lights(self.lighting)?;
        let d = self
            .params
            .slice_distance
            .unwrap_or(self.volume.spacing().min_element());
        let (lo, hi) = self.volume.bounds();
        if (hi - lo).length() / d > MAX_SLICES {
            return Err(Error::param(
                "render.slice_distance",
                format!("{d} would take over {MAX_SLICES} slices through the volume"),
            ));
        }
        Ok(d)
    }
}
