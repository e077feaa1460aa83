//! The ray caster's CPU and GPU twins render the same images. These tests need a Vulkan (or
//! Metal/DX12) adapter and fail without one: `apt-get install mesa-vulkan-drivers` provides
//! lavapipe on a machine without a GPU.
//!
//! Tolerance: per pixel, |RGBA_gpu - RGBA_cpu| <= 1e-3 * max(1, peak radiance) and depth within
//! 1e-3 world units (pixels where only one twin's transmittance crossed 0.5 or the
//! early-termination threshold within float rounding are allowed up to 0.5% of the image, and
//! none beyond 1e-2 of the peak). The twins interpolate the volume with the same f32
//! arithmetic (no sampler's 8-bit weights: tests/gpu_volume.rs), so on hardware as on lavapipe
//! they differ by the rounding of exp, pow and square roots and by fused multiply-adds.
//! Measured on lavapipe: see the printed worst differences.

mod common;
use common::twins::{assert_same, ctx, inside, orthographic, perspective};
use std::borrow::Cow;

use glam::Vec3;
use occlux::camera::Camera;
use occlux::classify::{presets, Classification};
use occlux::lights::{Light, Lighting};
use occlux::progress::NoProgress;
use occlux::render::raycast::{
    cpu, gpu, AoFactors, GradientShading, RaycastInput, RaycastParams, Shading,
};
use occlux::volume::{phantom, Volume};

fn lighting() -> Lighting {
    Lighting {
        lights: vec![
            Light::Ambient {
                radiance: Vec3::new(0.2, 0.25, 0.3),
            },
            Light::Directional {
                to_light: Vec3::new(-0.3, -1.0, 1.2).normalize(),
                irradiance: Vec3::splat(3.0),
            },
            Light::Point {
                position: Vec3::new(1.5, 1.0, 0.5),
                intensity: Vec3::new(2.0, 1.0, 0.5),
            },
        ],
        background: Vec3::new(0.05, 0.04, 0.03),
    }
}

/// Renders on both twins and checks the stated tolerance; returns the worst RGBA difference.
fn compare(
    volume: &Volume,
    classification: &Classification,
    camera: &Camera,
    params: &RaycastParams,
) -> f32 {
    compare_with_ao(volume, classification, camera, params, None)
}

fn compare_with_ao(
    volume: &Volume,
    classification: &Classification,
    camera: &Camera,
    params: &RaycastParams,
    ao: Option<AoFactors>,
) -> f32 {
    let lut = classification.bake(volume);
    let lighting = lighting();
    let input = RaycastInput {
        volume,
        lut: &lut,
        camera,
        lighting: &lighting,
        params,
        ao,
    };
    let on_cpu = cpu::render(&input, &NoProgress).unwrap();
    let on_gpu = gpu::render(&ctx(), &input, &NoProgress).unwrap();
    assert_same(&on_cpu, &on_gpu, 1e-3, None)
}

#[test]
fn gradient_shading_agrees_on_the_ct_phantom() {
    let volume = phantom::ct(48).unwrap();
    let params = RaycastParams {
        shading: Shading::Gradient(GradientShading::default()),
        ..RaycastParams::default()
    };
    compare(
        &volume,
        &presets::preset("ct-soft-tissue").unwrap(),
        &perspective(64),
        &params,
    );
}

#[test]
fn ambient_occlusion_shading_agrees_with_and_without_modulation_and_direct_light() {
    use occlux::ao::vao::{self, FieldKind, ScalarField, VaoParams};
    let volume = phantom::ct(48).unwrap();
    let classification = presets::preset("ct-soft-tissue").unwrap();
    let field = ScalarField::new(
        Cow::Borrowed(&volume),
        &classification,
        FieldKind::Extinction,
    )
    .unwrap();
    let ao = vao::ao_volume(
        &occlux::gpu::Compute::Cpu,
        Cow::Borrowed(&field),
        &VaoParams {
            radius: 4,
            variance: true,
            ..VaoParams::default()
        },
        &NoProgress,
    )
    .unwrap();
    let opacity = vao::opacity_modulation(ao.variance.as_ref().unwrap(), None).unwrap();
    for direct in [None, Some(GradientShading::default())] {
        for modulation in [None, Some(&opacity)] {
            let params = RaycastParams {
                shading: Shading::AmbientOcclusion { direct },
                ..RaycastParams::default()
            };
            let factors = AoFactors {
                openness: &ao.openness,
                opacity: modulation,
            };
            compare_with_ao(
                &volume,
                &classification,
                &perspective(48),
                &params,
                Some(factors),
            );
        }
    }
}

#[test]
fn unshaded_with_2d_transfer_function_and_emission_agrees() {
    let volume = phantom::shells(40).unwrap();
    let mut classification = presets::preset("boundary-2d").unwrap();
    classification.density_scale = 0.5;
    let params = RaycastParams {
        shading: Shading::Unshaded,
        step: Some(0.02),
        ert_threshold: 0.0,
    };
    compare(&volume, &classification, &perspective(48), &params);
    // Emission through a 1D table: the cloud glows.
    let cloud = phantom::cloud(40, 7).unwrap();
    let mut glow = presets::preset("simulation").unwrap();
    if let occlux::classify::TransferFunction::OneD(tf) = &glow.tf {
        let mut points = tf.points().to_vec();
        points
            .iter_mut()
            .for_each(|p| p.emission = [p.value, 0.5 * p.value, 0.1]);
        glow.tf = occlux::classify::TransferFunction::OneD(
            occlux::classify::TransferFunction1D::new(points).unwrap(),
        );
    }
    compare(&cloud, &glow, &perspective(48), &params);
}

#[test]
fn orthographic_and_inside_cameras_agree() {
    let volume = phantom::marschner_lobb(41).unwrap();
    let classification = presets::preset("simulation").unwrap();
    let params = RaycastParams {
        shading: Shading::Gradient(GradientShading::default()),
        ..RaycastParams::default()
    };
    let ortho = orthographic();
    compare(&volume, &classification, &ortho, &params);
    let inside = inside();
    compare(&volume, &classification, &inside, &params);
}

#[test]
fn volumes_beyond_one_storage_binding_render_on_both() {
    // 336 x 336 x 300 f32 = 129 MiB: more than lavapipe's 128 MiB storage binding.
    let dims = [336, 336, 300];
    let h = 2.0 / 336.0;
    let volume = Volume::from_fn(
        dims,
        Vec3::splat(h),
        Vec3::new(-1.0 + 0.5 * h, -1.0 + 0.5 * h, -0.9 + 0.5 * h),
        |p| (1.0 - p.length()).clamp(0.0, 1.0) * (0.5 + 0.5 * (6.0 * p.x).sin()),
    )
    .unwrap();
    assert!(volume.values().len() * 4 > 128 << 20);
    let params = RaycastParams {
        shading: Shading::Unshaded,
        step: Some(4.0 * h),
        ..RaycastParams::default()
    };
    compare(
        &volume,
        &presets::preset("simulation").unwrap(),
        &perspective(24),
        &params,
    );
}
