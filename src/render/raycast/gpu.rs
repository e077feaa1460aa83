//! GPU twin of the ray caster: shaders/raycast.wgsl, one invocation per pixel, dispatched in
//! bands of rows so that each band's output fits one storage binding and progress is reported.

use super::{RaycastInput, RaycastSetup, Shading};
use crate::camera::Camera;
use crate::classify::Lut;
use crate::error::Result;
use crate::gpu::{buffer, shader, GpuContext, VolumeTexture};
use crate::lights::{Light, MAX_LIGHTS};
use crate::progress::Progress;
use crate::render::occupancy::{Occupancy, CELL};
use crate::render::RenderImage;
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};

const SHADER: &str = "raycast.wgsl";
const WORKGROUP: u32 = 8;
/// Bands per image at least, so that long renders report progress.
const MIN_BANDS: u32 = 8;

/// One light as the shader's `Light` struct.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuLight {
    kind: Vec4,
    vector: Vec4,
    colour: Vec4,
}

/// The camera and the volume's placement, as the first fields of the kernels' `Params`
/// uniforms (shaders/raycast.wgsl, shaders/dos.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct ViewUniform {
    cam_position: Vec4,
    cam_forward: Vec4,
    cam_right: Vec4,
    cam_up: Vec4,
    image: Vec4,
    box_lo: Vec4,
    box_hi: Vec4,
    vol_origin: Vec4,
    vol_spacing: Vec4,
    vol_dims: Vec4,
}

impl ViewUniform {
    pub(crate) fn new(cam: &Camera, volume: &Volume) -> Self {
        let (hx, hy) = cam.half_extent();
        let (lo, hi) = volume.bounds();
        let [nx, ny, nz] = volume.dims();
        Self {
            cam_position: cam
                .position
                .extend(if cam.is_perspective() { 1.0 } else { 0.0 }),
            cam_forward: cam.forward.extend(0.0),
            cam_right: cam.right.extend(0.0),
            cam_up: cam.up.extend(0.0),
            image: Vec4::new(hx, hy, cam.width as f32, cam.height as f32),
            box_lo: lo.extend(0.0),
            box_hi: hi.extend(0.0),
            vol_origin: volume.origin().extend(0.0),
            vol_spacing: volume.spacing().extend(0.0),
            vol_dims: Vec3::new(nx as f32, ny as f32, nz as f32).extend(0.0),
        }
    }
}

/// The table's `lut_range` and `lut_size` fields (shaders/classify.wgsl's `lut_lookup`).
pub(crate) fn lut_uniform(lut: &Lut) -> [Vec4; 2] {
    let [vmin, vmax] = lut.value_range();
    let [nv, ng] = lut.size();
    [
        Vec4::new(vmin, vmax, lut.gradient_max().unwrap_or(0.0), 0.0),
        Vec4::new(nv as f32, ng as f32, 0.0, 0.0),
    ]
}

/// The shader's `Params` uniform, field for field.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    view: ViewUniform,
    ambient: Vec4,
    background: Vec4,
    lut_range: Vec4,
    lut_size: Vec4,
    march: Vec4,
    phong: Vec4,
    band: Vec4,
    cells: Vec4,
    lights: [GpuLight; MAX_LIGHTS],
}

/// A volume, its classification table and its occupancy grid resident on the GPU, reusable
/// across renders.
pub struct GpuVolume<'a> {
    volume: &'a Volume,
    lut: &'a Lut,
    texture: VolumeTexture,
    lut_buffer: wgpu::Buffer,
    cells: [usize; 3],
    occupancy_buffer: wgpu::Buffer,
    /// A one-voxel texture of 1 that stands in for the AO bindings of renders without AO.
    unit: VolumeTexture,
}

impl<'a> GpuVolume<'a> {
    /// Uploads the volume (3D texture), the table and the occupancy grid (storage buffers).
    pub fn upload(ctx: &GpuContext, volume: &'a Volume, lut: &'a Lut) -> Result<Self> {
        let occupancy = Occupancy::build(volume, lut);
        Ok(Self {
            volume,
            lut,
            texture: VolumeTexture::upload(ctx, volume)?,
            lut_buffer: buffer::storage_buffer(ctx, "classification table", lut.data())?,
            cells: occupancy.cells(),
            occupancy_buffer: buffer::storage_buffer(ctx, "occupancy", occupancy.flags())?,
            unit: VolumeTexture::upload(
                ctx,
                &Volume::new([1, 1, 1], Vec3::ONE, Vec3::ZERO, vec![1.0])?,
            )?,
        })
    }
}

impl GpuVolume<'_> {
    /// The volume as a 3D texture with its linear sampler.
    pub(crate) fn texture(&self) -> &VolumeTexture {
        &self.texture
    }
    /// The classification table's storage buffer.
    pub(crate) fn lut_buffer(&self) -> &wgpu::Buffer {
        &self.lut_buffer
    }
}

/// Uploads the inputs and renders.
pub fn render(
    ctx: &GpuContext,
    input: &RaycastInput,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    let uploaded = GpuVolume::upload(ctx, input.volume, input.lut)?;
    render_uploaded(ctx, &uploaded, input, progress)
}

/// Renders with an already uploaded volume; `input.volume` and `input.lut` must be the ones
/// uploaded (they are taken from `uploaded`).
pub fn render_uploaded(
    ctx: &GpuContext,
    uploaded: &GpuVolume,
    input: &RaycastInput,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    let input = RaycastInput {
        volume: uploaded.volume,
        lut: uploaded.lut,
        ..*input
    };
    let setup = input.setup()?;
    let pipeline = shader::compute_pipeline(ctx, SHADER, "main")?;
    let (width, height) = (input.camera.width, input.camera.height);
    let mut img = RenderImage::new(width, height);
    // Bytes per row of output: RGBA f32 plus depth f32.
    let max_rows = (ctx.limits.max_storage_buffer_binding_size / (width as u64 * 16)).max(1) as u32;
    let band_rows = height.div_ceil(MIN_BANDS).clamp(1, max_rows);
    let mut params = params(&input, &setup, uploaded.cells);
    // The AO volumes of this render, uploaded; the volume's unit texture stands in for those
    // it does not have.
    let upload = |grid: Option<&Volume>| grid.map(|g| VolumeTexture::upload(ctx, g)).transpose();
    let openness = upload(input.ao.map(|ao| ao.openness))?;
    let opacity = upload(input.ao.and_then(|ao| ao.opacity))?;
    let openness = openness.as_ref().unwrap_or(&uploaded.unit);
    let opacity = opacity.as_ref().unwrap_or(&uploaded.unit);
    let mut row0 = 0;
    while row0 < height {
        let rows = band_rows.min(height - row0);
        params.band = Vec4::new(row0 as f32, rows as f32, 0.0, 0.0);
        let pixels = (width * rows) as usize;
        let uniform = buffer::uniform_buffer(ctx, "raycast params", &params)?;
        let rgba = buffer::output_buffer::<[f32; 4]>(ctx, "raycast rgba", pixels)?;
        let depth = buffer::output_buffer::<f32>(ctx, "raycast depth", pixels)?;
        let bind = shader::bind_group(
            ctx,
            &pipeline,
            &[
                uniform.as_entire_binding(),
                wgpu::BindingResource::TextureView(&uploaded.texture.view),
                wgpu::BindingResource::Sampler(&uploaded.texture.sampler),
                uploaded.lut_buffer.as_entire_binding(),
                rgba.as_entire_binding(),
                depth.as_entire_binding(),
                uploaded.occupancy_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&openness.view),
                wgpu::BindingResource::TextureView(&opacity.view),
            ],
        )?;
        shader::dispatch(
            ctx,
            &pipeline,
            &bind,
            [width.div_ceil(WORKGROUP), rows.div_ceil(WORKGROUP), 1],
        )?;
        let start = (row0 * width) as usize;
        img.rgba[start..start + pixels].copy_from_slice(&buffer::read_buffer(ctx, &rgba)?);
        img.depth[start..start + pixels].copy_from_slice(&buffer::read_buffer(ctx, &depth)?);
        row0 += rows;
        progress.update(row0 as u64, height as u64);
    }
    Ok(img)
}

fn params(input: &RaycastInput, setup: &RaycastSetup, cells: [usize; 3]) -> Params {
    let [lut_range, lut_size] = lut_uniform(input.lut);
    // The shader's shading codes: 0 unshaded, 1 gradient, 2 AO, 3 AO with gradient direct.
    let (shading, specular, shininess) = match input.params.shading {
        Shading::Unshaded => (0.0, 0.0, 1.0),
        Shading::Gradient(g) => (1.0, g.specular, g.shininess),
        Shading::AmbientOcclusion { direct: None } => (2.0, 0.0, 1.0),
        Shading::AmbientOcclusion { direct: Some(g) } => (3.0, g.specular, g.shininess),
    };
    let modulated = input.ao.is_some_and(|ao| ao.opacity.is_some());
    let mut lights = [GpuLight::zeroed(); MAX_LIGHTS];
    let mut count = 0;
    for light in &input.lighting.lights {
        let (kind, vector, colour) = match *light {
            Light::Ambient { .. } => continue,
            Light::Directional {
                to_light,
                irradiance,
            } => (1.0, to_light, irradiance),
            Light::Point {
                position,
                intensity,
            } => (2.0, position, intensity),
        };
        lights[count] = GpuLight {
            kind: Vec4::new(kind, 0.0, 0.0, 0.0),
            vector: vector.extend(0.0),
            colour: colour.extend(0.0),
        };
        count += 1;
    }
    Params {
        view: ViewUniform::new(input.camera, input.volume),
        ambient: input.lighting.ambient().extend(0.0),
        background: input.lighting.background.extend(0.0),
        lut_range,
        lut_size,
        march: Vec4::new(
            setup.step,
            input.params.ert_threshold,
            setup.normal_threshold,
            shading,
        ),
        phong: Vec4::new(
            specular,
            shininess,
            count as f32,
            f32::from(u8::from(modulated)),
        ),
        band: Vec4::ZERO,
        cells: Vec4::new(
            cells[0] as f32,
            cells[1] as f32,
            cells[2] as f32,
            CELL as f32,
        ),
        lights,
    }
}
