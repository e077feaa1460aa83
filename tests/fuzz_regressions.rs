//! What the fuzz targets past the parser found (fuzz/README.md), each reproduced through the
//! public API; their inputs are in fuzz/regressions/<target>/.

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::classify::{presets, Classification};
use occlux::gpu::Compute;
use occlux::lights::{Light, Lighting};
use occlux::progress::NoProgress;
use occlux::registry::Method;
use occlux::render::{MethodInput, RenderImage};
use occlux::volume::Volume;

/// `[render]` keys `table` (TOML) rendered on the CPU at 8 x 8 pixels, the camera looking at
/// the volume's centre from `from` (relative to it).
fn render(
    table: &str,
    volume: &Volume,
    classification: &Classification,
    lighting: &Lighting,
    from: Vec3,
) -> RenderImage {
    let (lo, hi) = volume.bounds();
    let centre = 0.5 * (lo + hi);
    let camera = Camera::look_at(
        centre + from,
        centre,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.8 },
        8,
        8,
    )
    .unwrap();
    let method = Method::from_table(toml::from_str(table).unwrap()).unwrap();
    let lut = classification.bake(volume);
    let input = MethodInput {
        volume,
        classification,
        lut: &lut,
        camera: &camera,
        lighting,
        compute: &Compute::Cpu,
        progress: &NoProgress,
    };
    method.render(&input).unwrap().image
}

fn assert_finite(image: &RenderImage, what: &str) {
    for (p, rgba) in image.rgba.iter().enumerate() {
        assert!(
            rgba.iter().all(|c| c.is_finite()),
            "{what}: pixel {p} is {rgba:?}"
        );
    }
    assert!(image.depth.iter().all(|d| d.is_finite()), "{what}: depth");
}

/// fuzz/regressions/render/gradient-overflow: values near 1e30 (finite, and spanning a finite
/// range) have gradients near 1e30, whose squared length overflows to infinity: the largest
/// gradient magnitude (src/volume/mod.rs, `max_gradient_magnitude`) and a sample's
/// (`gradient(p).length()`) are both infinite, and a 2D table's lookup (src/classify/lut.rs,
/// `Lut::coord`) divides one by the other: NaN, which the clamp passes through, in every pixel.
#[test]
fn a_2d_classification_of_values_near_1e30_renders_finite_pixels() {
    let volume = Volume::from_fn([4, 4, 4], Vec3::ONE, Vec3::ZERO, |p| 1e30 * (1.0 + p.x)).unwrap();
    let classification = presets::preset("boundary-2d").unwrap();
    let lighting = Lighting {
        lights: vec![Light::Ambient {
            radiance: Vec3::ONE,
        }],
        background: Vec3::ZERO,
    };
    let image = render(
        "method = \"unshaded\"",
        &volume,
        &classification,
        &lighting,
        Vec3::new(6.0, -6.0, 5.0),
    );
    assert_finite(&image, "unshaded");
}
