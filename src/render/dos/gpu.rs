//! GPU twin of DOS: shaders/dos.wgsl, one dispatch per slab over the whole image, with the
//! occlusion buffers ping-ponged between two storage buffers. Slabs go to the GPU in batches:
//! one compute pass of consecutive dispatches per submission (wgpu orders them, with barriers,
//! within the pass), each dispatch binding its own 16-byte slice of a buffer of per-slab
//! uniforms, so that submissions and uniform writes do not grow with the slab count. On
//! lavapipe each dispatch still costs ~2.3 ms whatever its size (330 slabs of an 8 x 8 image
//! took 750 ms, batched or one submission per slab), which dominates small images there.

use super::{finish, DosInput, DosSetup, Formulation, MAX_CLIP_PLANES};
use crate::error::{Error, Result};
use crate::gpu::{buffer, shader, GpuContext};
use crate::progress::Progress;
use crate::render::raycast::gpu::{lut_uniform, GpuVolume, ViewUniform};
use crate::render::{RenderImage, BACKGROUND_DEPTH};
use bytemuck::{Pod, Zeroable};
use glam::Vec4;
use wgpu::util::DeviceExt;

const SHADER: &str = "dos.wgsl";
const WORKGROUP: u32 = 8;
/// Slabs per submission: bounds the bind groups alive at once and keeps cancellation prompt.
const SLABS_PER_SUBMIT: u32 = 32;

/// The shader's `Params` uniform, field for field.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    view: ViewUniform,
    lut_range: Vec4,
    lut_size: Vec4,
    ambient: Vec4,
    slabs: Vec4,
    march: Vec4,
    clip_point: [Vec4; MAX_CLIP_PLANES],
    clip_normal: [Vec4; MAX_CLIP_PLANES],
}

/// The shader's `Slab` uniform (padded to 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Slab {
    index: u32,
    radius_px: f32,
    pad: [u32; 2],
}

/// Uploads the inputs and renders.
pub fn render(ctx: &GpuContext, input: &DosInput, progress: &dyn Progress) -> Result<RenderImage> {
    let uploaded = GpuVolume::upload(ctx, input.volume, input.lut)?;
    render_uploaded(ctx, &uploaded, input, progress)
}

/// Renders with an already uploaded volume and table; they must be `input.volume` and
/// `input.lut`.
pub fn render_uploaded(
    ctx: &GpuContext,
    uploaded: &GpuVolume,
    input: &DosInput,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    let setup = input.setup()?;
    let cam = input.camera;
    let pixels = cam.width as usize * cam.height as usize;
    let pipeline = shader::compute_pipeline(ctx, SHADER, "main")?;
    let texture = uploaded.texture();
    let samples: Vec<Vec4> = setup
        .offsets
        .iter()
        .zip(&setup.sample_ring)
        .map(|(q, ring)| Vec4::new(q.x, q.y, *ring as f32, 0.0))
        .collect();
    let samples = buffer::storage_buffer(ctx, "cone samples", &samples)?;
    let ring_lengths = buffer::storage_buffer(ctx, "ring lengths", &setup.ring_lengths)?;
    let uniform = buffer::uniform_buffer(ctx, "dos params", &params(input, &setup))?;
    // Slab 0 reads nothing (V_0 = 1), so the buffers start zeroed.
    let occlusion = [
        buffer::output_buffer::<f32>(ctx, "occlusion a", setup.planes() * pixels)?,
        buffer::output_buffer::<f32>(ctx, "occlusion b", setup.planes() * pixels)?,
    ];
    let eye = buffer::storage_buffer(ctx, "eye", &vec![[0.0f32, 0.0, 0.0, 1.0]; pixels])?;
    let eye_depth =
        buffer::storage_buffer(ctx, "eye depth", &vec![[BACKGROUND_DEPTH, 1.0f32]; pixels])?;
    // Every slab's uniform at its own aligned offset.
    let stride =
        (ctx.limits.min_uniform_buffer_offset_alignment as usize).max(std::mem::size_of::<Slab>());
    let mut slab_bytes = vec![0u8; stride * setup.slabs.max(1) as usize];
    for k in 0..setup.slabs {
        let values = Slab {
            index: k,
            radius_px: setup.base_radius_px(cam, k),
            pad: [0; 2],
        };
        let at = k as usize * stride;
        slab_bytes[at..at + std::mem::size_of::<Slab>()]
            .copy_from_slice(bytemuck::bytes_of(&values));
    }
    let slabs = ctx.checked("buffer `dos slabs`", || {
        ctx.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("dos slabs"),
                contents: &slab_bytes,
                usage: wgpu::BufferUsages::UNIFORM,
            })
    })?;
    let workgroups = [
        cam.width.div_ceil(WORKGROUP),
        cam.height.div_ceil(WORKGROUP),
    ];
    let mut k0 = 0;
    while k0 < setup.slabs {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let batch = k0..(k0 + SLABS_PER_SUBMIT).min(setup.slabs);
        // Slab k reads buffer k % 2 and writes the other.
        let groups = batch
            .clone()
            .map(|k| {
                let g = (k % 2) as usize;
                shader::bind_group(
                    ctx,
                    &pipeline,
                    &[
                        uniform.as_entire_binding(),
                        wgpu::BindingResource::TextureView(&texture.view),
                        wgpu::BindingResource::Sampler(&texture.sampler),
                        uploaded.lut_buffer().as_entire_binding(),
                        samples.as_entire_binding(),
                        occlusion[g].as_entire_binding(),
                        occlusion[1 - g].as_entire_binding(),
                        eye.as_entire_binding(),
                        eye_depth.as_entire_binding(),
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &slabs,
                            offset: (k as usize * stride) as u64,
                            size: wgpu::BufferSize::new(std::mem::size_of::<Slab>() as u64),
                        }),
                        ring_lengths.as_entire_binding(),
                    ],
                )
            })
            .collect::<Result<Vec<_>>>()?;
        ctx.checked("dos dispatches", || {
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline);
                for group in &groups {
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(workgroups[0], workgroups[1], 1);
                }
            }
            ctx.queue.submit([encoder.finish()]);
        })?;
        for k in batch {
            progress.update(k as u64 + 1, setup.slabs as u64);
        }
        k0 += SLABS_PER_SUBMIT;
    }
    let radiance: Vec<[f32; 4]> = buffer::read_buffer(ctx, &eye)?;
    let depth: Vec<[f32; 2]> = buffer::read_buffer(ctx, &eye_depth)?;
    Ok(finish(cam, input.lighting.background, &radiance, &depth))
}

fn params(input: &DosInput, setup: &DosSetup) -> Params {
    let [lut_range, lut_size] = lut_uniform(input.lut);
    let mut clip_point = [Vec4::ZERO; MAX_CLIP_PLANES];
    let mut clip_normal = [Vec4::ZERO; MAX_CLIP_PLANES];
    for (i, plane) in input.params.clip_planes.iter().enumerate() {
        clip_point[i] = plane.point.extend(0.0);
        clip_normal[i] = plane.normal.extend(0.0);
    }
    Params {
        view: ViewUniform::new(input.camera, input.volume),
        lut_range,
        lut_size,
        ambient: setup.ambient.extend(0.0),
        slabs: Vec4::new(
            setup.slice_distance,
            setup.first_depth,
            setup.offsets.len() as f32,
            input.params.clip_planes.len() as f32,
        ),
        march: Vec4::new(
            f32::from(u8::from(input.params.formulation == Formulation::Rays)),
            setup.planes() as f32,
            0.0,
            0.0,
        ),
        clip_point,
        clip_normal,
    }
}
