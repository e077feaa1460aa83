//! Monte Carlo ambient occlusion of an iso-surface: the reference the geometric occlusion
//! sweep ([`crate::ao::sweep::geometric`]) is measured against.
//!
//! At a surface point p with outward normal N, AO(p) = 1/pi int_{N . w > 0} V(p, w) (N . w) dw,
//! V = 1 when the ray from p along w leaves the grid without entering the inside (a trilinear
//! value above the iso-value): cosine-weighted directions, so the estimate is the fraction of
//! unoccluded rays. Rays start a voxel off the surface along N (so a surface does not occlude
//! itself through its own discretisation) and march at a quarter of the smallest spacing.
//!
//! Points are the voxels within half a voxel of the surface by the signed distance, each
//! projected onto the surface along the normal of the field (-grad, towards smaller values).
//! Seeded, one PCG stream per point.

use crate::error::{Error, Result};
use crate::volume::Volume;
use glam::Vec3;
use rand::Rng;
use rand_pcg::Pcg32;
use rayon::prelude::*;

/// A surface point with its voxel.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Index of the voxel (x fastest).
    pub voxel: usize,
    pub position: Vec3,
    /// Outward unit normal.
    pub normal: Vec3,
}

/// Up to `count` surface points of the `iso` surface of `field`, picked evenly among the
/// voxels within half a voxel of it (by `sdf`, the signed distance on the same grid), whose
/// field gradient is not zero.
pub fn surface_points(field: &Volume, sdf: &Volume, count: usize) -> Vec<SurfacePoint> {
    let h = field.spacing().min_element();
    let [nx, ny, _] = field.dims();
    let near: Vec<usize> = (0..sdf.values().len())
        .filter(|&v| sdf.values()[v].abs() < 0.5 * h)
        .collect();
    let stride = near.len().div_ceil(count.max(1)).max(1);
    near.iter()
        .step_by(stride)
        .filter_map(|&voxel| {
            let (i, j, k) = (voxel % nx, (voxel / nx) % ny, voxel / (nx * ny));
            let centre = field.origin() + Vec3::new(i as f32, j as f32, k as f32) * field.spacing();
            let normal = (-field.gradient(centre)).try_normalize()?;
            Some(SurfacePoint {
                voxel,
                position: centre - sdf.values()[voxel] * normal,
                normal,
            })
        })
        .collect()
}

/// The Monte Carlo AO of each point with `samples` cosine-weighted rays.
pub fn surface_ao(
    field: &Volume,
    iso: f32,
    points: &[SurfacePoint],
    samples: u32,
    seed: u64,
) -> Result<Vec<f32>> {
    if samples == 0 {
        return Err(Error::param("samples", "at least one ray per point"));
    }
    let h = field.spacing().min_element();
    let (lo, hi) = field.bounds();
    Ok(points
        .par_iter()
        .enumerate()
        .map(|(index, point)| {
            let mut rng = Pcg32::new(seed, 2 * index as u64 + 1);
            let start = point.position + point.normal * h;
            let open = (0..samples)
                .filter(|_| {
                    let w = cosine_direction(point.normal, &mut rng);
                    !occluded(field, iso, start, w, 0.25 * h, lo, hi)
                })
                .count();
            open as f32 / samples as f32
        })
        .collect())
}

/// Whether the ray from `p` along `w` meets a value above `iso` before leaving [lo, hi].
fn occluded(field: &Volume, iso: f32, p: Vec3, w: Vec3, step: f32, lo: Vec3, hi: Vec3) -> bool {
    let mut q = p;
    while q.cmpge(lo).all() && q.cmple(hi).all() {
        if field.sample(q) > iso {
            return true;
        }
        q += w * step;
    }
    false
}

/// A direction about `n` with density cos(theta) / pi (Malley's method).
fn cosine_direction(n: Vec3, rng: &mut Pcg32) -> Vec3 {
    let (u, v): (f32, f32) = (rng.random(), rng.random());
    let r = u.sqrt();
    let phi = std::f32::consts::TAU * v;
    let (t, b) = n.any_orthonormal_pair();
    (t * r * phi.cos() + b * r * phi.sin() + n * (1.0 - u).max(0.0).sqrt()).normalize()
}
