//! The baseline ray caster: emission-absorption DVR, unshaded or gradient-shaded, front to back
//! with early ray termination. `cpu` and `gpu` are twins that produce the same image.
//!
//! Per ray: the ray is clipped to the volume's bounding box; the segment is cut into steps of
//! length `step`, shifted back by the pixel's own fraction of a step (the first and last one
//! shorter: [`crate::render::steps`], which turns step banding into fine noise), and sampled at
//! each step's midpoint. A step of length d with extinction sigma_t has opacity
//! alpha = 1 - exp(-sigma_t d) and adds
//! `T * (alpha * albedo * L_in + emission * alpha / sigma_t)` (emission * d when sigma_t = 0),
//! the exact integral for constant properties over the step. After the march the background
//! adds `T * L_b`; alpha is 1 - T. Depth is where T falls through 0.5, found exactly inside the
//! step, as distance along the ray from its origin.
//!
//! In-scattered radiance `L_in`:
//! - unshaded: no shadows, isotropic phase: `L_amb + sum_l E_l / (4 pi)`;
//! - ambient occlusion (the VAO paper's Eq. 5, colour = k_i O(x) C_TF(x)): `O(x) L_amb`, with
//!   O the openness of an AO volume sampled trilinearly, plus optionally the direct terms of
//!   gradient shading below. The paper's opacity modulation alpha' = alpha * m(x), with
//!   m = min(variance / variance_max, 1), is applied to the extinction, sigma_t' = m sigma_t:
//!   the same to first order in the step, and unlike a per-step alpha it does not change with
//!   the sample rate (opacity never depends on the step in this model);
//! - gradient: with n the unit normal -grad/|grad| turned towards the viewer and
//!   w = min(|grad| / threshold, 1) (w = 0 in homogeneous regions, where the normal is noise),
//!   `L_amb + sum_l E_l (w max(0, n.l) / pi + (1 - w) / (4 pi))` for the albedo-weighted part plus
//!   a white Blinn-Phong term `w ks E_l max(0, n.h)^p (p + 8) / (8 pi)` not multiplied by albedo.

pub mod cpu;
pub mod gpu;
mod method;

pub use method::{
    GradientParams, UnshadedParams, ERT_THRESHOLD, MARCH, NORMAL_THRESHOLD, SHININESS, SPECULAR,
    STEP,
};

use crate::error::{Error, Result};

/// Shading of the baseline ray caster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    /// Emission-absorption with unshadowed, isotropic in-scattering.
    Unshaded,
    /// Lambert plus Blinn-Phong from the gradient normal.
    Gradient(GradientShading),
    /// Ambient light times the openness of an AO volume ([`RaycastInput::ao`]), plus the direct
    /// terms of gradient shading when `direct` is given.
    AmbientOcclusion { direct: Option<GradientShading> },
}

impl Shading {
    /// The gradient-shading parameters the shading uses for its direct light, if any.
    pub fn gradient(&self) -> Option<GradientShading> {
        match *self {
            Shading::Unshaded | Shading::AmbientOcclusion { direct: None } => None,
            Shading::Gradient(g) | Shading::AmbientOcclusion { direct: Some(g) } => Some(g),
        }
    }
}

/// Per-voxel factors of AO shading, on the volume's grid.
#[derive(Clone, Copy)]
pub struct AoFactors<'a> {
    /// Openness in [0, 1] (1 = unoccluded), multiplying the ambient light.
    pub openness: &'a crate::volume::Volume,
    /// Opacity modulation factor in [0, 1] multiplying the extinction, if any.
    pub opacity: Option<&'a crate::volume::Volume>,
}

/// Parameters of gradient shading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientShading {
    /// Specular coefficient ks in [0, 1].
    pub specular: f32,
    /// Blinn-Phong exponent p in [1, 4096].
    pub shininess: f32,
    /// Gradient magnitude, as a fraction of the volume's largest, at and above which a sample is
    /// fully surface-shaded; below it shading blends linearly to the isotropic phase.
    pub normal_threshold: f32,
}

impl Default for GradientShading {
    fn default() -> Self {
        Self {
            specular: 0.25,
            shininess: 32.0,
            normal_threshold: 0.05,
        }
    }
}

/// Parameters of the ray caster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RaycastParams {
    pub shading: Shading,
    /// Step length in world units; None: half the smallest voxel spacing.
    pub step: Option<f32>,
    /// Early ray termination: stop when transmittance falls below this (0 disables).
    pub ert_threshold: f32,
}

impl Default for RaycastParams {
    fn default() -> Self {
        Self {
            shading: Shading::Unshaded,
            step: None,
            ert_threshold: 1e-3,
        }
    }
}

/// Most steps a ray may take (bounds the work of a tiny step on a large volume).
pub const MAX_STEPS: f32 = 1.0e6;

impl RaycastParams {
    /// Checks every parameter against the ranges of the registry's `gradient` entry.
    pub fn validate(&self) -> Result<()> {
        method::STEP.check_optional(self.step)?;
        method::ERT_THRESHOLD.check(self.ert_threshold as f64)?;
        if let Some(g) = self.shading.gradient() {
            method::SPECULAR.check(g.specular as f64)?;
            method::SHININESS.check(g.shininess as f64)?;
            method::NORMAL_THRESHOLD.check(g.normal_threshold as f64)?;
        }
        Ok(())
    }

    /// The step for a volume of the given spacing, checked against the longest ray through it.
    pub fn resolve_step(&self, volume: &crate::volume::Volume) -> Result<f32> {
        let step = self.step.unwrap_or(0.5 * volume.spacing().min_element());
        let (lo, hi) = volume.bounds();
        if (hi - lo).length() / step > MAX_STEPS {
            return Err(Error::param(
                "render.step",
                format!("{step} would take over {MAX_STEPS} steps through the volume"),
            ));
        }
        Ok(step)
    }
}

/// What a ray caster reads.
#[derive(Clone, Copy)]
pub struct RaycastInput<'a> {
    pub volume: &'a crate::volume::Volume,
    pub lut: &'a crate::classify::Lut,
    pub camera: &'a crate::camera::Camera,
    pub lighting: &'a crate::lights::Lighting,
    pub params: &'a RaycastParams,
    /// The AO volumes that `Shading::AmbientOcclusion` reads (None for other shadings).
    pub ao: Option<AoFactors<'a>>,
}

/// Values derived once per render and shared by both twins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RaycastSetup {
    pub step: f32,
    /// Absolute gradient magnitude at which shading is fully surface-like (gradient shading).
    pub normal_threshold: f32,
}

impl RaycastInput<'_> {
    /// Validates the inputs and derives the per-render values.
    pub fn setup(&self) -> Result<RaycastSetup> {
        self.params.validate()?;
        self.lighting.validate()?;
        let step = self.params.resolve_step(self.volume)?;
        self.check_ao()?;
        let normal_threshold = match self.params.shading.gradient() {
            None => 1.0,
            Some(g) => {
                let gmax = self
                    .lut
                    .gradient_max()
                    .unwrap_or_else(|| self.volume.max_gradient_magnitude());
                // A constant volume has no normals: any positive threshold keeps w = 0.
                (g.normal_threshold * gmax).max(f32::MIN_POSITIVE)
            }
        };
        Ok(RaycastSetup {
            step,
            normal_threshold,
        })
    }
}

impl RaycastInput<'_> {
    /// AO shading needs its volumes on the volume's grid, with factors in [0, 1].
    fn check_ao(&self) -> Result<()> {
        let wants_ao = matches!(self.params.shading, Shading::AmbientOcclusion { .. });
        match (wants_ao, &self.ao) {
            (true, None) => Err(Error::param(
                "render.method",
                "ambient-occlusion shading needs an AO volume",
            )),
            (false, Some(_)) => Err(Error::param(
                "render.method",
                "an AO volume was given to a shading that does not use it",
            )),
            (true, Some(ao)) => {
                for (name, grid) in [("openness", Some(ao.openness)), ("opacity", ao.opacity)] {
                    let Some(grid) = grid else { continue };
                    if grid.dims() != self.volume.dims() {
                        return Err(Error::param(
                            format!("ao.{name}"),
                            format!(
                                "dims {:?} differ from the volume's {:?}",
                                grid.dims(),
                                self.volume.dims()
                            ),
                        ));
                    }
                    if grid.values().iter().any(|v| !(0.0..=1.0).contains(v)) {
                        return Err(Error::param(
                            format!("ao.{name}"),
                            "factors must lie in [0, 1]",
                        ));
                    }
                }
                Ok(())
            }
            (false, None) => Ok(()),
        }
    }
}

/// Renders on the chosen device.
pub fn render(
    compute: &crate::gpu::Compute,
    input: &RaycastInput,
    progress: &dyn crate::progress::Progress,
) -> Result<crate::render::RenderImage> {
    match compute {
        crate::gpu::Compute::Cpu => cpu::render(input, progress),
        crate::gpu::Compute::Gpu(ctx) => gpu::render(ctx, input, progress),
    }
}
