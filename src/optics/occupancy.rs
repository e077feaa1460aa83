//! Empty-space skipping that cannot change an image: a grid of cells of `CELL^3` voxels, each
//! flagged when a trilinear sample inside it could have non-zero extinction or emission.
//!
//! A cell's flag looks at the voxel values from one voxel before the cell to one voxel after
//! it, so a sample whose cell the CPU and GPU twins round differently near a face still has all
//! its trilinear neighbours in the range checked; and it checks every table entry the values
//! in that range interpolate between, on every gradient row of a 2D table. A sample in an
//! unflagged cell is therefore exactly one the ray caster would have skipped after classifying
//! it, and both twins skip the same samples.

use crate::classify::Lut;
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;

/// Voxels per cell along each axis.
pub const CELL: usize = 8;

/// One flag (0 or 1, as u32 for the GPU) per cell, x fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct Occupancy {
    cells: [usize; 3],
    flags: Vec<u32>,
}

impl Occupancy {
    pub fn build(volume: &Volume, lut: &Lut) -> Self {
        let (cells, ranges) = cell_value_ranges(volume, CELL);
        let flags = ranges
            .into_par_iter()
            .map(|[lo, hi]| u32::from(lut.may_contribute(lo, hi)))
            .collect();
        Self { cells, flags }
    }

    pub fn cells(&self) -> [usize; 3] {
        self.cells
    }

    /// Flags for upload to the GPU.
    pub fn flags(&self) -> &[u32] {
        &self.flags
    }

    /// The cell holding continuous index coordinate `c` (clamped into the volume).
    #[inline]
    pub fn cell_of(&self, c: Vec3) -> [usize; 3] {
        let cell = |x: f32, n: usize| ((x.max(0.0) as usize) / CELL).min(n - 1);
        [
            cell(c.x, self.cells[0]),
            cell(c.y, self.cells[1]),
            cell(c.z, self.cells[2]),
        ]
    }

    #[inline]
    pub fn occupied(&self, cell: [usize; 3]) -> bool {
        self.flags[cell[0] + self.cells[0] * (cell[1] + self.cells[1] * cell[2])] != 0
    }

    /// Where a ray (in index coordinates: start `c0`, direction `dc` per unit t) leaves `cell`;
    /// the outermost cells extend to infinity, as sampling clamps there.
    #[inline]
    pub fn exit(&self, cell: [usize; 3], c0: Vec3, dc: Vec3) -> f32 {
        let mut t = f32::INFINITY;
        for a in 0..3 {
            let bound = if dc[a] > 0.0 {
                if cell[a] + 1 == self.cells[a] {
                    continue;
                }
                ((cell[a] + 1) * CELL) as f32
            } else if dc[a] < 0.0 {
                if cell[a] == 0 {
                    continue;
                }
                (cell[a] * CELL) as f32
            } else {
                continue;
            };
            t = t.min((bound - c0[a]) / dc[a]);
        }
        t
    }
}

/// The cells of `side^3` voxels along each axis, and per cell (x fastest) the least and greatest
/// voxel value from one voxel before it to one after it: every value a trilinear sample inside
/// the cell interpolates between, with a voxel to spare for rounding near its faces.
pub fn cell_value_ranges(volume: &Volume, side: usize) -> ([usize; 3], Vec<[f32; 2]>) {
    let dims = volume.dims();
    let cells = dims.map(|n| n.div_ceil(side));
    let range = |c: usize, n: usize| (c * side).saturating_sub(1)..((c + 1) * side + 2).min(n);
    let ranges = (0..cells[0] * cells[1] * cells[2])
        .into_par_iter()
        .map(|index| {
            let (ci, cj, ck) = (
                index % cells[0],
                (index / cells[0]) % cells[1],
                index / (cells[0] * cells[1]),
            );
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            let columns = range(ci, dims[0]);
            for k in range(ck, dims[2]) {
                for j in range(cj, dims[1]) {
                    let row = dims[0] * (j + dims[1] * k);
                    for &v in &volume.values()[row + columns.start..row + columns.end] {
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
            }
            [lo, hi]
        })
        .collect();
    (cells, ranges)
}

/// A march along a ray in index coordinates (`index_origin + t index_dir`): `steps` steps of
/// `step` from `start`, each sampled at its midpoint (a view ray's first and last step are
/// clipped to the box: `steps::ViewSteps`).
#[derive(Clone, Copy, Debug)]
pub struct March {
    pub index_origin: Vec3,
    pub index_dir: Vec3,
    pub start: f32,
    pub step: f32,
    pub steps: u32,
}

impl Occupancy {
    /// After step `k` of `march`, whose midpoint lies at index coordinate `at`: None when its
    /// cell may hold matter (sample it); else the step to go on with, the first whose midpoint
    /// lies at or beyond the cell's exit and at least k + 1 (`march.steps` when none is left,
    /// or the exit is unbounded or NaN).
    #[inline]
    pub fn skip(&self, at: Vec3, k: u32, march: &March) -> Option<u32> {
        let cell = self.cell_of(at);
        if self.occupied(cell) {
            return None;
        }
        let t_exit = self.exit(cell, march.index_origin, march.index_dir);
        let next = ((t_exit - march.start) / march.step - 0.5).ceil();
        Some(if next.is_nan() || next >= march.steps as f32 {
            march.steps
        } else {
            (next as u32).max(k + 1)
        })
    }
}

#[cfg(test)]
impl Occupancy {
    /// Every cell flagged: marching with it skips nothing.
    pub(crate) fn everywhere(volume: &Volume) -> Self {
        let cells = volume.dims().map(|n| n.div_ceil(CELL));
        Self {
            cells,
            flags: vec![1; cells[0] * cells[1] * cells[2]],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::presets::preset;
    use crate::volume::phantom;

    #[test]
    fn empty_cells_are_found_and_occupied_ones_kept() {
        // The sphere of radius 0.5 in [-1, 1]^3: the corners are empty, the centre is not.
        let volume = phantom::sphere(64, 0.5).unwrap();
        let lut = preset("simulation").unwrap().bake(&volume);
        let occupancy = Occupancy::build(&volume, &lut);
        assert_eq!(occupancy.cells(), [8, 8, 8]);
        assert!(!occupancy.occupied([0, 0, 0]));
        assert!(occupancy.occupied([4, 4, 4]));
        let empty = occupancy.flags().iter().filter(|f| **f == 0).count();
        assert!(empty > 300, "{empty} of 512 cells empty");
    }
}
