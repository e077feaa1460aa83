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
//! did not change since the last round are skipped; the eight orders are shared between two
//! teams on copies, merged by the minimum (Zhao 2007). `occlux bench-sweep` times it: about
//! 2.4 s for three rounds of 250^3 on 2 cores (from 8 s single-threaded before).
//!
//! GPU twin: [`super::sdf_gpu`] (src/ao/sweep/sweep_sdf.wgsl) sweeps the same orders plane by
//! plane.
//!
//! Bad input: a volume that never crosses the iso-value (including a constant one) has no
//! surface and so no distance: that is an error, not a grid of infinities. The output never
//! holds NaN or infinity.

use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

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
/// `compute` (the GPU twin: [`super::sdf_gpu`]).
pub fn signed_distance_on(
    compute: &crate::gpu::Compute,
    volume: &Volume,
    params: &SdfParams,
    progress: &dyn Progress,
) -> Result<SdfResult> {
    match compute {
        crate::gpu::Compute::Cpu => signed_distance(volume, params, progress),
        crate::gpu::Compute::Gpu(ctx) => {
            super::sdf_gpu::signed_distance(ctx, volume, params, progress)
        }
    }
}

/// The signed distance to the `params.iso` surface of `volume`, by fast sweeping on the CPU.
/// `progress` counts sweeps (eight per round) out of `8 * max_iterations`; cancelling stops
/// between sweeps with [`Error::Cancelled`].
pub fn signed_distance(
    volume: &Volume,
    params: &SdfParams,
    progress: &dyn Progress,
) -> Result<SdfResult> {
    let mut grid = start(volume, params)?;
    let h = volume.spacing().to_array();
    let weights = h.map(|x| 1.0 / (x * x));
    let total = 8 * params.max_iterations as u64;
    let mut rounds = Rounds::new(params);
    let done = AtomicU64::new(0);
    while !rounds.finished() {
        let change = grid.round(h, weights, rounds.iterations, &|| {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            progress.update(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            Ok(())
        })?;
        rounds.record(change);
    }
    progress.update(total, total);
    finish(volume, params, &grid.u, rounds)
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

/// The result from the swept distances `u` (padded, unsigned): signed and unpadded. Every
/// voxel was set in the first round (the grid is connected), but a value that is somehow still
/// unset is an error, never an infinity in the output.
pub(crate) fn finish(
    volume: &Volume,
    params: &SdfParams,
    u: &[f32],
    rounds: Rounds,
) -> Result<SdfResult> {
    let [nx, ny, nz] = volume.dims();
    let values = volume.values();
    let mut out = Vec::with_capacity(values.len());
    for k in 0..nz {
        for j in 0..ny {
            let start = 1 + (nx + 2) * ((j + 1) + (ny + 2) * (k + 1));
            let row = &values[(j + ny * k) * nx..][..nx];
            out.extend(u[start..start + nx].iter().zip(row).map(|(&d, &v)| {
                if v > params.iso {
                    -d
                } else {
                    d
                }
            }));
        }
    }
    if let Some(index) = out.iter().position(|d| !d.is_finite()) {
        return Err(Error::Volume(format!(
            "the signed distance at voxel {index} did not converge to a finite value"
        )));
    }
    Ok(SdfResult {
        sdf: Volume::new(volume.dims(), volume.spacing(), volume.origin(), out)?,
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
    pub fixed: Vec<bool>,
    /// Per padded row (j + 1) + (ny + 2) (k + 1): 1 + the last round a voxel of it decreased
    /// in (0: never; saturating). A row none of whose own and four neighbouring rows changed
    /// in this round or the last cannot change now: its update reads only those rows, and
    /// their values are what it last saw. Later rounds, which mostly confirm, skip such rows.
    changed: Vec<u8>,
}

impl Grid {
    fn new(dims: [usize; 3]) -> Self {
        let len = (dims[0] + 2) * (dims[1] + 2) * (dims[2] + 2);
        Self {
            dims,
            u: vec![f32::INFINITY; len],
            fixed: vec![false; len],
            changed: vec![0; (dims[1] + 2) * (dims[2] + 2)],
        }
    }

    #[inline]
    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        let [nx, ny, _] = self.dims;
        (i + 1) + (nx + 2) * ((j + 1) + (ny + 2) * (k + 1))
    }

    /// One round: the eight sweeps, shared between two teams that each sweep four orders on
    /// their own copy of the distances, merged by the minimum at the end (Zhao's parallel fast
    /// sweeping, 2007: the same fixed point, sometimes a round more). Two teams whatever the
    /// number of threads, so the result is the same bytes with any (the teams' update orders
    /// decide the last bits of the fixed point they reach). Returns the largest decrease of
    /// any voxel; `step` runs after every sweep (progress, cancelling).
    fn round(
        &mut self,
        h: [f32; 3],
        w: [f32; 3],
        round: u32,
        step: &(dyn Fn() -> Result<()> + Sync),
    ) -> Result<f32> {
        let dims = self.dims;
        let fixed = &self.fixed;
        let run = |orders: std::ops::Range<usize>, u: &mut [f32], changed: &mut [u8]| {
            let mut change = 0.0f32;
            for order in orders {
                let signs = [order & 1 == 0, order & 2 == 0, order & 4 == 0];
                change = change.max(sweep(dims, fixed, u, changed, signs, h, w, round));
                step()?;
            }
            Ok::<f32, Error>(change)
        };
        let (mut u, mut changed) = (self.u.clone(), self.changed.clone());
        let (first, second) = rayon::join(
            || run(0..4, &mut self.u, &mut self.changed),
            || run(4..8, &mut u, &mut changed),
        );
        let change = first?.max(second?);
        self.u
            .par_iter_mut()
            .zip(&u)
            .for_each(|(mine, theirs)| *mine = mine.min(*theirs));
        for (mine, theirs) in self.changed.iter_mut().zip(&changed) {
            *mine = (*mine).max(*theirs);
        }
        Ok(change)
    }
}

/// One Gauss-Seidel sweep of round `round` over `u` (a grid's padded distances, with its
/// `changed` stamps), each axis ascending where its sign is true; returns the largest decrease
/// of any voxel (infinite where a voxel got its first value).
///
/// Along a row each voxel reads the one just updated, a chain of dependent solves that
/// would bound the speed. So the row is done in two passes: first, independently per voxel
/// (a loop the core overlaps), the solution v from the y and z neighbours alone; then, in
/// order, the x neighbour a_x is taken in only where a_x < v. That is exact: Godunov's
/// update uses only neighbours below the solution, so where a_x >= v, v solves the full
/// update too.
#[allow(clippy::too_many_arguments)] // the grid's parts and the sweep's order
fn sweep(
    dims: [usize; 3],
    fixed: &[bool],
    u: &mut [f32],
    changed: &mut [u8],
    ascending: [bool; 3],
    h: [f32; 3],
    w: [f32; 3],
    round: u32,
) -> f32 {
    let [nx, ny, nz] = dims;
    let sy = nx + 2;
    let sz = sy * (ny + 2);
    let rows_y = ny + 2;
    let recent = round.min(u8::MAX as u32) as u8;
    let stamp = (round + 1).min(u8::MAX as u32) as u8;
    let mut change = 0.0f32;
    let mut ay = vec![0.0f32; nx];
    let mut az = vec![0.0f32; nx];
    let mut across = vec![0.0f32; nx];
    for kk in 0..nz {
        let k = if ascending[2] { kk } else { nz - 1 - kk };
        for jj in 0..ny {
            let j = if ascending[1] { jj } else { ny - 1 - jj };
            let row_at = (j + 1) + rows_y * (k + 1);
            let neighbours = [
                row_at,
                row_at - 1,
                row_at + 1,
                row_at - rows_y,
                row_at + rows_y,
            ];
            if round > 0 && neighbours.iter().all(|&r| changed[r] < recent) {
                continue;
            }
            let start = (j + 1) * sy + (k + 1) * sz + 1;
            // Neighbour minima across y and z, and the solution from them alone: those
            // rows are not written while this row is swept.
            {
                let (below, above) = (&u[start - sy..][..nx], &u[start + sy..][..nx]);
                for ((a, &p), &q) in ay.iter_mut().zip(below).zip(above) {
                    *a = p.min(q);
                }
                let (below, above) = (&u[start - sz..][..nx], &u[start + sz..][..nx]);
                for ((a, &p), &q) in az.iter_mut().zip(below).zip(above) {
                    *a = p.min(q);
                }
                for ((v, &b), &c) in across.iter_mut().zip(&ay).zip(&az) {
                    *v = solve_pair([b, c], [h[1], h[2]], [w[1], w[2]]);
                }
            }
            // Along the row, in order: the x neighbour where it lies below.
            let row = &mut u[start - 1..start + nx + 1];
            let fixed = &fixed[start..start + nx];
            let mut row_change = 0.0f32;
            let mut visit = |i: usize| {
                if fixed[i] {
                    return;
                }
                let ax = row[i].min(row[i + 2]);
                let new = if ax < across[i] {
                    solve([ax, ay[i], az[i]], h, w)
                } else {
                    across[i]
                };
                let old = row[i + 1];
                if new < old {
                    row[i + 1] = new;
                    row_change = row_change.max(old - new);
                }
            };
            if ascending[0] {
                (0..nx).for_each(&mut visit);
            } else {
                (0..nx).rev().for_each(&mut visit);
            }
            if row_change > 0.0 {
                changed[row_at] = stamp;
                change = change.max(row_change);
            }
        }
    }
    change
}

/// Zhao's update from two neighbours (the y and z ones): [`solve`] with the third at infinity.
#[inline]
fn solve_pair(a: [f32; 2], h: [f32; 2], w: [f32; 2]) -> f32 {
    if a[0] <= a[1] {
        solve_sorted_pair((a[0], h[0], w[0]), (a[1], w[1]))
    } else {
        solve_sorted_pair((a[1], h[1], w[1]), (a[0], w[0]))
    }
}

/// The 1D or 2D update from neighbours a0 <= a1 (with a0's spacing h0 and the weights
/// w = 1 / h^2): a0 + h0 if that is at most a1, else the root of
/// sum_{i <= 1} w_i (u - a_i)^2 = 1, computed relative to a0 for precision (the discriminant
/// by Lagrange's identity, w0 + w1 - w0 w1 (a1 - a0)^2, is at least w0 there since a1 - a0 < h0).
#[inline]
fn solve_sorted_pair((a0, h0, w0): (f32, f32, f32), (a1, w1): (f32, f32)) -> f32 {
    let u = a0 + h0;
    if u <= a1 {
        return u;
    }
    let b1 = a1 - a0;
    let s = w0 + w1;
    let disc = s - w0 * w1 * b1 * b1;
    a0 + (w1 * b1 + disc.max(0.0).sqrt()) / s
}

/// Zhao's local solver: the u >= min a with sum_i max(u - a_i, 0)^2 / h_i^2 = 1, the Godunov
/// upwind discretization of |grad u| = 1. `a` holds the smaller neighbour along each axis
/// (+infinity where none is set), `h` the spacing, `w` = 1 / h^2. Never NaN: an infinite
/// a_i is never subtracted (the candidate is accepted before it is reached).
#[inline]
pub fn solve(a: [f32; 3], h: [f32; 3], w: [f32; 3]) -> f32 {
    // Sort the three (a, h, w) by a.
    let mut p = [(a[0], h[0], w[0]), (a[1], h[1], w[1]), (a[2], h[2], w[2])];
    if p[0].0 > p[1].0 {
        p.swap(0, 1);
    }
    if p[1].0 > p[2].0 {
        p.swap(1, 2);
    }
    if p[0].0 > p[1].0 {
        p.swap(0, 1);
    }
    let [(a0, h0, w0), (a1, _, w1), (a2, _, w2)] = p;
    // 1D, then 2D.
    let u = solve_sorted_pair((a0, h0, w0), (a1, w1));
    if u <= a2 {
        return u;
    }
    // 3D.
    let b1 = a1 - a0;
    let b2 = a2 - a0;
    let s = w0 + w1 + w2;
    let d12 = b2 - b1;
    let disc = s - (w0 * w1 * b1 * b1 + w0 * w2 * b2 * b2 + w1 * w2 * d12 * d12);
    a0 + (w1 * b1 + w2 * b2 + disc.max(0.0).sqrt()) / s
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
                    grid.fixed[g] = true;
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
    use crate::progress::NoProgress;
    use glam::Vec3;

    const ONE: [f32; 3] = [1.0; 3];

    #[test]
    fn sdf_solver_picks_1d_2d_3d() {
        let inf = f32::INFINITY;
        // 1D: one set neighbour.
        assert_eq!(solve([2.0, inf, inf], ONE, ONE), 3.0);
        assert_eq!(
            solve([inf, inf, 0.5], [1.0, 1.0, 2.0], [1.0, 1.0, 0.25]),
            2.5
        );
        // 2D: equal neighbours on two axes give a + h / sqrt(2).
        let u = solve([1.0, 1.0, inf], ONE, ONE);
        assert!((u - (1.0 + 0.5f32.sqrt())).abs() < 1e-6, "{u}");
        // 3D: equal on all three give a + h / sqrt(3).
        let u = solve([1.0, 1.0, 1.0], ONE, ONE);
        assert!((u - (1.0 + 1.0 / 3f32.sqrt())).abs() < 1e-6, "{u}");
        // Far apart: the 1D solution wins.
        assert_eq!(solve([5.0, 1.0, 9.0], ONE, ONE), 2.0);
        // Unset everywhere stays unset, without NaN.
        assert_eq!(solve([inf; 3], ONE, ONE), inf);
    }

    #[test]
    fn sdf_solver_exact_for_planes_with_anisotropic_spacing() {
        // u(x) = n . x for a unit n: neighbours' values u - n_i h_i, and the update returns u.
        let h = [1.0f32, 1.5, 2.0];
        let w = h.map(|x| 1.0 / (x * x));
        let n = Vec3::new(0.3, 0.5, 0.8).normalize();
        let u = 10.0f32;
        let a = [u - n.x * h[0], u - n.y * h[1], u - n.z * h[2]];
        assert!((solve(a, h, w) - u).abs() < 1e-5, "{}", solve(a, h, w));
    }

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

    #[test]
    fn sdf_plane_is_exact() {
        // A plane z = 2.3 (value 10 - z; inside below): the distance is exact, with 1 x 1 x 2
        // spacing too.
        for spacing in [Vec3::ONE, Vec3::new(1.0, 1.0, 2.0)] {
            let v = Volume::from_fn([6, 5, 8], spacing, Vec3::ZERO, |p| 10.0 - p.z).unwrap();
            let r = signed_distance(
                &v,
                &SdfParams {
                    iso: 10.0 - 2.3,
                    ..Default::default()
                },
                &NoProgress,
            )
            .unwrap();
            for k in 0..8 {
                let want = k as f32 * spacing.z - 2.3;
                for &d in &r.sdf.values()[k * 30..(k + 1) * 30] {
                    assert!((d - want).abs() < 1e-5, "{d} vs {want}");
                }
            }
            assert!(r.converged && r.iterations <= 2, "{r:?}");
        }
    }
}
