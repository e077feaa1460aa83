//! What the sweeps share: a grid padded by one voxel on every side (so a step to a neighbour
//! needs no bounds check), the eight octants, and the order a sweep visits an axis in.

/// A grid with one voxel of padding on every side, x fastest.
pub struct Padded {
    pub dims: [usize; 3],
    pub values: Vec<f32>,
}

impl Padded {
    pub fn new(dims: [usize; 3], fill: f32) -> Self {
        let [nx, ny, nz] = dims;
        Self {
            dims,
            values: vec![fill; (nx + 2) * (ny + 2) * (nz + 2)],
        }
    }

    /// `f` of each of `values` (a grid of `dims`, x fastest), padded with `fill`.
    pub fn map(dims: [usize; 3], values: &[f32], fill: f32, f: impl Fn(f32) -> f32) -> Self {
        let [nx, ny, nz] = dims;
        let mut grid = Self::new(dims, fill);
        for k in 0..nz {
            for j in 0..ny {
                let start = grid.index(0, j, k);
                let row = &values[(j + ny * k) * nx..][..nx];
                for (t, &v) in grid.values[start..start + nx].iter_mut().zip(row) {
                    *t = f(v);
                }
            }
        }
        grid
    }

    /// Index of voxel (i, j, k) of the unpadded grid, each shifted by one.
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        let [nx, ny, _] = self.dims;
        (i + 1) + (nx + 2) * ((j + 1) + (ny + 2) * (k + 1))
    }

    /// Index offset of a step (dx, dy, dz).
    pub fn offset(&self, step: [i32; 3]) -> isize {
        let [nx, ny, _] = self.dims;
        let (px, py) = ((nx + 2) as isize, (ny + 2) as isize);
        step[0] as isize + px * (step[1] as isize + py * step[2] as isize)
    }

    /// The unpadded values, x fastest, each through `f`.
    pub fn unpad(&self, f: impl Fn(f32) -> f32) -> Vec<f32> {
        let [nx, ny, nz] = self.dims;
        let mut values = Vec::with_capacity(nx * ny * nz);
        for k in 0..nz {
            for j in 0..ny {
                let start = self.index(0, j, k);
                values.extend(self.values[start..start + nx].iter().map(|&v| f(v)));
            }
        }
        values
    }
}

/// The eight octants of directions as the signs of their axes: octant `o` has bit a of `o`
/// clear where it looks up axis a (sign +1), the order of the `ao_oct0`..`ao_oct7` grids.
pub fn octant_signs() -> [[i32; 3]; 8] {
    std::array::from_fn(|o| {
        [
            1 - 2 * (o as i32 & 1),
            1 - 2 * ((o as i32 >> 1) & 1),
            1 - 2 * ((o as i32 >> 2) & 1),
        ]
    })
}

/// The order a sweep for an octant looking along `sign` visits an axis of `n` voxels: away from
/// where its light comes from, so descending where the octant looks up the axis.
pub fn sweep_order(n: usize, sign: i32) -> Box<dyn Iterator<Item = usize>> {
    if sign > 0 {
        Box::new((0..n).rev())
    } else {
        Box::new(0..n)
    }
}
