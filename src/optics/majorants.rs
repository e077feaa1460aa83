//! Per-cell majorants for delta and ratio tracking (as pbrt-v4's majorant grid): the occupancy
//! grid's cells of `CELL^3` voxels, each holding the largest extinction any sample inside it
//! can have (and the least, the control extinction of residual ratio tracking), walked along a
//! ray cell by cell (Amanatides and Woo's DDA).
//!
//! Tracking with a majorant m samples free paths of mean 1 / m, so its cost is the majorant's
//! optical depth along the ray, not the medium's. With one majorant for the whole volume (the
//! table's largest extinction), empty space and thin tissue cost as much as the densest bone;
//! per cell they cost what their own densest sample does, and empty cells nothing. Free paths
//! are memoryless, so restarting one at each cell face keeps the estimators unbiased.

use crate::camera::Ray;
use crate::classify::Lut;
use crate::optics::occupancy::{cell_value_ranges, CELL};
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;

/// The extinction of every sample inside one cell lies in [min, max].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: f32,
    pub max: f32,
}

/// The extinction bounds of each cell, x fastest; the outermost cells extend to infinity, as
/// sampling clamps there.
#[derive(Clone, Debug, PartialEq)]
pub struct Majorants {
    cells: [usize; 3],
    /// Voxels per cell side (`CELL`, or the whole volume for a single cell).
    side: [f32; 3],
    bounds: Vec<Bounds>,
    origin: Vec3,
    spacing: Vec3,
}

impl Majorants {
    /// Per cell of `CELL^3` voxels: the least and the largest extinction the table gives any
    /// value a sample inside can interpolate.
    pub fn per_cell(volume: &Volume, lut: &Lut) -> Self {
        let (cells, ranges) = cell_value_ranges(volume, CELL);
        let bounds = ranges
            .into_par_iter()
            .map(|[lo, hi]| {
                let [min, max] = lut.sigma_t_bounds_between(lo, hi);
                Bounds { min, max }
            })
            .collect();
        Self {
            cells,
            side: [CELL as f32; 3],
            bounds,
            origin: volume.origin(),
            spacing: volume.spacing(),
        }
    }

    /// One cell over the whole volume holding the table's largest extinction and a minorant of
    /// 0 (for lookups that never track, or a volume too small for cells to pay).
    pub fn global(volume: &Volume, lut: &Lut) -> Self {
        Self {
            cells: [1; 3],
            side: volume.dims().map(|n| n as f32),
            bounds: vec![Bounds {
                min: 0.0,
                max: lut.max_sigma_t(),
            }],
            origin: volume.origin(),
            spacing: volume.spacing(),
        }
    }

    /// The largest majorant of all cells.
    pub fn largest(&self) -> f32 {
        self.bounds.iter().map(|b| b.max).fold(0.0, f32::max)
    }

    /// Visits the cells that `ray` crosses between t0 and t1, in order, as `visit(ta, tb, b)`:
    /// the segment [ta, tb] and its cell's bounds b. Stops early when `visit` returns true. Each
    /// call moves one cell on along one axis, so the walk ends after at most as many calls as
    /// there are cells along the three axes together. Face crossings are accumulated from the
    /// first (a cell's width of travel per axis), rounding by far less than the voxel of margin
    /// that each cell's majorant already covers.
    #[inline]
    pub fn walk(
        &self,
        ray: &Ray,
        t0: f32,
        t1: f32,
        mut visit: impl FnMut(f32, f32, Bounds) -> bool,
    ) {
        let c0 = (ray.origin - self.origin) / self.spacing;
        let dc = ray.dir / self.spacing;
        let start = c0 + t0 * dc;
        let strides = [1, self.cells[0], self.cells[0] * self.cells[1]];
        let mut cell = [0usize; 3];
        let mut next = [f32::INFINITY; 3];
        let mut width = [f32::INFINITY; 3];
        let mut index = 0;
        for a in 0..3 {
            let n = self.cells[a];
            cell[a] = ((start[a].max(0.0) / self.side[a]) as usize).min(n - 1);
            index += cell[a] * strides[a];
            if dc[a] > 0.0 && cell[a] + 1 < n {
                next[a] = ((cell[a] + 1) as f32 * self.side[a] - c0[a]) / dc[a];
            } else if dc[a] < 0.0 && cell[a] > 0 {
                next[a] = (cell[a] as f32 * self.side[a] - c0[a]) / dc[a];
            }
            width[a] = self.side[a] / dc[a].abs();
        }
        let mut ta = t0;
        loop {
            let axis = if next[0] < next[1] {
                if next[0] < next[2] {
                    0
                } else {
                    2
                }
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            let t_face = next[axis];
            let tb = t_face.min(t1);
            if tb > ta && visit(ta, tb, self.bounds[index]) {
                return;
            }
            if tb >= t1 || !t_face.is_finite() {
                return;
            }
            // On to the neighbour across the face crossed (finite faces only lead inwards of
            // the outermost cells), whose own far face is a cell's width further.
            let n = self.cells[axis];
            if dc[axis] > 0.0 {
                cell[axis] += 1;
                index += strides[axis];
                next[axis] = if cell[axis] + 1 < n {
                    t_face + width[axis]
                } else {
                    f32::INFINITY
                };
            } else {
                cell[axis] -= 1;
                index -= strides[axis];
                next[axis] = if cell[axis] > 0 {
                    t_face + width[axis]
                } else {
                    f32::INFINITY
                };
            }
            ta = ta.max(tb);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::presets::preset;
    use crate::volume::phantom;

    #[test]
    fn every_sample_lies_within_its_cells_bounds() {
        // The CT's bone never fills a cell; the sphere's solid core has cells of one value,
        // whose transmittance residual ratio tracking takes exactly.
        let with_minorant = [
            bounds_hold(phantom::ct(40).unwrap(), "ct-bone"),
            bounds_hold(phantom::sphere(40, 0.8).unwrap(), "simulation"),
        ];
        assert_eq!(with_minorant.map(|cells| cells > 0), [false, true]);
    }

    /// Checks the bounds along random rays; returns how many cells have a minorant.
    fn bounds_hold(volume: Volume, preset_name: &str) -> usize {
        let lut = preset(preset_name).unwrap().bake(&volume);
        let majorants = Majorants::per_cell(&volume, &lut);
        let (lo, hi) = volume.bounds();
        let mut state = 12345u32;
        let mut uniform = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / (1 << 24) as f32
        };
        let mut cells_seen = 0;
        for _ in 0..200 {
            let origin = lo + (hi - lo) * Vec3::new(uniform(), uniform(), uniform());
            let dir = (Vec3::new(uniform(), uniform(), uniform()) - 0.5).normalize();
            let ray = Ray { origin, dir };
            let Some((t0, t1)) = crate::camera::intersect_box(&ray, lo, hi) else {
                continue;
            };
            let mut covered = t0;
            majorants.walk(&ray, t0, t1, |ta, tb, b| {
                assert!((ta - covered).abs() < 1e-5, "a gap before {ta}: {covered}");
                covered = tb;
                cells_seen += 1;
                for k in 0..=16 {
                    let t = ta + (tb - ta) * k as f32 / 16.0;
                    let sigma = lut.sigma_t(volume.sample(origin + t * dir), 0.0);
                    assert!(
                        sigma <= b.max * (1.0 + 1e-6),
                        "{sigma} above {b:?} at t = {t}"
                    );
                    assert!(
                        sigma >= b.min * (1.0 - 1e-6),
                        "{sigma} below {b:?} at t = {t}"
                    );
                }
                false
            });
            assert!(
                (covered - t1).abs() < 1e-5,
                "walk ended at {covered}, not {t1}"
            );
        }
        assert!(cells_seen > 400, "{cells_seen} cells");
        assert!(majorants.largest() <= lut.max_sigma_t());
        // The phantom's air is empty: some cells cost nothing to cross.
        assert!(
            majorants.bounds.iter().any(|b| b.max == 0.0),
            "{preset_name}"
        );
        majorants.bounds.iter().filter(|b| b.min > 0.0).count()
    }

    #[test]
    fn a_single_cell_holds_the_tables_largest_extinction() {
        let volume = phantom::ct(16).unwrap();
        let lut = preset("ct-bone").unwrap().bake(&volume);
        let global = Majorants::global(&volume, &lut);
        let (lo, hi) = volume.bounds();
        let ray = Ray {
            origin: lo - Vec3::ONE,
            dir: (hi - lo).normalize(),
        };
        let (t0, t1) = crate::camera::intersect_box(&ray, lo, hi).unwrap();
        let mut segments = vec![];
        global.walk(&ray, t0, t1, |ta, tb, b| {
            segments.push((ta, tb, b.max, b.min));
            false
        });
        assert_eq!(segments, vec![(t0, t1, lut.max_sigma_t(), 0.0)]);
    }
}
