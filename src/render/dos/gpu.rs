//! GPU twin of DOS: src/render/dos/dos.wgsl, one dispatch per slab over the whole image, with the
//! occlusion buffers ping-ponged between two storage buffers. Slabs go to the GPU in batches:
//! one compute pass of consecutive dispatches per submission (wgpu orders them, with barriers,
//! within the pass), each dispatch binding its own 16-byte slice of a buffer of per-slab
//! uniforms, so that submissions and uniform writes do not grow with the slab count. On
//! lavapipe each dispatch still costs ~2.3 ms whatever its size (330 slabs of an 8 x 8 image
//! took 750 ms, batched or one submission per slab), which dominates small images there.

use super::{finish, DosInput, DosSetup, Formulation, MAX_CLIP_PLANES};
use crate::error::{Error, Result};
use crate::gpu::lut_shape::LutShapeUniform;
use crate::gpu::view::ViewUniform;
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::optics::occupancy::CELL;
use crate::progress::Progress;
use crate::render::raycast::gpu::GpuVolume;
use crate::render::{RenderImage, BACKGROUND_DEPTH};
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec2, Vec3};
use wgpu::util::DeviceExt;

const SHADER: Wgsl = Wgsl {
    name: "dos.wgsl",
    text: include_str!("dos.wgsl"),
    includes: &[],
};
const WORKGROUP: u32 = 8;
/// Slabs per submission: bounds the bind groups alive at once and keeps cancellation prompt.
const SLABS_PER_SUBMIT: u32 = 32;

/// The shader's `Params` uniform, field for field (see src/render/dos/dos.wgsl for each field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    view: ViewUniform,
    lut: LutShapeUniform,
    ambient: Vec3,
    slice_distance: f32,
    first_depth: f32,
    sample_count: u32,
    clip_count: u32,
    lock_step_rays: u32,
    planes: u32,
    self_occlusion: u32,
    _pad: [u32; 2],
    cells: UVec3,
    cell_voxels: u32,
    clip_planes: [GpuClipPlane; MAX_CLIP_PLANES],
}

/// The shader's `ClipPlane`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuClipPlane {
    point: Vec3,
    _pad0: u32,
    normal: Vec3,
    _pad1: u32,
}

/// The shader's `ConeSample`, an element of the `samples` storage array.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ConeSample {
    /// On the unit disc.
    offset: Vec2,
    /// The occlusion buffer's plane (the sample's ring).
    plane: u32,
    _pad: u32,
}

/// The shader's `Slab` uniform (padded to 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Slab {
    index: u32,
    radius_px: f32,
    _pad: [u32; 2],
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
    // The buffers' camera: the view and its guard band.
    let cam = &setup.camera;
    let pixels = cam.width as usize * cam.height as usize;
    let pipeline = shader::compute_pipeline(ctx, &SHADER, "main")?;
    let texture = uploaded.texture();
    let samples: Vec<ConeSample> = setup
        .offsets
        .iter()
        .zip(&setup.sample_ring)
        .map(|(&offset, &plane)| ConeSample {
            offset,
            plane,
            _pad: 0,
        })
        .collect();
    let samples = buffer::storage_buffer(ctx, "cone samples", &samples)?;
    let ring_lengths = buffer::storage_buffer(ctx, "ring lengths", &setup.ring_lengths)?;
    let (cells, occupancy) = uploaded.occupancy();
    let uniform = buffer::uniform_buffer(ctx, "dos params", &params(input, &setup, cells))?;
    // Slab 0 reads nothing (V_0 = 1), so the buffers start zeroed.
    let occlusion = [
        buffer::output_buffer::<f32>(ctx, "occlusion a", setup.planes() * pixels)?,
        buffer::output_buffer::<f32>(ctx, "occlusion b", setup.planes() * pixels)?,
    ];
    let eye = buffer::storage_buffer(ctx, "eye", &vec![[0.0f32, 0.0, 0.0, 1.0]; pixels])?;
    let eye_depth =
        buffer::storage_buffer(ctx, "eye depth", &vec![[BACKGROUND_DEPTH, 0.0f32]; pixels])?;
    // Every slab's uniform at its own aligned offset.
    let stride =
        (ctx.limits.min_uniform_buffer_offset_alignment as usize).max(std::mem::size_of::<Slab>());
    let mut slab_bytes = vec![0u8; stride * setup.slabs.max(1) as usize];
    for k in 0..setup.slabs {
        let values = Slab {
            index: k,
            radius_px: setup.base_radius_px(cam, k),
            _pad: [0; 2],
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
                        occupancy.as_entire_binding(),
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
    Ok(finish(input, setup.band, &radiance, &depth))
}

fn params(input: &DosInput, setup: &DosSetup, cells: [usize; 3]) -> Params {
    let mut clip_planes = [GpuClipPlane::zeroed(); MAX_CLIP_PLANES];
    for (gpu, plane) in clip_planes.iter_mut().zip(&input.params.clip_planes) {
        gpu.point = plane.point;
        gpu.normal = plane.normal;
    }
    Params {
        view: ViewUniform::new(&setup.camera, input.volume),
        lut: LutShapeUniform::new(input.lut),
        ambient: setup.ambient,
        slice_distance: setup.slice_distance,
        first_depth: setup.first_depth,
        sample_count: setup.offsets.len() as u32,
        clip_count: input.params.clip_planes.len() as u32,
        lock_step_rays: u32::from(input.params.formulation == Formulation::Rays),
        planes: setup.planes() as u32,
        self_occlusion: u32::from(input.params.self_occlusion),
        _pad: [0; 2],
        cells: UVec3::new(cells[0] as u32, cells[1] as u32, cells[2] as u32),
        cell_voxels: CELL as u32,
        clip_planes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::{assert_mirrors, u32_constant};

    #[test]
    fn uniforms_and_samples_match_the_shader() {
        assert_mirrors!(
            Params,
            SHADER,
            "Params",
            [
                view,
                lut,
                ambient,
                slice_distance,
                first_depth,
                sample_count,
                clip_count,
                lock_step_rays,
                planes,
                self_occlusion,
                cells,
                cell_voxels,
                clip_planes
            ]
        );
        assert_mirrors!(GpuClipPlane, SHADER, "ClipPlane", [point, normal]);
        assert_mirrors!(ConeSample, SHADER, "ConeSample", [offset, plane]);
        assert_mirrors!(Slab, SHADER, "Slab", [index, radius_px]);
        assert_eq!(
            u32_constant(&SHADER, "MAX_CLIP_PLANES") as usize,
            MAX_CLIP_PLANES
        );
    }
}
