//! DOS's CPU and GPU twins render the same images. These tests need a Vulkan (or Metal/DX12)
//! adapter and fail without one: `apt-get install mesa-vulkan-drivers` provides lavapipe on a
//! machine without a GPU.
//!
//! Tolerance: per pixel, |RGBA_gpu - RGBA_cpu| <= 1e-4 * max(1, peak radiance), the
//! occlusion layer's P and A each within 1e-4 and depth within 1e-3 world units; pixels where
//! only one twin's transmittance crossed 0.5 within float rounding are allowed up to 0.5% of
//! the image, and none beyond 1e-2 of the peak (tests/common/twins.rs). The twins interpolate
//! the volume with the same f32 arithmetic (the shader loads the eight voxels; no sampler's
//! low-precision weights, so this holds on hardware as on lavapipe) and differ by exp/log
//! rounding and fused multiply-adds; the occlusion buffer carries these differences from slab
//! to slab but averages them over the cone. Measured on lavapipe (LLVM 15): worst RGBA
//! difference 1.5e-5, worst difference of P or A 1.7e-5, no outliers; the tolerance leaves a
//! 6x margin for other drivers' exp and log.
//!
//! Why the layer's bound holds wherever the image's does (on hardware samplers too): A is the
//! image's alpha, and P = sum T alpha V is the image's lit term, sum T alpha albedo L_a V,
//! without albedo L_a, summed with the same weights in the same order on both twins. So P
//! differs as the radiance does divided by albedo L_a (about 1 in these cases: L_a 0.9-1.1,
//! the presets' albedo near 1; measured: P's worst difference 1.0-1.1 times the RGBA one),
//! and no threshold can turn a rounding difference into a step of the layer (the old layer,
//! V where T crossed 0.5, could jump between slabs there).

mod common;
use common::twins::{assert_same, ctx, inside, orthographic, perspective};

use glam::Vec3;
use occlux::camera::Camera;
use occlux::classify::{presets, Classification};
use occlux::lights::{Light, Lighting};
use occlux::progress::NoProgress;
use occlux::render::dos::{
    cpu, gpu, ClipPlane, ConeDistance, ConeSampling, DosInput, DosParams, Formulation,
};
use occlux::volume::{phantom, Volume};

fn lighting() -> Lighting {
    Lighting {
        lights: vec![Light::Ambient {
            radiance: Vec3::new(0.9, 1.0, 1.1),
        }],
        background: Vec3::new(0.05, 0.04, 0.03),
    }
}

/// Renders on both twins and checks the stated tolerance; returns the worst RGBA difference.
fn compare(
    volume: &Volume,
    classification: &Classification,
    camera: &Camera,
    params: &DosParams,
) -> f32 {
    let lut = classification.bake(volume);
    let lighting = lighting();
    let input = DosInput {
        volume,
        lut: &lut,
        camera,
        lighting: &lighting,
        params,
    };
    let on_cpu = cpu::render(&input, &NoProgress).unwrap();
    let on_gpu = gpu::render(&ctx(), &input, &NoProgress).unwrap();
    assert!(
        on_cpu.rgba.iter().any(|p| p[3] > 0.5),
        "the volume covers part of the image"
    );
    assert_same(&on_cpu, &on_gpu, 1e-4, Some(1e-4))
}

#[test]
fn ct_phantom_agrees_for_exact_and_approximated_cones() {
    let volume = phantom::ct(40).unwrap();
    let classification = presets::preset("ct-bone").unwrap();
    for (theta_deg, grid, distance) in [
        (50.0, 5, ConeDistance::Exact),
        (80.0, 2, ConeDistance::Approximate),
    ] {
        let params = DosParams {
            theta_deg,
            grid,
            distance,
            ..DosParams::default()
        };
        compare(&volume, &classification, &perspective(48), &params);
    }
}

#[test]
fn two_dimensional_tf_clip_planes_and_wide_cones_agree() {
    let volume = phantom::shells(32).unwrap();
    let classification = presets::preset("boundary-2d").unwrap();
    let params = DosParams {
        theta_deg: 85.0,
        grid: 13,
        slice_distance: Some(0.05),
        distance: ConeDistance::Exact,
        sampling: ConeSampling::Area,
        formulation: Formulation::Slices,
        self_occlusion: true,
        clip_planes: vec![
            ClipPlane {
                point: Vec3::new(0.0, -0.2, 0.0),
                normal: Vec3::new(0.0, -1.0, 0.0),
            },
            ClipPlane {
                point: Vec3::new(0.0, 0.0, 0.6),
                normal: Vec3::Z,
            },
        ],
    };
    compare(&volume, &classification, &perspective(40), &params);
}

#[test]
fn orthographic_and_inside_cameras_agree() {
    let volume = phantom::marschner_lobb(33).unwrap();
    let classification = presets::preset("simulation").unwrap();
    let params = DosParams::default();
    let ortho = orthographic();
    compare(&volume, &classification, &ortho, &params);
    let inside = inside();
    // From inside, the box reaches behind the image plane: the buffers take the widest band.
    let lut = classification.bake(&volume);
    let band = DosInput {
        volume: &volume,
        lut: &lut,
        camera: &inside,
        lighting: &lighting(),
        params: &params,
    }
    .setup()
    .unwrap()
    .band;
    assert_eq!(band, inside.width.max(inside.height) / 2);
    compare(&volume, &classification, &inside, &params);
    let rays = DosParams {
        formulation: Formulation::Rays,
        ..params
    };
    compare(&volume, &classification, &perspective(32), &rays);
    compare(&volume, &classification, &inside, &rays);
}
