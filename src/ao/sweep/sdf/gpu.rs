//! GPU twin of the fast sweeping signed distance (src/ao/sweep/sdf/sweep_sdf.wgsl): the interface
//! voxels are set on the CPU ([`super::start`]), then each round sweeps the eight orders plane
//! by plane (one dispatch per anti-diagonal plane, the voxels of a plane in parallel) and reads
//! back the round's largest decrease; the signs and the unpadding are the CPU's
//! ([`super::finish`]).
//!
//! The planes visit the voxels in another order than the CPU's rows, so a round may leave
//! other intermediate values, but both sweep to the same fixed point of Zhao's update: they
//! agree to float rounding once converged (tests/sweep_twins.rs). Dispatches:
//! rounds x 8 x (nx + ny + nz - 2).

use super::super::planes::Plan;
use super::{finish, start, Rounds, SdfParams, SdfResult};
use crate::error::{Error, Result};
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::progress::Progress;
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

const SHADER: Wgsl = Wgsl {
    name: "sweep_sdf.wgsl",
    text: include_str!("sweep_sdf.wgsl"),
    includes: &[],
};
/// The shader's stand-in for an unset distance (`UNSET`).
const UNSET: f32 = 1.0e30;

/// sweep_sdf.wgsl's `Params`, field for field (see the shader for each field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    dims: UVec3,
    solved_axis: u32,
    spacing: Vec3,
    plane: u32,
    weights: Vec3,
    order: u32,
}

/// The signed distance to the `params.iso` surface of `volume` on the GPU, as
/// [`super::cpu::signed_distance`] computes it. `progress` counts sweeps (eight per round) out
/// of `8 * max_iterations`; cancelling stops between sweeps.
pub fn signed_distance(
    ctx: &GpuContext,
    volume: &Volume,
    params: &SdfParams,
    progress: &dyn Progress,
) -> Result<SdfResult> {
    let grid = start(volume, params)?;
    let dims = volume.dims();
    let plan = Plan::new(dims, &ctx.limits)?;
    let pipeline = shader::compute_pipeline(ctx, &SHADER, "sdf_plane")?;
    let h = volume.spacing();
    let mut uniforms = Params {
        dims: UVec3::new(dims[0] as u32, dims[1] as u32, dims[2] as u32),
        solved_axis: plan.solved_axis as u32,
        spacing: h,
        plane: 0,
        weights: Vec3::ONE / (h * h),
        order: 0,
    };
    let uniform = buffer::uniform_buffer(ctx, "sdf params", &uniforms)?;
    let start_values: Vec<f32> = grid
        .u
        .iter()
        .map(|&d| if d.is_finite() { d } else { UNSET })
        .collect();
    let distance = buffer::storage_buffer(ctx, "sdf distances", &start_values)?;
    let fixed: Vec<u32> = (0..grid.u.len())
        .map(|i| grid.fixed.get(i) as u32)
        .collect();
    let fixed = buffer::storage_buffer(ctx, "sdf fixed voxels", &fixed)?;
    let change = buffer::storage_buffer(ctx, "sdf change", &[0u32])?;
    let bind = shader::bind_group_at(
        ctx,
        &pipeline,
        &[
            (0, uniform.as_entire_binding()),
            (1, distance.as_entire_binding()),
            (2, fixed.as_entire_binding()),
            (3, change.as_entire_binding()),
        ],
    )?;
    let total = 8 * params.max_iterations as u64;
    let mut rounds = Rounds::new(params);
    while !rounds.finished() {
        ctx.queue
            .write_buffer(&change, 0, bytemuck::bytes_of(&0u32));
        for order in 0..8u32 {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            uniforms.order = order;
            for t in 0..plan.planes() {
                uniforms.plane = t as u32;
                // Lands at the start of the next submission: each dispatch sees its own.
                ctx.queue
                    .write_buffer(&uniform, 0, bytemuck::bytes_of(&uniforms));
                shader::dispatch(ctx, &pipeline, &bind, plan.plane_workgroups(t, 1))?;
            }
            ctx.wait()?;
            progress.update(8 * rounds.iterations as u64 + order as u64 + 1, total);
        }
        let [bits] = buffer::read_buffer::<u32>(ctx, &change)?[..] else {
            return Err(Error::Gpu("the sweep's change did not read back".into()));
        };
        let decrease = f32::from_bits(bits);
        // A first value set from UNSET is an infinite decrease, as on the CPU.
        rounds.record(if decrease >= 0.5 * UNSET {
            f32::INFINITY
        } else {
            decrease
        });
    }
    progress.update(total, total);
    let u: Vec<f32> = buffer::read_buffer::<f32>(ctx, &distance)?
        .into_iter()
        .map(|d| if d >= UNSET { f32::INFINITY } else { d })
        .collect();
    finish(volume, params, u, rounds)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors;

    #[test]
    fn uniforms_match_the_shader() {
        assert_mirrors!(
            Params,
            SHADER,
            "Params",
            [dims, solved_axis, spacing, plane, weights, order]
        );
    }
}
