//! Ambient-occlusion volumes: per-voxel occlusion grids that renderers (and Blender, through
//! VDB) shade with. `reference` holds the Monte Carlo references the fast methods are measured
//! against.

pub mod reference;
