//! AO-shaded DVR (the VAO paper's Eq. 5): an AO volume of the classified volume, computed on
//! the same device, then the ray caster with `Shading::AmbientOcclusion` reading it, optionally
//! with the paper's opacity modulation by local variance.

use crate::ao::vao::{self, Estimator, FieldKind, VaoParams, MAX_RADIUS};
use crate::ao::{self as ao_volumes, AoMethod, AoVolumeParams};
use crate::error::Result;
use crate::registry::{Choice, MethodSpec, ParamKind, ParamSpec, Range, RenderMethod, ALL_LIGHTS};
use crate::render::raycast::{
    self, AoFactors, GradientShading, RaycastInput, RaycastParams, Shading, ERT_THRESHOLD,
    NORMAL_THRESHOLD, SHININESS, SPECULAR, STEP,
};
use crate::render::{Grid, MethodInput, Rendered};
use serde::{Deserialize, Serialize};

/// The AO volume's grid, and its local variance's.
pub const AO_GRID: &str = "ao";
pub const AO_VARIANCE_GRID: &str = "ao_variance";

/// `method = "ao"`: the ray caster's keys, the VAO volume's (`ao_*`), opacity modulation, and
/// gradient shading of the direct light (`specular`, `shininess` and `normal_threshold`, absent:
/// the gradient method's defaults; refused with `direct = false`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AoParams {
    pub step: Option<f32>,
    pub ert_threshold: f32,
    pub ao_method: AoMethod,
    pub ao_radius: u32,
    pub ao_field: FieldKind,
    pub ao_variance: bool,
    pub opacity_modulation: bool,
    pub variance_max: Option<f32>,
    pub direct: bool,
    pub specular: Option<f32>,
    pub shininess: Option<f32>,
    pub normal_threshold: Option<f32>,
}

impl Default for AoParams {
    fn default() -> Self {
        let vao = VaoParams::default();
        let march = RaycastParams::default();
        Self {
            step: march.step,
            ert_threshold: march.ert_threshold,
            ao_method: AoMethod::Vao(vao.estimator),
            ao_radius: vao.radius,
            ao_field: FieldKind::default(),
            ao_variance: vao.variance,
            opacity_modulation: false,
            variance_max: None,
            direct: true,
            specular: None,
            shininess: None,
            normal_threshold: None,
        }
    }
}

const AO_METHOD: ParamSpec = ParamSpec {
    key: "ao_method",
    doc: "How the openness is estimated from the local statistics",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "cdf",
                doc: "The CDF reconstruction t^beta from the local minimum, maximum and mean",
            },
            Choice {
                name: "gauss",
                doc: "The normal CDF of the local mean and variance (Winitzki's erf)",
            },
            Choice {
                name: "gauss-exact",
                doc: "The normal CDF with the exact erf",
            },
            Choice {
                name: "penner",
                doc: "Penner and Mitchell's Chebyshev bound: the baseline, too dark",
            },
            Choice {
                name: "exact",
                doc: "Count the voxels in every ball: slow, CPU only, the reference",
            },
            Choice {
                name: "sweep",
                doc: "Visibility: the mean transmittance over all directions, in eight sweeps \
                      at any range; ao_radius and ao_field do not apply",
            },
        ],
    },
};
const AO_RADIUS: ParamSpec = ParamSpec {
    key: "ao_radius",
    doc: "Tangent-sphere radius in voxels (VAO's estimators)",
    kind: ParamKind::Int {
        range: Range::closed(1.0, MAX_RADIUS as f64),
    },
};
const AO_FIELD: ParamSpec = ParamSpec {
    key: "ao_field",
    doc: "The field whose local statistics give the openness",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "extinction",
                doc: "The classified extinction sigma_t (what occludes light)",
            },
            Choice {
                name: "value",
                doc: "The volume's raw values",
            },
        ],
    },
};
const AO_VARIANCE: ParamSpec = ParamSpec {
    key: "ao_variance",
    doc: "Also export the local variance (grid ao_variance)",
    kind: ParamKind::Bool,
};
const OPACITY_MODULATION: ParamSpec = ParamSpec {
    key: "opacity_modulation",
    doc: "Modulate the extinction by min(variance / variance_max, 1) (the VAO paper)",
    kind: ParamKind::Bool,
};
const VARIANCE_MAX: ParamSpec = ParamSpec {
    key: "variance_max",
    doc: "Variance of full opacity with opacity_modulation; absent: the largest local variance",
    kind: ParamKind::Float {
        range: Range::POSITIVE,
        optional: true,
    },
};
const DIRECT: ParamSpec = ParamSpec {
    key: "direct",
    doc: "Add the directional and point lights, gradient-shaded",
    kind: ParamKind::Bool,
};

impl AoParams {
    /// The ray caster's parameters: ambient occlusion shading, with gradient-shaded direct light
    /// unless `direct` is off.
    pub fn raycast(&self) -> RaycastParams {
        let d = GradientShading::default();
        let gradient = GradientShading {
            specular: self.specular.unwrap_or(d.specular),
            shininess: self.shininess.unwrap_or(d.shininess),
            normal_threshold: self.normal_threshold.unwrap_or(d.normal_threshold),
        };
        RaycastParams {
            shading: Shading::AmbientOcclusion {
                direct: self.direct.then_some(gradient),
            },
            step: self.step,
            ert_threshold: self.ert_threshold,
        }
    }

    /// The AO volume's parameters (the variance too when opacity modulation needs it).
    pub fn ao_volume(&self) -> AoVolumeParams {
        AoVolumeParams {
            method: self.ao_method,
            radius: self.ao_radius,
            field: self.ao_field,
            variance: self.ao_variance || self.opacity_modulation,
        }
    }

    /// VAO's parameters, for a VAO estimator.
    pub fn vao(&self) -> Option<VaoParams> {
        self.ao_volume().vao()
    }
}

impl RenderMethod for AoParams {
    const SPEC: MethodSpec = MethodSpec {
        name: "ao",
        summary: "AO-shaded DVR: ambient light times a VAO volume's openness (Ruiz et al. 2010)",
        module: "render::ao_shaded",
        shaders: &[
            "raycast.wgsl",
            "vao_stats.wgsl",
            "vao_estimate.wgsl",
            "sweep.wgsl",
        ],
        lights: ALL_LIGHTS,
        layers: &["beauty", "depth"],
        grids: &[AO_GRID, AO_VARIANCE_GRID],
        params: &[
            STEP,
            ERT_THRESHOLD,
            AO_METHOD,
            AO_RADIUS,
            AO_FIELD,
            AO_VARIANCE,
            OPACITY_MODULATION,
            VARIANCE_MAX,
            DIRECT,
            SPECULAR,
            SHININESS,
            NORMAL_THRESHOLD,
        ],
    };

    fn resolve(self) -> Result<Self> {
        AO_RADIUS.check(self.ao_radius as f64)?;
        VARIANCE_MAX.check_optional(self.variance_max)?;
        if self.variance_max.is_some() && !self.opacity_modulation {
            return Err(VARIANCE_MAX.error("is for opacity_modulation = true"));
        }
        let gradient_keys = [self.specular, self.shininess, self.normal_threshold];
        if !self.direct && gradient_keys.iter().any(Option::is_some) {
            return Err(SPECULAR.error(
                "specular, shininess and normal_threshold shade direct light: not with direct = false",
            ));
        }
        match self.ao_method {
            AoMethod::Vao(Estimator::Exact) if self.ao_variance => {
                return Err(
                    AO_VARIANCE.error("the exact estimator counts voxels and computes no variance")
                );
            }
            AoMethod::Sweep if self.ao_field != FieldKind::Extinction => {
                return Err(AO_FIELD.error(
                    "the sweep's visibility is a transmittance: it reads the extinction only",
                ));
            }
            AoMethod::Sweep if self.ao_variance || self.opacity_modulation => {
                return Err(AO_VARIANCE.error(
                    "the sweep computes no local variance (nor opacity modulation from it)",
                ));
            }
            _ => {}
        }
        self.raycast().validate()?;
        self.ao_volume().validate()?;
        Ok(self)
    }

    fn render(&self, input: &MethodInput) -> Result<Rendered> {
        render(input, self)
    }
}

/// Computes the AO volume (progress: its units first, then the image rows) and renders with it;
/// the grids are the openness and, if asked for, the local variance.
pub fn render(input: &MethodInput, params: &AoParams) -> Result<Rendered> {
    let (compute, progress) = (input.compute, input.progress);
    let ao = ao_volumes::ao_volume(
        compute,
        input.volume,
        input.classification,
        &params.ao_volume(),
        progress,
    )?;
    let opacity = match (&ao.variance, params.opacity_modulation) {
        (Some(variance), true) => Some(vao::opacity_modulation(variance, params.variance_max)?),
        _ => None,
    };
    let raycast_params = params.raycast();
    let raycast_input = RaycastInput {
        volume: input.volume,
        lut: input.lut,
        camera: input.camera,
        lighting: input.lighting,
        params: &raycast_params,
        ao: Some(AoFactors {
            openness: &ao.openness,
            opacity: opacity.as_ref(),
        }),
    };
    let image = raycast::render(compute, &raycast_input, progress)?;
    let mut grids = vec![Grid {
        name: AO_GRID,
        volume: ao.openness,
    }];
    if let (true, Some(variance)) = (params.ao_variance, ao.variance) {
        grids.push(Grid {
            name: AO_VARIANCE_GRID,
            volume: variance,
        });
    }
    Ok(Rendered { image, grids })
}
