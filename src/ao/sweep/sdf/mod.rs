//! Signed distance to an iso-surface by fast sweeping (Zhao 2005, "A fast sweeping method for
//! Eikonal equations", Math. Comp. 74): the first step of occlusion sweeping.
//!
//! Convention: the distance is in world units, **negative inside** (where the value is greater
//! than the iso-value) and positive outside (value at or below it), as OpenVDB level sets are.
//!
//! The method:
//! 1. Initialization. A voxel whose neighbour along an axis lies on the other side of the
//!    iso-value is next to the surface: along that axis the surface crosses the edge between
//!    the two centres at the fraction t = (iso - v0) / (v1 - v0) of it, at t h_i from the voxel
//!    (the nearer crossing where both neighbours cross). Taking the surface as the plane
//!    through the crossings of the axes that have one, the voxel's distance is
//!    d = 1 / sqrt(sum_i 1 / d_i^2): exact for a plane whatever the spacing. These voxels are
//!    fixed; all others start unset (+infinity, internally only).
//! 2. Gauss-Seidel sweeps in the eight diagonal orders (each axis ascending or descending),
//!    rows along x so the inner loop runs over contiguous memory. At a voxel, Zhao's update of
//!    the Godunov discretization of |grad d| = 1 with spacing (hx, hy, hz): a_i is the smaller
//!    neighbour along axis i; sorted ascending, the 1D solution a_1 + h_1 is taken if it is
//!    at most a_2, else the 2D solution of sum_{i<=2} (u - a_i)^2 / h_i^2 = 1 if at most a_3,
//!    else the 3D one; the voxel keeps the smaller of its value and u (Zhao's Eq. 1 and (2.4)).
//! 3. A round is the eight sweeps; rounds repeat until the largest change of any voxel in a
//!    round is below the tolerance (world units), or the iteration limit is reached
//!    ([`SdfResult::converged`] says which). Values only decrease, so the change is exactly
//!    zero once the discrete solution is reached; Zhao shows a few rounds suffice (the first
//!    round sets every voxel, since any voxel is reached from the surface in one of the eight
//!    orders, and on a grid with no obstacles the second round typically only confirms it).
//!
//! Accuracy: first order (measured in tests/sdf.rs against the exact distance of a sphere of
//! radius 15 h: under 0.4 h within 3 h of the surface; the scheme overestimates along the
//! diagonals, increasingly with the distance, to 0.66 h at 27 h outside and 1.0 h at the
//! centre, where the distance has its kink; RMS 0.28 h over a 48^3 grid). Small features
//! (thin shells, rods) spread like point sources and give the largest errors far from them.
//!
//! Speed: a row is solved first from its y and z neighbours (independent voxels), then along
//! x in order, solving again only where the x neighbour lies below; rows whose neighbourhood
//! did not change since the last round are skipped. A sweep runs its rows by wavefronts, the
//! rows with the same j + k in parallel: a row reads only its own and the four neighbouring
//! rows, which lie on the wavefronts before and after it, so every row sees exactly what it
//! sees in a one-threaded sweep, and the result is the same bytes with any number of threads
//! (the hyperplane ordering of Detrixhe et al. 2013, by rows). `occlux bench-sweep` times it.
//!
//! Memory: the padded distances (the size of the input), one bit per voxel for the fixed
//! ones and a byte per row; the result is made from the distances in place
//! ([`finish`]), so the peak is the input and one grid beside it. (Before, the eight orders were
//! shared between two teams, each on its own copy of the distances merged by the minimum,
//! Zhao 2007: a third grid, and a fixed point that differed from the one-threaded sweep's in
//! its last bits; tests/sdf.rs holds the same accuracy bounds for both.)
//!
//! Twins: [`cpu`] sweeps rows in those orders; [`gpu`] (src/ao/sweep/sdf/sweep_sdf.wgsl) sweeps
//! the same orders plane by plane. This module checks the input, sets the interface voxels and
//! turns the swept distances into the result, for both.
//!
//! Bad input: a volume that never crosses the iso-value (including a constant one) has no
//! surface and so no distance: that is an error, not a grid of infinities. The output never
//! holds NaN or infinity.

pub mod cpu;
pub mod gpu;

use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::volume::Volume;
use std::sync::atomic::AtomicU8;

/// Parameters of the signed distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdfParams {
    /// The iso-value whose surface the distance is measured to; voxels with a value above it
    /// are inside (negative distance). Default 0.5, the middle of a [0, 1] volume such as the
    /// phantoms and classified opacity. Must be finite.
    pub iso: f32,
    /// Stop when the largest change of any voxel in a round of eight sweeps is below this, in
    /// world units. Default 1e-6: fast sweeping reaches its discrete solution exactly (the
    /// change drops to zero) in a few rounds, so the default asks for that. Must be positive
    /// and finite.
    pub tolerance: f32,
    /// Most rounds of eight sweeps. Default 16 (Zhao: a few rounds are enough on grids without
    /// obstacles; the sweep reports when it stopped here unconverged). Must be at least 1.
    pub max_iterations: u32,
}

impl Default for SdfParams {
    fn default() -> Self {
        Self {
            iso: 0.5,
            tolerance: 1e-6,
            max_iterations: 16,
        }
    }
}

impl SdfParams {
    /// Checks the ranges above; errors name the parameter (`sdf.iso`, `sdf.tolerance`,
    /// `sdf.max_iterations`).
    pub fn validate(&self) -> Result<()> {
        if !self.iso.is_finite() {
            return Err(Error::param(
                "sdf.iso",
                format!("the iso-value must be finite, got {}", self.iso),
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(Error::param(
                "sdf.tolerance",
                format!(
                    "the tolerance must be a positive, finite distance in world units, got {}",
                    self.tolerance
                ),
            ));
        }
        if self.max_iterations < 1 {
            return Err(Error::param(
                "sdf.max_iterations",
                "at least one round of eight sweeps is needed, got 0",
            ));
        }
        Ok(())
    }
}

/// The signed distance and how the sweeps ended.
#[derive(Clone, Debug)]
pub struct SdfResult {
    /// Signed distance in world units on the input's grid (same dims, spacing and origin):
    /// negative inside (value > iso), positive outside. Always finite.
    pub sdf: Volume,
    /// Rounds of eight sweeps done.
    pub iterations: u32,
    /// Largest change of any voxel in the last round, in world units; infinite when only one
    /// round ran (it set voxels that had no value yet).
    pub max_change: f32,
    /// Whether `max_change` fell below the tolerance (else the iteration limit stopped it).
    pub converged: bool,
}

/// The signed distance to the `params.iso` surface of `volume`, by fast sweeping, on
/// `compute`.
pub fn signed_distance_on(
    compute: &Compute,
    volume: &Volume,
    params: &SdfParams,
    progress: &dyn Progress,
) -> Result<SdfResult> {
    match compute {
        Compute::Cpu => cpu::signed_distance(volume, params, progress),
        Compute::Gpu(ctx) => gpu::signed_distance(ctx, volume, params, progress),
    }
}

/// Rounds of eight sweeps until the change falls below the tolerance or the limit is reached.
pub(crate) struct Rounds {
    pub iterations: u32,
    max_iterations: u32,
    tolerance: f32,
    max_change: f32,
    converged: bool,
}

impl Rounds {
    pub fn new(params: &SdfParams) -> Self {
        Self {
            iterations: 0,
            max_iterations: params.max_iterations,
            tolerance: params.tolerance,
            max_change: f32::INFINITY,
            converged: false,
        }
    }

    pub fn finished(&self) -> bool {
        self.converged || self.iterations >= self.max_iterations
    }

    /// A round ended with `change` as its largest decrease.
    pub fn record(&mut self, change: f32) {
        self.iterations += 1;
        self.max_change = change;
        self.converged = change < self.tolerance;
    }
}

/// Checks the input and sets the voxels next to the surface: the grid the sweeps start from.
pub(crate) fn start(volume: &Volume, params: &SdfParams) -> Result<Grid> {
    params.validate()?;
    let spacing = volume.spacing();
    if !(spacing.is_finite() && spacing.min_element() > 0.0) {
        return Err(Error::Volume(format!(
            "spacing {spacing} must be positive and finite for the signed distance"
        )));
    }
    let mut grid = Grid::new(volume.dims());
    let fixed = initialize(volume, params.iso, spacing.to_array(), &mut grid);
    if fixed == 0 {
        let (lo, hi) = volume.value_range();
        return Err(Error::Volume(format!(
            "the volume never crosses the iso-value {}: its values lie in [{lo}, {hi}], so there \
             is no surface to measure a distance to",
            params.iso
        )));
    }
    Ok(grid)
}

/// The result from the swept distances `u` (padded, unsigned): signed and unpadded in place, so
/// no second grid is held beside them. Every voxel was set in the first round (the grid is
/// connected), but a value that is somehow still unset is an error, never an infinity in the
/// output.
pub(crate) fn finish(
    volume: &Volume,
    params: &SdfParams,
    mut u: Vec<f32>,
    rounds: Rounds,
) -> Result<SdfResult> {
    let [nx, ny, nz] = volume.dims();
    let values = volume.values();
    // Row by row to the front: a voxel's unpadded index is below its padded one, so a row
    // moves onto distances already read.
    for k in 0..nz {
        for j in 0..ny {
            let to = (j + ny * k) * nx;
            let from = 1 + (nx + 2) * ((j + 1) + (ny + 2) * (k + 1));
            u.copy_within(from..from + nx, to);
            for (d, &v) in u[to..to + nx].iter_mut().zip(&values[to..to + nx]) {
                if v > params.iso {
                    *d = -*d;
                }
            }
        }
    }
    u.truncate(values.len());
    u.shrink_to_fit();
    if let Some(index) = u.iter().position(|d| !d.is_finite()) {
        return Err(Error::Volume(format!(
            "the signed distance at voxel {index} did not converge to a finite value"
        )));
    }
    Ok(SdfResult {
        sdf: Volume::new(volume.dims(), volume.spacing(), volume.origin(), u)?,
        iterations: rounds.iterations,
        max_change: rounds.max_change,
        converged: rounds.converged,
    })
}

/// Unsigned distances on a grid padded by one voxel of +infinity on every side (so the
/// neighbour minima need no bounds checks), x fastest, with the fixed (interface) voxels marked
/// and, per row, the last round in which one of its voxels changed.
pub(crate) struct Grid {
    dims: [usize; 3],
    pub u: Vec<f32>,
    pub fixed: Bits,
    /// Per padded row (j + 1) + (ny + 2) (k + 1): 1 + the last round a voxel of it decreased
    /// in (0: never; saturating). A row none of whose own and four neighbouring rows changed
    /// in this round or the last cannot change now: its update reads only those rows, and
    /// their values are what it last saw. Later rounds, which mostly confirm, skip such rows.
    /// Atomic because the rows of a wavefront stamp their own while reading their neighbours'.
    changed: Vec<AtomicU8>,
}

impl Grid {
    fn new(dims: [usize; 3]) -> Self {
        let len = (dims[0] + 2) * (dims[1] + 2) * (dims[2] + 2);
        Self {
            dims,
            u: vec![f32::INFINITY; len],
            fixed: Bits::new(len),
            changed: (0..(dims[1] + 2) * (dims[2] + 2))
                .map(|_| AtomicU8::new(0))
                .collect(),
        }
    }

    #[inline]
    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        let [nx, ny, _] = self.dims;
        (i + 1) + (nx + 2) * ((j + 1) + (ny + 2) * (k + 1))
    }
}

/// One bit per voxel: which are fixed (a byte each would be a quarter of the distances again).
pub(crate) struct Bits {
    words: Vec<u64>,
}

impl Bits {
    fn new(len: usize) -> Self {
        Self {
            words: vec![0; len.div_ceil(64)],
        }
    }

    fn set(&mut self, index: usize) {
        self.words[index / 64] |= 1 << (index % 64);
    }

    #[inline]
    pub fn get(&self, index: usize) -> bool {
        self.words[index / 64] >> (index % 64) & 1 == 1
    }
}

/// Sets the voxels next to a sign change to their interpolated distance and marks them fixed;
/// returns how many there are.
fn initialize(volume: &Volume, iso: f32, h: [f32; 3], grid: &mut Grid) -> usize {
    let [nx, ny, nz] = volume.dims();
    let values = volume.values();
    let strides = [1usize, nx, nx * ny];
    let extents = [nx, ny, nz];
    let iso = iso as f64;
    let mut count = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let at = [i, j, k];
                let index = i + nx * (j + ny * k);
                let v0 = values[index] as f64;
                let inside = v0 > iso;
                let mut inverse_sum = 0.0f64;
                let mut touches = false;
                let mut on_surface = false;
                for axis in 0..3 {
                    // Fraction of the edge to the nearer crossing along this axis.
                    let mut t = f64::INFINITY;
                    let stride = strides[axis];
                    let mut consider = |other: usize| {
                        let v1 = values[other] as f64;
                        if (v1 > iso) != inside {
                            // v0 and v1 differ (one is above iso, the other not): no 0/0.
                            t = t.min(((iso - v0) / (v1 - v0)).clamp(0.0, 1.0));
                        }
                    };
                    if at[axis] > 0 {
                        consider(index - stride);
                    }
                    if at[axis] + 1 < extents[axis] {
                        consider(index + stride);
                    }
                    if t.is_finite() {
                        touches = true;
                        let d = t * h[axis] as f64;
                        if d <= 0.0 {
                            on_surface = true;
                        } else {
                            inverse_sum += 1.0 / (d * d);
                        }
                    }
                }
                if touches {
                    let d = if on_surface || !inverse_sum.is_finite() {
                        0.0
                    } else {
                        (1.0 / inverse_sum.sqrt()) as f32
                    };
                    let g = grid.index(i, j, k);
                    grid.u[g] = d;
                    grid.fixed.set(g);
                    count += 1;
                }
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sdf_params_validate() {
        assert!(SdfParams::default().validate().is_ok());
        let bad = [
            SdfParams {
                iso: f32::NAN,
                ..Default::default()
            },
            SdfParams {
                tolerance: 0.0,
                ..Default::default()
            },
            SdfParams {
                tolerance: f32::INFINITY,
                ..Default::default()
            },
            SdfParams {
                max_iterations: 0,
                ..Default::default()
            },
        ];
        for (p, key) in bad
            .iter()
            .zip(["sdf.iso", "sdf.tolerance", "sdf.tolerance", "sdf.max"])
        {
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
    }
}
