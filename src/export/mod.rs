//! Writers for results: EXR images, PNG previews; all written atomically.

pub mod atomic;
pub mod exr;
pub mod png;
pub mod vdb;
