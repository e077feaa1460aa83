//! The geometric mode's octant sweeps and shading on the GPU: the physical mode's plane kernel
//! (src/ao/sweep/physical/sweep.wgsl) run with the paper's three-neighbour terms over the
//! surface's transmittance, then `sweep_shade`.

use super::super::padded::Padded;
use super::super::physical::gpu::{base_params, Octants, SHADER};
use super::super::planes::Plan;
use super::{GeometricParams, Surface};
use crate::error::Result;
use crate::gpu::{buffer, shader, GpuContext};
use crate::progress::Progress;
use glam::Vec4;

/// The geometric mode's octants and shading on the GPU (twin of [`super::cpu::octants`]): the eight sweeps of Eq. 6 over the padded `transmittance`, then
/// sum_s I_s G_s V_s read at each voxel's cell step, clamped and raised to 1 / gamma.
/// Returns the AO (unpadded, x fastest) and, when `keep_octants`, each V_s unpadded.
pub fn octants(
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
