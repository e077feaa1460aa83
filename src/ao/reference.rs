//! Monte Carlo reference AO volumes: for every voxel centre x, an unbiased estimate of its
//! openness (1 = unoccluded) and the estimate's standard error, seeded and deterministic (one
//! PCG stream per voxel).
//!
//! Variants (the AO literature uses all three):
//! - `Sphere`: mean transmittance from x over the sphere of directions, T(x, w) along w up to
//!   `radius` (or out of the volume), by ratio tracking.
//! - `Hemisphere`: the same over the hemisphere around the outward normal
//!   n = -grad(sigma_t) / |grad(sigma_t)| (towards less matter), uniform in solid angle; where
//!   the extinction has no gradient there is no side to prefer, and the whole sphere is used.
//! - `TangentSphere`: the continuous form of the volumetric-AO papers' estimate: for y uniform
//!   in the ball of `radius` around x, the probability that sigma_t(y) < sigma_t(x), ties
//!   counting one half; on a flat interface it is 1/2, and it rises where x sits in a hollow.
//!   (The exact voxel-count estimate of the VAO issue is its discrete counterpart.)
//!
//! Extinction is the classified sigma_t of the renderers (trilinear value, then the table).

use crate::camera::Ray;
use crate::classify::Lut;
use crate::error::{Error, Result};
use crate::optics::medium::Medium;
use crate::optics::phase::{sample_cone, sample_sphere};
use crate::progress::Progress;
use crate::volume::Volume;
use glam::Vec3;
use rand::Rng;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Which openness to estimate (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AoVariant {
    Sphere,
    Hemisphere,
    TangentSphere,
}

impl AoVariant {
    /// Every variant by its name on the command line and in file names.
    const NAMES: [(&'static str, AoVariant); 3] = [
        ("sphere", AoVariant::Sphere),
        ("hemisphere", AoVariant::Hemisphere),
        ("tangent-sphere", AoVariant::TangentSphere),
    ];

    /// The name on the command line and in file names.
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(_, variant)| *variant == self)
            .map_or("", |(name, _)| name)
    }
}

impl std::str::FromStr for AoVariant {
    type Err = crate::error::Error;

    fn from_str(name: &str) -> crate::error::Result<Self> {
        crate::names::parse_name("variant", name, &Self::NAMES)
    }
}

/// Parameters of a reference AO volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoReferenceParams {
    pub variant: AoVariant,
    /// Samples per voxel (at least 2, for a standard error).
    pub samples: u32,
    pub seed: u64,
    /// World units: how far occluders count (`Sphere`, `Hemisphere`; None: out of the volume)
    /// or the ball's radius (`TangentSphere`, required).
    pub radius: Option<f32>,
}

impl AoReferenceParams {
    pub fn validate(&self) -> Result<()> {
        if !(2..=1 << 20).contains(&self.samples) {
            return Err(Error::param(
                "samples",
                format!("must be in [2, 1048576], got {}", self.samples),
            ));
        }
        match self.radius {
            Some(r) if !(r > 0.0 && r.is_finite()) => Err(Error::param(
                "radius",
                format!("must be positive and finite, got {r}"),
            )),
            None if self.variant == AoVariant::TangentSphere => Err(Error::param(
                "radius",
                "the tangent-sphere variant needs a radius",
            )),
            _ => Ok(()),
        }
    }
}

/// Openness per voxel and its standard error, on the volume's grid.
pub struct AoReference {
    pub openness: Volume,
    pub stderr: Volume,
}

/// Estimates the AO volume of `volume` classified by `lut`.
pub fn ao_reference(
    volume: &Volume,
    lut: &Lut,
    params: &AoReferenceParams,
    progress: &dyn Progress,
) -> Result<AoReference> {
    params.validate()?;
    let medium = Medium::tracking(volume, lut)?;
    let [nx, ny, nz] = volume.dims();
    let count = nx * ny * nz;
    let mut openness = vec![0.0f32; count];
    let mut stderr = vec![0.0f32; count];
    let slices_done = AtomicU64::new(0);
    openness
        .par_chunks_mut(nx * ny)
        .zip(stderr.par_chunks_mut(nx * ny))
        .enumerate()
        .for_each(|(k, (open_slice, err_slice))| {
            if progress.cancelled() {
                return;
            }
            for (n, (o, e)) in open_slice.iter_mut().zip(err_slice).enumerate() {
                let (i, j) = (n % nx, n / nx);
                let x =
                    volume.origin() + Vec3::new(i as f32, j as f32, k as f32) * volume.spacing();
                let index = (k * nx * ny + n) as u64;
                (*o, *e) = estimate_voxel(&medium, volume, x, params, index);
            }
            let done = slices_done.fetch_add(1, Ordering::Relaxed) + 1;
            progress.update(done, nz as u64);
        });
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    let grid = |values| Volume::new(volume.dims(), volume.spacing(), volume.origin(), values);
    Ok(AoReference {
        openness: grid(openness)?,
        stderr: grid(stderr)?,
    })
}

/// The same estimates at the given voxels only (for measuring on large volumes): (openness,
/// standard error) per voxel, each from its own stream, so a voxel's estimate does not depend
/// on which others are asked for.
pub fn ao_reference_at(
    volume: &Volume,
    lut: &Lut,
    params: &AoReferenceParams,
    voxels: &[[usize; 3]],
) -> Result<Vec<(f32, f32)>> {
    params.validate()?;
    let medium = Medium::tracking(volume, lut)?;
    let [nx, ny, _] = volume.dims();
    Ok(voxels
        .par_iter()
        .map(|&[i, j, k]| {
            let x = volume.origin() + Vec3::new(i as f32, j as f32, k as f32) * volume.spacing();
            let index = (i + nx * (j + ny * k)) as u64;
            estimate_voxel(&medium, volume, x, params, index)
        })
        .collect())
}

fn estimate_voxel(
    medium: &Medium,
    volume: &Volume,
    x: Vec3,
    params: &AoReferenceParams,
    index: u64,
) -> (f32, f32) {
    let mut rng = Pcg32::new(params.seed ^ 0xa076_1d64_78bd_642f, index);
    let reach = params.radius.unwrap_or(f32::INFINITY);
    let normal = match params.variant {
        AoVariant::Hemisphere => extinction_normal(medium, volume, x),
        _ => None,
    };
    let sigma_x = medium.optical(x).sigma_t;
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    for _ in 0..params.samples {
        let s = match params.variant {
            AoVariant::Sphere | AoVariant::Hemisphere => {
                let w = match normal {
                    Some(n) => sample_cone(n, 0.0, &mut rng),
                    None => sample_sphere(&mut rng),
                };
                medium.transmittance(&Ray { origin: x, dir: w }, reach, &mut rng)
            }
            AoVariant::TangentSphere => {
                let y = x + reach * sample_ball(&mut rng);
                let sigma_y = medium.optical_or_empty(y).sigma_t;
                if sigma_y < sigma_x {
                    1.0
                } else if sigma_y == sigma_x {
                    0.5
                } else {
                    0.0
                }
            }
        } as f64;
        sum += s;
        sum_sq += s * s;
    }
    let n = params.samples as f64;
    let mean = sum / n;
    let variance = ((sum_sq - n * mean * mean) / (n - 1.0)).max(0.0);
    (mean as f32, (variance / n).sqrt() as f32)
}

/// The outward normal of the classified extinction at `x` (central differences one voxel
/// apart), or None where it has no gradient.
fn extinction_normal(medium: &Medium, volume: &Volume, x: Vec3) -> Option<Vec3> {
    let h = volume.spacing();
    let d = |axis: Vec3| {
        let step = axis * h;
        (medium.optical_or_empty(x + step).sigma_t - medium.optical_or_empty(x - step).sigma_t)
            / (2.0 * step.length())
    };
    let grad = Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z));
    (grad.length_squared() > 0.0).then(|| -grad.normalize())
}

/// A point uniformly distributed in the unit ball.
fn sample_ball(rng: &mut Pcg32) -> Vec3 {
    sample_sphere(rng) * rng.random::<f32>().cbrt()
}
