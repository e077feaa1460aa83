//! The discrete-ordinates visibility's CPU and GPU twins agree. These tests need a Vulkan (or
//! Metal/DX12) adapter and fail without one: `apt-get install mesa-vulkan-drivers` provides
//! lavapipe on a machine without a GPU.
//!
//! Tolerance: per voxel, |V_gpu - V_cpu| <= 1e-4 (V is in [0, 1]). Why it holds on any
//! conforming GPU: the twins read the same f32 extinction at the voxel centres (storage
//! buffers, no texture filtering), interpolate with the same four weights in the same order,
//! and add each voxel's directions in the same order; they differ only by the rounding of exp
//! (WGSL allows 3 + 2|x| ULP, an absolute error within 3 * 2^-23 of T since
//! (3 + 2x) e^-x <= 3; Rust's f32 exp is within 1 ULP) and by fused multiply-adds the GPU
//! compiler may form. Each T is a convex combination of upwind T's times exp, so a difference
//! is never amplified: it grows per plane by at most about 8 * 2^-24 (the exp and the seven
//! roundings of the interpolation), over at most the longest axis's planes, and V is a mean of
//! the directions' T. At 24 planes that bounds it by 24 * 8 * 2^-24 = 1.1e-5; the 1e-4 also
//! covers the 48^3 phantom's 48 planes nine times over.
//! Measured on lavapipe (LLVM 15): worst 1.8e-7 on the random fields, 2.4e-7 on the CT phantom.

mod common;
use common::twins::ctx;

use glam::Vec3;
use occlux::classify::presets;
use occlux::gpu::Compute;
use occlux::progress::NoProgress;
use occlux::transport::{self, DEFAULT_DIRECTIONS};
use occlux::volume::{phantom, Volume};
use rand::{Rng, SeedableRng};

const TOLERANCE: f32 = 1e-4;

fn compare(label: &str, extinction: &Volume, directions: u32) {
    let on_cpu = transport::visibility(&Compute::Cpu, extinction, directions, &NoProgress).unwrap();
    let on_gpu =
        transport::visibility(&Compute::Gpu(ctx()), extinction, directions, &NoProgress).unwrap();
    assert_eq!(on_gpu.dims(), extinction.dims());
    assert_eq!(on_gpu.spacing(), extinction.spacing());
    let mut worst = 0.0f32;
    for (i, (a, b)) in on_cpu.values().iter().zip(on_gpu.values()).enumerate() {
        assert!(
            b.is_finite() && (0.0..=1.0).contains(b),
            "{label}: voxel {i}: {b}"
        );
        let d = (a - b).abs();
        assert!(d <= TOLERANCE, "{label}: voxel {i}: CPU {a} vs GPU {b}");
        worst = worst.max(d);
    }
    println!(
        "{label}: worst difference {worst:.2e} over {} voxels",
        on_cpu.values().len()
    );
}

#[test]
fn random_fields_with_anisotropic_spacing_agree() {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(11);
    for (dims, spacing) in [
        ([13, 9, 11], Vec3::new(1.0, 0.5, 2.0)),
        ([7, 24, 5], Vec3::new(0.3, 0.3, 0.3)),
        ([1, 1, 1], Vec3::ONE),
    ] {
        let len = dims.iter().product();
        let values: Vec<f32> = (0..len)
            .map(|_| {
                if rng.random_bool(0.3) {
                    0.0
                } else {
                    rng.random_range(0.0..3.0)
                }
            })
            .collect();
        let volume = Volume::new(dims, spacing, Vec3::ZERO, values).unwrap();
        compare(&format!("random {dims:?}"), &volume, 48);
    }
}

#[test]
fn classified_ct_phantom_agrees() {
    let raw = phantom::ct(48).unwrap();
    let classification = presets::preset("ct-bone").unwrap();
    let extinction = classification.extinction(&raw).unwrap();
    assert!(extinction.values().iter().any(|&s| s > 0.0));
    compare("ct phantom", &extinction, DEFAULT_DIRECTIONS);
}
