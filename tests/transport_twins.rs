//! The discrete-ordinates solvers' CPU and GPU twins agree (the visibility and, below, multiple
//! scattering). These tests need a Vulkan (or Metal/DX12) adapter and fail without one:
//! `apt-get install mesa-vulkan-drivers` provides lavapipe on a machine without a GPU.
//!
//! Tolerance: per voxel, |V_gpu - V_cpu| <= 1e-4 (V is in [0, 1]). Why it holds on any
//! conforming GPU: the twins read the same f32 extinction at the voxel centres (storage
//! buffers, no texture filtering), interpolate with the same four weights in the same order
//! (but for the fourth: the CPU's is 1 less the other three, so that they make exactly 1 and
//! empty space can be skipped, within two ULP of the GPU's fb fc, which shifts T by at most
//! 2^-23 per plane, inside the budget below), and add each voxel's directions in the same
//! order; they differ only by the rounding of exp
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
use occlux::gpu::GpuContext;
use occlux::lights::Light;
use occlux::progress::NoProgress;
use occlux::transport::medium::Medium;
use occlux::transport::scattering::{
    ambient_in_scattered, in_scattered, InScattered, ScatteringParams,
};
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

/// An extinction field of `dims` voxels: a third empty, the rest up to 3 per world unit.
fn random_extinction(rng: &mut rand_pcg::Pcg32, dims: [usize; 3], spacing: Vec3) -> Volume {
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
    Volume::new(dims, spacing, Vec3::ZERO, values).unwrap()
}

#[test]
fn random_fields_with_anisotropic_spacing_agree() {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(11);
    for (dims, spacing) in [
        ([13, 9, 11], Vec3::new(1.0, 0.5, 2.0)),
        ([7, 24, 5], Vec3::new(0.3, 0.3, 0.3)),
        ([1, 1, 1], Vec3::ONE),
    ] {
        let volume = random_extinction(&mut rng, dims, spacing);
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

/// The multiple-scattering solver's twins: per cell and colour channel, every band
/// coefficient of J within `SCATTERING_TOLERANCE` of the field's largest band-0 value.
///
/// Why it holds on any conforming GPU: both twins take the same first source from the CPU and
/// sweep the same f32 medium (storage buffers, no texture filtering) with the same upwind
/// weights, segment weights and gathering coefficients in the same order; they differ by the
/// rounding of exp (3 + 2|x| ULP in WGSL: within 3 * 2^-23 relative of each e^-tau term) and
/// by the fused multiply-adds a GPU compiler may form (half an ULP per operation). Each
/// radiance is a sum of non-negative terms, so a relative difference is never amplified: it
/// grows by about 16 * 2^-24 per plane (the exp and the roundings of the interpolation, the
/// segment and the source), over at most the longest axis's planes, and each bounce adds its
/// source's difference to its own. At 14 planes and 8 bounces that bounds it by
/// 8 * 14 * 16 * 2^-24 = 1.1e-4 of the light carried; 1e-3 covers it nine times, and the
/// coefficients of bands 1 and 2 are weighted sums of the same radiances, at most the field's
/// band 0 in size.
/// Measured on lavapipe (LLVM 15): worst 4.2e-7 (a random medium under a sun at g = 0.6).
const SCATTERING_TOLERANCE: f32 = 1e-3;

fn compare_scattering(label: &str, medium: &Medium, light: &Light, g: f32) {
    compare_solves(label, medium, g, |gpu, params| {
        in_scattered(gpu, medium, light, params, &NoProgress).unwrap()
    });
}

/// The twins of `solve` (on the CPU: None; on the GPU) agree on `medium`.
fn compare_solves(
    label: &str,
    medium: &Medium,
    g: f32,
    solve: impl Fn(Option<&GpuContext>, &ScatteringParams) -> InScattered,
) {
    let params = ScatteringParams {
        directions: 16,
        bounces: 8,
        g,
    };
    let on_cpu = solve(None, &params);
    let on_gpu = solve(Some(&ctx()), &params);
    assert_eq!(on_cpu.bounces, on_gpu.bounces, "{label}: bounces");
    let (a, b) = (on_cpu.bands.values(), on_gpu.bands.values());
    assert_eq!(a.len(), b.len(), "{label}: layout");
    let cells = medium.scattering.len();
    let scale = (0..cells)
        .map(|cell| on_cpu.bands.mean(cell).max_element())
        .fold(0.0f32, f32::max);
    assert!(scale > 0.0, "{label}: no scattered light");
    let mut worst = 0.0f32;
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(y.is_finite(), "{label}: coefficient {i}: {y}");
        let d = (x - y).abs() / scale;
        assert!(
            d <= SCATTERING_TOLERANCE,
            "{label}: coefficient {i}: CPU {x} vs GPU {y}"
        );
        worst = worst.max(d);
    }
    println!(
        "{label}: worst difference {worst:.2e} of the largest J over {cells} cells, {} bounces",
        on_cpu.bounces
    );
}

/// A random medium of `dims` cells: [`random_extinction`]'s, with per-channel albedos in
/// [0.3, 0.99).
fn random_medium(dims: [usize; 3], spacing: Vec3, seed: u64) -> Medium {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let extinction = random_extinction(&mut rng, dims, spacing);
    let scattering = extinction
        .values()
        .iter()
        .map(|&s| s * Vec3::from_array(std::array::from_fn(|_| rng.random_range(0.3..0.99))))
        .collect();
    Medium {
        extinction,
        scattering,
    }
}

#[test]
fn scattering_twins_agree_under_a_sun_and_a_lamp() {
    let medium = random_medium([11, 8, 14], Vec3::new(1.0, 0.5, 0.8), 5);
    let sun = Light::Directional {
        to_light: Vec3::new(0.3, 0.8, -0.5).normalize(),
        irradiance: Vec3::new(1.0, 0.8, 0.6),
    };
    // Inside the grid: the cells around it are lit from every side.
    let lamp = Light::Point {
        position: Vec3::new(4.0, 2.0, 5.0),
        intensity: Vec3::splat(3.0),
    };
    for g in [0.0, 0.6] {
        compare_scattering(&format!("sun, g = {g}"), &medium, &sun, g);
        compare_scattering(&format!("lamp, g = {g}"), &medium, &lamp, g);
    }
}

/// Ambient light starts from its visibility (uploaded as the first field on the GPU) rather
/// than from a light's first scattering.
#[test]
fn scattering_twins_agree_under_ambient_light() {
    let medium = random_medium([11, 8, 14], Vec3::new(1.0, 0.5, 0.8), 9);
    let visibility =
        transport::visibility(&Compute::Cpu, &medium.extinction, 16, &NoProgress).unwrap();
    for g in [0.0, 0.6] {
        compare_solves(&format!("ambient, g = {g}"), &medium, g, |gpu, params| {
            ambient_in_scattered(gpu, &medium, &visibility, params, &NoProgress).unwrap()
        });
    }
}

#[test]
fn scattering_twins_agree_on_the_classified_ct_phantom() {
    let raw = phantom::ct(24).unwrap();
    let classification = presets::preset("ct-bone").unwrap();
    let medium = Medium::classify(&raw, &classification.bake(&raw), 1).unwrap();
    let sun = Light::Directional {
        to_light: Vec3::new(-0.4, 0.2, 0.9).normalize(),
        irradiance: Vec3::ONE,
    };
    compare_scattering("ct phantom, g = 0.6", &medium, &sun, 0.6);
}
