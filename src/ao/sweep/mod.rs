//! Occlusion sweeping (after the fast occlusion sweeping paper, seed 003): ambient occlusion in
//! eight sweeps over the grid, one per octant of directions, each O(voxels) at any range.
//!
//! Two modes, each a folder whose `mod.rs` holds its parameters and chooses the device, with
//! `cpu` and `gpu` twins beside it:
//! - [`physical`]: the visibility V(x), the mean transmittance of the extinction from x over
//!   all directions, by a seven-neighbour stencil; under ambient light it makes AO-shaded DVR
//!   exact up to V's error.
//! - [`geometric`] (the paper's): ambient occlusion of an iso-surface from its signed distance
//!   ([`sdf`], fast sweeping), by the paper's three-neighbour average, weighed by the octants'
//!   geometry terms. Its GPU octants run the physical mode's kernel with the paper's terms.
//!
//! What they share: [`padded`] (the padded grid, the octants, the sweep orders) and, on the
//! GPU, `planes` (how a volume's plane-by-plane sweep fits the adapter, the host side of
//! shaders/shared/plane.wgsl).

pub mod geometric;
pub mod padded;
pub mod physical;
mod planes;
pub mod sdf;
