//! Scenes, CPU renders, Monte Carlo references and finiteness checks shared by the stability
//! suite (tests/stability.rs) and the temporal suite (tests/temporal.rs).

use occlux::gpu::Compute;
use occlux::progress::NoProgress;
use occlux::render::reference::{self, Estimator, ReferenceImage, ReferenceInput, ReferenceParams};
use occlux::render::{MethodInput, RenderImage, Rendered};
use occlux::scene::Scene;
use occlux::volume::Volume;
use std::path::Path;

/// What [`check_finite`] measured: the range of RGB and alpha over the image.
#[derive(Debug, Clone, Copy)]
pub struct Range {
    pub rgb: (f32, f32),
    pub alpha: (f32, f32),
}

/// Asserts every RGBA, depth (and shading-factor) value of `image` is finite, RGB >= 0 and
/// alpha in [0, 1]; the message counts the NaN and infinite values. Returns the value range.
pub fn check_finite(name: &str, image: &RenderImage) -> Range {
    let problems = finite_problems(image);
    assert!(problems.is_empty(), "{name}: {problems}");
    range_of(image)
}

/// As [`check_finite`], but returns the problem as text ("" when none) instead of panicking.
pub fn finite_problems(image: &RenderImage) -> String {
    let values = image
        .rgba
        .iter()
        .flatten()
        .chain(&image.depth)
        .chain(image.factor.iter().flat_map(|f| f.values.as_flattened()));
    let (mut nan, mut inf) = (0usize, 0usize);
    for v in values {
        nan += v.is_nan() as usize;
        inf += v.is_infinite() as usize;
    }
    let negative = image
        .rgba
        .iter()
        .flat_map(|p| &p[..3])
        .filter(|v| **v < 0.0)
        .count();
    let bad_alpha = image
        .rgba
        .iter()
        .filter(|p| !(0.0..=1.0).contains(&p[3]))
        .count();
    let n = image.rgba.len();
    let expected = n == (image.width * image.height) as usize && image.depth.len() == n;
    if nan + inf + negative + bad_alpha == 0 && expected {
        String::new()
    } else {
        format!(
            "{nan} NaN, {inf} infinite, {negative} negative RGB, {bad_alpha} alpha outside [0, 1] \
             over {n} pixels (sizes as expected: {expected})"
        )
    }
}

impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "RGB {:.4e}..{:.4e}, alpha {:.4}..{:.4}",
            self.rgb.0, self.rgb.1, self.alpha.0, self.alpha.1
        )
    }
}

pub fn range_of(image: &RenderImage) -> Range {
    let fold = |it: &mut dyn Iterator<Item = f32>| {
        it.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
    };
    Range {
        rgb: fold(&mut image.rgba.iter().flat_map(|p| p[..3].iter().copied())),
        alpha: fold(&mut image.rgba.iter().map(|p| p[3])),
    }
}

pub fn scene(text: &str) -> Scene {
    Scene::parse(text, Path::new(".")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Renders `scene`'s method on the CPU, on `volume` (the scene's own when None).
pub fn render_on(scene: &Scene, volume: &Volume) -> occlux::error::Result<Rendered> {
    let lut = scene.classification.bake(volume);
    scene.method.render(&MethodInput {
        volume,
        classification: &scene.classification,
        lut: &lut,
        camera: &scene.camera,
        lighting: &scene.lighting,
        compute: &Compute::Cpu,
        progress: &NoProgress,
    })
}

pub fn render(scene: &Scene) -> occlux::error::Result<RenderImage> {
    let volume = scene.load_volume()?;
    render_on(scene, &volume).map(|r| r.image)
}

/// The Monte Carlo reference of the scene (its own lights) at `spp`.
pub fn reference_of(scene: &Scene, estimator: Estimator, spp: u32) -> ReferenceImage {
    let volume = scene.load_volume().unwrap();
    reference_on(scene, &volume, estimator, spp)
}

/// As [`reference_of`], on `volume` (already loaded, so that a series of cameras loads it once).
pub fn reference_on(
    scene: &Scene,
    volume: &Volume,
    estimator: Estimator,
    spp: u32,
) -> ReferenceImage {
    let lut = scene.classification.bake(volume);
    reference::render(
        &ReferenceInput {
            volume,
            lut: &lut,
            camera: &scene.camera,
            lighting: &scene.lighting,
            params: &ReferenceParams {
                estimator,
                spp,
                seed: 11,
                g: 0.0,
            },
        },
        &NoProgress,
    )
    .unwrap()
}
