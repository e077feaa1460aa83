//! GPU twin of the sweep (src/ao/sweep/sweep.wgsl): the half-step transmittances once per distinct
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

use super::geometric::{GeometricParams, Surface};
use super::padded::Padded;
use super::{Stencil, STEPS};
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

/// The anti-diagonal plane of a sweep, shared with the signed distance's kernel.
pub(crate) const PLANE: Wgsl = Wgsl {
    name: "plane.wgsl",
    text: include_str!("plane.wgsl"),
    includes: &[],
};
const SHADER: Wgsl = Wgsl {
    name: "sweep.wgsl",
    text: include_str!("sweep.wgsl"),
    includes: &[&PLANE],
};
/// Invocations per workgroup of the 1D kernels (`@workgroup_size(64, 1, 1)`).
const WORKGROUP_1D: u32 = 64;
/// Side of a plane kernel's workgroup (`@workgroup_size(8, 8, 1)`).
const WORKGROUP_PLANE: u32 = 8;
/// Planes submitted between waits: the unit of progress and of cancellation.
const PLANES_PER_BLOCK: usize = 32;
/// Storage buffers that sweep_plane binds: the group's octants and a half-step grid per step.
const PLANE_STORAGE_BUFFERS: u32 = 1 + STEPS.len() as u32;

/// sweep.wgsl's `Params`, field for field (see the shader for each field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    dims: UVec3,
    solved_axis: u32,
    face_weights: Vec3,
    corner_weight: f32,
    edge_weights: Vec3,
    step_length: f32,
    first_octant: u32,
    octants: u32,
    padded_voxels: u32,
    plane: u32,
    row_width: u32,
    geometric: u32,
    inverse_gamma: f32,
    _pad: u32,
    intensities_low: Vec4,
    intensities_high: Vec4,
}

/// How a volume's sweep fits the adapter: checked before anything is allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Plan {
    dims: [usize; 3],
    /// Voxels of one padded grid.
    padded_voxels: usize,
    /// Octants per group (one storage binding holds a group's grids).
    group: usize,
    /// The axis solved from the plane index: the longest, so that the dispatch over the other
    /// two wastes the fewest invocations.
    pub(super) solved_axis: usize,
}

impl Plan {
    pub(super) fn new(dims: [usize; 3], limits: &wgpu::Limits) -> Result<Self> {
        let padded_voxels: usize = dims.iter().map(|n| n + 2).product();
        let binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let grid_bytes = padded_voxels as u64 * 4;
        if grid_bytes > binding {
            return Err(Error::Gpu(format!(
                "the sweep of a {}x{}x{} volume needs {:.1} MiB per padded octant grid, over \
                 the adapter's max_storage_buffer_binding_size of {:.1} MiB: use the CPU twin \
                 (--device cpu) or a smaller volume",
                dims[0],
                dims[1],
                dims[2],
                mib(grid_bytes),
                mib(binding)
            )));
        }
        if limits.max_storage_buffers_per_shader_stage < PLANE_STORAGE_BUFFERS {
            return Err(Error::Gpu(format!(
                "the sweep binds {PLANE_STORAGE_BUFFERS} storage buffers in one kernel, over \
                 the adapter's max_storage_buffers_per_shader_stage of {}",
                limits.max_storage_buffers_per_shader_stage
            )));
        }
        // Indices into a group's buffer are u32 in the shader.
        let group = (binding / grid_bytes)
            .min(u32::MAX as u64 / padded_voxels as u64)
            .min(8) as usize;
        let solved_axis = (0..3).rev().max_by_key(|&a| dims[a]).unwrap_or(2);
        let plan = Self {
            dims,
            padded_voxels,
            group,
            solved_axis,
        };
        let max = limits.max_compute_workgroups_per_dimension;
        let widest = (1..3)
            .map(|o| dims[(solved_axis + o) % 3].div_ceil(WORKGROUP_PLANE as usize))
            .max()
            .unwrap_or(0);
        let items = padded_voxels * group;
        if widest > max as usize || items.div_ceil(WORKGROUP_1D as usize) > (max as usize).pow(2) {
            return Err(Error::Gpu(format!(
                "the sweep of a {}x{}x{} volume needs {widest} workgroups along one dimension \
                 of a plane's dispatch (or {} in all for a 1D kernel), over the adapter's \
                 max_compute_workgroups_per_dimension of {max}",
                dims[0],
                dims[1],
                dims[2],
                items.div_ceil(WORKGROUP_1D as usize)
            )));
        }
        Ok(plan)
    }

    /// Anti-diagonal planes per octant.
    pub(super) fn planes(&self) -> usize {
        self.dims.iter().sum::<usize>() - 2
    }

    fn groups(&self) -> usize {
        8usize.div_ceil(self.group)
    }

    /// Dispatches in all, given the distinct step lengths: half steps, then per group a fill,
    /// the planes and an average.
    #[cfg(test)]
    fn dispatches(&self, lengths: usize) -> usize {
        lengths + self.groups() * (self.planes() + 2)
    }

    /// Workgroups of plane `t`'s dispatch for `octants` octants: the enumerated axes' ranges
    /// on the plane, as sweep_plane recomputes them.
    pub(super) fn plane_workgroups(&self, t: usize, octants: usize) -> [u32; 3] {
        let n = self.dims.map(|n| n as i64);
        let s = self.solved_axis;
        let (a, b) = ((s + 1) % 3, (s + 2) % 3);
        let t = t as i64;
        let range = |axis: usize, other: usize| {
            let lo = (t - (n[other] - 1) - (n[s] - 1)).max(0);
            let hi = t.min(n[axis] - 1);
            ((hi - lo + 1).max(0) as u32).div_ceil(WORKGROUP_PLANE)
        };
        [range(a, b), range(b, a), octants as u32]
    }
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// A 1D kernel's workgroups for `items` invocations as a 2D grid within the per-dimension
/// limit (checked by [`Plan::new`]), and the invocations per grid row.
fn grid(ctx: &GpuContext, items: usize) -> ([u32; 3], u32) {
    let groups = items.div_ceil(WORKGROUP_1D as usize).max(1) as u32;
    let x = groups.min(ctx.limits.max_compute_workgroups_per_dimension);
    ([x, groups.div_ceil(x), 1], x * WORKGROUP_1D)
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
struct Octants<'a> {
    ctx: &'a GpuContext,
    plan: Plan,
    params: Params,
    uniform: wgpu::Buffer,
    fill: wgpu::ComputePipeline,
    plane: wgpu::ComputePipeline,
    fill_bind: wgpu::BindGroup,
    plane_bind: wgpu::BindGroup,
    /// The group's padded octant grids, one after the other.
    grids: wgpu::Buffer,
}

impl<'a> Octants<'a> {
    fn new(
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
    fn dispatch_1d(
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
    fn sweep(
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
fn base_params(dims: [usize; 3], plan: &Plan, weights: [f32; 7]) -> Params {
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

/// The geometric mode's octants and shading on the GPU (twin of the octant part of
/// [`super::geometric`]): the eight sweeps of Eq. 6 over the padded `transmittance`, then
/// sum_s I_s G_s V_s read at each voxel's cell step, clamped and raised to 1 / gamma.
/// Returns the AO (unpadded, x fastest) and, when `keep_octants`, each V_s unpadded.
pub fn geometric_octants(
    ctx: &GpuContext,
    surface: &Surface,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<(Vec<f32>, Vec<Vec<f32>>)> {
    let Surface {
        transmittance,
        cells,
        table,
    } = surface;
    let dims = transmittance.dims;
    let plan = Plan::new(dims, &ctx.limits)?;
    let voxels = cells.len();
    let third = 1.0 / 3.0;
    let mut uniforms = base_params(dims, &plan, [third, third, third, 0.0, 0.0, 0.0, 0.0]);
    uniforms.geometric = 1;
    uniforms.inverse_gamma = 1.0 / params.gamma;
    let i = params.intensities;
    uniforms.intensities_low = Vec4::new(i[0], i[1], i[2], i[3]);
    uniforms.intensities_high = Vec4::new(i[4], i[5], i[6], i[7]);
    let uniform = buffer::uniform_buffer(ctx, "sweep params", &uniforms)?;
    let tau = buffer::storage_buffer(ctx, "sweep transmittance", &transmittance.values)?;
    let cell_words = buffer::storage_buffer(ctx, "sweep surface terms", cells)?;
    let geometry = buffer::storage_buffer(ctx, "sweep geometry table", table.values())?;
    let sum = buffer::output_buffer::<f32>(ctx, "sweep ao", voxels)?;
    let shade = shader::compute_pipeline(ctx, &SHADER, "sweep_shade")?;
    let mut octants = Octants::new(ctx, plan, uniforms, uniform, [&tau; 7])?;
    let shade_bind = shader::bind_group_at(
        ctx,
        &shade,
        &[
            (0, octants.uniform.as_entire_binding()),
            (3, octants.grids.as_entire_binding()),
            (11, sum.as_entire_binding()),
            (12, cell_words.as_entire_binding()),
            (13, geometry.as_entire_binding()),
        ],
    )?;
    let mut kept = Vec::new();
    octants.sweep(progress, |o| {
        o.dispatch_1d(&shade, &shade_bind, voxels)?;
        if keep_octants {
            let grids = buffer::read_buffer::<f32>(ctx, &o.grids)?;
            for g in grids
                .chunks(plan.padded_voxels)
                .take(o.params.octants as usize)
            {
                let padded = Padded {
                    dims,
                    values: g.to_vec(),
                };
                kept.push(padded.unpad(|x| x));
            }
        }
        Ok(())
    })?;
    Ok((buffer::read_buffer::<f32>(ctx, &sum)?, kept))
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

    /// wgpu's default limits: a 128 MiB storage binding, as lavapipe's.
    fn limits() -> wgpu::Limits {
        wgpu::Limits::default()
    }

    #[test]
    fn groups_fill_a_storage_binding_and_dispatches_follow_the_planes() {
        let small = Plan::new([13, 9, 7], &limits()).unwrap();
        assert_eq!((small.group, small.groups(), small.planes()), (8, 1, 27));
        assert_eq!(small.solved_axis, 0);
        // 256 x 256 x 128: 8.65 M padded voxels, 34.6 MB a grid: three octants per 128 MiB.
        let big = Plan::new([256, 256, 128], &limits()).unwrap();
        assert_eq!((big.group, big.groups(), big.planes()), (3, 3, 638));
        assert_eq!(big.dispatches(3), 3 + 3 * 640);
        let roomy = wgpu::Limits {
            max_storage_buffer_binding_size: 1 << 30,
            max_buffer_size: 1 << 30,
            ..limits()
        };
        let one_group = Plan::new([256, 256, 128], &roomy).unwrap();
        assert_eq!(one_group.dispatches(3), 3 + 640);
        // The enumerated axes' ranges: a corner plane has one voxel, a middle plane spans both.
        assert_eq!(small.plane_workgroups(0, 8), [1, 1, 8]);
        assert_eq!(small.plane_workgroups(13, 8), [2, 1, 8]);
        assert_eq!(small.plane_workgroups(26, 8), [1, 1, 8]);
    }

    #[test]
    fn volumes_over_the_adapters_limits_are_refused_naming_the_limit() {
        let err = Plan::new([512, 512, 512], &limits())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("max_storage_buffer_binding_size") && err.contains("512x512x512"),
            "{err}"
        );
        let few = wgpu::Limits {
            max_storage_buffers_per_shader_stage: 4,
            ..limits()
        };
        let err = Plan::new([8, 8, 8], &few).unwrap_err().to_string();
        assert!(
            err.contains("max_storage_buffers_per_shader_stage"),
            "{err}"
        );
        let narrow = wgpu::Limits {
            max_compute_workgroups_per_dimension: 4,
            ..limits()
        };
        let err = Plan::new([64, 64, 64], &narrow).unwrap_err().to_string();
        assert!(
            err.contains("max_compute_workgroups_per_dimension"),
            "{err}"
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
