//! IPSVI's CPU and GPU twins render the same images. These tests need a Vulkan (or Metal/DX12)
//! adapter and fail without one: `apt-get install mesa-vulkan-drivers` provides lavapipe on a
//! machine without a GPU.
//!
//! Tolerance, per case (the CT phantom, 32^3, "ct-bone", 48 x 48 pixels):
//! - what the view alone decides, per pixel as the ray caster's twins (tests/raycast_twins.rs):
//!   alpha within 1e-3 and depth within 1e-3 world units (or background in both), except where
//!   a transmittance crossed 0.5 or the early-termination threshold in one twin only (up to
//!   0.5 % of the image);
//! - the light, per pixel: RGB within 1e-3 times max(1, peak radiance), as the ray caster's
//!   twins, and the shadow layer's P within 1e-2, except on up to 1 % of the image (its A is
//!   the alpha, to the bit on each twin);
//! - the light, over the image: the relative RMSE of RGB over the volume's pixels
//!   (docs/architecture.md#error-measure, `design_error`) and the RMSE of the shadow layer's P,
//!   each at most 1e-3.
//!
//! Why: the twins run the same operations in the same order, trilinear interpolation included
//! (the shader loads the eight voxels and interpolates in f32 as the CPU does, so no sampler's
//! 8-bit weights enter on hardware: tests/gpu_volume.rs), so most pixels differ by float
//! rounding alone (exp, division and square roots may differ in the last bits on a GPU, and
//! the compiler may fuse multiply-adds); the ray caster's twins allow 1e-3 of the peak per
//! pixel for it, and here the same samples also make up the light's optical depth, an
//! integral of the same kind as the view's, so 1e-3 bounds the image's RMS difference too. Some differences are not rounding: a comparison of two travels `s <= s_x`,
//! the least of two nearly equal entries of a texel or (basic scheme) the heavier of two nearly
//! equal bilinear weights can go the other way in one twin, and then a sample takes its light
//! from another entry. With piecewise integration both entries hold the same cache ray's
//! transmittance cut into other midpoint pieces, so the sample's light differs by the
//! quadrature's error, and the entries built on it later inherit that much (no more: each is
//! again an integral along its ray); in the basic scheme it differs by the method's
//! interpolation error, and carries on along the light. Such pixels are rare and isolated,
//! hence an allowed fraction of them rather than a wider per-pixel bound. How far rounding alone
//! moves the method, measured on the CPU by moving the camera by 2e-7 of its distance: here
//! 6e-7 to 1.5e-5 relative RMSE (the same order as between the twins); on the engine at 256^2
//! (examples/engine-sun.toml) 1.9e-4 piecewise and 9e-4 in the basic scheme, where the twins
//! differed by 8e-6 and 4.4e-4 on lavapipe. A wrong cache or merge changes whole regions by up
//! to the method's own error (1e-2 to 1e-1, tests/ipsvi.rs): a cache that could move back
//! towards the light made 2e-4 to 5e-3 here. Traced in pieces, a line must give the same image
//! to the bit: the merge is exact whatever the threads do.
//!
//! The shadow layer's P = sum_l W_l P_l / sum_l W_l is built from the sums the image is: P_l
//! sums the light's transmittance with the view's weights T alpha, and W_l the irradiance with
//! the same weights, where the image sums their product with albedo and phase. So it differs
//! as the light and the alpha do, and is held to the bounds the image's RGB and alpha have
//! (which is why they hold on hardware samplers, above, for it too); being continuous (no
//! threshold at opacity 0.5 any more), it has no pixel where one twin's rounding flips it.
//!
//! Multiple scattering is held to the same tolerance: its diffuse term is a smooth function of
//! the same transmittance and of each cache ray's optical depth through the box (the chords,
//! the same midpoint sums on both twins), so it differs as the light does; the GPU's
//! exp(x) - 1 where WGSL has no expm1 adds about 1e-5 of the term at most (|x| >= 1e-2 there).
//!
//! Measured on lavapipe (Mesa 22.3, LLVM 15): relative RMSE 1.3e-7 to 6.3e-6 (8.0e-6 with
//! multiple scattering), worst RGB 7.1e-6 (7.5e-5 with multiple scattering: the one pixel of
//! the lamp inside whose light single scattering already takes from another entry, 2.0e-5
//! there, times the brighter diffuse light; every other pixel within 2e-6), worst alpha 9.1e-6,
//! the shadow layer's P: RMSE at most 4.5e-7 (worst pixel 9.4e-6), no outliers; the printed
//! lines give each case's.

mod common;
use common::twins::{ctx, orthographic};

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::classify::presets::preset;
use occlux::lights::{Light, Lighting};
use occlux::metric::design_error;
use occlux::progress::NoProgress;
use occlux::render::ipsvi::sweep::{Lines, Shape};
use occlux::render::ipsvi::{cpu, gpu, IpsviInput, IpsviParams, Scattering};
use occlux::render::{RenderImage, BACKGROUND_DEPTH};
use occlux::volume::{phantom, Volume};

/// The largest light difference an outlier may have (RGB relative to the peak, or the shadow
/// layer's): a sample that takes its light from another cache entry differs by the method's
/// interpolation or quadrature error, a few percent at most (tests/ipsvi.rs); more is a defect
/// however rare (the image's RMSE bound alone would let one pixel of 2304 differ by ~0.05).
const OUTLIER_CAP: f32 = 0.05;

const BACKGROUND: Vec3 = Vec3::new(0.05, 0.04, 0.03);

fn sun(to_light: Vec3) -> Light {
    Light::Directional {
        to_light: to_light.normalize(),
        irradiance: Vec3::new(3.0, 2.8, 2.5),
    }
}

/// A lamp giving about the sun's irradiance at the volume.
fn lamp(position: Vec3) -> Light {
    Light::Point {
        position,
        intensity: Vec3::new(3.0, 2.8, 2.5) * position.length_squared().max(1.0),
    }
}

/// A perspective view that the phantom fills, 48 x 48.
fn camera() -> Camera {
    Camera::look_at(
        Vec3::new(2.4, -2.6, 1.4),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective {
            fov_y: 30f32.to_radians(),
        },
        48,
        48,
    )
    .unwrap()
}

fn phantom() -> Volume {
    phantom::ct(32).unwrap()
}

type Render = (RenderImage, Vec<f32>);

/// Renders on both twins.
fn render_both(
    volume: &Volume,
    camera: &Camera,
    lights: Vec<Light>,
    params: &IpsviParams,
) -> (Render, Render) {
    let lut = preset("ct-bone").unwrap().bake(volume);
    let lighting = Lighting {
        lights,
        background: BACKGROUND,
    };
    let input = IpsviInput {
        volume,
        lut: &lut,
        camera,
        lighting: &lighting,
        params,
    };
    // Each image with its shadow layer's P (its A is the image's alpha).
    let with_layer = |img: RenderImage| {
        let layer = img.factor("shadow").expect("a shadow layer");
        let coverage: Vec<f32> = img.rgba.iter().map(|p| p[3]).collect();
        assert_eq!(layer.coverage(), coverage, "A is the alpha");
        let shadow = layer.premultiplied();
        (img, shadow)
    };
    let on_cpu = with_layer(cpu::render(&input, &NoProgress).unwrap());
    let on_gpu = with_layer(gpu::render(&ctx(), &input, &NoProgress).unwrap());
    (on_cpu, on_gpu)
}

/// How the GPU's render differs from the CPU's (see the module docs for each measure).
struct Differences {
    pixels: usize,
    rel_rmse: f64,
    bias: f64,
    shadow_rmse: f64,
    /// Largest differences among the pixels within the per-pixel bounds.
    worst_rgb: f32,
    worst_alpha: f32,
    worst_shadow: f32,
    /// Pixels beyond the per-pixel bounds of the view (alpha, depth) and of the light.
    view_outliers: usize,
    light_outliers: usize,
    /// The largest light difference among the outliers: RGB relative to the peak, or shadow.
    worst_outlier: f32,
}

impl Differences {
    fn between((cpu_img, cpu_shadow): &Render, (gpu_img, gpu_shadow): &Render) -> Self {
        let rgb: Vec<[f32; 3]> = cpu_img.rgba.iter().map(|p| [p[0], p[1], p[2]]).collect();
        let grey_background = BACKGROUND.element_sum() / 3.0;
        let (_, rel_rmse, bias, _) =
            design_error(&gpu_img.rgba, &rgb, None, grey_background).unwrap();
        let peak = rgb.iter().flatten().fold(1.0f32, |a, &b| a.max(b));
        let pixels = rgb.len();
        let mut d = Self {
            pixels,
            rel_rmse,
            bias,
            shadow_rmse: 0.0,
            worst_rgb: 0.0,
            worst_alpha: 0.0,
            worst_shadow: 0.0,
            view_outliers: 0,
            light_outliers: 0,
            worst_outlier: 0.0,
        };
        let mut shadow_sq = 0.0f64;
        for i in 0..pixels {
            let (a, b) = (cpu_img.rgba[i], gpu_img.rgba[i]);
            let (da, db) = (cpu_img.depth[i], gpu_img.depth[i]);
            let alpha = (a[3] - b[3]).abs();
            let depth_ok =
                (da == BACKGROUND_DEPTH) == (db == BACKGROUND_DEPTH) && (da - db).abs() <= 1e-3;
            if alpha > 1e-3 || !depth_ok {
                d.view_outliers += 1;
            } else {
                d.worst_alpha = d.worst_alpha.max(alpha);
            }
            let colour = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max);
            let shadow = (cpu_shadow[i] - gpu_shadow[i]).abs();
            shadow_sq += (shadow as f64).powi(2);
            if colour > 1e-3 * peak || shadow > 1e-2 {
                d.light_outliers += 1;
                d.worst_outlier = d.worst_outlier.max(colour / peak).max(shadow);
            } else {
                d.worst_rgb = d.worst_rgb.max(colour);
                d.worst_shadow = d.worst_shadow.max(shadow);
            }
        }
        d.shadow_rmse = (shadow_sq / pixels as f64).sqrt();
        d
    }

    /// Prints the measures and checks the stated tolerance.
    fn assert_within_tolerance(&self, name: &str) {
        println!(
            "{name:<34} RGB relative RMSE {:.1e} (bias {:+.1e}), worst {:.1e}; alpha worst \
             {:.1e}; shadow RMSE {:.1e}, worst {:.1e}; outliers: view {}, light {} of {} \
             (worst {:.1e})",
            self.rel_rmse,
            self.bias,
            self.worst_rgb,
            self.worst_alpha,
            self.shadow_rmse,
            self.worst_shadow,
            self.view_outliers,
            self.light_outliers,
            self.pixels,
            self.worst_outlier
        );
        assert!(
            self.view_outliers <= self.pixels / 200,
            "{name}: {} pixels' alpha or depth differ",
            self.view_outliers
        );
        assert!(
            self.light_outliers <= self.pixels / 100,
            "{name}: {} pixels' light differs",
            self.light_outliers
        );
        assert!(
            self.worst_outlier <= OUTLIER_CAP,
            "{name}: an outlier's light differs by {}",
            self.worst_outlier
        );
        assert!(
            self.rel_rmse <= 1e-3,
            "{name}: RGB relative RMSE {}",
            self.rel_rmse
        );
        assert!(
            self.shadow_rmse <= 1e-3,
            "{name}: shadow RMSE {}",
            self.shadow_rmse
        );
    }
}

/// Renders on both twins and checks that they agree; the image must show the volume lit.
fn compare(name: &str, camera: &Camera, lights: Vec<Light>, params: &IpsviParams) {
    let (on_cpu, on_gpu) = render_both(&phantom(), camera, lights, params);
    let covered = on_cpu.0.rgba.iter().filter(|p| p[3] > 0.5).count();
    assert!(
        covered > on_cpu.0.rgba.len() / 4,
        "{name}: {covered} pixels"
    );
    let mut gpu_values = on_gpu.0.rgba.iter().flatten().chain(&on_gpu.1);
    assert!(gpu_values.all(|v| v.is_finite()), "{name}: not finite");
    Differences::between(&on_cpu, &on_gpu).assert_within_tolerance(name);
}

#[test]
fn suns_and_lamps_anywhere_agree() {
    let camera = camera();
    let params = IpsviParams::default();
    for (name, light) in [
        ("sun behind the viewer", sun(Vec3::new(0.6, -0.7, 0.9))),
        ("sun behind the volume", sun(Vec3::new(-0.8, 1.0, 0.3))),
        // Within 60 degrees of the box as the lamp sees it: the planar map.
        ("lamp outside", lamp(Vec3::new(-1.5, -2.5, 2.0))),
        // In the phantom's larger air cavity: the octahedral map over the whole sphere.
        ("lamp inside the volume", lamp(Vec3::new(0.35, 0.1, 0.1))),
    ] {
        compare(name, &camera, vec![light], &params);
    }
}

#[test]
fn a_sun_along_an_orthographic_view_agrees_as_one_line() {
    let camera = orthographic();
    let light = sun(-camera.forward);
    let shape = Shape::of(&light, &camera).unwrap();
    assert_eq!(shape, Shape::Degenerate);
    assert_eq!(Lines::new(shape, camera.width, camera.height, 1).count(), 1);
    compare(
        "orthographic sun along the view",
        &camera,
        vec![light],
        &IpsviParams::default(),
    );
}

#[test]
fn wide_lines_the_basic_scheme_and_a_set_cache_size_agree() {
    let camera = camera();
    let behind = sun(Vec3::new(-0.8, 1.0, 0.3));
    let cases = [
        (
            "line width 4",
            IpsviParams {
                line_width: 4,
                ..IpsviParams::default()
            },
        ),
        (
            "basic scheme (piecewise off)",
            IpsviParams {
                piecewise: false,
                ..IpsviParams::default()
            },
        ),
        (
            "cache of 40 texels",
            IpsviParams {
                cache_size: Some(40),
                g: 0.4,
                ..IpsviParams::default()
            },
        ),
    ];
    for (name, params) in cases {
        compare(name, &camera, vec![behind], &params);
    }
}

#[test]
fn transport_agrees() {
    // Both twins read the same field (solved on the CPU) trilinearly in the same corner
    // order, so it adds only the rounding of eight products per sample to the tolerance's
    // causes above: the light scattered once more differs as the samples' positions do.
    let camera = camera();
    let params = IpsviParams {
        scattering: Scattering::Transport,
        g: 0.4,
        ..IpsviParams::default()
    };
    compare(
        "transport, a sun and a lamp inside",
        &camera,
        vec![
            sun(Vec3::new(-0.8, 1.0, 0.3)),
            lamp(Vec3::new(0.35, 0.1, 0.1)),
        ],
        &params,
    );
}

#[test]
fn multiple_scattering_agrees() {
    // The diffuse term is a smooth function of the same transmittance (its slope in the
    // optical depth is below the albedo), so it differs as the light does; the GPU's
    // exp(x) - 1 where WGSL has no expm1 adds at most 1e-5 relative (|x| >= 1e-2 there).
    let camera = camera();
    let params = IpsviParams {
        scattering: Scattering::Multiple,
        g: 0.4,
        ..IpsviParams::default()
    };
    for (name, light) in [
        (
            "multiple, sun behind the volume",
            sun(Vec3::new(-0.8, 1.0, 0.3)),
        ),
        (
            "multiple, lamp inside the volume",
            lamp(Vec3::new(0.35, 0.1, 0.1)),
        ),
    ] {
        compare(name, &camera, vec![light], &params);
    }
}

#[test]
fn two_lights_agree() {
    // The second pass starts from an empty cache of another size and adds its light.
    compare(
        "a sun and a lamp inside",
        &camera(),
        vec![
            sun(Vec3::new(0.6, -0.7, 0.9)),
            lamp(Vec3::new(0.35, 0.1, 0.1)),
        ],
        &IpsviParams::default(),
    );
}

#[test]
fn lines_traced_in_pieces_give_the_same_image() {
    // A write list of 64 KiB holds the writes of 12 rays (448 each at most through this box), so
    // every longer line is traced in pieces that read the same cache: the merge is exact, so
    // nothing may change, to the bit.
    let volume = phantom();
    let lut = preset("ct-bone").unwrap().bake(&volume);
    let params = IpsviParams::default();
    for (camera, light) in [
        (orthographic(), sun(-orthographic().forward)),
        (camera(), sun(Vec3::new(-0.8, 1.0, 0.3))),
    ] {
        let lighting = Lighting {
            lights: vec![light],
            background: BACKGROUND,
        };
        let input = IpsviInput {
            volume: &volume,
            lut: &lut,
            camera: &camera,
            lighting: &lighting,
            params: &params,
        };
        let whole = gpu::render(&ctx(), &input, &NoProgress).unwrap();
        let pieces = gpu::render_with_write_list(&ctx(), &input, &NoProgress, 64 << 10).unwrap();
        let layer = |img: &RenderImage| img.factor("shadow").unwrap().values.clone();
        let (whole_layer, pieces_layer) = (layer(&whole), layer(&pieces));
        let differ = (0..whole.rgba.len())
            .filter(|&i| {
                whole.rgba[i] != pieces.rgba[i]
                    || whole.depth[i] != pieces.depth[i]
                    || whole_layer[i] != pieces_layer[i]
            })
            .count();
        assert_eq!(
            differ, 0,
            "pixels that differ when lines are traced in pieces"
        );
    }
}
