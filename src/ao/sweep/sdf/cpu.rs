//! The signed distance on the CPU: rounds of Gauss-Seidel sweeps in the eight orders (the
//! method and its accuracy: [`super`]).

use super::{finish, start, Bits, Grid, Rounds, SdfParams, SdfResult};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};

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
    finish(volume, params, grid.u, rounds)
}

impl Grid {
    /// One round: the eight sweeps in order. Returns the largest decrease of any voxel; `step`
    /// runs after every sweep (progress, cancelling).
    fn round(
        &mut self,
        h: [f32; 3],
        w: [f32; 3],
        round: u32,
        step: &dyn Fn() -> Result<()>,
    ) -> Result<f32> {
        let mut change = 0.0f32;
        for order in 0..8 {
            let ascending = [order & 1 == 0, order & 2 == 0, order & 4 == 0];
            change = change.max(self.sweep(ascending, h, w, round));
            step()?;
        }
        Ok(change)
    }

    /// One Gauss-Seidel sweep of round `round`, each axis ascending where `ascending` says;
    /// returns the largest decrease of any voxel (infinite where a voxel got its first value).
    ///
    /// The rows (j, k) go by wavefronts of equal jj + kk (jj, kk: their places in the sweep's
    /// order), a wavefront's rows in parallel. A row reads its own and the four neighbouring
    /// rows; those lie on the wavefronts just before (done, as in the one-threaded order) and
    /// just after (not yet started, likewise), never on its own: no row of a wavefront reads
    /// what another writes, and each computes what it would one-threaded.
    fn sweep(&mut self, ascending: [bool; 3], h: [f32; 3], w: [f32; 3], round: u32) -> f32 {
        let [nx, ny, nz] = self.dims;
        let place = |at: usize, n: usize, up: bool| if up { at } else { n - 1 - at };
        let rows = Rows::new(&mut self.u);
        let sweep = RowSweep {
            nx,
            rows_y: ny + 2,
            fixed: &self.fixed,
            changed: &self.changed,
            h,
            w,
            round,
            ascending: ascending[0],
        };
        let mut change = 0.0f32;
        for front in 0..ny + nz - 1 {
            let first = front.saturating_sub(ny - 1);
            let last = front.min(nz - 1);
            let front_change = (first..=last)
                .into_par_iter()
                .map_init(
                    || Scratch::new(nx),
                    |scratch, kk| {
                        let j = place(front - kk, ny, ascending[1]);
                        let k = place(kk, nz, ascending[2]);
                        // SAFETY: see `Rows`: the rows of one wavefront are apart.
                        unsafe { sweep.row(&rows, j, k, scratch) }
                    },
                )
                .reduce(|| 0.0, f32::max);
            change = change.max(front_change);
        }
        change
    }
}

/// The padded distances, shared by the rows of a wavefront: each writes its own row (with its
/// two padding voxels) and reads the four rows beside it, which no row of its wavefront writes.
struct Rows<'a> {
    values: *mut f32,
    len: usize,
    _borrow: PhantomData<&'a mut [f32]>,
}

// SAFETY: access goes through `read` and `write`, whose callers keep what one thread writes
// apart from what the others read or write.
unsafe impl Sync for Rows<'_> {}

impl<'a> Rows<'a> {
    fn new(values: &'a mut [f32]) -> Self {
        Self {
            values: values.as_mut_ptr(),
            len: values.len(),
            _borrow: PhantomData,
        }
    }

    /// `len` values from `start`.
    ///
    /// # Safety
    /// No other thread writes them while the slice lives.
    unsafe fn read(&self, start: usize, len: usize) -> &[f32] {
        assert!(start + len <= self.len);
        std::slice::from_raw_parts(self.values.add(start), len)
    }

    /// `len` values from `start`, to write.
    ///
    /// # Safety
    /// No other thread reads or writes them while the slice lives.
    #[allow(clippy::mut_from_ref)] // the point of the type: disjoint rows from shared threads
    unsafe fn write(&self, start: usize, len: usize) -> &mut [f32] {
        assert!(start + len <= self.len);
        std::slice::from_raw_parts_mut(self.values.add(start), len)
    }
}

/// A row's working space: its neighbour minima across y and z and the solution from them.
struct Scratch {
    ay: Vec<f32>,
    az: Vec<f32>,
    across: Vec<f32>,
}

impl Scratch {
    fn new(nx: usize) -> Self {
        Self {
            ay: vec![0.0; nx],
            az: vec![0.0; nx],
            across: vec![0.0; nx],
        }
    }
}

/// What every row of a sweep shares: the grid's layout and marks, the spacing, the round and
/// the direction along x.
struct RowSweep<'a> {
    nx: usize,
    rows_y: usize,
    fixed: &'a Bits,
    changed: &'a [AtomicU8],
    h: [f32; 3],
    w: [f32; 3],
    round: u32,
    ascending: bool,
}

impl RowSweep<'_> {
    /// Sweeps row (j, k) of `rows`; returns its largest decrease.
    ///
    /// Along a row each voxel reads the one just updated, a chain of dependent solves that
    /// would bound the speed. So the row is done in two passes: first, independently per voxel
    /// (a loop the core overlaps), the solution v from the y and z neighbours alone; then, in
    /// order, the x neighbour a_x is taken in only where a_x < v. That is exact: Godunov's
    /// update uses only neighbours below the solution, so where a_x >= v, v solves the full
    /// update too.
    ///
    /// # Safety
    /// No other thread writes the rows beside (j, k), nor reads or writes row (j, k) itself,
    /// meanwhile.
    unsafe fn row(&self, rows: &Rows, j: usize, k: usize, scratch: &mut Scratch) -> f32 {
        let (nx, h, w) = (self.nx, self.h, self.w);
        let row_at = (j + 1) + self.rows_y * (k + 1);
        let neighbours = [
            row_at,
            row_at - 1,
            row_at + 1,
            row_at - self.rows_y,
            row_at + self.rows_y,
        ];
        let recent = self.round.min(u8::MAX as u32) as u8;
        let unchanged = |r: usize| self.changed[r].load(Ordering::Relaxed) < recent;
        if self.round > 0 && neighbours.into_iter().all(unchanged) {
            return 0.0;
        }
        let sy = nx + 2;
        let sz = sy * self.rows_y;
        let start = row_at * sy + 1;
        let Scratch { ay, az, across } = scratch;
        // Neighbour minima across y and z, and the solution from them alone.
        for (a, stride) in [(&mut *ay, sy), (&mut *az, sz)] {
            let (below, above) = (rows.read(start - stride, nx), rows.read(start + stride, nx));
            for ((a, &p), &q) in a.iter_mut().zip(below).zip(above) {
                *a = p.min(q);
            }
        }
        for ((v, &b), &c) in across.iter_mut().zip(&*ay).zip(&*az) {
            *v = solve_pair([b, c], [h[1], h[2]], [w[1], w[2]]);
        }
        // Along the row, in order: the x neighbour where it lies below.
        let row = rows.write(start - 1, nx + 2);
        let mut row_change = 0.0f32;
        let mut visit = |i: usize| {
            if self.fixed.get(start + i) {
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
        if self.ascending {
            (0..nx).for_each(&mut visit);
        } else {
            (0..nx).rev().for_each(&mut visit);
        }
        if row_change > 0.0 {
            let stamp = (self.round + 1).min(u8::MAX as u32) as u8;
            self.changed[row_at].store(stamp, Ordering::Relaxed);
        }
        row_change
    }
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
