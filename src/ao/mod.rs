//! Ambient-occlusion volumes: per-voxel occlusion grids that renderers (and Blender, through
//! VDB) shade with. `vao` computes them fast from local statistics (CPU and GPU twins);
//! `reference` holds the Monte Carlo references the fast methods are measured against.

pub mod commands;
pub mod reference;
pub mod vao;
