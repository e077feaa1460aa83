//! wgpu context and helpers: small and generic.
//!
//! - [`context`]: opening a device ([`GpuContext`]), `--device auto|gpu|cpu` ([`DeviceChoice`],
//!   [`Compute`]), one shared context per process ([`shared_context`]).
//! - [`texture`]: a `Volume` as a filterable 3D texture ([`VolumeTexture`]).
//! - [`shader`]: WGSL from shaders/ with `//#include`, cached compute pipelines, bind groups,
//!   dispatch.
//! - [`buffer`]: storage/uniform buffers from plain data, readback.

pub mod buffer;
pub mod context;
pub mod shader;
pub mod texture;

pub use context::{shared_context, Compute, DeviceChoice, GpuContext};
pub use texture::{VolumeFormat, VolumeTexture};
