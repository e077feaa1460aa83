//! (d) The exact openness: over the voxels of the ball of radius R around x (x itself
//! included), the fraction with less matter than x, ties counting one half: the discrete form
//! of the tangent-sphere reference (`ao::reference`, `TangentSphere`). Voxels beyond the grid
//! hold the field's outside value. Cost O(R^3) per voxel: a reference, run on the CPU.

use super::ScalarField;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The ball as runs along x: (dj, dk, m) stands for the offsets (-m..=m, dj, dk).
fn ball_runs(radius: u32) -> Vec<(isize, isize, isize)> {
    let r = radius as isize;
    let mut runs = Vec::new();
    for dk in -r..=r {
        for dj in -r..=r {
            let rest = r * r - dj * dj - dk * dk;
            if rest >= 0 {
                runs.push((dj, dk, (rest as f64).sqrt().floor() as isize));
            }
        }
    }
    runs
}

/// Voxels in the ball of `radius`.
pub fn ball_size(radius: u32) -> usize {
    ball_runs(radius)
        .iter()
        .map(|&(_, _, m)| (2 * m + 1) as usize)
        .sum()
}

/// The exact openness of every voxel.
pub fn exact_volume(field: &ScalarField, radius: u32, progress: &dyn Progress) -> Result<Volume> {
    let f = &field.values;
    let [nx, ny, nz] = f.dims();
    let runs = ball_runs(radius);
    let size = ball_size(radius) as f32;
    let values = f.values();
    let mut open = vec![0.0f32; values.len()];
    let rows_done = AtomicU64::new(0);
    let total = (ny * nz) as u64;
    open.par_chunks_mut(nx).enumerate().for_each_init(
        || (vec![0u32; nx], vec![0u32; nx]),
        |(less, ties), (row, out)| {
            if progress.cancelled() {
                return;
            }
            let (j, k) = ((row % ny) as isize, (row / ny) as isize);
            let centre = &values[row * nx..(row + 1) * nx];
            less.fill(0);
            ties.fill(0);
            for &(dj, dk, m) in &runs {
                let (jj, kk) = (j + dj, k + dk);
                let inside_row = (0..ny as isize).contains(&jj) && (0..nz as isize).contains(&kk);
                let other = inside_row.then(|| {
                    let start = (jj as usize + ny * kk as usize) * nx;
                    &values[start..start + nx]
                });
                for di in -m..=m {
                    count_row(centre, other, di, field.outside, less, ties);
                }
            }
            for ((o, l), t) in out.iter_mut().zip(less.iter()).zip(ties.iter()) {
                *o = (*l as f32 + 0.5 * *t as f32) / size;
            }
            let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            progress.update(done, total);
        },
    );
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    Volume::new(f.dims(), f.spacing(), f.origin(), open)
}

/// Adds, for every x in the row, whether the neighbour at x + di in `other` (None: a row
/// beyond the grid) holds less than, or as much as, x.
fn count_row(
    centre: &[f32],
    other: Option<&[f32]>,
    di: isize,
    outside: f32,
    less: &mut [u32],
    ties: &mut [u32],
) {
    let n = centre.len() as isize;
    // x whose neighbour x + di lies in the row: [lo, hi).
    let lo = (-di).clamp(0, n) as usize;
    let hi = (n - di).clamp(0, n) as usize;
    let mut add_outside = |range: std::ops::Range<usize>| {
        for x in range {
            less[x] += u32::from(outside < centre[x]);
            ties[x] += u32::from(outside == centre[x]);
        }
    };
    match other {
        None => add_outside(0..centre.len()),
        Some(other) => {
            add_outside(0..lo);
            add_outside(hi..centre.len());
            if lo < hi {
                let shifted = &other[(lo as isize + di) as usize..(hi as isize + di) as usize];
                for (((l, t), c), o) in less[lo..hi]
                    .iter_mut()
                    .zip(ties[lo..hi].iter_mut())
                    .zip(&centre[lo..hi])
                    .zip(shifted)
                {
                    *l += u32::from(*o < *c);
                    *t += u32::from(*o == *c);
                }
            }
        }
    }
}

/// The exact openness at the given voxels only (for measuring on large volumes).
pub fn exact_at(field: &ScalarField, radius: u32, voxels: &[[usize; 3]]) -> Vec<f32> {
    let f = &field.values;
    let [nx, ny, nz] = f.dims();
    let runs = ball_runs(radius);
    let size = ball_size(radius) as f32;
    let value = |i: isize, j: isize, k: isize| {
        if (0..nx as isize).contains(&i)
            && (0..ny as isize).contains(&j)
            && (0..nz as isize).contains(&k)
        {
            f.at(i as usize, j as usize, k as usize)
        } else {
            field.outside
        }
    };
    voxels
        .par_iter()
        .map(|&[i, j, k]| {
            let c = f.at(i, j, k);
            let (i, j, k) = (i as isize, j as isize, k as isize);
            let mut count = 0.0f64;
            for &(dj, dk, m) in &runs {
                for di in -m..=m {
                    let v = value(i + di, j + dj, k + dk);
                    count += if v < c {
                        1.0
                    } else if v == c {
                        0.5
                    } else {
                        0.0
                    };
                }
            }
            (count / size as f64) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ball_sizes_are_the_lattice_point_counts() {
        // Gauss circle problem in 3D: OEIS A000605 (points with x^2 + y^2 + z^2 <= n^2).
        assert_eq!(ball_size(1), 7);
        assert_eq!(ball_size(2), 33);
        assert_eq!(ball_size(3), 123);
        assert_eq!(ball_size(4), 257);
        assert_eq!(ball_size(5), 515);
    }
}
