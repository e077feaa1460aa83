//! AO-shaded DVR (the VAO paper's Eq. 5): an AO volume of the classified volume, computed on
//! the same device, then the ray caster with `Shading::AmbientOcclusion` reading it, optionally
//! with the paper's opacity modulation by local variance.

use crate::ao::sweep::geometric::{self, GeometricParams};
use crate::ao::vao::{self, Estimator, FieldKind, VaoParams, MAX_RADIUS};
use crate::ao::{self as ao_volumes, AoConvention, AoMethod, AoVolumeParams};
use crate::error::Result;
use crate::lights::LightKind;
use crate::method::{
    Choice, MethodSpec, Model, ParamKind, ParamSpec, Range, RenderMethod, ALL_LIGHTS,
};
use crate::render::raycast::{
    self, AoFactors, GradientShading, RaycastInput, RaycastParams, Shading, ERT_THRESHOLD,
    NORMAL_THRESHOLD, SHININESS, SPECULAR, STEP,
};
use crate::render::{Grid, MethodInput, Rendered};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// The AO volume's grid, and its local variance's.
pub const AO_GRID: &str = "ao";
pub const AO_VARIANCE_GRID: &str = "ao_variance";
/// Occlusion sweeping's signed distance (a level set) and octant visibilities.
pub const SDF_GRID: &str = "sdf";
pub const AO_OCTANT_GRIDS: [&str; 8] = [
    "ao_oct0", "ao_oct1", "ao_oct2", "ao_oct3", "ao_oct4", "ao_oct5", "ao_oct6", "ao_oct7",
];

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
    pub ao_directions: u32,
    pub ao_field: FieldKind,
    pub ao_variance: bool,
    pub ao_iso: Option<f32>,
    pub ao_gamma: f32,
    pub ao_alpha: f32,
    pub ao_light: AoLight,
    pub ao_convention: AoConvention,
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
        let geometric = GeometricParams::default();
        let march = RaycastParams::default();
        Self {
            step: march.step,
            ert_threshold: march.ert_threshold,
            ao_method: AoMethod::default(),
            ao_radius: vao.radius,
            ao_directions: crate::transport::DEFAULT_DIRECTIONS,
            ao_field: FieldKind::default(),
            ao_variance: vao.variance,
            ao_iso: None,
            ao_gamma: geometric.gamma,
            ao_alpha: geometric.alpha,
            ao_light: AoLight::Ambient,
            ao_convention: AoConvention::default(),
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
    doc: "How the AO volume is computed: the visibility by discrete ordinates (the default: \
          straight paths, the most accurate at O(voxels x directions)), occlusion sweeping, or a \
          VAO estimator from the local statistics",
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
                doc: "Occlusion sweeping: the ambient occlusion of an iso-surface (ao_iso) from \
                      its signed distance, in eight octant sweeps at any range",
            },
            Choice {
                name: "sweep-physical",
                doc: "Visibility: the mean transmittance of the extinction over all directions, \
                      in eight sweeps at any range (exact AO-shaded DVR up to its error)",
            },
            Choice {
                name: "ordinates",
                doc: "Visibility by discrete ordinates: the mean transmittance along straight \
                      paths in 64 directions, each swept across the grid, at any range",
            },
        ],
    },
};
const AO_RADIUS: ParamSpec = ParamSpec {
    key: "ao_radius",
    doc: "Tangent-sphere radius in voxels (VAO's estimators)",
    kind: ParamKind::Int {
        range: Range::closed(1.0, MAX_RADIUS as f64),
        optional: false,
    },
};
const AO_DIRECTIONS: ParamSpec = ParamSpec {
    key: "ao_directions",
    doc: "Directions of the discrete ordinates (ao_method = \"ordinates\")",
    kind: ParamKind::Int {
        range: Range::closed(
            crate::transport::directions::MIN_DIRECTIONS as f64,
            crate::transport::directions::MAX_DIRECTIONS as f64,
        ),
        optional: false,
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
const AO_ISO: ParamSpec = ParamSpec {
    key: "ao_iso",
    doc: "Occlusion sweeping: the raw value's iso-surface; absent: where a voxel of the \
          classified extinction is half opaque",
    kind: ParamKind::Float {
        range: Range::FINITE,
        optional: true,
    },
};
const AO_GAMMA: ParamSpec = ParamSpec {
    key: "ao_gamma",
    doc: "Occlusion sweeping: AO^(1/gamma) as a post-process",
    kind: ParamKind::Float {
        range: Range::closed(0.1, 10.0),
        optional: false,
    },
};
const AO_ALPHA: ParamSpec = ParamSpec {
    key: "ao_alpha",
    doc:
        "Occlusion sweeping: the surface's opacity; below 1 it is translucent, lit from both sides",
    kind: ParamKind::Float {
        range: Range::above(0.0, 1.0),
        optional: false,
    },
};
const AO_LIGHT: ParamSpec = ParamSpec {
    key: "ao_light",
    doc: "Occlusion sweeping: where the ambient light comes from",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "ambient",
                doc: "Every direction: ambient occlusion",
            },
            Choice {
                name: "sky",
                doc: "The four octants above (+z): the paper's cloudy day, low-frequency shadows",
            },
        ],
    },
};

/// Where the geometric sweep's light comes from (`ao_light`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AoLight {
    #[default]
    Ambient,
    Sky,
}

impl AoLight {
    /// The octants' intensities.
    pub fn intensities(self) -> [f32; 8] {
        match self {
            AoLight::Ambient => [1.0; 8],
            AoLight::Sky => geometric::SKY,
        }
    }
}

const AO_CONVENTION: ParamSpec = ParamSpec {
    key: "ao_convention",
    doc: "What the exported ao grid means (the image shades with VAO's raw openness either way)",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "unoccluded",
                doc: "1 = unoccluded, as Blender shades: empty space and an open flat surface \
                      read 1, crevices and the air beside matter less (VAO: min(1, 2 x raw))",
            },
            Choice {
                name: "raw",
                doc: "VAO's openness as the paper defines it: the fraction of the tangent \
                      sphere less dense than the voxel, 1/2 in empty space and on a flat \
                      interface (VAO's estimators only)",
            },
        ],
    },
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
            iso: self.ao_iso,
            geometric: GeometricParams {
                gamma: self.ao_gamma,
                alpha: self.ao_alpha,
                intensities: self.ao_light.intensities(),
                ..Default::default()
            },
            octants: false,
            convention: self.ao_convention,
            directions: self.ao_directions,
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
        summary: "AO-shaded DVR: ambient light times an AO volume's openness (VAO, Ruiz et al. \
                  2010, or occlusion sweeping)",
        module: "render::ao_shaded",
        shaders: &[
            "raycast.wgsl",
            "vao_stats.wgsl",
            "vao_estimate.wgsl",
            "sweep.wgsl",
            "sweep_sdf.wgsl",
            "visibility.wgsl",
        ],
        lights: ALL_LIGHTS,
        layers: &["beauty", "depth"],
        grids: &[AO_GRID, AO_VARIANCE_GRID, SDF_GRID],
        chart: &[
            "ao_method = \"gauss\"\nao_radius = 4",
            "ao_method = \"gauss\"\nao_radius = 10",
            "ao_method = \"penner\"\nao_radius = 10",
            "ao_method = \"sweep-physical\"",
            "ao_method = \"ordinates\"",
        ],
        for_lights: &[LightKind::Ambient],
        params: &[
            STEP,
            ERT_THRESHOLD,
            AO_METHOD,
            AO_RADIUS,
            AO_DIRECTIONS,
            AO_FIELD,
            AO_VARIANCE,
            AO_ISO,
            AO_GAMMA,
            AO_ALPHA,
            AO_LIGHT,
            AO_CONVENTION,
            OPACITY_MODULATION,
            VARIANCE_MAX,
            DIRECT,
            SPECULAR,
            SHININESS,
            NORMAL_THRESHOLD,
        ],
    };

    /// Ambient light occluded by the medium's transmittance (the `ambient` reference): what
    /// the physical sweep computes, and what the other AO volumes stand in for.
    fn model(&self) -> Option<Model> {
        Some(Model {
            estimator: crate::render::reference::Estimator::Ambient,
            g: 0.0,
        })
    }

    fn resolve(self) -> Result<Self> {
        let defaults = Self::default();
        AO_RADIUS.check(self.ao_radius as f64)?;
        AO_DIRECTIONS.check(self.ao_directions as f64)?;
        AO_ISO.check_optional(self.ao_iso)?;
        AO_GAMMA.check(self.ao_gamma as f64)?;
        AO_ALPHA.check(self.ao_alpha as f64)?;
        let geometric_keys = [
            (AO_ISO, self.ao_iso.is_some()),
            (AO_GAMMA, self.ao_gamma != defaults.ao_gamma),
            (AO_ALPHA, self.ao_alpha != defaults.ao_alpha),
            (AO_LIGHT, self.ao_light != defaults.ao_light),
        ];
        if let Some((key, _)) = geometric_keys.iter().find(|(_, set)| *set) {
            if self.ao_method != AoMethod::Sweep {
                return Err(key.error(format!(
                    "shapes occlusion sweeping: only for ao_method = \"sweep\" (not \"{}\")",
                    self.ao_method.name()
                )));
            }
        }
        if self.ao_convention != defaults.ao_convention
            && !matches!(self.ao_method, AoMethod::Vao(_))
        {
            return Err(AO_CONVENTION.error(format!(
                "\"{}\" is VAO's own openness: only for VAO's estimators (the sweeps' AO already \
                 reads 1 where nothing occludes; not \"{}\")",
                self.ao_convention.name(),
                self.ao_method.name()
            )));
        }
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
            AoMethod::Sweep | AoMethod::SweepPhysical | AoMethod::Ordinates
                if self.ao_field != FieldKind::Extinction =>
            {
                return Err(AO_FIELD.error(
                    "the sweeps read the classified extinction (ao_iso picks a raw value's surface)",
                ));
            }
            AoMethod::Sweep | AoMethod::SweepPhysical | AoMethod::Ordinates
                if self.ao_variance || self.opacity_modulation =>
            {
                return Err(AO_VARIANCE.error(
                    "the sweeps compute no local variance (nor opacity modulation from it)",
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

    /// The openness; VAO's variance when asked for; the geometric sweep's signed distance.
    fn grids(&self) -> Vec<&'static str> {
        let mut grids = vec![AO_GRID];
        if self.ao_variance && matches!(self.ao_method, AoMethod::Vao(_)) {
            grids.push(AO_VARIANCE_GRID);
        }
        if self.ao_method == AoMethod::Sweep {
            grids.push(SDF_GRID);
        }
        grids
    }

    /// The AO volume's computation, and then its grids beside the volume while rendering.
    fn peak_volumes(&self) -> f64 {
        self.ao_method
            .peak_volumes()
            .max(crate::method::RENDER_PEAK_VOLUMES + self.grids().len() as f64)
    }
}

/// Computes the AO volume (progress: its units first, then the image rows) and renders with it;
/// the grids are the openness (in `ao_convention`) and, if asked for, the local variance; the
/// geometric sweep's signed distance.
///
/// The image shades with the openness as the method computes it: VAO's raw openness, the
/// fraction of the whole tangent sphere (1/2 on a flat interface, as the visibility of a point on
/// an opaque wall under ambient light), whatever the grid's convention.
pub fn render(input: &MethodInput, params: &AoParams) -> Result<Rendered> {
    let (compute, progress) = (input.compute, input.progress);
    let mut volume_params = params.ao_volume();
    if volume_params.vao().is_some() {
        volume_params.convention = AoConvention::Raw;
    }
    let ao = ao_volumes::ao_volume(
        compute,
        Cow::Borrowed(input.volume),
        input.classification,
        &volume_params,
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
        volume: params.ao_convention.apply(params.ao_method, ao.openness)?,
    }];
    if let (true, Some(variance)) = (params.ao_variance, ao.variance) {
        grids.push(Grid {
            name: AO_VARIANCE_GRID,
            volume: variance,
        });
    }
    if let Some(sdf) = ao.sdf {
        grids.push(Grid {
            name: SDF_GRID,
            volume: sdf,
        });
    }
    Ok(Rendered { image, grids })
}
