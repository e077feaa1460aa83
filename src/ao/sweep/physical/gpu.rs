//! GPU twin of the sweep (src/ao/sweep/physical/sweep.wgsl): the half-step transmittances once per distinct
//! step length, then per group of octants a fill, one dispatch per anti-diagonal plane, in
//! order, and an average into the visibility.
//!
//! A voxel of the octant of signs s reads only neighbours whose sweep index (the sum over axes
//! of the index counted from the side the light comes from) is 1 to 3 smaller, so the voxels
//! of one plane of equal index are independent: nx + ny + nz - 2 planes per octant. All the
//! octants of a group share each plane's dispatch; a group holds as many of the eight padded
//! octant grids as one storage binding takes (all eight up to about 159^3 voxels on lavapipe's
//! 128 MiB, three at 256 x 256 x 128), so a volume needs 1 to 8 groups, and the groups run one
//! after another on one buffer: dispatches = distinct step lengths + groups x (planes + 2), e.g.
//! 643 at 256 x 256 x 128 with one group, 1923 with lavapipe's three. A volume whose padded grid
//! alone is over the largest storage binding is refused; the CPU twin has no such limit.
//!
//! Each step's terms are summed in the CPU twin's order (steps 1..7, then step 0), so the
//! twins differ only by the rounding of exp and of fused multiply-adds (tests/sweep_twins.rs).
//! On lavapipe (2 cores) it is much slower than the CPU twin: 128^3 took 5.9 s against 0.34 s.

use super::super::planes::{grid, Plan};
use super::Stencil;
use crate::error::{Error, Result};
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::progress::Progress;
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3, Vec4};

/// The octant kernels of both modes (the geometric one's GPU twin runs them with the paper's
/// terms).
pub(in crate::ao::sweep) const SHADER: Wgsl = Wgsl {
    name: "sweep.wgsl",
    text: include_str!("sweep.wgsl"),
    includes: &[],
};
/// Planes submitted between waits: the unit of progress and of cancellation.
const PLANES_PER_BLOCK: usize = 32;

/// sweep.wgsl's `Params`, field for field (see the shader for each field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(in crate::ao::sweep) struct Params {
    dims: UVec3,
    solved_axis: u32,
    face_weights: Vec3,
    corner_weight: f32,
    edge_weights: Vec3,
    step_length: f32,
    first_octant: u32,
    pub(in crate::ao::sweep) octants: u32,
    padded_voxels: u32,
    plane: u32,
    row_width: u32,
    pub(in crate::ao::sweep) geometric: u32,
    pub(in crate::ao::sweep) inverse_gamma: f32,
    _pad: u32,
    pub(in crate::ao::sweep) intensities_low: Vec4,
    pub(in crate::ao::sweep) intensities_high: Vec4,
}

/// The distinct step lengths of `stencil` (exactly equal lengths share one), and the index of
/// each step's length among them.
fn distinct_lengths(stencil: &Stencil) -> (Vec<f32>, [usize; 7]) {
    let mut lengths: Vec<f32> = Vec::new();
    let of_step = stencil.lengths.map(|l| {
        lengths.iter().position(|&m| m == l).unwrap_or_else(|| {
            lengths.push(l);
            lengths.len() - 1
        })
    });
    (lengths, of_step)
}

/// The octant sweeps of one volume: the uniform, the fill and plane kernels bound to the
/// group's octant grids and the seven half-step grids, as both modes use them.
pub(in crate::ao::sweep) struct Octants<'a> {
    ctx: &'a GpuContext,
    plan: Plan,
    pub(in crate::ao::sweep) params: Params,
    pub(in crate::ao::sweep) uniform: wgpu::Buffer,
    fill: wgpu::ComputePipeline,
    plane: wgpu::ComputePipeline,
    fill_bind: wgpu::BindGroup,
    plane_bind: wgpu::BindGroup,
    /// The group's padded octant grids, one after the other.
    pub(in crate::ao::sweep) grids: wgpu::Buffer,
}

impl<'a> Octants<'a> {
    pub(in crate::ao::sweep) fn new(
        ctx: &'a GpuContext,
        plan: Plan,
        params: Params,
        uniform: wgpu::Buffer,
        halves: [&wgpu::Buffer; 7],
    ) -> Result<Self> {
        let fill = shader::compute_pipeline(ctx, &SHADER, "sweep_fill")?;
        let plane = shader::compute_pipeline(ctx, &SHADER, "sweep_plane")?;
        let grids =
            buffer::output_buffer::<f32>(ctx, "sweep octants", plan.group * plan.padded_voxels)?;
        let mut plane_resources = vec![
            (0, uniform.as_entire_binding()),
            (3, grids.as_entire_binding()),
        ];
        for (step, half) in halves.iter().enumerate() {
            plane_resources.push((4 + step as u32, half.as_entire_binding()));
        }
        let plane_bind = shader::bind_group_at(ctx, &plane, &plane_resources)?;
        let fill_bind = shader::bind_group_at(
            ctx,
            &fill,
            &[
                (0, uniform.as_entire_binding()),
                (3, grids.as_entire_binding()),
            ],
        )?;
        Ok(Self {
            ctx,
            plan,
            params,
            uniform,
            fill,
            plane,
            fill_bind,
            plane_bind,
            grids,
        })
    }

    /// Written before each dispatch: the write lands at the start of the next submission, so
    /// each dispatch (submitted on its own) sees its own values.
    fn set(&self) {
        self.ctx
            .queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.params));
    }

    /// A 1D kernel over `items` invocations, with the current parameters.
    pub(in crate::ao::sweep) fn dispatch_1d(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        bind: &wgpu::BindGroup,
        items: usize,
    ) -> Result<()> {
        let (workgroups, row_width) = grid(self.ctx, items);
        self.params.row_width = row_width;
        self.set();
        shader::dispatch(self.ctx, pipeline, bind, workgroups)
    }

    /// Sweeps the octants group by group, calling `finish` after each group's planes (with
    /// `params.first_octant` and `params.octants` set to the group). `progress` counts planes
    /// over all groups, reported and checked for cancellation every few dozen planes.
    pub(in crate::ao::sweep) fn sweep(
        &mut self,
        progress: &dyn Progress,
        mut finish: impl FnMut(&mut Self) -> Result<()>,
    ) -> Result<()> {
        let plan = self.plan;
        let planes = plan.planes();
        let total = (plan.groups() * planes) as u64;
        for g in 0..plan.groups() {
            let first = g * plan.group;
            let count = plan.group.min(8 - first);
            self.params.first_octant = first as u32;
            self.params.octants = count as u32;
            let (fill, fill_bind) = (self.fill.clone(), self.fill_bind.clone());
            self.dispatch_1d(&fill, &fill_bind, count * plan.padded_voxels)?;
            for block in (0..planes).step_by(PLANES_PER_BLOCK) {
                if progress.cancelled() {
                    return Err(Error::Cancelled);
                }
                let end = (block + PLANES_PER_BLOCK).min(planes);
                for t in block..end {
                    self.params.plane = t as u32;
                    self.set();
                    let workgroups = plan.plane_workgroups(t, count);
                    shader::dispatch(self.ctx, &self.plane, &self.plane_bind, workgroups)?;
                }
                self.ctx.wait()?;
                progress.update((g * planes + end) as u64, total);
            }
            finish(self)?;
        }
        Ok(())
    }
}

/// The shared uniform values of a volume's sweep.
pub(in crate::ao::sweep) fn base_params(
    dims: [usize; 3],
    plan: &Plan,
    weights: [f32; 7],
) -> Params {
    let w = weights;
    Params {
        dims: UVec3::new(dims[0] as u32, dims[1] as u32, dims[2] as u32),
        solved_axis: plan.solved_axis as u32,
        face_weights: Vec3::new(w[0], w[1], w[2]),
        corner_weight: w[6],
        edge_weights: Vec3::new(w[3], w[4], w[5]),
        step_length: 0.0,
        first_octant: 0,
        octants: 0,
        padded_voxels: plan.padded_voxels as u32,
        plane: 0,
        row_width: 0,
        geometric: 0,
        inverse_gamma: 1.0,
        _pad: 0,
        intensities_low: Vec4::ONE,
        intensities_high: Vec4::ONE,
    }
}

/// The visibility volume of `extinction` (sigma_t per world unit at each voxel centre) on the
/// GPU: the mean of the eight octant visibilities, as [`super::cpu::visibility`] computes it.
/// `progress` counts planes (over all groups of octants), reported and checked for
/// cancellation every few dozen planes.
pub fn visibility(
    ctx: &GpuContext,
    extinction: &Volume,
    progress: &dyn Progress,
) -> Result<Volume> {
    let stencil = super::validate(extinction)?;
    let dims = extinction.dims();
    let plan = Plan::new(dims, &ctx.limits)?;
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    let half_steps = shader::compute_pipeline(ctx, &SHADER, "sweep_half_steps")?;
    let average = shader::compute_pipeline(ctx, &SHADER, "sweep_average")?;
    let voxels = extinction.values().len();
    let padded = plan.padded_voxels;
    let mut params = base_params(dims, &plan, stencil.weights);
    let uniform = buffer::uniform_buffer(ctx, "sweep params", &params)?;

    let (lengths, of_step) = distinct_lengths(&stencil);
    let sigma = buffer::storage_buffer(ctx, "sweep extinction", extinction.values())?;
    let (workgroups, row_width) = grid(ctx, padded);
    let mut halves = Vec::with_capacity(lengths.len());
    for &length in &lengths {
        let half = buffer::output_buffer::<f32>(ctx, "sweep half steps", padded)?;
        params.step_length = length;
        params.row_width = row_width;
        ctx.queue
            .write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
        let bind = shader::bind_group_at(
            ctx,
            &half_steps,
            &[
                (0, uniform.as_entire_binding()),
                (1, sigma.as_entire_binding()),
                (2, half.as_entire_binding()),
            ],
        )?;
        shader::dispatch(ctx, &half_steps, &bind, workgroups)?;
        halves.push(half);
    }
    drop(sigma);

    let sum = buffer::output_buffer::<f32>(ctx, "sweep visibility", voxels)?;
    let mut octants = Octants::new(ctx, plan, params, uniform, of_step.map(|l| &halves[l]))?;
    let average_bind = shader::bind_group_at(
        ctx,
        &average,
        &[
            (0, octants.uniform.as_entire_binding()),
            (3, octants.grids.as_entire_binding()),
            (11, sum.as_entire_binding()),
        ],
    )?;
    octants.sweep(progress, |o| o.dispatch_1d(&average, &average_bind, voxels))?;
    let values = buffer::read_buffer::<f32>(ctx, &sum)?;
    Volume::new(dims, extinction.spacing(), extinction.origin(), values)
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
            [
                dims,
                solved_axis,
                face_weights,
                corner_weight,
                edge_weights,
                step_length,
                first_octant,
                octants,
                padded_voxels,
                plane,
                row_width,
                geometric,
                inverse_gamma,
                intensities_low,
                intensities_high
            ]
        );
    }

    #[test]
    fn steps_of_equal_length_share_a_half_step_grid() {
        let cubic = Stencil::new(Vec3::ONE).unwrap();
        let (lengths, of_step) = distinct_lengths(&cubic);
        assert_eq!(lengths.len(), 3);
        assert_eq!(of_step, [0, 0, 0, 1, 1, 1, 2]);
        let skewed = Stencil::new(Vec3::new(1.0, 2.0, 3.0)).unwrap();
        assert_eq!(distinct_lengths(&skewed).0.len(), 7);
    }
}
