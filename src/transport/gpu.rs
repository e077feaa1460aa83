//! GPU twin of the ordinates sweep (src/transport/visibility.wgsl): per sweep order the planes
//! in order, one dispatch per plane over its voxels, each invocation looping over the order's
//! directions ([`sweep_orders`], which the scattering solve's twin shares). Dispatches: the planes of every sweep order (at most 3 (nx + ny + nz)); memory:
//! the extinction, the output and two padded planes per direction of the largest order.

use super::directions::{Ordinate, Ordinates};
use super::{total_planes, Planes};
use crate::error::{Error, Result};
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::progress::Progress;
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::{IVec2, UVec2, UVec3, Vec2};

const SHADER: Wgsl = Wgsl {
    name: "visibility.wgsl",
    text: include_str!("visibility.wgsl"),
    includes: &[],
};
/// Side of the plane kernels' workgroups (`@workgroup_size(8, 8, 1)`).
const WORKGROUP: u32 = 8;
/// Planes submitted between waits: the unit of progress and of cancellation.
const PLANES_PER_BLOCK: usize = 32;

/// ordinates.wgsl's `OrdinatesPlane`, field for field: the plane of a sweep order a dispatch
/// sweeps, as the uniforms of both ordinates kernels begin.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct OrdinatesPlane {
    lateral: UVec2,
    plane: u32,
    upwind_plane: i32,
    strides: UVec3,
    planes: u32,
    first: u32,
    count: u32,
    slot: u32,
    padded_len: u32,
}

/// visibility.wgsl's `Params`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    sweep: OrdinatesPlane,
}

/// Dispatches every sweep order's planes in order, as both ordinates kernels are swept:
/// `start` before an order's first plane (its planes and its count of directions), then per
/// plane `dispatch` with the plane's uniform fields and the workgroups that cover it, waiting
/// on the GPU every [`PLANES_PER_BLOCK`] planes to report progress (planes, of
/// [`total_planes`]) and to honour cancellation.
pub fn sweep_orders(
    ctx: &GpuContext,
    dims: [usize; 3],
    ordinates: &Ordinates,
    progress: &dyn Progress,
    mut start: impl FnMut(&Planes, usize),
    mut dispatch: impl FnMut(&OrdinatesPlane, [u32; 3]) -> Result<()>,
) -> Result<()> {
    let total = total_planes(dims, ordinates);
    let mut done = 0u64;
    for group in ordinates.groups() {
        let planes = Planes::new(dims, group.axis);
        let count = group.members.len();
        start(&planes, count);
        let mut sweep = OrdinatesPlane {
            lateral: UVec2::new(planes.lateral[0] as u32, planes.lateral[1] as u32),
            strides: UVec3::from(planes.strides.map(|s| s as u32)),
            planes: planes.count as u32,
            first: group.members.start as u32,
            count: count as u32,
            padded_len: planes.padded_len() as u32,
            ..OrdinatesPlane::zeroed()
        };
        let workgroups = [
            sweep.lateral.x.div_ceil(WORKGROUP),
            sweep.lateral.y.div_ceil(WORKGROUP),
            1,
        ];
        let order: Vec<usize> = planes.order(group.sign).collect();
        for (block, ks) in order.chunks(PLANES_PER_BLOCK).enumerate() {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            for (n, &k) in ks.iter().enumerate() {
                sweep.plane = k as u32;
                sweep.upwind_plane = k as i32 + group.sign;
                sweep.slot = ((block * PLANES_PER_BLOCK + n) % 2) as u32;
                dispatch(&sweep, workgroups)?;
            }
            ctx.wait()?;
            done += ks.len() as u64;
            progress.update(done, total);
        }
    }
    Ok(())
}

/// visibility.wgsl's `Ordinate`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuOrdinate {
    floor: IVec2,
    fraction: Vec2,
    half_length: f32,
    weight: f32,
    _pad: Vec2,
}

impl From<&Ordinate> for GpuOrdinate {
    fn from(o: &Ordinate) -> Self {
        Self {
            floor: IVec2::from(o.floor),
            fraction: Vec2::from(o.fraction),
            half_length: 0.5 * o.length,
            weight: o.weight,
            _pad: Vec2::ZERO,
        }
    }
}

/// The visibility volume of `extinction` over `ordinates` (from [`super::prepare`]), as
/// [`super::cpu::visibility`] computes it.
pub fn visibility(
    ctx: &GpuContext,
    extinction: &Volume,
    ordinates: &Ordinates,
    progress: &dyn Progress,
) -> Result<Volume> {
    let dims = extinction.dims();
    let pipeline = shader::compute_pipeline(ctx, &SHADER, "sweep_plane")?;
    let largest = ordinates
        .groups()
        .iter()
        .map(|g| (g.members.len(), Planes::new(dims, g.axis).padded_len()))
        .fold((0, 0), |(n, l), (m, k)| (n.max(m), l.max(k)));
    let plane_values = 2 * largest.0 * largest.1;
    let table: Vec<GpuOrdinate> = ordinates.all().iter().map(GpuOrdinate::from).collect();
    let sigma = buffer::storage_buffer(ctx, "transport extinction", extinction.values())?;
    let directions = buffer::storage_buffer(ctx, "transport ordinates", &table)?;
    let planes_buffer = buffer::output_buffer::<f32>(ctx, "transport planes", plane_values)?;
    let sum = buffer::output_buffer::<f32>(ctx, "transport visibility", extinction.values().len())?;
    let uniform = buffer::uniform_buffer(ctx, "transport params", &Params::zeroed())?;
    let bind = shader::bind_group_at(
        ctx,
        &pipeline,
        &[
            (0, uniform.as_entire_binding()),
            (1, sigma.as_entire_binding()),
            (2, directions.as_entire_binding()),
            (3, planes_buffer.as_entire_binding()),
            (4, sum.as_entire_binding()),
        ],
    )?;
    sweep_orders(
        ctx,
        dims,
        ordinates,
        progress,
        // No matter upwind of an order's first plane nor in the padding: T = 1.
        |planes, count| {
            let ones = vec![1.0f32; 2 * count * planes.padded_len()];
            ctx.queue
                .write_buffer(&planes_buffer, 0, bytemuck::cast_slice(&ones));
        },
        |sweep, workgroups| {
            // Written before each dispatch: the write lands at the start of the next
            // submission, so each dispatch (submitted on its own) sees its own values.
            let params = Params { sweep: *sweep };
            ctx.queue
                .write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
            shader::dispatch(ctx, &pipeline, &bind, workgroups)
        },
    )?;
    let mut values = buffer::read_buffer::<f32>(ctx, &sum)?;
    for v in &mut values {
        *v = v.clamp(0.0, 1.0);
    }
    Volume::new(dims, extinction.spacing(), extinction.origin(), values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors;

    #[test]
    fn uniforms_match_the_shader() {
        assert_mirrors!(Params, SHADER, "Params", [sweep]);
        assert_mirrors!(
            OrdinatesPlane,
            SHADER,
            "OrdinatesPlane",
            [
                lateral,
                plane,
                upwind_plane,
                strides,
                planes,
                first,
                count,
                slot,
                padded_len
            ]
        );
        assert_mirrors!(
            GpuOrdinate,
            SHADER,
            "Ordinate",
            [floor, fraction, half_length, weight]
        );
    }
}
