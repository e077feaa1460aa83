//! The volume texture and shaders/shared/common.wgsl against the CPU's `Volume::sample_index` and
//! `Volume::gradient`. These tests need a Vulkan (or Metal/DX12) adapter and fail without one:
//! on a machine without a GPU, `apt-get install mesa-vulkan-drivers` provides lavapipe.

use std::sync::Arc;

use glam::Vec3;
use occlux::gpu::{buffer, shader, shared_context, GpuContext, VolumeTexture};
use occlux::volume::Volume;

/// The process-wide context: the device opens (and the kernel compiles) once per test binary.
fn ctx() -> Arc<GpuContext> {
    shared_context().unwrap_or_else(|e| {
        panic!("GPU tests need an adapter (apt-get install mesa-vulkan-drivers): {e}")
    })
}

/// The kernel that samples the volume texture at given index coordinates (a test's, not in the
/// production shaders; it includes their shaders/shared/common.wgsl).
const SAMPLE_KERNEL: &str = include_str!("shaders/sample_volume.wgsl");

/// The kernel's `Params` uniform.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    dims: [u32; 3],
    count: u32,
    spacing: [f32; 3],
    _pad: u32,
}

fn sample_pipeline(ctx: &GpuContext, entry_point: &str) -> occlux::Result<wgpu::ComputePipeline> {
    shader::compute_pipeline_from_text(ctx, "sample_volume.wgsl", SAMPLE_KERNEL, entry_point)
}

/// (value, gradient) at each index coordinate, computed by tests/shaders/sample_volume.wgsl.
fn gpu_samples(
    ctx: &GpuContext,
    volume: &Volume,
    tex: &VolumeTexture,
    points: &[Vec3],
) -> Vec<(f32, Vec3)> {
    let [nx, ny, nz] = volume.dims();
    let params = Params {
        dims: [nx as u32, ny as u32, nz as u32],
        count: points.len() as u32,
        spacing: volume.spacing().to_array(),
        _pad: 0,
    };
    let coords: Vec<[f32; 4]> = points.iter().map(|p| p.extend(0.0).to_array()).collect();
    let pipeline = sample_pipeline(ctx, "main").unwrap();
    let uniform = buffer::uniform_buffer(ctx, "params", &params).unwrap();
    let input = buffer::storage_buffer(ctx, "points", &coords).unwrap();
    let output = buffer::output_buffer::<[f32; 4]>(ctx, "results", points.len()).unwrap();
    let group = shader::bind_group(
        ctx,
        &pipeline,
        &[
            uniform.as_entire_binding(),
            wgpu::BindingResource::TextureView(&tex.view),
            input.as_entire_binding(),
            output.as_entire_binding(),
        ],
    )
    .unwrap();
    let groups = (points.len() as u32).div_ceil(64);
    shader::dispatch(ctx, &pipeline, &group, [groups, 1, 1]).unwrap();
    buffer::read_buffer::<[f32; 4]>(ctx, &output)
        .unwrap()
        .into_iter()
        .map(|[gx, gy, gz, v]| (v, Vec3::new(gx, gy, gz)))
        .collect()
}

/// A small deterministic generator (xorshift64*), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// 17x9x13 voxels of uncorrelated values in [-3, 5) with anisotropic spacing: neighbouring
/// voxels differ by O(range), so any interpolation or indexing slip shows.
fn random_volume() -> Volume {
    let dims = [17, 9, 13];
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let values = (0..17 * 9 * 13).map(|_| -3.0 + 8.0 * rng.unit()).collect();
    Volume::new(
        dims,
        Vec3::new(0.5, 1.25, 2.0),
        Vec3::new(1.0, -2.0, 0.5),
        values,
    )
    .unwrap()
}

/// Random continuous index coordinates from 3 voxels before the first centre to 3 after the
/// last (a third of them outside, where sampling clamps), plus every corner centre.
fn sample_points(dims: [usize; 3], count: usize) -> Vec<Vec3> {
    let mut rng = Rng(0x0123_4567_89ab_cdef);
    let n = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let mut points: Vec<Vec3> = (0..count)
        .map(|_| {
            let u = Vec3::new(rng.unit(), rng.unit(), rng.unit());
            Vec3::splat(-3.0) + u * (n + 5.0)
        })
        .collect();
    for corner in 0..8 {
        let pick = |bit: usize, hi: f32| {
            if corner >> bit & 1 == 1 {
                hi - 1.0
            } else {
                0.0
            }
        };
        points.push(Vec3::new(pick(0, n.x), pick(1, n.y), pick(2, n.z)));
    }
    points
}

/// Largest |GPU - CPU| over the points for the value and for each gradient axis.
fn max_errors(volume: &Volume, points: &[Vec3], gpu: &[(f32, Vec3)]) -> (f32, Vec3) {
    let mut worst = (0.0f32, Vec3::ZERO);
    for (&c, &(value, gradient)) in points.iter().zip(gpu) {
        let world = volume.origin() + c * volume.spacing();
        worst.0 = worst.0.max((value - volume.sample_index(c)).abs());
        worst.1 = worst.1.max((gradient - volume.gradient(world)).abs());
    }
    worst
}

/// Gradient tolerance that follows from a value tolerance: two samples per axis over 2 spacing.
fn gradient_tolerance(volume: &Volume, value_tolerance: f32) -> Vec3 {
    Vec3::splat(value_tolerance) / volume.spacing()
}

/// How far the shader's interpolation may stray from the CPU's, where neighbouring voxels
/// differ by up to `span`: both run the same seven lerps a + (b - a) t in f32 on the same
/// texels (the texture stores f32 exactly), so only the shader compiler's fusing of a multiply
/// and an add (one rounding fewer per lerp) differs, a few ulps of the span. This holds on any
/// hardware because no sampler's low-precision weights are involved.
fn arithmetic_tolerance(span: f32) -> f32 {
    1e-5 * span
}

/// Every voxel centre, where the weights are exactly 0 and 1: samples are the voxel values.
fn voxel_centres(dims: [usize; 3]) -> Vec<Vec3> {
    let [nx, ny, nz] = dims;
    (0..nx * ny * nz)
        .map(|n| {
            Vec3::new(
                (n % nx) as f32,
                (n / nx % ny) as f32,
                (n / (nx * ny)) as f32,
            )
        })
        .collect()
}

/// Largest |GPU sample - voxel value| over the voxel centres.
fn max_centre_error(ctx: &GpuContext, volume: &Volume, tex: &VolumeTexture) -> f32 {
    let centres = voxel_centres(volume.dims());
    let gpu = gpu_samples(ctx, volume, tex, &centres);
    centres
        .iter()
        .zip(gpu)
        .map(|(c, (value, _))| {
            let expected = volume.at(c.x as usize, c.y as usize, c.z as usize);
            (value - expected).abs()
        })
        .fold(0.0, f32::max)
}

/// Value range of `random_volume`, the largest difference between neighbouring voxels.
const RANDOM_SPAN: f32 = 8.0;

#[test]
fn texture_sampling_matches_cpu_trilinear_and_gradient() {
    let ctx = ctx();
    let volume = random_volume();
    let tex = VolumeTexture::upload(&ctx, &volume).unwrap();
    // f32 storage is exact: voxel centres return the voxel values.
    let centre_err = max_centre_error(&ctx, &volume, &tex);
    assert!(centre_err == 0.0, "voxel centres differ by {centre_err}");
    let points = sample_points(volume.dims(), 4000);
    let gpu = gpu_samples(&ctx, &volume, &tex, &points);
    let (value_err, gradient_err) = max_errors(&volume, &points, &gpu);
    let tolerance = arithmetic_tolerance(RANDOM_SPAN);
    println!("value error {value_err:e}, gradient error {gradient_err}");
    assert!(
        value_err <= tolerance,
        "value error {value_err} > {tolerance}"
    );
    let gradient_tol = gradient_tolerance(&volume, tolerance);
    assert!(
        gradient_err.cmple(gradient_tol).all(),
        "gradient error {gradient_err} > {gradient_tol}"
    );
}

/// Points a sampler with 8-bit weights gets wrong by about 2^-9 of the span: fractions that
/// are not multiples of 1/256. Sampled in the shader, they are exact.
#[test]
fn fine_fractions_between_voxels_are_not_quantised() {
    let ctx = ctx();
    // Voxels 0 and 1 along x, the rest constant: the sample is the fraction itself.
    let volume = Volume::from_fn([2, 2, 2], Vec3::ONE, Vec3::ZERO, |p| p.x).unwrap();
    let tex = VolumeTexture::upload(&ctx, &volume).unwrap();
    let points: Vec<Vec3> = (0..200)
        .map(|i| Vec3::new((i as f32 + 0.5) / 1000.0, 0.5, 0.5))
        .collect();
    let gpu = gpu_samples(&ctx, &volume, &tex, &points);
    let worst = points
        .iter()
        .zip(&gpu)
        .map(|(p, (value, _))| (value - p.x).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= arithmetic_tolerance(1.0), "worst {worst}");
}

#[test]
fn volume_beyond_one_storage_binding_uploads_and_samples() {
    let ctx = ctx();
    // 336x336x300 f32 = 129.2 MiB, over lavapipe's 128 MiB storage binding. A linear field is
    // reproduced exactly by trilinear sampling, and its distinct slopes expose any slab, row or
    // axis landing in the wrong place.
    let dims = [336, 336, 300];
    assert!(dims.iter().product::<usize>() * 4 > 128 << 20);
    let volume = Volume::from_fn(dims, Vec3::ONE, Vec3::ZERO, |p| {
        0.01 * p.x + 0.1 * p.y + p.z
    })
    .unwrap();
    let tex = VolumeTexture::upload(&ctx, &volume).unwrap();
    assert_eq!(tex.dims, [336, 336, 300]);
    // Corners, slab seams (32 MiB slabs hold 74 slices here), interior points, outside points.
    let points = [
        Vec3::ZERO,
        Vec3::new(335.0, 335.0, 299.0),
        Vec3::new(0.0, 335.0, 0.0),
        Vec3::new(335.0, 0.0, 299.0),
        Vec3::new(12.25, 200.5, 73.5),
        Vec3::new(300.75, 17.125, 147.9),
        Vec3::new(168.0, 168.0, 222.2),
        Vec3::new(-40.0, 500.0, 298.6),
        Vec3::new(100.3, 250.7, 1000.0),
    ];
    let gpu = gpu_samples(&ctx, &volume, &tex, &points);
    let (value_err, gradient_err) = max_errors(&volume, &points, &gpu);
    // Values reach 337, where one f32 ulp is 3e-5, and neighbours differ by up to 1 (along z).
    let tolerance = 1e-5 * 337.0 + arithmetic_tolerance(1.0);
    assert!(
        value_err <= tolerance,
        "value error {value_err} > {tolerance}"
    );
    assert!(
        gradient_err.max_element() <= tolerance,
        "gradient error {gradient_err}"
    );
}

#[test]
fn oversized_volumes_are_clear_errors() {
    let ctx = ctx();
    let max = ctx.limits.max_texture_dimension_3d as usize;
    let long = Volume::new([max + 1, 1, 1], Vec3::ONE, Vec3::ZERO, vec![0.0; max + 1]).unwrap();
    let err = VolumeTexture::upload(&ctx, &long).unwrap_err().to_string();
    assert!(
        err.contains("3D texture limit") && err.contains(&format!("{}x1x1", max + 1)),
        "{err}"
    );
}

#[test]
fn buffers_round_trip_and_refuse_bad_sizes() {
    let ctx = ctx();
    let data: Vec<[u32; 2]> = (0..1000u32)
        .map(|i| [i, i.wrapping_mul(2654435761)])
        .collect();
    let buf = buffer::storage_buffer(&ctx, "round trip", &data).unwrap();
    assert_eq!(buffer::read_buffer::<[u32; 2]>(&ctx, &buf).unwrap(), data);
    // 8000 bytes are not a whole number of 3-float values.
    let err = buffer::read_buffer::<[f32; 3]>(&ctx, &buf).unwrap_err();
    assert!(err.to_string().contains("whole number"), "{err}");
    let too_many = (ctx.limits.max_storage_buffer_binding_size / 4 + 1) as usize;
    let err = buffer::output_buffer::<f32>(&ctx, "huge", too_many).unwrap_err();
    assert!(err.to_string().contains("largest storage binding"), "{err}");
    let err = buffer::storage_buffer::<f32>(&ctx, "none", &[]).unwrap_err();
    assert!(err.to_string().contains("empty"), "{err}");
}

#[test]
fn pipelines_are_cached_and_contexts_shared() {
    let ctx = ctx();
    assert!(Arc::ptr_eq(&ctx, &shared_context().unwrap()));
    let a = sample_pipeline(&ctx, "main").unwrap();
    let b = sample_pipeline(&ctx, "main").unwrap();
    assert_eq!(a, b);
    let err = sample_pipeline(&ctx, "nope").unwrap_err();
    assert!(err.to_string().contains("nope"), "{err}");
}
