//! Renderers. Each method has a CPU twin and a GPU twin that give the same image.

pub mod ao_shaded;
pub mod dos;
pub mod half_angle;
pub mod ipsvi;
pub mod occupancy;
pub mod raycast;
pub mod reference;

use crate::camera::Camera;
use crate::classify::{Classification, Lut};
use crate::gpu::Compute;
use crate::lights::Lighting;
use crate::progress::Progress;
use crate::volume::Volume;

/// What every rendering method reads: the placed volume, its classification baked into a
/// table, the scene's camera and lights, where to compute and whom to report progress to.
#[derive(Clone, Copy)]
pub struct MethodInput<'a> {
    pub volume: &'a Volume,
    pub classification: &'a Classification,
    pub lut: &'a Lut,
    pub camera: &'a Camera,
    pub lighting: &'a Lighting,
    pub compute: &'a Compute,
    pub progress: &'a dyn Progress,
}

/// A method's render and the grids it computed on the way (AO-shaded DVR's `ao`), which
/// `export` writes beside `density` and `value`.
pub struct Rendered {
    pub image: RenderImage,
    pub grids: Vec<Grid>,
}

/// A named grid on the volume's voxels.
pub struct Grid {
    pub name: &'static str,
    pub volume: Volume,
}

/// Depth written where a ray never reaches 50 % opacity (the value Blender writes for background).
pub const BACKGROUND_DEPTH: f32 = 1.0e10;

/// A rendered image: linear RGBA radiance (alpha = 1 - transmittance) and depth, row 0 at the
/// top, x fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderImage {
    pub width: u32,
    pub height: u32,
    /// Linear radiance with the background composited in; alpha is the volume's opacity.
    pub rgba: Vec<[f32; 4]>,
    /// Distance along the ray from the eye to where accumulated opacity crosses 0.5, or
    /// [`BACKGROUND_DEPTH`].
    pub depth: Vec<f32>,
    /// A method's shading factor at the depth, if it computes one.
    pub factor: Option<Factor>,
}

/// A per-pixel shading factor at the depth, 1 where the opacity never reaches 0.5: DOS's
/// `occlusion` (1 = unoccluded), IPSVI's `shadow` (1 = unshadowed). The EXR holds it as a
/// layer `name`, and the shaded image again under `method`, for compositing beside other
/// methods' layers.
#[derive(Clone, Debug, PartialEq)]
pub struct Factor {
    pub method: &'static str,
    pub name: &'static str,
    pub values: Vec<f32>,
}

impl RenderImage {
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            rgba: vec![[0.0; 4]; n],
            depth: vec![BACKGROUND_DEPTH; n],
            factor: None,
        }
    }

    /// The values of the shading factor called `name`, if the render has it.
    pub fn factor(&self, name: &str) -> Option<&[f32]> {
        self.factor
            .as_ref()
            .filter(|f| f.name == name)
            .map(|f| f.values.as_slice())
    }
}
