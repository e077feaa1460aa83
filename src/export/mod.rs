//! Writers for results: EXR images, PNG previews, OpenVDB grids and USD stages; all written
//! atomically.

pub mod atomic;
pub mod exr;
pub mod png;
pub mod usd;
pub mod vdb;
