//! Renderers. Each method has a CPU twin and a GPU twin that give the same image.

pub mod ao_shaded;
pub mod dos;
pub mod half_angle;
pub mod ipsvi;
pub mod raycast;
pub mod reference;
pub mod steps;

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
    /// A method's shading factor, premultiplied by coverage, if it computes one.
    pub factor: Option<Factor>,
}

/// A per-pixel shading factor made for compositing: DOS's `occlusion` (the lit fraction of the
/// ambient light), IPSVI's and half-angle slicing's `shadow` (the lights' transmittance).
///
/// Along a pixel's ray, sample i has the contribution weight `w_i = T_i alpha_i` (T_i the
/// view's transmittance in front of it, alpha_i its opacity: the weights its colour is
/// composited with) and the method's factor `f_i` in [0, 1]. The layer holds per pixel
/// `[P, A]`: `P = sum_i w_i f_i`, the factor premultiplied by coverage, and
/// `A = sum_i w_i = 1 - T_final`, the coverage (the beauty's alpha). So `0 <= P <= A`, `P = A`
/// where nothing occludes and `P = A = 0` where nothing is; no threshold anywhere, so both
/// are as continuous as the image (an alpha-premultiplied grey, as EXR stores colour). To
/// shade another render of the same view by it: `render * (1 - strength * (A - P))`, which is
/// 1 where the layer has no coverage.
#[derive(Clone, Debug, PartialEq)]
pub struct Factor {
    pub name: &'static str,
    /// Per pixel `[P, A]`, row 0 at the top, x fastest.
    pub values: Vec<[f32; 2]>,
}

impl Factor {
    /// The layer `name` from per-pixel premultiplied factors and coverages: each P is clamped to
    /// [0, A], so that rounding never puts it outside.
    pub fn new(name: &'static str, premultiplied: &[f32], coverage: &[f32]) -> Self {
        Self {
            name,
            values: premultiplied
                .iter()
                .zip(coverage)
                .map(|(&p, &a)| [p.clamp(0.0, a.max(0.0)), a])
                .collect(),
        }
    }

    /// The factor's mean over what the image shows: the sum of P over the sum of coverage A
    /// (NaN if nothing covers any pixel).
    pub fn mean(&self) -> f64 {
        let (p, a) = self.values.iter().fold((0.0f64, 0.0f64), |(p, a), v| {
            (p + v[0] as f64, a + v[1] as f64)
        });
        if a > 0.0 {
            p / a
        } else {
            f64::NAN
        }
    }

    /// P per pixel.
    pub fn premultiplied(&self) -> Vec<f32> {
        self.values.iter().map(|v| v[0]).collect()
    }

    /// A per pixel.
    pub fn coverage(&self) -> Vec<f32> {
        self.values.iter().map(|v| v[1]).collect()
    }

    /// P / A per pixel, the coverage-weighted mean factor of what the pixel shows, and 1 where
    /// A is 0 (nothing there to shade).
    pub fn unpremultiplied(&self) -> Vec<f32> {
        self.values
            .iter()
            .map(|&[p, a]| if a > 0.0 { (p / a).min(1.0) } else { 1.0 })
            .collect()
    }
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

    /// The shading factor called `name`, if the render has it.
    pub fn factor(&self, name: &str) -> Option<&Factor> {
        self.factor.as_ref().filter(|f| f.name == name)
    }
}
