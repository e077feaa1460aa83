//! The volume texture and shaders/common.wgsl against the CPU's `Volume::sample_index` and
//! `Volume::gradient`. These tests need a Vulkan (or Metal/DX12) adapter and fail without one:
//! on a machine without a GPU, `apt-get install mesa-vulkan-drivers` provides lavapipe.

use std::sync::Arc;

use glam::Vec3;
use occlux::gpu::{buffer, shader, shared_context, GpuContext, VolumeFormat, VolumeTexture};
use occlux::volume::Volume;

/// The process-wide context: the device opens (and the kernel compiles) once per test binary.
fn ctx() -> Arc<GpuContext> {
    shared_context().unwrap_or_else(|e| {
        panic!("GPU tests need an adapter (apt-get install mesa-vulkan-drivers): {e}")
    })
}

/// The kernel that samples the volume texture at given index coordinates (a test's, not in the
/// production shaders; it includes their shaders/common.wgsl).
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
            wgpu::BindingResource::Sampler(&tex.sampler),
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

/// How far the sampler's filter may stray from exact trilinear interpolation of the stored
/// texels, where neighbouring texels differ by up to `span`. lavapipe (a CPU device)
/// interpolates in f32: 1e-5 of the span. Hardware samplers round the weights to
/// subTexelPrecisionBits (8 on NVIDIA, AMD and Intel): up to 2^-8 of the span per axis.
fn filter_tolerance(ctx: &GpuContext, span: f32) -> f32 {
    if ctx.adapter_info.device_type == wgpu::DeviceType::Cpu {
        1e-5 * span
    } else {
        3.0 * 2f32.powi(-8) * span
    }
}

/// Every voxel centre, where the filter's weights are 0 and 1 up to coordinate rounding (about
/// 1e-7, so samples stay within 1e-5 of the span of the texel values on any hardware).
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

/// Largest |GPU sample - stored(voxel value)| over the voxel centres.
fn max_centre_error(
    ctx: &GpuContext,
    volume: &Volume,
    tex: &VolumeTexture,
    stored: impl Fn(f32) -> f32,
) -> f32 {
    let centres = voxel_centres(volume.dims());
    let gpu = gpu_samples(ctx, volume, tex, &centres);
    centres
        .iter()
        .zip(gpu)
        .map(|(c, (value, _))| {
            let expected = volume.at(c.x as usize, c.y as usize, c.z as usize);
            (value - stored(expected)).abs()
        })
        .fold(0.0, f32::max)
}

/// Value range of `random_volume`, the largest difference between neighbouring voxels.
const RANDOM_SPAN: f32 = 8.0;

/// Tolerance at voxel centres (see `voxel_centres`).
const CENTRE_TOLERANCE: f32 = 1e-5 * RANDOM_SPAN;

#[test]
fn r32float_texture_matches_cpu_trilinear_and_gradient() {
    let ctx = ctx();
    assert!(
        ctx.float32_filterable,
        "{} lacks FLOAT32_FILTERABLE",
        ctx.describe()
    );
    let volume = random_volume();
    let tex = VolumeTexture::upload(&ctx, &volume).unwrap();
    assert_eq!(tex.format, VolumeFormat::R32Float);
    // f32 storage is exact: voxel centres return the voxel values.
    let centre_err = max_centre_error(&ctx, &volume, &tex, |v| v);
    assert!(
        centre_err <= CENTRE_TOLERANCE,
        "voxel centres differ by {centre_err}"
    );
    let points = sample_points(volume.dims(), 4000);
    let gpu = gpu_samples(&ctx, &volume, &tex, &points);
    let (value_err, gradient_err) = max_errors(&volume, &points, &gpu);
    // Only the filter's arithmetic differs from the CPU.
    let tolerance = filter_tolerance(&ctx, RANDOM_SPAN);
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

#[test]
fn r16float_texture_matches_within_half_precision() {
    let ctx = ctx();
    let volume = random_volume();
    let tex = VolumeTexture::upload_as(&ctx, &volume, VolumeFormat::R16Float).unwrap();
    assert_eq!(tex.format, VolumeFormat::R16Float);
    // The forced format really stored halves: voxel centres return the values rounded to f16,
    // which differ from the f32 values by up to half an f16 ulp (2^-9 for values in [4, 5)).
    let to_half = |v: f32| half::f16::from_f32(v).to_f32();
    let centre_err = max_centre_error(&ctx, &volume, &tex, to_half);
    assert!(
        centre_err <= CENTRE_TOLERANCE,
        "voxel centres differ from f16 by {centre_err}"
    );
    assert!(max_centre_error(&ctx, &volume, &tex, |v| v) > 1e-3);
    let points = sample_points(volume.dims(), 4000);
    let gpu = gpu_samples(&ctx, &volume, &tex, &points);
    let (value_err, gradient_err) = max_errors(&volume, &points, &gpu);
    // Rounding to f16 moves each voxel by at most 2^-11 of its magnitude (|v| <= 5 here), and
    // trilinear weights are convex, so a sample moves by at most as much; plus the filter's own.
    let tolerance = 5.0 * 2f32.powi(-11) + filter_tolerance(&ctx, RANDOM_SPAN);
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
    let tolerance = 1e-5 * 337.0 + filter_tolerance(&ctx, 1.0);
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
fn oversized_or_unrepresentable_volumes_are_clear_errors() {
    let ctx = ctx();
    let max = ctx.limits.max_texture_dimension_3d as usize;
    let long = Volume::new([max + 1, 1, 1], Vec3::ONE, Vec3::ZERO, vec![0.0; max + 1]).unwrap();
    let err = VolumeTexture::upload(&ctx, &long).unwrap_err().to_string();
    assert!(
        err.contains("3D texture limit") && err.contains(&format!("{}x1x1", max + 1)),
        "{err}"
    );
    let hot = Volume::new([2, 2, 2], Vec3::ONE, Vec3::ZERO, vec![1e6; 8]).unwrap();
    let err = VolumeTexture::upload_as(&ctx, &hot, VolumeFormat::R16Float).unwrap_err();
    assert!(err.to_string().contains("float16"), "{err}");
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
