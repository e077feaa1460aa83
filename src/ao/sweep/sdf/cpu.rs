//! The signed distance on the CPU: rounds of Gauss-Seidel sweeps in the eight orders (the
//! method and its accuracy: [`super`]).

use super::{finish, start, Grid, Rounds, SdfParams, SdfResult};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

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

impl Grid {
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
