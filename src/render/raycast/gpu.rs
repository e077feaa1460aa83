//! GPU twin of the ray caster: src/render/raycast/raycast.wgsl, one invocation per pixel,
//! dispatched in bands of rows so that each band's output fits one storage binding and progress is
//! reported.

use super::{RaycastInput, RaycastSetup, Shading};
use crate::classify::Lut;
use crate::error::Result;
use crate::gpu::lut_shape::LutShapeUniform;
use crate::gpu::view::ViewUniform;
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext, VolumeTexture,
};
use crate::lights::{Light, MAX_LIGHTS};
use crate::optics::occupancy::{Occupancy, CELL};
use crate::progress::Progress;
use crate::render::RenderImage;
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

pub(crate) const SHADER: Wgsl = Wgsl {
    name: "raycast.wgsl",
    text: include_str!("raycast.wgsl"),
    includes: &[],
};
const WORKGROUP: u32 = 8;
/// Bands per image at least, so that long renders report progress.
const MIN_BANDS: u32 = 8;

/// `Params::shading`: the shader's SHADING_* constants.
const SHADING_UNSHADED: u32 = 0;
const SHADING_GRADIENT: u32 = 1;
const SHADING_AO: u32 = 2;
/// AO for the ambient light, gradient shading for the others.
const SHADING_AO_GRADIENT: u32 = 3;

/// `GpuLight::kind`: the shader's LIGHT_* constants.
const LIGHT_DIRECTIONAL: u32 = 1;
const LIGHT_POINT: u32 = 2;

/// One light as the shader's `Light` struct.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuLight {
    /// Directional: unit direction towards the light; point: position.
    vector: Vec3,
    kind: u32,
    /// Irradiance (directional) or intensity (point).
    colour: Vec3,
    _pad: u32,
}

/// The shader's `Params` uniform, field for field (see src/render/raycast/raycast.wgsl for each
/// field).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    view: ViewUniform,
    lut: LutShapeUniform,
    ambient: Vec3,
    step: f32,
    background: Vec3,
    ert_threshold: f32,
    normal_threshold: f32,
    shading: u32,
    specular: f32,
    shininess: f32,
    light_count: u32,
    opacity_modulation: u32,
    first_row: u32,
    rows: u32,
    cells: UVec3,
    cell_voxels: u32,
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
    /// The volume as a 3D texture.
    pub(crate) fn texture(&self) -> &VolumeTexture {
        &self.texture
    }
    /// The classification table's storage buffer.
    pub(crate) fn lut_buffer(&self) -> &wgpu::Buffer {
        &self.lut_buffer
    }
    /// The occupancy grid: its cells per axis and its flags' storage buffer.
    pub(crate) fn occupancy(&self) -> ([usize; 3], &wgpu::Buffer) {
        (self.cells, &self.occupancy_buffer)
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
    let pipeline = shader::compute_pipeline(ctx, &SHADER, "main")?;
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
        params.first_row = row0;
        params.rows = rows;
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
    let (shading, specular, shininess) = match input.params.shading {
        Shading::Unshaded => (SHADING_UNSHADED, 0.0, 1.0),
        Shading::Gradient(g) => (SHADING_GRADIENT, g.specular, g.shininess),
        Shading::AmbientOcclusion { direct: None } => (SHADING_AO, 0.0, 1.0),
        Shading::AmbientOcclusion { direct: Some(g) } => {
            (SHADING_AO_GRADIENT, g.specular, g.shininess)
        }
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
            } => (LIGHT_DIRECTIONAL, to_light, irradiance),
            Light::Point {
                position,
                intensity,
            } => (LIGHT_POINT, position, intensity),
        };
        lights[count] = GpuLight {
            vector,
            kind,
            colour,
            _pad: 0,
        };
        count += 1;
    }
    Params {
        view: ViewUniform::new(input.camera, input.volume),
        lut: LutShapeUniform::new(input.lut),
        ambient: input.lighting.ambient(),
        step: setup.step,
        background: input.lighting.background,
        ert_threshold: input.params.ert_threshold,
        normal_threshold: setup.normal_threshold,
        shading,
        specular,
        shininess,
        light_count: count as u32,
        opacity_modulation: u32::from(modulated),
        first_row: 0,
        rows: 0,
        cells: UVec3::new(cells[0] as u32, cells[1] as u32, cells[2] as u32),
        cell_voxels: CELL as u32,
        lights,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::{assert_mirrors, u32_constant};

    #[test]
    fn uniforms_match_the_shader() {
        assert_mirrors!(
            Params,
            SHADER,
            "Params",
            [
                view,
                lut,
                ambient,
                step,
                background,
                ert_threshold,
                normal_threshold,
                shading,
                specular,
                shininess,
                light_count,
                opacity_modulation,
                first_row,
                rows,
                cells,
                cell_voxels,
                lights
            ]
        );
        assert_mirrors!(GpuLight, SHADER, "Light", [vector, kind, colour]);
        assert_eq!(u32_constant(&SHADER, "MAX_LIGHTS") as usize, MAX_LIGHTS);
    }

    #[test]
    fn codes_match_the_shader() {
        for (name, code) in [
            ("SHADING_UNSHADED", SHADING_UNSHADED),
            ("SHADING_GRADIENT", SHADING_GRADIENT),
            ("SHADING_AO", SHADING_AO),
            ("SHADING_AO_GRADIENT", SHADING_AO_GRADIENT),
            ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
            ("LIGHT_POINT", LIGHT_POINT),
        ] {
            assert_eq!(u32_constant(&SHADER, name), code, "{name}");
        }
    }
}
