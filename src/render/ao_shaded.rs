//! AO-shaded DVR (the VAO paper's Eq. 5): an AO volume of the classified volume, computed on
//! the same device, then the ray caster with `Shading::AmbientOcclusion` reading it, optionally
//! with the paper's opacity modulation by local variance.

use crate::ao::vao::{self, AoVolume, FieldKind, ScalarField, VaoParams};
use crate::classify::{Classification, Lut};
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::render::raycast::{self, AoFactors, RaycastInput, RaycastParams, Shading};
use crate::render::RenderImage;
use crate::volume::Volume;

/// Parameters of AO-shaded DVR.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoRenderParams {
    /// The ray caster's parameters; the shading must be `Shading::AmbientOcclusion`.
    pub raycast: RaycastParams,
    pub vao: VaoParams,
    pub field: FieldKind,
    /// Modulate opacity by min(variance / variance_max, 1).
    pub opacity_modulation: bool,
    /// None: the largest local variance in the volume.
    pub variance_max: Option<f32>,
}

impl AoRenderParams {
    pub fn validate(&self) -> Result<()> {
        if !matches!(self.raycast.shading, Shading::AmbientOcclusion { .. }) {
            return Err(Error::param(
                "render.method",
                "AO-shaded rendering needs ambient-occlusion shading",
            ));
        }
        if self.variance_max.is_some() && !self.opacity_modulation {
            return Err(Error::param(
                "render.variance_max",
                "is for opacity_modulation = true",
            ));
        }
        self.raycast.validate()?;
        self.vao.validate()
    }
}

/// What the scene's camera and lights are, for the ray caster.
pub struct View<'a> {
    pub camera: &'a crate::camera::Camera,
    pub lighting: &'a crate::lights::Lighting,
}

/// Computes the AO volume (progress: its units first, then the image rows) and renders with it.
pub fn render(
    compute: &Compute,
    volume: &Volume,
    classification: &Classification,
    lut: &Lut,
    view: &View,
    params: &AoRenderParams,
    progress: &dyn Progress,
) -> Result<(RenderImage, AoVolume)> {
    params.validate()?;
    let field = ScalarField::new(volume, classification, params.field)?;
    let vao_params = VaoParams {
        variance: params.vao.variance || params.opacity_modulation,
        ..params.vao
    };
    let mut ao = vao::ao_volume(compute, &field, &vao_params, progress)?;
    let opacity = match (&ao.variance, params.opacity_modulation) {
        (Some(variance), true) => Some(vao::opacity_modulation(variance, params.variance_max)?),
        _ => None,
    };
    let input = RaycastInput {
        volume,
        lut,
        camera: view.camera,
        lighting: view.lighting,
        params: &params.raycast,
        ao: Some(AoFactors {
            openness: &ao.openness,
            opacity: opacity.as_ref(),
        }),
    };
    let image = raycast::render(compute, &input, progress)?;
    if !params.vao.variance {
        ao.variance = None;
    }
    Ok((image, ao))
}
