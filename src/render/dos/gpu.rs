//! GPU twin of DOS: shaders/dos.wgsl, one dispatch per slab over the whole image, with the
//! occlusion buffers ping-ponged between two storage buffers.

use super::{finish, DosInput, DosSetup, Formulation, MAX_CLIP_PLANES};
use crate::error::{Error, Result};
use crate::gpu::{buffer, shader, GpuContext};
use crate::progress::Progress;
use crate::render::raycast::gpu::{lut_uniform, GpuVolume, ViewUniform};
use crate::render::{RenderImage, BACKGROUND_DEPTH};
use bytemuck::{Pod, Zeroable};
use glam::Vec4;

const SHADER: &str = "dos.wgsl";
const WORKGROUP: u32 = 8;
/// Slabs submitted between waits: keeps the queue short and cancellation prompt.
const SLABS_PER_WAIT: u32 = 16;

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
        .zip(&setup.path_lengths)
        .map(|(q, l)| Vec4::new(q.x, q.y, *l, 0.0))
        .collect();
    let samples = buffer::storage_buffer(ctx, "cone samples", &samples)?;
    let uniform = buffer::uniform_buffer(ctx, "dos params", &params(input, &setup))?;
    let slab = buffer::uniform_buffer(ctx, "dos slab", &Slab::zeroed())?;
    let occlusion = [
        buffer::storage_buffer(ctx, "occlusion a", &vec![[1.0f32, 0.0]; pixels])?,
        buffer::storage_buffer(ctx, "occlusion b", &vec![[1.0f32, 0.0]; pixels])?,
    ];
    let eye = buffer::storage_buffer(ctx, "eye", &vec![[0.0f32, 0.0, 0.0, 1.0]; pixels])?;
    let eye_depth =
        buffer::storage_buffer(ctx, "eye depth", &vec![[BACKGROUND_DEPTH, 1.0f32]; pixels])?;
    // Bind group `g` reads buffer g and writes the other: slab k uses group k % 2.
    let groups = [0, 1].map(|g| {
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
                slab.as_entire_binding(),
            ],
        )
    });
    let [a, b] = groups;
    let groups = [a?, b?];
    let workgroups = [
        cam.width.div_ceil(WORKGROUP),
        cam.height.div_ceil(WORKGROUP),
        1,
    ];
    for k in 0..setup.slabs {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let values = Slab {
            index: k,
            radius_px: setup.base_radius_px(cam, k),
            pad: [0; 2],
        };
        // A queued write lands before the next submission, so each dispatch sees its slab.
        ctx.queue
            .write_buffer(&slab, 0, bytemuck::bytes_of(&values));
        shader::dispatch(ctx, &pipeline, &groups[(k % 2) as usize], workgroups)?;
        if (k + 1) % SLABS_PER_WAIT == 0 {
            ctx.wait()?;
        }
        progress.update(k as u64 + 1, setup.slabs as u64);
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
            0.0,
            0.0,
            0.0,
        ),
        clip_point,
        clip_normal,
    }
}
