//! The occlusion sweep's CPU and GPU twins compute the same visibility (physical mode) and the
//! same octants and AO (geometric mode). These tests need a
//! Vulkan (or Metal/DX12) adapter and fail without one: `apt-get install mesa-vulkan-drivers`
//! provides lavapipe on a machine without a GPU.
//!
//! Tolerance: per voxel, |V_gpu - V_cpu| <= 1e-4 (V is in [0, 1]). Why it holds on any
//! conforming GPU: the twins read the same f32 extinction at the voxel centres (storage
//! buffers, no texture filtering), compute the same half-step transmittances
//! exp((-0.5 sigma) |n|), and sum each voxel's seven terms in the same order with the same
//! association (steps 1..7, then step 0); they differ only by the rounding of exp (WGSL allows
//! 3 + 2|x| ULP, an absolute error within 3 * 2^-23 since (3 + 2x) e^-x <= 3; Rust's f32 exp is
//! within 1 ULP), by fused multiply-adds the GPU compiler may form, and by the order in which
//! the eight octants are added. A voxel's visibility is a sum of its neighbours' with weights
//! w_n h h summing to at most 1, so a difference is never amplified: it grows per plane of the
//! sweep by at most the local rounding, about 22 * 2^-24 (two exps per term weighted by w, plus
//! eight roundings), over nx + ny + nz - 2 planes. At 24^3 (70 planes) that bounds it by
//! 70 * 22 * 2^-24 = 9.2e-5 < 1e-4; the other volumes have fewer planes. Measured on lavapipe
//! (LLVM 15): worst 1.8e-7 on the random fields, 1.2e-7 on the CT phantom, 0 in empty space.

mod common;
use common::twins::ctx;

use glam::Vec3;
use occlux::ao::sweep::geometric::{occlusion, GeometricParams, SKY};
use occlux::ao::sweep::physical::{cpu, gpu, Stencil};
use occlux::ao::sweep::sdf::SdfParams;
use occlux::classify::presets;
use occlux::error::Error;
use occlux::gpu::Compute;
use occlux::progress::{NoProgress, Progress};
use occlux::volume::{phantom, Volume};
use rand::{Rng, SeedableRng};
use std::sync::atomic::{AtomicU64, Ordering};

const TOLERANCE: f32 = 1e-4;

/// Runs both twins and checks the stated tolerance; returns the GPU's visibility.
fn compare(label: &str, extinction: &Volume) -> Volume {
    let on_cpu = cpu::visibility(extinction, &NoProgress).unwrap();
    let on_gpu = gpu::visibility(&ctx(), extinction, &NoProgress).unwrap();
    assert_eq!(on_gpu.dims(), extinction.dims());
    assert_eq!(on_gpu.spacing(), extinction.spacing());
    assert_eq!(on_gpu.origin(), extinction.origin());
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
    on_gpu
}

/// Extinction in [0, 12) per world unit, a third of the voxels empty, on a grid of `dims`.
fn random_field(dims: [usize; 3], spacing: Vec3, seed: u64) -> Volume {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let n = dims.iter().product();
    let values = (0..n)
        .map(|_| {
            if rng.random_range(0.0..1.0) < 0.33 {
                0.0
            } else {
                rng.random_range(0.0..12.0f32)
            }
        })
        .collect();
    Volume::new(dims, spacing, Vec3::new(-0.3, 0.1, 2.0), values).unwrap()
}

#[test]
fn random_fields_with_anisotropic_spacing_agree() {
    // Non-cubic dims with the longest axis along x, y or z (the axis the planes solve for),
    // and spacings with three and with seven distinct step lengths.
    for (dims, spacing, seed) in [
        ([13, 9, 7], Vec3::new(0.1, 0.15, 0.25), 1),
        ([6, 11, 5], Vec3::new(0.2, 0.2, 0.1), 2),
        ([5, 4, 12], Vec3::splat(0.125), 3),
    ] {
        let label = format!("random {dims:?} spacing {spacing}");
        let v = compare(&label, &random_field(dims, spacing, seed));
        assert!(
            v.values().iter().any(|&x| x < 0.5),
            "{label}: matter occludes"
        );
    }
}

#[test]
fn classified_ct_phantom_agrees() {
    let volume = phantom::ct(24).unwrap();
    let classification = presets::preset("ct-bone").unwrap();
    let extinction = classification.extinction(&volume).unwrap();
    assert!(extinction.values().iter().any(|&s| s > 0.0));
    compare("CT phantom 24^3, ct-bone", &extinction);
}

#[test]
fn empty_space_and_a_single_voxel_agree() {
    let empty = Volume::new([5, 4, 3], Vec3::ONE, Vec3::ZERO, vec![0.0; 60]).unwrap();
    let v = compare("empty 5x4x3", &empty);
    assert!(v.values().iter().all(|&x| (x - 1.0).abs() < 1e-6));

    // One voxel of extinction sigma: every step out crosses half its length in matter.
    let sigma = 0.7;
    let spacing = Vec3::new(0.5, 1.0, 2.0);
    let one = Volume::new([1, 1, 1], spacing, Vec3::ZERO, vec![sigma]).unwrap();
    let v = compare("single voxel", &one);
    let s = Stencil::new(spacing).unwrap();
    let want: f32 = s
        .weights
        .iter()
        .zip(s.lengths)
        .map(|(w, l)| w * (-0.5 * sigma * l).exp())
        .sum();
    assert!(
        (v.values()[0] - want).abs() < 1e-5,
        "{} vs {want}",
        v.values()[0]
    );
}

/// Records progress and cancels once `cancel_after` planes are reported (never when 0).
struct Recorder {
    last: AtomicU64,
    total: AtomicU64,
    calls: AtomicU64,
    cancel_after: u64,
}

impl Recorder {
    fn new(cancel_after: u64) -> Self {
        Self {
            last: AtomicU64::new(0),
            total: AtomicU64::new(0),
            calls: AtomicU64::new(0),
            cancel_after,
        }
    }
}

impl Progress for Recorder {
    fn update(&self, done: u64, total: u64) {
        assert!(done >= self.last.load(Ordering::Relaxed) && done <= total);
        self.last.store(done, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        self.calls.fetch_add(1, Ordering::Relaxed);
    }

    fn cancelled(&self) -> bool {
        self.cancel_after > 0 && self.last.load(Ordering::Relaxed) >= self.cancel_after
    }
}

#[test]
fn progress_counts_planes_and_cancellation_stops_the_sweep() {
    // 40 + 6 + 5 - 2 = 49 planes: two blocks.
    let extinction = random_field([40, 6, 5], Vec3::ONE, 4);
    let progress = Recorder::new(0);
    gpu::visibility(&ctx(), &extinction, &progress).unwrap();
    assert_eq!(progress.total.load(Ordering::Relaxed), 49);
    assert_eq!(progress.last.load(Ordering::Relaxed), 49);
    assert_eq!(progress.calls.load(Ordering::Relaxed), 2);

    let cancelling = Recorder::new(1);
    let result = gpu::visibility(&ctx(), &extinction, &cancelling);
    assert!(matches!(result, Err(Error::Cancelled)), "{result:?}");
    assert_eq!(cancelling.calls.load(Ordering::Relaxed), 1);
}

#[test]
fn both_twins_refuse_negative_extinction_alike() {
    let negative = Volume::new([2, 3, 2], Vec3::ONE, Vec3::ZERO, vec![-1.0; 12]).unwrap();
    let on_cpu = cpu::visibility(&negative, &NoProgress)
        .unwrap_err()
        .to_string();
    let on_gpu = gpu::visibility(&ctx(), &negative, &NoProgress)
        .unwrap_err()
        .to_string();
    assert_eq!(on_cpu, on_gpu);
    assert!(on_gpu.contains("non-negative extinction"), "{on_gpu}");
}

/// The geometric mode's twins (each with its own signed distance; the surface terms on the CPU
/// from it): AO and each octant. Tolerance: at gamma 1 the same bound as the visibility's, 1e-4 (the
/// octants' recurrence is a weighted mean with weights tau / 3 summing to at most 1, the
/// geometry terms are the same table read the same way, the sums differ in order only); at
/// gamma g the AO's difference near 0 can grow to that bound to the power 1 / g (x^(1/g) is
/// steep there), so at the default gamma 2 the AO is compared within 1e-2.
fn compare_geometric(label: &str, field: &Volume, iso: f32, params: &GeometricParams) {
    let surface = SdfParams {
        iso,
        ..Default::default()
    };
    let gpu = Compute::Gpu(ctx());
    let run = |compute: &Compute| occlusion(compute, field, &surface, params, true, &NoProgress);
    let (on_cpu, on_gpu) = (run(&Compute::Cpu).unwrap(), run(&gpu).unwrap());
    let ao_tolerance = TOLERANCE.powf(1.0 / params.gamma);
    let pairs = std::iter::once((&on_cpu.ao, &on_gpu.ao, ao_tolerance)).chain(
        on_cpu
            .octants
            .iter()
            .flatten()
            .zip(on_gpu.octants.iter().flatten())
            .map(|(a, b)| (a, b, TOLERANCE)),
    );
    let mut worst = [0.0f32; 2];
    for (n, (a, b, tolerance)) in pairs.enumerate() {
        for (i, (x, y)) in a.values().iter().zip(b.values()).enumerate() {
            assert!(
                y.is_finite() && (0.0..=1.0).contains(y),
                "{label} {n} {i}: {y}"
            );
            let d = (x - y).abs();
            assert!(
                d <= tolerance,
                "{label}: grid {n} voxel {i}: CPU {x} vs GPU {y}"
            );
            worst[(n > 0) as usize] = worst[(n > 0) as usize].max(d);
        }
    }
    println!(
        "{label}: worst difference AO {:.2e}, octants {:.2e}",
        worst[0], worst[1]
    );
}

#[test]
fn geometric_sweep_twins_agree() {
    // Measured on lavapipe (LLVM 15): worst 4.8e-7 (AO) and 3.6e-7 (octants).
    let scene = phantom::box_and_sphere([24, 20, 16]).unwrap();
    let linear = GeometricParams {
        gamma: 1.0,
        ..Default::default()
    };
    compare_geometric("box and sphere, gamma 1", &scene, 0.5, &linear);
    compare_geometric(
        "box and sphere, sky, translucent, gamma 2",
        &scene,
        0.5,
        &GeometricParams {
            intensities: SKY,
            alpha: 0.4,
            ..Default::default()
        },
    );
    let ct = phantom::ct(24).unwrap();
    compare_geometric(
        "CT tissue, combined",
        &ct,
        0.25,
        &GeometricParams {
            normal_weighted: false,
            ..linear
        },
    );
}

/// The signed distance's twins sweep in other orders (rows against planes) to the same fixed
/// point of Zhao's update. Tolerance, relative to max(|d|, 1): each update rounds within a few
/// ULP (WGSL's sqrt and division within 2.5 ULP, Rust's correctly rounded), and the update is
/// non-expansive (a neighbour's error passes on at most as large), so errors add at most along
/// a path from the surface, nx + ny + nz voxels: (nx + ny + nz) * 3 * 2^-23. Measured on
/// lavapipe: 2.1e-7 (ball, anisotropic spacing), 6.0e-8 (box and sphere).
#[test]
fn signed_distance_twins_agree() {
    use occlux::ao::sweep::sdf::{cpu::signed_distance, signed_distance_on};
    let ball = Volume::from_fn([30, 26, 22], Vec3::new(1.0, 1.0, 1.5), Vec3::ZERO, |p| {
        9.0 - (p - Vec3::new(14.3, 12.1, 15.2)).length()
    })
    .unwrap();
    let scene = phantom::box_and_sphere([32, 28, 24]).unwrap();
    let gpu = Compute::Gpu(ctx());
    for (label, field, iso) in [("ball", &ball, 0.0), ("box and sphere", &scene, 0.5)] {
        let surface = SdfParams {
            iso,
            ..Default::default()
        };
        let on_cpu = signed_distance(field, &surface, &NoProgress).unwrap();
        let on_gpu = signed_distance_on(&gpu, field, &surface, &NoProgress).unwrap();
        assert!(on_cpu.converged && on_gpu.converged);
        let mut worst = 0.0f32;
        for (a, b) in on_cpu.sdf.values().iter().zip(on_gpu.sdf.values()) {
            assert!(b.is_finite() && a.signum() == b.signum());
            worst = worst.max((a - b).abs() / a.abs().max(1.0));
        }
        println!(
            "{label}: worst relative difference {worst:.2e}, rounds CPU {} GPU {}",
            on_cpu.iterations, on_gpu.iterations
        );
        let bound = field.dims().iter().sum::<usize>() as f32 * 3.0 * f32::EPSILON;
        assert!(worst <= bound, "{label}: {worst} over {bound}");
    }
}
