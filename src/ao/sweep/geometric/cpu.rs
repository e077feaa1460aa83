//! The geometric mode's octant sweeps and shading on the CPU: two parallel groups of four
//! octants, each V_s by the paper's three-neighbour average (Eq. 6).

use super::super::padded::{octant_signs, sweep_order, Padded};
use super::{GeometricParams, Surface};
use crate::error::{Error, Result};
use crate::progress::Progress;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The octant sweeps and the shading on the CPU: AO after gamma and, when `keep_octants`,
/// each V_s (unpadded).
pub fn octants(
    surface: &Surface,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<(Vec<f32>, Vec<Vec<f32>>)> {
    let Surface {
        transmittance,
        cells,
        table,
    } = surface;
    let done = AtomicU64::new(0);
    let voxels = cells.len();
    // Two fixed groups of four octants, each summed in order into its own accumulator: the
    // sum does not depend on the number of threads, and at most two grids are in flight.
    let group = |octants: &[usize]| -> Result<(Vec<f32>, Vec<Vec<f32>>)> {
        let mut lit = vec![0.0f32; voxels];
        let mut kept = Vec::new();
        let mut v = Padded::new(transmittance.dims, 1.0);
        for &o in octants {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            let intensity = params.intensities[o];
            sweep_octant(transmittance, octant_signs()[o], &mut v);
            let [nx, ny, nz] = v.dims;
            for k in 0..nz {
                for j in 0..ny {
                    let start = v.index(0, j, k);
                    let at = (j + ny * k) * nx;
                    let sums = lit[at..at + nx].iter_mut().zip(&cells[at..at + nx]);
                    for (i, (sum, cell)) in sums.enumerate() {
                        let seen = v.values[(start + i).wrapping_add_signed(cell.step as isize)];
                        *sum += intensity * table.share(*cell, o) * seen;
                    }
                }
            }
            if keep_octants {
                kept.push(v.unpad(|x| x));
            }
            progress.update(done.fetch_add(1, Ordering::Relaxed) + 1, 8);
        }
        Ok((lit, kept))
    };
    let (first, second) = rayon::join(|| group(&[0, 1, 2, 3]), || group(&[4, 5, 6, 7]));
    let ((mut sum, mut kept), (other, more)) = (first?, second?);
    kept.extend(more);
    let exponent = 1.0 / params.gamma;
    sum.par_iter_mut()
        .zip(&other)
        .for_each(|(a, b)| *a = (*a + b).clamp(0.0, 1.0).powf(exponent));
    Ok((sum, kept))
}

/// V_s by the three-neighbour average (Eq. 6) for the octant of `signs`, into `v` (whose
/// padding holds 1).
fn sweep_octant(transmittance: &Padded, signs: [i32; 3], v: &mut Padded) {
    let [nx, ny, nz] = transmittance.dims;
    let offset = |axis: usize| {
        let mut step = [0; 3];
        step[axis] = signs[axis];
        transmittance.offset(step)
    };
    let (dy, dz) = (offset(1), offset(2));
    let t = &transmittance.values;
    let mut off_row = vec![0.0f32; nx];
    for k in sweep_order(nz, signs[2]) {
        for j in sweep_order(ny, signs[1]) {
            let start = v.index(0, j, k);
            // The y and z neighbours lie on rows already swept: a plain loop over the row.
            let (fy, fz) = (
                (start as isize + dy) as usize,
                (start as isize + dz) as usize,
            );
            for (i, acc) in off_row.iter_mut().enumerate() {
                *acc = t[fy + i] * v.values[fy + i] + t[fz + i] * v.values[fz + i];
            }
            // The x neighbour is on this row: a recurrence, in the sweep's order.
            let row = &mut v.values[start - 1..start + nx + 1];
            let trow = &t[start - 1..start + nx + 1];
            let third = 1.0 / 3.0;
            if signs[0] > 0 {
                for i in (0..nx).rev() {
                    row[i + 1] = third * (off_row[i] + trow[i + 2] * row[i + 2]);
                }
            } else {
                for i in 0..nx {
                    row[i + 1] = third * (off_row[i] + trow[i] * row[i]);
                }
            }
        }
    }
}
