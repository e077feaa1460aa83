//! The geometric mode's octant sweeps and shading on the CPU, plane by plane: each V_s by the
//! paper's three-neighbour average (Eq. 6), the four octants that share a z direction in
//! lockstep.
//!
//! V_s on a plane depends only on the plane before it in the octant's sweep, and the shading
//! reads V_s one voxel out along the normal, on the plane before, the plane itself or the plane
//! after. So each octant holds three planes of V_s, and the surface terms (transmittance and
//! cells) are made a plane at a time from the signed distance ([`SurfaceTerms::plane`]), twice:
//! once for each z direction. The only grid beside the signed distance is the AO itself (and,
//! with `keep_octants`, the eight V_s that are asked for).
//!
//! The sum over the octants is the one a grid per octant gave, in the same order: per voxel the
//! four octants looking up z in order, then the four looking down in order, then the two sums
//! added; so the result is the same bytes with any number of threads, and as those of the
//! full-grid sweeps (tests/sweep_geometric.rs compares them).

use super::super::padded::{octant_signs, sweep_order};
use super::{Cell, GeometricParams, GeometryTable, SurfaceTerms};
use crate::error::{Error, Result};
use crate::progress::Progress;
use rayon::prelude::*;

/// The octant sweeps and the shading on the CPU: AO after gamma and, when `keep_octants`,
/// each V_s (unpadded). `progress` counts planes, two passes of nz.
pub fn octants(
    terms: &SurfaceTerms,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<(Vec<f32>, Vec<Vec<f32>>)> {
    let [nx, ny, nz] = terms.dims();
    let mut ao = vec![0.0f32; nx * ny * nz];
    let mut kept = Vec::new();
    // Octants 0-3 look up z, 4-7 down (the order of `octant_signs`).
    for (pass, group) in [[0, 1, 2, 3], [4, 5, 6, 7]].into_iter().enumerate() {
        let counted = |plane: u64| {
            progress.update(pass as u64 * nz as u64 + plane, 2 * nz as u64);
        };
        let swept = pass_of(
            terms,
            params,
            group,
            keep_octants,
            &mut ao,
            progress,
            &counted,
        )?;
        kept.extend(swept);
    }
    let exponent = 1.0 / params.gamma;
    ao.par_iter_mut()
        .for_each(|a| *a = a.clamp(0.0, 1.0).powf(exponent));
    Ok((ao, kept))
}

/// The four octants of `group` (one z direction), swept in lockstep down the planes in their
/// order, each plane's shading added into `ao` (in the group's order, the group's sum added to
/// what `ao` holds). Returns the kept V_s. Cancelling stops between planes.
fn pass_of(
    terms: &SurfaceTerms,
    params: &GeometricParams,
    group: [usize; 4],
    keep: bool,
    ao: &mut [f32],
    progress: &dyn Progress,
    counted: &dyn Fn(u64),
) -> Result<Vec<Vec<f32>>> {
    let [nx, ny, nz] = terms.dims();
    let plane = nx * ny;
    let mut sweeps = group.map(|o| OctantSweep::new(o, params.intensities[o], [nx, ny, nz], keep));
    // The surface terms of the plane swept before and of the plane swept now.
    let mut surface = [SurfacePlane::new(nx, ny), SurfacePlane::new(nx, ny)];
    let order: Vec<usize> = sweep_order(nz, octant_signs()[group[0]][2]).collect();
    // Step t sweeps plane order[t] and shades plane order[t - 1], which needs V_s beyond it;
    // a last step past the end shades the last plane (beyond it, the padding).
    for t in 0..=nz {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        surface.swap(0, 1);
        let now = order.get(t).copied();
        if let Some(k) = now {
            let SurfacePlane { tau, cells } = &mut surface[1];
            terms.plane(k, tau, cells);
        }
        let [before, current] = &surface;
        let shaded = t.checked_sub(1).map(|_| &before.cells[..]);
        sweeps.par_iter_mut().for_each(|sweep| {
            sweep.step(now, &current.tau, &before.tau, shaded, terms.table);
        });
        if let Some(k) = t.checked_sub(1).map(|s| order[s]) {
            let sum = &mut ao[k * plane..(k + 1) * plane];
            let [a, b, c, d] = sweeps.each_ref().map(|s| &s.lit[..]);
            for (i, sum) in sum.iter_mut().enumerate() {
                *sum += ((a[i] + b[i]) + c[i]) + d[i];
            }
            counted(t as u64);
        }
    }
    Ok(sweeps.into_iter().filter_map(|s| s.kept).collect())
}

/// One plane's surface terms: the transmittance (padded with 1) and the cells.
struct SurfacePlane {
    tau: Vec<f32>,
    cells: Vec<Cell>,
}

impl SurfacePlane {
    fn new(nx: usize, ny: usize) -> Self {
        Self {
            tau: vec![1.0; (nx + 2) * (ny + 2)],
            cells: vec![Cell::NONE; nx * ny],
        }
    }
}

/// An octant's sweep in progress: V_s on the last three planes swept, its shading of the plane
/// between them, and V_s everywhere when it is kept.
struct OctantSweep {
    octant: usize,
    signs: [i32; 3],
    intensity: f32,
    dims: [usize; 3],
    /// Padded planes (border 1), in the sweep's order: two planes back, one back, the newest.
    /// Before the first plane and after the last they hold the padding.
    v: [Vec<f32>; 3],
    /// I_s G_s V_s of the plane one back.
    lit: Vec<f32>,
    /// A row's y and z terms.
    off_row: Vec<f32>,
    kept: Option<Vec<f32>>,
}

impl OctantSweep {
    fn new(octant: usize, intensity: f32, dims: [usize; 3], keep: bool) -> Self {
        let [nx, ny, nz] = dims;
        let padded = (nx + 2) * (ny + 2);
        Self {
            octant,
            signs: octant_signs()[octant],
            intensity,
            dims,
            v: std::array::from_fn(|_| vec![1.0; padded]),
            lit: vec![0.0; nx * ny],
            off_row: vec![0.0; nx],
            kept: keep.then(|| vec![0.0; nx * ny * nz]),
        }
    }

    /// Sweeps plane `now` (none: past the last plane, the padding) with its transmittance `tau`
    /// and that of the plane before, `tau_before`; then, given the cells of the plane one back,
    /// shades it into `lit`.
    fn step(
        &mut self,
        now: Option<usize>,
        tau: &[f32],
        tau_before: &[f32],
        shaded: Option<&[Cell]>,
        table: &GeometryTable,
    ) {
        self.v.rotate_left(1);
        let [.., before, newest] = &mut self.v;
        match now {
            Some(k) => {
                sweep_plane(
                    self.signs,
                    self.dims,
                    tau,
                    tau_before,
                    before,
                    newest,
                    &mut self.off_row,
                );
                if let Some(kept) = &mut self.kept {
                    let [nx, ny, _] = self.dims;
                    let plane = &mut kept[k * nx * ny..(k + 1) * nx * ny];
                    for (j, row) in plane.chunks_mut(nx).enumerate() {
                        let start = (nx + 2) * (j + 1) + 1;
                        row.copy_from_slice(&newest[start..start + nx]);
                    }
                }
            }
            None => newest.fill(1.0),
        }
        if let Some(cells) = shaded {
            self.shade(cells, table);
        }
    }

    /// I_s G_s(N) V_s of the plane one back, V_s read at each cell's step: on the plane two
    /// back, one back or the newest, as the step's z part says.
    fn shade(&mut self, cells: &[Cell], table: &GeometryTable) {
        let [nx, ny, _] = self.dims;
        let padded = ((nx + 2) * (ny + 2)) as i32;
        let sz = self.signs[2];
        for (j, (lit, cells)) in self.lit.chunks_mut(nx).zip(cells.chunks(nx)).enumerate() {
            let start = (nx + 2) * (j + 1) + 1;
            for (i, (lit, cell)) in lit.iter_mut().zip(cells).enumerate() {
                let (dz, in_plane) = split_step(cell.step, padded);
                // The plane at z + dz: one back is z itself; the sweep came from z + s_z.
                let v = &self.v[(1 - dz * sz) as usize];
                let seen = v[(start + i).wrapping_add_signed(in_plane as isize)];
                *lit = self.intensity * table.share(*cell, self.octant) * seen;
            }
        }
    }
}

/// A padded-grid step (dx + px (dy + py dz), each of dx, dy, dz in {-1, 0, 1}) as its z part
/// dz and its step within a plane of `padded` voxels: that step is at most px + 1, under half
/// a plane, so dz is the side of a half plane the step falls on.
#[inline]
fn split_step(step: i32, padded: i32) -> (i32, i32) {
    let half = padded / 2;
    let dz = (step > half) as i32 - (step < -half) as i32;
    (dz, step - dz * padded)
}

/// V_s on one plane by the three-neighbour average (Eq. 6) for the octant of `signs`, into the
/// padded plane `v` (whose border holds 1), from the plane swept before (`before`, with its
/// transmittance `tau_before`) and this plane's transmittance `tau`.
fn sweep_plane(
    signs: [i32; 3],
    dims: [usize; 3],
    tau: &[f32],
    tau_before: &[f32],
    before: &[f32],
    v: &mut [f32],
    off_row: &mut [f32],
) {
    let [nx, ny, _] = dims;
    let third = 1.0 / 3.0;
    for j in sweep_order(ny, signs[1]) {
        let start = (nx + 2) * (j + 1) + 1;
        // The y neighbour lies on a row already swept, the z one on the plane before: a
        // plain loop over the row.
        let fy = start.wrapping_add_signed(signs[1] as isize * (nx + 2) as isize);
        for (i, acc) in off_row.iter_mut().enumerate() {
            *acc = tau[fy + i] * v[fy + i] + tau_before[start + i] * before[start + i];
        }
        // The x neighbour is on this row: a recurrence, in the sweep's order.
        let row = &mut v[start - 1..start + nx + 1];
        let trow = &tau[start - 1..start + nx + 1];
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

#[cfg(test)]
mod tests {
    use super::super::super::padded::Padded;
    use super::super::Surface;
    use super::*;
    use crate::ao::sweep::sdf::{cpu::signed_distance, SdfParams};
    use crate::progress::NoProgress;
    use crate::volume::phantom;

    /// The full-grid formulation the plane-wise sweep replaced: each octant's V_s on a whole
    /// padded grid from the whole surface, then shaded, the octants summed in two groups of
    /// four. The reference the plane-wise sweep must reproduce to the bit.
    fn full_grid(surface: &Surface, params: &GeometricParams) -> (Vec<f32>, Vec<Vec<f32>>) {
        let t = &surface.transmittance;
        let [nx, ny, nz] = t.dims;
        let mut kept = Vec::new();
        let mut groups = [vec![0.0f32; nx * ny * nz], vec![0.0f32; nx * ny * nz]];
        for o in 0..8 {
            let signs = octant_signs()[o];
            let mut v = Padded::new(t.dims, 1.0);
            for k in sweep_order(nz, signs[2]) {
                for j in sweep_order(ny, signs[1]) {
                    for i in sweep_order(nx, signs[0]) {
                        let at = v.index(i, j, k);
                        let term = |axis: usize| {
                            let mut step = [0; 3];
                            step[axis] = signs[axis];
                            let n = at.wrapping_add_signed(t.offset(step));
                            t.values[n] * v.values[n]
                        };
                        let (x, y, z) = (term(0), term(1), term(2));
                        v.values[at] = 1.0 / 3.0 * ((y + z) + x);
                    }
                }
            }
            for k in 0..nz {
                for j in 0..ny {
                    for i in 0..nx {
                        let index = i + nx * (j + ny * k);
                        let cell = surface.cells[index];
                        let at = v.index(i, j, k).wrapping_add_signed(cell.step as isize);
                        let lit =
                            params.intensities[o] * surface.table.share(cell, o) * v.values[at];
                        groups[o / 4][index] += lit;
                    }
                }
            }
            kept.push(v.unpad(|x| x));
        }
        let [up, down] = groups;
        let ao = up
            .iter()
            .zip(&down)
            .map(|(a, b)| (a + b).clamp(0.0, 1.0).powf(1.0 / params.gamma))
            .collect();
        (ao, kept)
    }

    #[test]
    fn plane_wise_sweep_matches_the_full_grid_to_the_bit() {
        let field = phantom::box_and_sphere([19, 17, 16]).unwrap();
        let sdf = signed_distance(&field, &SdfParams::default(), &NoProgress).unwrap();
        let sky_translucent = GeometricParams {
            intensities: [1.0, 0.8, 0.6, 0.4, 0.2, 0.1, 0.0, 0.3],
            alpha: 0.6,
            gamma: 1.7,
            ..Default::default()
        };
        let combined = GeometricParams {
            normal_weighted: false,
            ..Default::default()
        };
        for params in [GeometricParams::default(), sky_translucent, combined] {
            let table = if params.alpha < 1.0 {
                GeometryTable::two_sided()
            } else {
                GeometryTable::hemisphere()
            };
            let terms = SurfaceTerms::new(&sdf.sdf, table, &params);
            let (ao, kept) = octants(&terms, &params, true, &NoProgress).unwrap();
            let (want_ao, want_kept) = full_grid(&Surface::new(&terms), &params);
            assert!(ao
                .iter()
                .map(|x| x.to_bits())
                .eq(want_ao.iter().map(|x| x.to_bits())));
            assert_eq!(kept.len(), 8);
            for (got, want) in kept.iter().zip(&want_kept) {
                assert!(got
                    .iter()
                    .map(|x| x.to_bits())
                    .eq(want.iter().map(|x| x.to_bits())));
            }
            // Without the kept octants, the same AO.
            let (alone, none) = octants(&terms, &params, false, &NoProgress).unwrap();
            assert!(none.is_empty() && alone == ao);
        }
    }

    #[test]
    fn split_step_recovers_each_part() {
        let (nx, ny) = (4, 1);
        let (px, py) = (nx + 2, ny + 2);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let step = dx + px * (dy + py * dz);
                    assert_eq!(split_step(step, px * py), (dz, dx + px * dy));
                }
            }
        }
    }
}
