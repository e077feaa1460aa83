//! A `Volume` as an r32float 3D texture: texel (i, j, k) holds voxel (i, j, k)'s value exactly.
//!
//! Kernels interpolate it themselves (`sample_volume` in shaders/shared/common.wgsl loads the eight
//! texels and reproduces `Volume::sample_index` in f32), so no sampler is bound: hardware
//! filters weigh texels in low precision, and r32float needs FLOAT32_FILTERABLE to be filtered
//! at all. A texture, not a storage buffer, because volumes outgrow one storage binding
//! (128 MiB on lavapipe) long before they outgrow a 3D texture.

use crate::error::{Error, Result};
use crate::volume::Volume;

use super::context::GpuContext;

/// Largest single upload: the volume goes up in z-slabs of about this size, so the staging
/// copies wgpu makes stay small however large the volume is.
const SLAB_BYTES: usize = 32 << 20;

/// Bytes per voxel of the texture (r32float).
const BYTES_PER_VOXEL: usize = 4;

/// A volume uploaded to the GPU: bind `view` as `texture_3d<f32>`.
#[derive(Debug)]
pub struct VolumeTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub dims: [u32; 3],
}

impl VolumeTexture {
    /// Uploads `volume`; waits until the upload is done.
    pub fn upload(ctx: &GpuContext, volume: &Volume) -> Result<Self> {
        let dims = texture_dims(ctx, volume.dims())?;
        let texture = ctx.checked("volume texture", || {
            ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("volume"),
                size: extent(dims),
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })?;
        write_slabs(ctx, &texture, volume.values(), dims)?;
        let view = texture.create_view(&Default::default());
        Ok(Self {
            texture,
            view,
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
) -> Result<()> {
    let slice_len = dims[0] as usize * dims[1] as usize;
    let slab_depth = (SLAB_BYTES / (slice_len * BYTES_PER_VOXEL)).max(1);
    for (slab, chunk) in values.chunks(slab_depth * slice_len).enumerate() {
        let bytes: &[u8] = bytemuck::cast_slice(chunk);
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
                    bytes_per_row: Some(dims[0] * BYTES_PER_VOXEL as u32),
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
