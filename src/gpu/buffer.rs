//! Storage and uniform buffers from plain data, and reading results back to the CPU.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use crate::error::{Error, Result};

use super::context::GpuContext;

/// Usages of every storage buffer: bound in shaders, filled from the CPU, read back.
const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC);

/// A storage buffer holding `data`.
pub fn storage_buffer<T: Pod>(ctx: &GpuContext, label: &str, data: &[T]) -> Result<wgpu::Buffer> {
    check_storage_size(ctx, label, std::mem::size_of_val(data) as u64)?;
    ctx.checked(&format!("buffer `{label}`"), || {
        ctx.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(data),
                usage: STORAGE,
            })
    })
}

/// A zeroed storage buffer for `len` values of `T` (a kernel's output).
pub fn output_buffer<T: Pod>(ctx: &GpuContext, label: &str, len: usize) -> Result<wgpu::Buffer> {
    let size = (len as u64)
        .checked_mul(std::mem::size_of::<T>() as u64)
        .ok_or_else(|| Error::Gpu(format!("buffer `{label}`: {len} values overflow")))?;
    check_storage_size(ctx, label, size)?;
    ctx.checked(&format!("buffer `{label}`"), || {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: STORAGE,
            mapped_at_creation: false,
        })
    })
}

/// A uniform buffer holding `value` (a `#[repr(C)]` struct laid out as the WGSL struct).
pub fn uniform_buffer<T: Pod>(ctx: &GpuContext, label: &str, value: &T) -> Result<wgpu::Buffer> {
    ctx.checked(&format!("buffer `{label}`"), || {
        ctx.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::bytes_of(value),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
    })
}

/// Rejects empty buffers and ones larger than one storage binding, before allocating.
fn check_storage_size(ctx: &GpuContext, label: &str, size: u64) -> Result<()> {
    let max = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    if size == 0 {
        return Err(Error::Gpu(format!("buffer `{label}` would be empty")));
    }
    if size > max {
        return Err(Error::Gpu(format!(
            "buffer `{label}` needs {:.1} MiB, over the adapter's largest storage binding of \
             {:.1} MiB: split the work into smaller pieces",
            mib(size),
            mib(max)
        )));
    }
    Ok(())
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// Waits for submitted work, then copies `buffer` (a storage buffer) back as values of `T`.
pub fn read_buffer<T: Pod>(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<T>> {
    let size = buffer.size();
    if !size.is_multiple_of(std::mem::size_of::<T>() as u64) {
        return Err(Error::Gpu(format!(
            "buffer of {size} bytes is not a whole number of {}-byte values",
            std::mem::size_of::<T>()
        )));
    }
    // Storage buffers cannot be mapped: copy into a mappable staging buffer first.
    let staging = ctx.checked("readback staging buffer", || {
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        ctx.queue.submit([encoder.finish()]);
        staging
    })?;
    let (sender, receiver) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |result| {
        // The receiver outlives the poll below, so a send cannot fail.
        let _ = sender.send(result);
    });
    ctx.wait()?;
    receiver
        .recv()
        .map_err(|_| Error::Gpu("readback: the map callback never ran".into()))?
        .map_err(|e| Error::Gpu(format!("readback: mapping failed: {e}")))?;
    let values = {
        let view = staging
            .get_mapped_range(..)
            .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
        // pod_collect_to_vec copies, so the mapped bytes need not be aligned for T.
        bytemuck::pod_collect_to_vec(&view[..])
    };
    staging.unmap();
    Ok(values)
}
