//! Occlux: illumination for scientific volumes (ambient occlusion, directional occlusion,
//! sweeps), computed on the GPU through wgpu with a CPU twin that gives the same answers.
//!
//! Data flows one way: [`volume`] (load) -> [`classify`] -> [`render`] -> [`export`].

pub mod ao;
pub mod bake;
pub mod budget;
pub mod camera;
pub mod classify;
pub mod error;
pub mod export;
pub mod font;
pub mod framing;
pub mod gpu;
pub mod json;
pub mod lights;
pub mod memory;
pub mod method;
pub mod metric;
pub mod names;
pub mod octahedral;
pub mod optics;
pub mod pipeline;
pub mod plan;
pub mod progress;
pub mod registry;
pub mod render;
pub mod scene;
pub mod series;
pub mod span;
pub mod transport;
pub mod volume;

pub use error::{Error, Result};
