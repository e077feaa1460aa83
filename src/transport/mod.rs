//! Light transport on the volume's grid by straight paths: discrete ordinates with short
//! characteristics, as radiative-transfer solvers sweep a grid.
//!
//! The ambient visibility V(x), the mean transmittance from x over all directions (under
//! uniform ambient light with an isotropic phase function, the single-scattered radiance at x
//! is the ambient radiance times V(x): docs/architecture.md#truth-per-lighting), is the
//! weighted sum over a set of directions w ([`directions`]) of T_w(x), the transmittance from
//! x to the grid's edge along w. Per direction one sweep computes T_w on every voxel:
//! - the planes across w's dominant axis (in voxel units) are visited from the side w points
//!   to, so the plane upwind of a voxel is always done before it;
//! - the straight path from x towards w meets the upwind plane at a point p between four
//!   voxel centres (the same four, with the same bilinear weights, for every voxel of the
//!   direction), where T_w and the extinction are interpolated;
//! - T_w(x) = T_w(p) exp(-|x - p| (sigma_t(x) + sigma_t(p)) / 2), the trapezoid rule over the
//!   segment; outside the grid there is no matter: T = 1 and sigma_t = 0.
//!
//! Every path is straight, so unlike a lattice walk (the occlusion sweep's physical mode,
//! which crosses about 19 % more optical depth than the straight paths it stands for) there is
//! no path-length bias: in a homogeneous medium every step is exact but for the bilinear
//! interpolation, which is exact where T is linear across a voxel. The errors that remain, and
//! how they fall:
//! - angular: N directions stand for 4 pi / N of the sphere each; a feature of width w at
//!   distance r is seen by about N w^2 / (4 pi r^2) of them, so the error of V at x falls as
//!   1 / N where T_w varies smoothly with w and is set, for thin features far away, by how many
//!   directions meet them (ray effects);
//! - spatial: the interpolation on the upwind plane diffuses T across the direction by up to a
//!   voxel per step (sqrt(n) voxels after n steps), blurring shadows of sharp edges; it falls
//!   as the grid is refined (first order in the voxel size for a step edge, second order for
//!   smooth fields);
//! - the trapezoid rule: second order in the voxel size along the path.
//!
//! Both twins visit the sweep orders (a dominant axis and its sign, [`directions::Group`]) in
//! the same order, the planes of each in the sweep's order, and add each voxel's directions in
//! the set's order, so they differ only by the rounding of exp (tests/transport_twins.rs).
//! Memory: the output, the extinction, and per direction of one sweep order two padded planes
//! (the upwind one and the one being swept): a direction's working set is two planes, not the
//! whole angular field.

pub mod cpu;
pub mod directions;
pub mod gpu;
pub mod medium;
pub mod scattering;

use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::volume::Volume;
use directions::Ordinates;

/// Directions by default. The per-voxel error of V against straight-ray marching in 256
/// directions falls from about 0.02 at 16 directions to 0.01 at 32 and 0.008 at 64, where the
/// spatial error (the interpolation's diffusion, which more directions do not reduce) begins
/// to dominate, and the time is linear in the count: 64 is where doubling stops paying, and
/// that does not depend on the volume (the angular error falls as 1 / N on any volume; the
/// spatial one is set by the grid).
pub const DEFAULT_DIRECTIONS: u32 = 64;

/// The visibility volume of `extinction` (sigma_t per world unit at each voxel centre) over
/// `directions` Fibonacci directions, on `compute`. `progress` counts planes (each sweep order
/// visits all planes across its axis once).
pub fn visibility(
    compute: &Compute,
    extinction: &Volume,
    directions: u32,
    progress: &dyn Progress,
) -> Result<Volume> {
    let ordinates = prepare(extinction, directions)?;
    match compute {
        Compute::Gpu(ctx) => gpu::visibility(ctx, extinction, &ordinates, progress),
        Compute::Cpu => cpu::visibility(extinction, &ordinates, progress),
    }
}

/// The ordinates for `extinction`'s grid, once its extinction is known to be finite and
/// non-negative everywhere: what both twins accept.
pub fn prepare(extinction: &Volume, directions: u32) -> Result<Ordinates> {
    let ordinates = Ordinates::new(directions, extinction.spacing())?;
    if let Some(at) = extinction
        .values()
        .iter()
        .position(|s| !(s.is_finite() && *s >= 0.0))
    {
        return Err(Error::Volume(format!(
            "light transport needs a finite, non-negative extinction at every voxel; voxel {at} \
             holds {}",
            extinction.values()[at]
        )));
    }
    Ok(ordinates)
}

/// The planes across one axis of a grid, padded by one voxel on each side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Planes {
    /// Voxels of a plane along its two axes (unpadded), and the planes across the axis.
    pub lateral: [usize; 2],
    pub count: usize,
    /// The grid's strides (in voxels) of the plane's two axes and of the axis.
    pub strides: [usize; 3],
}

impl Planes {
    pub fn new(dims: [usize; 3], axis: usize) -> Self {
        let [b, c] = directions::lateral_axes(axis);
        let stride = [1, dims[0], dims[0] * dims[1]];
        Self {
            lateral: [dims[b], dims[c]],
            count: dims[axis],
            strides: [stride[b], stride[c], stride[axis]],
        }
    }

    /// Values per padded row and per padded plane.
    pub fn padded_row(&self) -> usize {
        self.lateral[0] + 2
    }

    pub fn padded_len(&self) -> usize {
        (self.lateral[0] + 2) * (self.lateral[1] + 2)
    }

    /// The planes in the order a sweep of `sign` visits them (from the side the light is on).
    pub fn order(&self, sign: i32) -> Box<dyn Iterator<Item = usize>> {
        if sign > 0 {
            Box::new((0..self.count).rev())
        } else {
            Box::new(0..self.count)
        }
    }
}

/// Sweeps in all: the planes visited over every sweep order (the unit of progress).
pub fn total_planes(dims: [usize; 3], ordinates: &Ordinates) -> u64 {
    ordinates.groups().iter().map(|g| dims[g.axis] as u64).sum()
}
