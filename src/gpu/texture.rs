//! A `Volume` as a 3D texture with a linear, clamp-to-edge sampler.
//!
//! Voxel (i, j, k)'s centre sits at texture coordinate ((i + 0.5) / nx, (j + 0.5) / ny,
//! (k + 0.5) / nz), so the sampler's trilinear filter at continuous index c reproduces
//! `Volume::sample_index(c)`, clamping included (see `sample_volume` in shaders/common.wgsl).
//! A texture, not a storage buffer, because volumes outgrow one storage binding (128 MiB on
//! lavapipe) long before they outgrow a 3D texture.

use half::slice::HalfFloatSliceExt;

use crate::error::{Error, Result};
use crate::volume::Volume;

use super::context::GpuContext;

/// Largest single upload: the volume goes up in z-slabs of about this size, so the staging
/// copies wgpu makes stay small however large the volume is.
const SLAB_BYTES: usize = 32 << 20;

/// How voxel values are stored on the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeFormat {
    /// Exact f32 values; needs the FLOAT32_FILTERABLE feature to be sampled linearly.
    R32Float,
    /// Half floats (11-bit significand, |value| up to 65504); always filterable.
    R16Float,
}

impl VolumeFormat {
    /// r32float when the context can filter it, else r16float.
    pub fn preferred(ctx: &GpuContext) -> Self {
        if ctx.float32_filterable {
            VolumeFormat::R32Float
        } else {
            VolumeFormat::R16Float
        }
    }

    /// "r32float" or "r16float", as WGSL names the formats.
    pub fn name(self) -> &'static str {
        match self {
            VolumeFormat::R32Float => "r32float",
            VolumeFormat::R16Float => "r16float",
        }
    }

    fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            VolumeFormat::R32Float => wgpu::TextureFormat::R32Float,
            VolumeFormat::R16Float => wgpu::TextureFormat::R16Float,
        }
    }

    fn bytes_per_voxel(self) -> usize {
        match self {
            VolumeFormat::R32Float => 4,
            VolumeFormat::R16Float => 2,
        }
    }
}

/// A volume uploaded to the GPU: bind `view` as `texture_3d<f32>` and `sampler` as `sampler`.
#[derive(Debug)]
pub struct VolumeTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub sampler: wgpu::Sampler,
    pub format: VolumeFormat,
    pub dims: [u32; 3],
}

impl VolumeTexture {
    /// Uploads `volume` in the context's preferred format.
    pub fn upload(ctx: &GpuContext, volume: &Volume) -> Result<Self> {
        Self::upload_as(ctx, volume, VolumeFormat::preferred(ctx))
    }

    /// Uploads `volume` stored as `format`; waits until the upload is done.
    pub fn upload_as(ctx: &GpuContext, volume: &Volume, format: VolumeFormat) -> Result<Self> {
        if format == VolumeFormat::R32Float && !ctx.float32_filterable {
            return Err(Error::Gpu(format!(
                "{} cannot filter r32float textures: upload as r16float",
                ctx.describe()
            )));
        }
        if format == VolumeFormat::R16Float {
            check_half_range(volume)?;
        }
        let dims = texture_dims(ctx, volume.dims())?;
        let texture = ctx.checked("volume texture", || {
            ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("volume"),
                size: extent(dims),
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: format.texture_format(),
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })?;
        write_slabs(ctx, &texture, volume.values(), dims, format)?;
        let view = texture.create_view(&Default::default());
        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("volume trilinear"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Nearest,
            ..Default::default()
        });
        Ok(Self {
            texture,
            view,
            sampler,
            format,
            dims,
        })
    }
}

/// The volume's dims as texture dims, each within the adapter's 3D texture limit.
fn texture_dims(ctx: &GpuContext, dims: [usize; 3]) -> Result<[u32; 3]> {
    let max = ctx.limits.max_texture_dimension_3d;
    if dims.iter().any(|&n| n > max as usize) {
        return Err(Error::Gpu(format!(
            "volume {}x{}x{} is over {}'s 3D texture limit of {max} voxels per axis: \
             downsample or crop it, or use --device cpu",
            dims[0],
            dims[1],
            dims[2],
            ctx.describe()
        )));
    }
    Ok(dims.map(|n| n as u32))
}

/// Half floats overflow to infinity beyond 65504: refuse rather than upload infinities.
fn check_half_range(volume: &Volume) -> Result<()> {
    let (lo, hi) = volume.value_range();
    let limit = half::f16::MAX.to_f32();
    if lo < -limit || hi > limit {
        return Err(Error::Gpu(format!(
            "values span [{lo}, {hi}], beyond float16's +-{limit}: this adapter cannot filter \
             float32 textures, so rescale the volume or use --device cpu"
        )));
    }
    Ok(())
}

fn extent([width, height, depth]: [u32; 3]) -> wgpu::Extent3d {
    wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: depth,
    }
}

/// Writes `values` (x fastest) into `texture` one z-slab at a time, waiting after each slab so
/// that wgpu frees its staging copy before the next.
fn write_slabs(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    values: &[f32],
    dims: [u32; 3],
    format: VolumeFormat,
) -> Result<()> {
    let slice_len = dims[0] as usize * dims[1] as usize;
    let slab_depth = (SLAB_BYTES / (slice_len * format.bytes_per_voxel())).max(1);
    let mut halves = Vec::new();
    for (slab, chunk) in values.chunks(slab_depth * slice_len).enumerate() {
        let bytes: &[u8] = match format {
            VolumeFormat::R32Float => bytemuck::cast_slice(chunk),
            VolumeFormat::R16Float => {
                halves.resize(chunk.len(), half::f16::ZERO);
                halves.convert_from_f32_slice(chunk);
                bytemuck::cast_slice(&halves)
            }
        };
        let z = (slab * slab_depth) as u32;
        let depth = (chunk.len() / slice_len) as u32;
        ctx.checked("volume upload", || {
            ctx.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: 0, z },
                    aspect: wgpu::TextureAspect::All,
                },
                bytes,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(dims[0] * format.bytes_per_voxel() as u32),
                    rows_per_image: Some(dims[1]),
                },
                extent([dims[0], dims[1], depth]),
            );
            ctx.queue.submit([]);
        })?;
        ctx.wait()?;
    }
    Ok(())
}
