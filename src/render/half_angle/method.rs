//! Half-angle slicing as a scene method: its `[render]` keys, ranges and registry entry.

use super::{HalfAngleInput, HalfAngleParams};
use crate::error::Result;
use crate::lights::LightKind;
use crate::method::{MethodSpec, Model, ParamKind, ParamSpec, Range, RenderMethod};
use crate::optics::phase::G;
use crate::render::reference::Estimator;
use crate::render::{MethodInput, Rendered};

pub const SLICE_DISTANCE: ParamSpec = ParamSpec {
    key: "slice_distance",
    doc: "Distance between slices along the half vector in world units; absent: the smallest \
          voxel spacing",
    kind: ParamKind::Float {
        range: Range::POSITIVE,
        optional: true,
    },
};
pub const LIGHT_BUFFER: ParamSpec = ParamSpec {
    key: "light_buffer",
    doc: "Texels along the light buffer's longer side; absent: half a pixel wide at the \
          volume's centre, at most a voxel",
    kind: ParamKind::Int {
        range: Range::closed(1.0, crate::render::ipsvi::MAX_CACHE_SIZE as f64),
        optional: true,
    },
};

impl RenderMethod for HalfAngleParams {
    const SPEC: MethodSpec = MethodSpec {
        name: "half-angle",
        summary: "Half-angle slicing: single scattering with shadows from suns and lamps, slices \
                  along the half vector shared by the eye and a light buffer (Kniss et al. 2003; \
                  IPSVI's baseline); CPU only",
        module: "render::half_angle",
        shaders: &[],
        lights: &[LightKind::Directional, LightKind::Point],
        layers: &["beauty", "depth", "shadow"],
        grids: &[],
        chart: &[""],
        for_lights: &[LightKind::Directional, LightKind::Point],
        params: &[SLICE_DISTANCE, LIGHT_BUFFER, G],
    };

    /// Single scattering with shadows, with its phase asymmetry.
    fn model(&self) -> Option<Model> {
        Some(Model {
            estimator: Estimator::Single,
            g: self.g,
        })
    }

    fn resolve(self) -> Result<Self> {
        self.validate()?;
        Ok(self)
    }

    /// Renders on the CPU whatever the device: there is no GPU twin.
    fn render(&self, input: &MethodInput) -> Result<Rendered> {
        let half_angle = HalfAngleInput {
            volume: input.volume,
            lut: input.lut,
            camera: input.camera,
            lighting: input.lighting,
            params: self,
        };
        let image = super::cpu::render(&half_angle, input.progress)?;
        Ok(Rendered {
            image,
            grids: Vec::new(),
        })
    }
}
