//! GPU twin of the VAO volume: src/ao/vao/vao_stats.wgsl (three 1D passes per statistic, one
//! invocation per line) and src/ao/vao/vao_estimate.wgsl (one invocation per voxel). Every
//! buffer holds a whole volume, so a volume must fit the adapter's largest storage binding
//! (128 MiB on lavapipe: 33.5 M voxels); beyond it the error says so and the CPU twin runs it.

use super::stats::{LocalStats, QUANTITIES};
use super::{AoVolume, ScalarField, UnitMap, VaoParams};
use crate::error::{Error, Result};
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::progress::Progress;
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

const STATS_SHADER: Wgsl = Wgsl {
    name: "vao_stats.wgsl",
    text: include_str!("vao_stats.wgsl"),
    includes: &[],
};
const ESTIMATE_SHADER: Wgsl = Wgsl {
    name: "vao_estimate.wgsl",
    text: include_str!("vao_estimate.wgsl"),
    includes: &[],
};
const WORKGROUP: u32 = 64;

/// vao_stats.wgsl's `Params`, field for field (see the shader for each field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PassParams {
    dims: UVec3,
    axis: u32,
    radius: u32,
    /// `Reduce::shader_code`.
    reduce: u32,
    square: u32,
    lines_per_row: u32,
    outside: f32,
    scale: f32,
    offset: f32,
    _pad: u32,
}

/// vao_estimate.wgsl's `Params`, field for field (see the shader for each field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct EstimateParams {
    voxels: u32,
    /// `Estimator::shader_code`.
    estimator: u32,
    write_variance: u32,
    voxels_per_row: u32,
    scale: f32,
    offset: f32,
}

/// The statistics resident on the GPU, in the order of [`QUANTITIES`].
struct GpuStats {
    field: wgpu::Buffer,
    quantities: Vec<wgpu::Buffer>,
}

/// Workgroups for `items` invocations as a 2D grid within the per-dimension limit, and the
/// invocations per grid row.
fn grid(ctx: &GpuContext, items: usize) -> Result<([u32; 3], u32)> {
    let groups = u32::try_from(items.div_ceil(WORKGROUP as usize))
        .map_err(|_| Error::Gpu(format!("{items} invocations are too many for one dispatch")))?;
    let x = groups.clamp(1, ctx.limits.max_compute_workgroups_per_dimension);
    Ok(([x, groups.div_ceil(x), 1], x * WORKGROUP))
}

fn compute_stats(
    ctx: &GpuContext,
    field: &ScalarField,
    map: UnitMap,
    radius: u32,
    progress: &dyn Progress,
) -> Result<GpuStats> {
    let values = field.values.values();
    let [nx, ny, nz] = field.values.dims();
    let len = values.len();
    let pipeline = shader::compute_pipeline(ctx, &STATS_SHADER, "main")?;
    let field_buffer = buffer::storage_buffer(ctx, "vao field", values)?;
    let ping = buffer::output_buffer::<f32>(ctx, "vao pass a", len)?;
    let pong = buffer::output_buffer::<f32>(ctx, "vao pass b", len)?;
    let prefix = buffer::output_buffer::<f32>(ctx, "vao prefix", len)?;
    let suffix = buffer::output_buffer::<f32>(ctx, "vao suffix", len)?;
    let lines = [ny * nz, nx * nz, nx * ny];
    let total = (QUANTITIES.len() * 3) as u64;
    let mut quantities = Vec::with_capacity(QUANTITIES.len());
    for (q, (reduce, squared)) in QUANTITIES.into_iter().enumerate() {
        let result = buffer::output_buffer::<f32>(ctx, "vao statistic", len)?;
        let outside = map.apply(field.outside);
        let outside = if squared { outside * outside } else { outside };
        // x: field -> ping, y: ping -> pong, z: pong -> result.
        let route = [(&field_buffer, &ping), (&ping, &pong), (&pong, &result)];
        for (axis, (src, dst)) in route.into_iter().enumerate() {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            let (workgroups, per_row) = grid(ctx, lines[axis])?;
            // Only the first pass reads the field; later ones read mapped statistics.
            let (scale, offset) = if axis == 0 {
                (map.scale, map.offset)
            } else {
                (1.0, 0.0)
            };
            let params = PassParams {
                dims: UVec3::new(nx as u32, ny as u32, nz as u32),
                axis: axis as u32,
                radius,
                reduce: reduce.shader_code(),
                square: u32::from(squared && axis == 0),
                lines_per_row: per_row,
                outside,
                scale,
                offset,
                _pad: 0,
            };
            let uniform = buffer::uniform_buffer(ctx, "vao pass params", &params)?;
            let bind = shader::bind_group(
                ctx,
                &pipeline,
                &[
                    uniform.as_entire_binding(),
                    src.as_entire_binding(),
                    dst.as_entire_binding(),
                    prefix.as_entire_binding(),
                    suffix.as_entire_binding(),
                ],
            )?;
            shader::dispatch(ctx, &pipeline, &bind, workgroups)?;
            ctx.wait()?;
            progress.update((q * 3 + axis + 1) as u64, total);
        }
        quantities.push(result);
    }
    Ok(GpuStats {
        field: field_buffer,
        quantities,
    })
}

/// The statistics computed on the GPU, read back (for comparing the twins).
pub fn local_stats(
    ctx: &GpuContext,
    field: &ScalarField,
    map: UnitMap,
    radius: u32,
) -> Result<LocalStats> {
    let stats = compute_stats(ctx, field, map, radius, &crate::progress::NoProgress)?;
    let mut read = stats
        .quantities
        .iter()
        .map(|b| buffer::read_buffer::<f32>(ctx, b));
    let mut next = || {
        read.next()
            .unwrap_or_else(|| Err(Error::Gpu("statistic missing".into())))
    };
    Ok(LocalStats {
        min: next()?,
        max: next()?,
        mean: next()?,
        second: next()?,
    })
}

/// Computes the AO volume of `field` mapped by `map` on the GPU (`params` validated by the
/// caller); the variance is that of the mapped field.
pub fn ao_volume(
    ctx: &GpuContext,
    field: &ScalarField,
    map: UnitMap,
    params: &VaoParams,
    progress: &dyn Progress,
) -> Result<AoVolume> {
    let code = params
        .estimator
        .shader_code()
        .ok_or_else(|| Error::param("method", "the exact estimator runs on the CPU only"))?;
    let stats = compute_stats(ctx, field, map, params.radius, progress)?;
    let len = field.values.values().len();
    let pipeline = shader::compute_pipeline(ctx, &ESTIMATE_SHADER, "main")?;
    let open = buffer::output_buffer::<f32>(ctx, "vao openness", len)?;
    // Without a variance to return, a one-value buffer stands in for the binding.
    let variance =
        buffer::output_buffer::<f32>(ctx, "vao variance", if params.variance { len } else { 1 })?;
    let (workgroups, per_row) = grid(ctx, len)?;
    let uniform = buffer::uniform_buffer(
        ctx,
        "vao estimate params",
        &EstimateParams {
            voxels: len as u32,
            estimator: code,
            write_variance: u32::from(params.variance),
            voxels_per_row: per_row,
            scale: map.scale,
            offset: map.offset,
        },
    )?;
    let [q_min, q_max, q_mean, q_second] = &stats.quantities[..] else {
        return Err(Error::Gpu("statistics incomplete".into()));
    };
    let bind = shader::bind_group(
        ctx,
        &pipeline,
        &[
            uniform.as_entire_binding(),
            stats.field.as_entire_binding(),
            q_min.as_entire_binding(),
            q_max.as_entire_binding(),
            q_mean.as_entire_binding(),
            q_second.as_entire_binding(),
            open.as_entire_binding(),
            variance.as_entire_binding(),
        ],
    )?;
    shader::dispatch(ctx, &pipeline, &bind, workgroups)?;
    let f = &field.values;
    let grid = |v| Volume::new(f.dims(), f.spacing(), f.origin(), v);
    let variance = if params.variance {
        Some(grid(buffer::read_buffer(ctx, &variance)?)?)
    } else {
        None
    };
    Ok(AoVolume::new(
        grid(buffer::read_buffer(ctx, &open)?)?,
        variance,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ao::vao::{stats::Reduce, Estimator};
    use crate::gpu::layout::{assert_mirrors, u32_constant};

    #[test]
    fn uniforms_match_the_shaders() {
        assert_mirrors!(
            PassParams,
            STATS_SHADER,
            "Params",
            [
                dims,
                axis,
                radius,
                reduce,
                square,
                lines_per_row,
                outside,
                scale,
                offset
            ]
        );
        assert_mirrors!(
            EstimateParams,
            ESTIMATE_SHADER,
            "Params",
            [
                voxels,
                estimator,
                write_variance,
                voxels_per_row,
                scale,
                offset
            ]
        );
    }

    #[test]
    fn codes_match_the_shaders() {
        for (name, reduce) in [
            ("REDUCE_MEAN", Reduce::Mean),
            ("REDUCE_MIN", Reduce::Min),
            ("REDUCE_MAX", Reduce::Max),
        ] {
            assert_eq!(u32_constant(&STATS_SHADER, name), reduce.shader_code());
        }
        for (name, estimator) in [
            ("ESTIMATOR_CDF", Estimator::Cdf),
            ("ESTIMATOR_GAUSS", Estimator::Gauss),
            ("ESTIMATOR_GAUSS_EXACT_ERF", Estimator::GaussExactErf),
            ("ESTIMATOR_PENNER", Estimator::Penner),
        ] {
            assert_eq!(
                Some(u32_constant(&ESTIMATE_SHADER, name)),
                estimator.shader_code()
            );
        }
    }
}
