//! The ray caster's scene methods, `unshaded` and `gradient`: their `[render]` keys, ranges and
//! registry entries. The ray caster's own [`RaycastParams`] are built from them.

use super::{GradientShading, RaycastInput, RaycastParams, Shading};
use crate::error::Result;
use crate::method::{MethodSpec, ParamKind, ParamSpec, Range, RenderMethod, ALL_LIGHTS};
use crate::render::{MethodInput, Rendered};
use serde::{Deserialize, Serialize};

pub const STEP: ParamSpec = ParamSpec {
    key: "step",
    doc: "Step along each ray in world units; absent: half the smallest voxel spacing",
    kind: ParamKind::Float {
        range: Range::POSITIVE,
        optional: true,
    },
};
pub const ERT_THRESHOLD: ParamSpec = ParamSpec {
    key: "ert_threshold",
    doc: "Early ray termination: stop when the transmittance falls below this (0 disables)",
    kind: ParamKind::Float {
        range: Range::below(0.0, 1.0),
        optional: false,
    },
};
pub const SPECULAR: ParamSpec = ParamSpec {
    key: "specular",
    doc: "Blinn-Phong specular coefficient",
    kind: ParamKind::Float {
        range: Range::closed(0.0, 1.0),
        optional: false,
    },
};
pub const SHININESS: ParamSpec = ParamSpec {
    key: "shininess",
    doc: "Blinn-Phong exponent",
    kind: ParamKind::Float {
        range: Range::closed(1.0, 4096.0),
        optional: false,
    },
};
pub const NORMAL_THRESHOLD: ParamSpec = ParamSpec {
    key: "normal_threshold",
    doc: "Gradient magnitude, as a fraction of the volume's largest, at and above which a sample \
          is fully surface-shaded; below it shading blends to the isotropic phase",
    kind: ParamKind::Float {
        range: Range::above(0.0, 1.0),
        optional: false,
    },
};

/// The keys every ray-casting method takes.
pub const MARCH: [ParamSpec; 2] = [STEP, ERT_THRESHOLD];

/// `method = "unshaded"`: emission-absorption DVR with unshadowed isotropic in-scattering.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UnshadedParams {
    pub step: Option<f32>,
    pub ert_threshold: f32,
}

impl Default for UnshadedParams {
    fn default() -> Self {
        let d = RaycastParams::default();
        Self {
            step: d.step,
            ert_threshold: d.ert_threshold,
        }
    }
}

/// `method = "gradient"`: Lambert plus Blinn-Phong from the gradient normal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GradientParams {
    pub step: Option<f32>,
    pub ert_threshold: f32,
    pub specular: f32,
    pub shininess: f32,
    pub normal_threshold: f32,
}

impl Default for GradientParams {
    fn default() -> Self {
        let march = UnshadedParams::default();
        let g = GradientShading::default();
        Self {
            step: march.step,
            ert_threshold: march.ert_threshold,
            specular: g.specular,
            shininess: g.shininess,
            normal_threshold: g.normal_threshold,
        }
    }
}

impl UnshadedParams {
    pub fn raycast(&self) -> RaycastParams {
        RaycastParams {
            shading: Shading::Unshaded,
            step: self.step,
            ert_threshold: self.ert_threshold,
        }
    }
}

impl GradientParams {
    pub fn raycast(&self) -> RaycastParams {
        RaycastParams {
            shading: Shading::Gradient(GradientShading {
                specular: self.specular,
                shininess: self.shininess,
                normal_threshold: self.normal_threshold,
            }),
            step: self.step,
            ert_threshold: self.ert_threshold,
        }
    }
}

/// Renders the ray caster's parameters without AO volumes.
fn render_plain(params: &RaycastParams, input: &MethodInput) -> Result<Rendered> {
    let raycast_input = RaycastInput {
        volume: input.volume,
        lut: input.lut,
        camera: input.camera,
        lighting: input.lighting,
        params,
        ao: None,
    };
    Ok(Rendered {
        image: super::render(input.compute, &raycast_input, input.progress)?,
        grids: Vec::new(),
    })
}

const LAYERS: &[&str] = &["beauty", "depth"];

impl RenderMethod for UnshadedParams {
    const SPEC: MethodSpec = MethodSpec {
        name: "unshaded",
        summary: "Emission-absorption DVR, unshadowed isotropic in-scattering (the baseline)",
        module: "render::raycast",
        shaders: &["raycast.wgsl"],
        lights: ALL_LIGHTS,
        layers: LAYERS,
        grids: &[],
        chart: &[""],
        for_lights: ALL_LIGHTS,
        params: &MARCH,
    };

    fn resolve(self) -> Result<Self> {
        self.raycast().validate()?;
        Ok(self)
    }

    fn render(&self, input: &MethodInput) -> Result<Rendered> {
        render_plain(&self.raycast(), input)
    }
}

impl RenderMethod for GradientParams {
    const SPEC: MethodSpec = MethodSpec {
        name: "gradient",
        summary:
            "Gradient-shaded DVR: Lambert and Blinn-Phong from the gradient normal, no shadows",
        module: "render::raycast",
        shaders: &["raycast.wgsl"],
        lights: ALL_LIGHTS,
        layers: LAYERS,
        grids: &[],
        chart: &[""],
        for_lights: ALL_LIGHTS,
        params: &[STEP, ERT_THRESHOLD, SPECULAR, SHININESS, NORMAL_THRESHOLD],
    };

    fn resolve(self) -> Result<Self> {
        self.raycast().validate()?;
        Ok(self)
    }

    fn render(&self, input: &MethodInput) -> Result<Rendered> {
        render_plain(&self.raycast(), input)
    }
}
