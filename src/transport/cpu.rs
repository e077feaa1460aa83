//! CPU twin of the ordinates sweep: per sweep order the planes in order, per plane each
//! direction's rows in parallel. Each plane's extinction and output are gathered into
//! contiguous padded planes once per sweep order, so the directions' loops run over
//! contiguous rows whatever the axis.

use super::directions::{Ordinate, Ordinates};
use super::{total_planes, Planes};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;

/// The visibility volume of `extinction` over `ordinates` (from [`super::prepare`]).
pub fn visibility(
    extinction: &Volume,
    ordinates: &Ordinates,
    progress: &dyn Progress,
) -> Result<Volume> {
    let dims = extinction.dims();
    let sigma = extinction.values();
    let mut sum = vec![0.0f32; sigma.len()];
    let total = total_planes(dims, ordinates);
    let mut done = 0;
    for group in ordinates.groups() {
        let planes = Planes::new(dims, group.axis);
        let members = &ordinates.all()[group.members.clone()];
        let len = planes.padded_len();
        // Padding holds T = 1 and sigma = 0 (no matter outside the grid) and is never written.
        let mut upwind_t = vec![vec![1.0f32; len]; members.len()];
        let mut swept_t = upwind_t.clone();
        let mut upwind_sigma = vec![0.0f32; len];
        let mut swept_sigma = vec![0.0f32; len];
        let mut lit = vec![0.0f32; planes.lateral[0] * planes.lateral[1]];
        for k in planes.order(group.sign) {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            gather(&planes, k, sigma, &mut swept_sigma, &mut lit, &sum);
            for (o, (upwind, swept)) in members.iter().zip(upwind_t.iter().zip(&mut swept_t)) {
                sweep_plane(
                    &planes,
                    o,
                    upwind,
                    &upwind_sigma,
                    &swept_sigma,
                    swept,
                    &mut lit,
                );
            }
            scatter(&planes, k, &lit, &mut sum);
            std::mem::swap(&mut upwind_t, &mut swept_t);
            std::mem::swap(&mut upwind_sigma, &mut swept_sigma);
            done += 1;
            progress.update(done, total);
        }
    }
    for v in &mut sum {
        *v = v.clamp(0.0, 1.0);
    }
    Volume::new(dims, extinction.spacing(), extinction.origin(), sum)
}

/// Plane `k`'s extinction into the padded `sigma` and its sum so far into `lit`.
fn gather(
    planes: &Planes,
    k: usize,
    values: &[f32],
    sigma: &mut [f32],
    lit: &mut [f32],
    sum: &[f32],
) {
    let [nb, nc] = planes.lateral;
    let [sb, sc, sa] = planes.strides;
    let row = planes.padded_row();
    for c in 0..nc {
        let base = k * sa + c * sc;
        for b in 0..nb {
            sigma[(b + 1) + row * (c + 1)] = values[base + b * sb];
            lit[b + nb * c] = sum[base + b * sb];
        }
    }
}

/// `lit` back into plane `k` of `sum`.
fn scatter(planes: &Planes, k: usize, lit: &[f32], sum: &mut [f32]) {
    let [nb, nc] = planes.lateral;
    let [sb, sc, sa] = planes.strides;
    for c in 0..nc {
        let base = k * sa + c * sc;
        for b in 0..nb {
            sum[base + b * sb] = lit[b + nb * c];
        }
    }
}

/// One direction across one plane: T at each voxel from the upwind plane, into `swept`, and
/// its weighted share added to `lit`.
fn sweep_plane(
    planes: &Planes,
    o: &Ordinate,
    upwind: &[f32],
    upwind_sigma: &[f32],
    sigma: &[f32],
    swept: &mut [f32],
    lit: &mut [f32],
) {
    let [nb, _] = planes.lateral;
    let row = planes.padded_row();
    let weights = o.upwind_weights();
    let shift = o.upwind_shift(row);
    let half_length = 0.5 * o.length;
    swept[row..row * (planes.lateral[1] + 1)]
        .par_chunks_mut(row)
        .zip(lit.par_chunks_mut(nb))
        .enumerate()
        .for_each(|(c, (swept_row, lit_row))| {
            let start = row * (c + 1) + 1;
            for b in 0..nb {
                let at = start + b;
                let p = (at as isize + shift) as usize;
                let bilinear = |f: &[f32]| {
                    weights[0] * f[p]
                        + weights[1] * f[p + 1]
                        + weights[2] * f[p + row]
                        + weights[3] * f[p + row + 1]
                };
                let depth = half_length * (sigma[at] + bilinear(upwind_sigma));
                let t = bilinear(upwind) * (-depth).exp();
                swept_row[b + 1] = t;
                lit_row[b] += o.weight * t;
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;
    use glam::Vec3;

    fn uniform(n: usize, sigma: f32, spacing: f32) -> Volume {
        Volume::new(
            [n; 3],
            Vec3::splat(spacing),
            Vec3::ZERO,
            vec![sigma; n * n * n],
        )
        .unwrap()
    }

    #[test]
    fn empty_space_sees_the_whole_sky() {
        let v = visibility(
            &uniform(6, 0.0, 1.0),
            &Ordinates::new(32, Vec3::ONE).unwrap(),
            &NoProgress,
        )
        .unwrap();
        assert!(v.values().iter().all(|&x| (x - 1.0).abs() < 1e-6));
    }

    #[test]
    fn axis_and_lattice_diagonal_directions_are_exact_in_a_homogeneous_medium() {
        // Straight up z, or along a voxel diagonal (each step lands on a voxel centre), through
        // sigma: T = exp(-sigma L (m + 1/2)) at the m-th plane from the top, L the step's
        // length (half a step of matter past the last centre, none outside).
        let (n, sigma, h) = (8, 0.3f32, 0.5f32);
        for (towards, floor, fraction, length) in [
            (Vec3::Z, [0, 0], [0.0, 0.0], h),
            (Vec3::ONE.normalize(), [0, 0], [1.0, 1.0], h * 3f32.sqrt()),
        ] {
            let o = Ordinate {
                towards,
                weight: 1.0,
                axis: 2,
                sign: 1,
                floor,
                fraction,
                length,
            };
            let planes = Planes::new([n; 3], 2);
            let len = planes.padded_len();
            let (mut upwind, mut swept) = (vec![1.0f32; len], vec![1.0f32; len]);
            let (mut upwind_sigma, mut swept_sigma) = (vec![0.0f32; len], vec![0.0f32; len]);
            let volume = uniform(n, sigma, h);
            let mut lit = vec![0.0; n * n];
            let mut sum = vec![0.0; n * n * n];
            for (m, k) in planes.order(1).enumerate() {
                gather(
                    &planes,
                    k,
                    volume.values(),
                    &mut swept_sigma,
                    &mut lit,
                    &sum,
                );
                let planes_ = &planes;
                sweep_plane(
                    planes_,
                    &o,
                    &upwind,
                    &upwind_sigma,
                    &swept_sigma,
                    &mut swept,
                    &mut lit,
                );
                scatter(&planes, k, &lit, &mut sum);
                // Voxel (0, 0): its diagonal path stays in the grid for every plane above.
                let want = (-sigma * length * (m as f32 + 0.5)).exp();
                let got = swept[1 + planes.padded_row()];
                assert!(
                    (got - want).abs() < 1e-6,
                    "{towards} plane {k}: {got} vs {want}"
                );
                std::mem::swap(&mut upwind, &mut swept);
                std::mem::swap(&mut upwind_sigma, &mut swept_sigma);
            }
        }
    }
}
