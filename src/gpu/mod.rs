//! wgpu context and helpers: small and generic.
//!
//! - [`context`]: opening a device ([`GpuContext`]), `--device auto|gpu|cpu` ([`DeviceChoice`],
//!   [`Compute`]), one shared context per process ([`shared_context`]).
//! - [`texture`]: a `Volume` as an r32float 3D texture ([`VolumeTexture`]).
//! - [`shader`]: WGSL files ([`shader::Wgsl`], each embedded by the method that owns it; the
//!   shared helpers of shaders/shared/) with `//#include`, cached compute pipelines, bind
//!   groups, dispatch.
//! - [`buffer`]: storage/uniform buffers from plain data, readback.
//! - `view`, `lut_shape`: the uniform parts the renderers share (shaders/shared/view.wgsl's
//!   `View`, shaders/shared/classify.wgsl's `LutShape`); tests check their layout against naga's
//!   (`layout`).

pub mod buffer;
pub mod context;
#[cfg(test)]
pub(crate) mod layout;
pub(crate) mod lut_shape;
pub mod shader;
pub mod texture;
pub(crate) mod view;

pub use context::{shared_context, Compute, DeviceChoice, GpuContext};
pub use texture::VolumeTexture;
