//! DOS as a scene method: its `[render]` keys, ranges and registry entry.

use super::{ClipPlane, DosInput, DosParams, MAX_CLIP_PLANES, MAX_GRID};
use crate::error::{Error, Result};
use crate::lights::LightKind;
use crate::method::{Choice, MethodSpec, Model, ParamKind, ParamSpec, Range, RenderMethod};
use crate::render::reference::Estimator;
use crate::render::{MethodInput, Rendered};

pub const THETA_DEG: ParamSpec = ParamSpec {
    key: "theta_deg",
    doc: "Cone half-angle in degrees; 0 is the line towards the viewer",
    kind: ParamKind::Float {
        range: Range::below(0.0, 90.0),
        optional: false,
    },
};
pub const GRID: ParamSpec = ParamSpec {
    key: "grid",
    doc: "n: the cone base is sampled on an n x n grid",
    kind: ParamKind::Int {
        range: Range::closed(1.0, MAX_GRID as f64),
        optional: false,
    },
};
pub const SLICE_DISTANCE: ParamSpec = ParamSpec {
    key: "slice_distance",
    doc: "Distance between slices in world units; absent: the smallest voxel spacing",
    kind: ParamKind::Float {
        range: Range::POSITIVE,
        optional: true,
    },
};
const DISTANCE: ParamSpec = ParamSpec {
    key: "distance",
    doc: "Path length of a cone sample through the previous slab",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "exact",
                doc: "sqrt(d^2 + r^2): the slanted path (the paper's Algorithm 2)",
            },
            Choice {
                name: "approximate",
                doc: "d for every sample (Algorithm 3)",
            },
        ],
    },
};
const SAMPLING: ParamSpec = ParamSpec {
    key: "sampling",
    doc: "How the n x n samples spread over the cone",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "solid-angle",
                doc: "each sample stands for an equal solid angle, as the cone phase function \
                      weighs directions",
            },
            Choice {
                name: "area",
                doc: "each stands for an equal area of the base, a disc of radius d tan(theta) \
                      (the paper)",
            },
        ],
    },
};
const FORMULATION: ParamSpec = ParamSpec {
    key: "formulation",
    doc: "How the volume is cut into slabs",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "slices",
                doc: "View-aligned planes d apart in depth (the paper)",
            },
            Choice {
                name: "rays",
                doc: "Lock-step ray marching: steps of d along every ray",
            },
        ],
    },
};
const SELF_OCCLUSION: ParamSpec = ParamSpec {
    key: "self_occlusion",
    doc: "Light also crosses the front half of the sample's own segment (not in the paper)",
    kind: ParamKind::Bool,
};
pub const CLIP_PLANES: ParamSpec = ParamSpec {
    key: "clip_planes",
    doc: "Planes { point, normal } removing the material on the side the normal points to",
    kind: ParamKind::Planes {
        max: MAX_CLIP_PLANES,
    },
};

impl RenderMethod for DosParams {
    const SPEC: MethodSpec = MethodSpec {
        name: "dos",
        summary: "Directional occlusion shading: ambient light through a cone towards the viewer \
                  (Schott et al. 2009)",
        module: "render::dos",
        shaders: &["dos.wgsl"],
        lights: &[LightKind::Ambient],
        layers: &["beauty", "depth", "occlusion"],
        grids: &[],
        chart: &[
            "theta_deg = 30",
            "theta_deg = 50",
            "theta_deg = 80",
            "theta_deg = 80\nsampling = \"area\"",
        ],
        for_lights: &[LightKind::Ambient],
        params: &[
            THETA_DEG,
            GRID,
            SLICE_DISTANCE,
            DISTANCE,
            SAMPLING,
            FORMULATION,
            SELF_OCCLUSION,
            CLIP_PLANES,
        ],
    };

    /// Ambient light through the cone of half-angle theta towards the viewer (the `cone`
    /// reference).
    fn model(&self) -> Option<Model> {
        Some(Model {
            estimator: Estimator::Cone {
                aperture: self.theta_deg.to_radians(),
            },
            g: 0.0,
        })
    }

    /// Normalises the clipping planes' normals, then validates.
    fn resolve(mut self) -> Result<Self> {
        for (i, plane) in self.clip_planes.iter_mut().enumerate() {
            if !plane.normal.is_finite() || plane.normal.length() == 0.0 {
                return Err(Error::param(
                    format!("render.clip_planes[{i}].normal"),
                    "must be a finite non-zero vector",
                ));
            }
            *plane = ClipPlane {
                point: plane.point,
                normal: plane.normal.normalize(),
            };
        }
        self.validate()?;
        Ok(self)
    }

    fn render(&self, input: &MethodInput) -> Result<Rendered> {
        let dos_input = DosInput {
            volume: input.volume,
            lut: input.lut,
            camera: input.camera,
            lighting: input.lighting,
            params: self,
        };
        Ok(Rendered {
            image: super::render(input.compute, &dos_input, input.progress)?,
            grids: Vec::new(),
        })
    }
}
