//! The medium a transport solve runs on: the classified volume's extinction and scattering
//! per voxel, averaged over blocks of `coarsen`^3 voxels when light that varies slowly allows a
//! coarser grid, and the solved fields read back at any point by trilinear interpolation.
//!
//! A block's extinction is the mean of its voxels' sigma_t, and its scattering coefficient
//! the mean of theirs (sigma_t times albedo), so the block scatters the light its voxels would
//! in the thin limit. A block holding dense matter beside empty voxels lets light through as
//! its mean does, which is darker than the voxels would (exp of a mean is below the mean of
//! exps): coarsening errs dark at sharp boundaries of dense matter, by an amount that falls
//! with the block's size against the matter's mean free path (docs/transport.md measures it).

use crate::classify::Lut;
use crate::error::Result;
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;

/// Extinction and scattering on a solver grid.
#[derive(Clone, Debug)]
pub struct Medium {
    /// sigma_t per world unit at each cell centre (the grid's dims, spacing and origin).
    pub extinction: Volume,
    /// sigma_s = albedo sigma_t per colour channel, one per cell.
    pub scattering: Vec<Vec3>,
}

impl Medium {
    /// The medium of `volume` classified by `lut` (a 2D table reads the gradient at each
    /// voxel), on blocks of `coarsen`^3 voxels (1: the volume's own grid). The last block along
    /// an axis may be partial; it averages the voxels it has and keeps the regular centre.
    pub fn classify(volume: &Volume, lut: &Lut, coarsen: usize) -> Result<Self> {
        let f = coarsen.max(1);
        let dims = volume.dims();
        let coarse = dims.map(|n| n.div_ceil(f));
        let spacing = volume.spacing();
        let origin = volume.origin() + spacing * 0.5 * (f as f32 - 1.0);
        let with_gradient = lut.gradient_max().is_some();
        let cells = coarse[0] * coarse[1] * coarse[2];
        let blocks: Vec<(f32, Vec3)> = (0..cells)
            .into_par_iter()
            .map(|cell| {
                let c = [
                    cell % coarse[0],
                    (cell / coarse[0]) % coarse[1],
                    cell / (coarse[0] * coarse[1]),
                ];
                let span = |a: usize| (c[a] * f)..((c[a] + 1) * f).min(dims[a]);
                let (mut sigma_t, mut sigma_s, mut count) = (0.0f32, Vec3::ZERO, 0.0f32);
                for k in span(2) {
                    for j in span(1) {
                        for i in span(0) {
                            let gradient = if with_gradient {
                                let p = volume.origin()
                                    + spacing * Vec3::new(i as f32, j as f32, k as f32);
                                volume.gradient(p).length()
                            } else {
                                0.0
                            };
                            let o = lut.lookup(volume.at(i, j, k), gradient);
                            sigma_t += o.sigma_t;
                            sigma_s += o.albedo * o.sigma_t;
                            count += 1.0;
                        }
                    }
                }
                (sigma_t / count, sigma_s / count)
            })
            .collect();
        let (extinction, scattering): (Vec<f32>, Vec<Vec3>) = blocks.into_iter().unzip();
        Ok(Self {
            extinction: Volume::new(coarse, spacing * f as f32, origin, extinction)?,
            scattering,
        })
    }

    pub fn dims(&self) -> [usize; 3] {
        self.extinction.dims()
    }

    /// World position of cell `index` (x fastest).
    pub fn centre(&self, index: usize) -> Vec3 {
        self.extinction.centre(index)
    }
}

/// The eight cells around world point `p` on a grid (clamped to its edge cells, as volumes
/// are sampled) and their trilinear weights.
pub fn trilinear(grid: &Volume, p: Vec3) -> [(usize, f32); 8] {
    let [nx, ny, nz] = grid.dims();
    let max = Vec3::new((nx - 1) as f32, (ny - 1) as f32, (nz - 1) as f32);
    let c = grid.to_index(p).clamp(Vec3::ZERO, max);
    // c >= 0, so truncation is the floor.
    let i0 = [c.x as usize, c.y as usize, c.z as usize];
    let f = c - Vec3::new(i0[0] as f32, i0[1] as f32, i0[2] as f32);
    let i1 = [
        (i0[0] + 1).min(nx - 1),
        (i0[1] + 1).min(ny - 1),
        (i0[2] + 1).min(nz - 1),
    ];
    let mut out = [(0usize, 0.0f32); 8];
    for (corner, slot) in out.iter_mut().enumerate() {
        let pick = |a: usize| if corner >> a & 1 == 0 { i0[a] } else { i1[a] };
        let weight = |a: usize| {
            if corner >> a & 1 == 0 {
                1.0 - f[a]
            } else {
                f[a]
            }
        };
        *slot = (
            pick(0) + nx * (pick(1) + ny * pick(2)),
            weight(0) * weight(1) * weight(2),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::presets::preset;

    #[test]
    fn blocks_average_extinction_and_scattering_and_keep_the_volume_centred() {
        let volume = Volume::from_fn([5, 4, 4], Vec3::splat(0.5), Vec3::ZERO, |p| p.x).unwrap();
        let lut = preset("ct-bone").unwrap().bake(&volume);
        let fine = Medium::classify(&volume, &lut, 1).unwrap();
        let coarse = Medium::classify(&volume, &lut, 2).unwrap();
        assert_eq!(coarse.dims(), [3, 2, 2]);
        // Cell (0, 0, 0) averages fine cells x in {0, 1}, y, z in {0, 1}.
        let mut want = 0.0;
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..2 {
                    want += fine.extinction.at(i, j, k) / 8.0;
                }
            }
        }
        assert!((coarse.extinction.at(0, 0, 0) - want).abs() < 1e-5 * want.max(1.0));
        // The first coarse centre lies between the first two fine ones.
        assert!((coarse.centre(0) - (fine.centre(0) + Vec3::splat(0.25))).length() < 1e-6);
        // Trilinear weights sum to 1 and reproduce a cell's own value at its centre.
        let at = trilinear(&coarse.extinction, coarse.centre(7));
        assert!((at.iter().map(|c| c.1).sum::<f32>() - 1.0).abs() < 1e-6);
        let got: f32 = at
            .iter()
            .map(|&(i, w)| w * coarse.extinction.values()[i])
            .sum();
        assert!((got - coarse.extinction.values()[7]).abs() < 1e-5);
    }
}
