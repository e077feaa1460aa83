//! DOS's CPU and GPU twins render the same images. These tests need a Vulkan (or Metal/DX12)
//! adapter and fail without one: `apt-get install mesa-vulkan-drivers` provides lavapipe on a
//! machine without a GPU.
//!
//! Tolerance: per pixel, |RGBA_gpu - RGBA_cpu| <= 1e-4 * max(1, peak radiance), occlusion
//! within 1e-4 and depth within 1e-3 world units; pixels where only one twin's transmittance
//! crossed 0.5 within float rounding are allowed up to 0.5% of the image. The twins differ by
//! the texture unit's trilinear filtering (lavapipe's fixed-point weights) against the CPU's
//! f32 weights and by exp/log rounding; the occlusion buffer carries these differences from
//! slab to slab but averages them over the cone. Measured on lavapipe (LLVM 15): worst RGBA
//! difference 1.5e-5, worst occlusion difference 4.7e-6, no outliers; the tolerance leaves a
//! 6x margin for other drivers' filtering.

mod common;
use common::twins::{ctx, perspective};

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::classify::{presets, Classification};
use occlux::lights::{Light, Lighting};
use occlux::progress::NoProgress;
use occlux::render::dos::{cpu, gpu, ClipPlane, ConeDistance, DosInput, DosParams, Formulation};
use occlux::render::{RenderImage, BACKGROUND_DEPTH};
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
    assert_same(&on_cpu, &on_gpu)
}

fn assert_same(a: &RenderImage, b: &RenderImage) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let peak = a
        .rgba
        .iter()
        .flat_map(|p| p[..3].iter().copied())
        .fold(1.0f32, f32::max);
    let tolerance = 1e-4 * peak;
    assert!(
        a.rgba.iter().any(|p| p[3] > 0.5),
        "the volume covers part of the image"
    );
    let (occ_a, occ_b) = (a.occlusion.as_ref().unwrap(), b.occlusion.as_ref().unwrap());
    let mut worst = 0.0f32;
    let mut worst_occlusion = 0.0f32;
    let mut outliers = 0;
    for (i, (pa, pb)) in a.rgba.iter().zip(&b.rgba).enumerate() {
        let diff = pa
            .iter()
            .zip(pb)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        let occlusion = (occ_a[i] - occ_b[i]).abs();
        let depth_ok = (a.depth[i] == BACKGROUND_DEPTH) == (b.depth[i] == BACKGROUND_DEPTH)
            && (a.depth[i] - b.depth[i]).abs() <= 1e-3;
        assert!(
            pb.iter().all(|x| x.is_finite()) && occ_b[i].is_finite(),
            "pixel {i}: {pb:?}"
        );
        if diff > tolerance || !depth_ok || occlusion > 1e-4 {
            outliers += 1;
        } else {
            worst = worst.max(diff);
            worst_occlusion = worst_occlusion.max(occlusion);
        }
    }
    let allowed = a.rgba.len() / 200;
    assert!(
        outliers <= allowed,
        "{outliers} pixels differ beyond tolerance {tolerance} (allowed {allowed})"
    );
    println!(
        "worst RGBA difference {worst:.3e} (peak {peak:.3}), worst occlusion difference \
         {worst_occlusion:.3e}, {outliers} outliers"
    );
    worst
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
    let ortho = Camera::look_at(
        Vec3::new(0.3, -4.0, 0.2),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Orthographic { scale: 2.5 },
        40,
        32,
    )
    .unwrap();
    compare(&volume, &classification, &ortho, &params);
    let inside = Camera::look_at(
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(1.0, 1.0, 0.3),
        Vec3::Z,
        Projection::Perspective {
            fov_y: 70f32.to_radians(),
        },
        32,
        40,
    )
    .unwrap();
    compare(&volume, &classification, &inside, &params);
    let rays = DosParams {
        formulation: Formulation::Rays,
        ..params
    };
    compare(&volume, &classification, &perspective(32), &rays);
    compare(&volume, &classification, &inside, &rays);
}
