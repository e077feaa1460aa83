//! IPSVI as a scene method: its `[render]` keys, ranges and registry entry.

use super::{IpsviInput, IpsviParams, Scattering, MAX_CACHE_SIZE};
use crate::error::Result;
use crate::lights::LightKind;
use crate::method::{Choice, MethodSpec, Model, ParamKind, ParamSpec, Range, RenderMethod};
use crate::optics::phase::G;
use crate::render::raycast::{ERT_THRESHOLD, STEP};
use crate::render::reference::Estimator;
use crate::render::{MethodInput, Rendered};

pub const CACHE_SIZE: ParamSpec = ParamSpec {
    key: "cache_size",
    doc: "Texels along the longer side of the illumination cache (fitted to the volume as the \
          light sees it); absent: texels half a pixel wide at the volume's centre, at most a voxel",
    kind: ParamKind::Int {
        range: Range::closed(1.0, MAX_CACHE_SIZE as f64),
        optional: true,
    },
};
pub const LINE_WIDTH: ParamSpec = ParamSpec {
    key: "line_width",
    doc: "Rings or columns of pixels swept together after the first line (one pixel wide)",
    kind: ParamKind::Int {
        range: Range::closed(1.0, crate::camera::MAX_IMAGE_SIDE as f64),
        optional: false,
    },
};
const PIECEWISE: ParamSpec = ParamSpec {
    key: "piecewise",
    doc: "Integrate the light along its own path from the cache entry to the sample (off: the \
          paper's basic scheme, attenuating by the view ray's steps)",
    kind: ParamKind::Bool,
};

const SCATTERING: ParamSpec = ParamSpec {
    key: "scattering",
    doc: "Which scattered light is rendered",
    kind: ParamKind::Choice {
        options: &[
            Choice {
                name: "single",
                doc: "The light's first scattering, shadowed (Eq. 2 of the paper; the `single` \
                      reference)",
            },
            Choice {
                name: "multiple",
                doc: "Also light scattered before: the diffusion solution of a beam along each \
                      light ray, from its shadow transmittance (approximates the `multiple` \
                      reference)",
            },
            Choice {
                name: "transport",
                doc: "Also light scattered before, solved on the volume's grid by discrete \
                      ordinates (the `multiple` reference's model, 8 bounces)",
            },
        ],
    },
};

impl RenderMethod for IpsviParams {
    const SPEC: MethodSpec = MethodSpec {
        name: "ipsvi",
        summary: "Image plane sweep volume illumination: single (or approximated multiple) \
                  scattering with shadows from suns and lamps in one ray-casting pass (Sundén et al. 2011)",
        module: "render::ipsvi",
        shaders: &["ipsvi.wgsl", "ipsvi_merge.wgsl", "scattering.wgsl"],
        lights: &[LightKind::Directional, LightKind::Point],
        layers: &["beauty", "depth", "shadow"],
        grids: &[],
        chart: &[
            "",
            "cache_size = 128",
            "scattering = \"multiple\"",
            "scattering = \"transport\"",
        ],
        for_lights: &[LightKind::Directional, LightKind::Point],
        params: &[
            CACHE_SIZE,
            LINE_WIDTH,
            PIECEWISE,
            SCATTERING,
            G,
            STEP,
            ERT_THRESHOLD,
        ],
    };

    /// Single scattering with shadows, or multiple scattering, with its phase asymmetry.
    fn model(&self) -> Option<Model> {
        let estimator = match self.scattering {
            Scattering::Single => Estimator::Single,
            Scattering::Multiple | Scattering::Transport => Estimator::Multiple {
                bounces: crate::render::reference::DEFAULT_BOUNCES,
            },
        };
        Some(Model {
            estimator,
            g: self.g,
        })
    }

    fn resolve(self) -> Result<Self> {
        self.validate()?;
        Ok(self)
    }

    fn render(&self, input: &MethodInput) -> Result<Rendered> {
        let ipsvi_input = IpsviInput {
            volume: input.volume,
            lut: input.lut,
            camera: input.camera,
            lighting: input.lighting,
            params: self,
        };
        let image = super::render(input.compute, &ipsvi_input, input.progress)?;
        Ok(Rendered {
            image,
            grids: Vec::new(),
        })
    }
}
