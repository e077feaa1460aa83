//! GPU twin of the source iteration's sweeps (src/transport/scattering/scattering.wgsl): per
//! bounce, per sweep order the planes in order, one dispatch per plane over its cells, each
//! invocation looping over the order's directions as [`super::cpu`] does. The first source
//! (one sweep towards a sun, or a march per cell towards a lamp: one direction, a small share
//! of the work) is computed on the CPU and uploaded; the bounces' fields stay on the GPU, the
//! previous one read as the next one's source, and each is read back once for the sum and the
//! convergence test, which [`super::iterate`] runs for both twins.
//! Memory on the GPU: the medium (5 f32 per cell), the first source (8 f32 per cell), two
//! fields (3 or 27 f32 per cell each), and per direction of the largest sweep order two padded
//! planes of radiance and source (16 f32 per padded cell).

use super::bands::{coefficients_for, gathering, Bands, THROUGH_BAND_2};
use super::{iterate, InScattered, Lit, ScatteringParams, Source};
use crate::error::Result;
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::progress::Progress;
use crate::transport::directions::{Ordinate, Ordinates};
use crate::transport::gpu::{sweep_orders, OrdinatesPlane};
use crate::transport::medium::Medium;
use crate::transport::Planes;
use bytemuck::{Pod, Zeroable};
use glam::{IVec2, Vec2, Vec3, Vec4};

const SHADER: Wgsl = Wgsl {
    name: "scattering.wgsl",
    text: include_str!("scattering.wgsl"),
    includes: &[],
};
/// scattering.wgsl's `Params`, field for field.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    sweep: OrdinatesPlane,
    per_channel: u32,
    first_bounce: u32,
    g: f32,
    _pad: u32,
}

/// scattering.wgsl's `Ordinate`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuOrdinate {
    floor: IVec2,
    fraction: Vec2,
    towards: Vec3,
    length: f32,
    gather: [f32; THROUGH_BAND_2],
    _pad: [f32; 3],
}

impl GpuOrdinate {
    fn new(o: &Ordinate, gather: &[f32; THROUGH_BAND_2]) -> Self {
        Self {
            floor: IVec2::from(o.floor),
            fraction: Vec2::from(o.fraction),
            towards: o.towards,
            length: o.length,
            gather: *gather,
            _pad: [0.0; 3],
        }
    }
}

/// The in-scattered radiance as [`super::cpu::solve`] computes it, on `ctx`.
pub fn solve(
    ctx: &GpuContext,
    medium: &Medium,
    lit: &Lit,
    ordinates: &Ordinates,
    params: &ScatteringParams,
    progress: &dyn Progress,
) -> Result<InScattered> {
    let dims = medium.dims();
    let cells = medium.scattering.len();
    let per_channel = coefficients_for(params.g);
    let pipeline = shader::compute_pipeline(ctx, &SHADER, "scatter_plane")?;
    let table: Vec<GpuOrdinate> = ordinates
        .all()
        .iter()
        .zip(gathering(ordinates, params.g))
        .map(|(o, gather)| GpuOrdinate::new(o, &gather))
        .collect();
    let largest = ordinates
        .groups()
        .iter()
        .map(|g| (g.members.len(), Planes::new(dims, g.axis).padded_len()))
        .fold((0, 0), |(n, l), (m, k)| (n.max(m), l.max(k)));
    let scattering: Vec<Vec4> = medium.scattering.iter().map(|s| s.extend(0.0)).collect();
    let field_len = cells * 3 * per_channel;
    let buffers = Buffers {
        sigma: buffer::storage_buffer(ctx, "scattering extinction", medium.extinction.values())?,
        ordinates: buffer::storage_buffer(ctx, "scattering ordinates", &table)?,
        planes: buffer::output_buffer::<Vec4>(ctx, "scattering planes", 4 * largest.0 * largest.1)?,
        direct: buffer::output_buffer::<Vec4>(ctx, "scattering first source", 2 * cells)?,
        scattering: buffer::storage_buffer(ctx, "scattering coefficients", &scattering)?,
        fields: [
            buffer::output_buffer::<f32>(ctx, "scattering field a", field_len)?,
            buffer::output_buffer::<f32>(ctx, "scattering field b", field_len)?,
        ],
        uniform: buffer::uniform_buffer(ctx, "scattering params", &Params::zeroed())?,
    };
    // Bind group n sweeps into field n and reads the other as the previous bounce's.
    let binds = [
        buffers.bind(ctx, &pipeline, 0)?,
        buffers.bind(ctx, &pipeline, 1)?,
    ];
    let mut bounce = 0usize;
    iterate(medium, lit, ordinates, params, progress, |source, part| {
        let now = bounce % 2;
        let first_bounce = match source {
            Source::Direct(d) => {
                let packed: Vec<Vec4> = d
                    .towards
                    .iter()
                    .zip(&d.irradiance)
                    .flat_map(|(t, e)| [t.extend(0.0), e.extend(0.0)])
                    .collect();
                ctx.queue
                    .write_buffer(&buffers.direct, 0, bytemuck::cast_slice(&packed));
                true
            }
            Source::Bands(ref start) if bounce == 0 => {
                // Ambient light's first field (its visibility), read as a previous
                // bounce's; later bounces read the field the last one left on the GPU.
                ctx.queue.write_buffer(
                    &buffers.fields[1 - now],
                    0,
                    bytemuck::cast_slice(start.values()),
                );
                false
            }
            Source::Bands(_) => false,
        };
        clear(ctx, &buffers.fields[now]);
        let mut uniform = Params {
            per_channel: per_channel as u32,
            first_bounce: first_bounce as u32,
            g: params.g,
            ..Params::zeroed()
        };
        sweep_orders(
            ctx,
            dims,
            ordinates,
            part,
            // Each order starts with no light upwind and padding that holds none.
            |_, _| clear(ctx, &buffers.planes),
            |sweep, workgroups| {
                // Written before each dispatch: the write lands at the start of the next
                // submission, so each dispatch (submitted on its own) sees its own values.
                uniform.sweep = *sweep;
                ctx.queue
                    .write_buffer(&buffers.uniform, 0, bytemuck::bytes_of(&uniform));
                shader::dispatch(ctx, &pipeline, &binds[now], workgroups)
            },
        )?;
        bounce += 1;
        let values = buffer::read_buffer::<f32>(ctx, &buffers.fields[now])?;
        Ok(Bands::from_values(per_channel, values))
    })
}

/// The solve's buffers on the GPU.
struct Buffers {
    sigma: wgpu::Buffer,
    ordinates: wgpu::Buffer,
    planes: wgpu::Buffer,
    direct: wgpu::Buffer,
    scattering: wgpu::Buffer,
    fields: [wgpu::Buffer; 2],
    uniform: wgpu::Buffer,
}

impl Buffers {
    /// The bind group that sweeps into field `now` and reads the other as the previous one.
    fn bind(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        now: usize,
    ) -> Result<wgpu::BindGroup> {
        shader::bind_group_at(
            ctx,
            pipeline,
            &[
                (0, self.uniform.as_entire_binding()),
                (1, self.sigma.as_entire_binding()),
                (2, self.ordinates.as_entire_binding()),
                (3, self.planes.as_entire_binding()),
                (4, self.direct.as_entire_binding()),
                (5, self.scattering.as_entire_binding()),
                (6, self.fields[1 - now].as_entire_binding()),
                (7, self.fields[now].as_entire_binding()),
            ],
        )
    }
}

/// Zeroes `buffer` before the submissions that follow.
fn clear(ctx: &GpuContext, buffer: &wgpu::Buffer) {
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("scattering clear"),
        });
    encoder.clear_buffer(buffer, 0, None);
    ctx.queue.submit([encoder.finish()]);
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
            [sweep, per_channel, first_bounce, g]
        );
        assert_mirrors!(
            GpuOrdinate,
            SHADER,
            "Ordinate",
            [floor, fraction, towards, length, gather]
        );
    }
}
