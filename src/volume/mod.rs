//! The volume model: a dense scalar grid with dims, spacing and origin in world units.
//!
//! Voxel (i, j, k) has its centre at `origin + (i, j, k) * spacing`; values are stored x fastest.
//! A voxel covers half a spacing on each side of its centre, so the bounding box runs from
//! `origin - spacing / 2` to `origin + (dims - 1/2) * spacing` (the OpenVDB/Blender convention).
//! Between centres, samples are trilinear; in the half-voxel border they clamp to the edge.

pub mod info;
mod loaders;
pub mod phantom;

pub use loaders::{
    frame_count, load, load_with_info, Frame, LoadOptions, NonFinite, RawSpec, ScalarType,
    SourceInfo,
};

use crate::error::{Error, Result};
use glam::Vec3;
use std::sync::OnceLock;

/// A dense scalar volume in world units.
#[derive(Clone, Debug)]
pub struct Volume {
    dims: [usize; 3],
    spacing: Vec3,
    origin: Vec3,
    values: Vec<f32>,
    /// Largest gradient magnitude, computed on first use (the volume never changes).
    max_gradient: OnceLock<f32>,
}

impl PartialEq for Volume {
    fn eq(&self, other: &Self) -> bool {
        self.dims == other.dims
            && self.spacing == other.spacing
            && self.origin == other.origin
            && self.values == other.values
    }
}

impl Volume {
    /// Builds a volume, checking that dims are positive, the value count matches, spacing is
    /// positive and finite, and every value is finite.
    pub fn new(dims: [usize; 3], spacing: Vec3, origin: Vec3, values: Vec<f32>) -> Result<Self> {
        let count = voxel_count(dims)?;
        if values.len() != count {
            return Err(Error::Volume(format!(
                "dims {}x{}x{} need {count} values, got {}",
                dims[0],
                dims[1],
                dims[2],
                values.len()
            )));
        }
        if !spacing.is_finite() || spacing.min_element() <= 0.0 {
            return Err(Error::Volume(format!(
                "spacing must be positive and finite, got {spacing}"
            )));
        }
        if !origin.is_finite() {
            return Err(Error::Volume(format!(
                "origin must be finite, got {origin}"
            )));
        }
        check_box(dims, spacing, origin)?;
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::Volume(format!(
                "value {} at voxel {:?} is not finite",
                values[index],
                unflatten(dims, index)
            )));
        }
        Ok(Self {
            dims,
            spacing,
            origin,
            values,
            max_gradient: OnceLock::new(),
        })
    }

    /// Builds a volume by evaluating `f` at every voxel centre (world coordinates).
    pub fn from_fn(
        dims: [usize; 3],
        spacing: Vec3,
        origin: Vec3,
        f: impl Fn(Vec3) -> f32 + Sync,
    ) -> Result<Self> {
        use rayon::prelude::*;
        let count = voxel_count(dims)?;
        let mut values = vec![0.0f32; count];
        values
            .par_chunks_mut(dims[0])
            .enumerate()
            .for_each(|(row, out)| {
                let (j, k) = (row % dims[1], row / dims[1]);
                for (i, v) in out.iter_mut().enumerate() {
                    *v = f(origin + Vec3::new(i as f32, j as f32, k as f32) * spacing);
                }
            });
        Self::new(dims, spacing, origin, values)
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    pub fn spacing(&self) -> Vec3 {
        self.spacing
    }
    pub fn origin(&self) -> Vec3 {
        self.origin
    }
    /// Values, x fastest, then y, then z.
    pub fn values(&self) -> &[f32] {
        &self.values
    }
    pub fn into_values(self) -> Vec<f32> {
        self.values
    }

    /// Moves the volume so that its bounding box is centred on `centre`.
    pub fn with_centre(mut self, centre: Vec3) -> Self {
        let (lo, hi) = self.bounds();
        self.origin += centre - 0.5 * (lo + hi);
        self
    }

    /// Value of voxel (i, j, k); the caller keeps indices in range.
    #[inline]
    pub fn at(&self, i: usize, j: usize, k: usize) -> f32 {
        self.values[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// World-space bounding box (min corner, max corner) of the voxels' cells.
    /// The world position of the centre of voxel `index` (x fastest, then y, then z).
    pub fn centre(&self, index: usize) -> Vec3 {
        let [nx, ny, _] = self.dims;
        let c = Vec3::new(
            (index % nx) as f32,
            ((index / nx) % ny) as f32,
            (index / (nx * ny)) as f32,
        );
        self.origin + self.spacing * c
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        let d = Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        );
        (
            self.origin - 0.5 * self.spacing,
            self.origin + (d - 0.5) * self.spacing,
        )
    }

    /// Smallest and largest value.
    pub fn value_range(&self) -> (f32, f32) {
        self.values
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }

    /// Continuous index coordinates of a world position (voxel centres at integers).
    #[inline]
    pub fn to_index(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.spacing
    }

    /// Trilinear sample at a world position, clamped to the edge voxels outside the centres.
    #[inline]
    pub fn sample(&self, p: Vec3) -> f32 {
        self.sample_index(self.to_index(p))
    }

    /// Trilinear sample at continuous index coordinates, clamped to the edge voxels.
    #[inline]
    pub fn sample_index(&self, c: Vec3) -> f32 {
        let [nx, ny, nz] = self.dims;
        let max = Vec3::new((nx - 1) as f32, (ny - 1) as f32, (nz - 1) as f32);
        let c = c.clamp(Vec3::ZERO, max);
        // c >= 0, so truncation is the floor (and needs no libm call without SSE4.1).
        let (i0, j0, k0) = (c.x as usize, c.y as usize, c.z as usize);
        let f = c - Vec3::new(i0 as f32, j0 as f32, k0 as f32);
        let (i1, j1, k1) = (
            (i0 + 1).min(nx - 1),
            (j0 + 1).min(ny - 1),
            (k0 + 1).min(nz - 1),
        );
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let c00 = lerp(self.at(i0, j0, k0), self.at(i1, j0, k0), f.x);
        let c10 = lerp(self.at(i0, j1, k0), self.at(i1, j1, k0), f.x);
        let c01 = lerp(self.at(i0, j0, k1), self.at(i1, j0, k1), f.x);
        let c11 = lerp(self.at(i0, j1, k1), self.at(i1, j1, k1), f.x);
        lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z)
    }

    /// Gradient in world units (value per world unit) by central differences of trilinear
    /// samples one voxel spacing apart along each axis.
    #[inline]
    pub fn gradient(&self, p: Vec3) -> Vec3 {
        let c = self.to_index(p);
        let dx = self.sample_index(c + Vec3::X) - self.sample_index(c - Vec3::X);
        let dy = self.sample_index(c + Vec3::Y) - self.sample_index(c - Vec3::Y);
        let dz = self.sample_index(c + Vec3::Z) - self.sample_index(c - Vec3::Z);
        Vec3::new(dx, dy, dz) / (2.0 * self.spacing)
    }

    /// Largest gradient magnitude over the voxel centres (normalises 2D transfer functions and
    /// the gradient-shading threshold). Computed once; at a centre, `gradient`'s samples one
    /// voxel away are the neighbouring voxels (clamped at the faces), so it reads them directly.
    /// Differences and squared lengths are in f64: values near 1e30 (finite) have gradients whose square
    /// overflows f32, and an infinite maximum made 2D tables divide infinity by infinity.
    pub fn max_gradient_magnitude(&self) -> f32 {
        *self.max_gradient.get_or_init(|| {
            use rayon::prelude::*;
            let [nx, ny, nz] = self.dims;
            let inv = (0.5 / self.spacing).as_dvec3();
            (0..nz)
                .into_par_iter()
                .map(|k| {
                    let (k0, k1) = (k.saturating_sub(1), (k + 1).min(nz - 1));
                    let mut best = 0.0f64;
                    for j in 0..ny {
                        let (j0, j1) = (j.saturating_sub(1), (j + 1).min(ny - 1));
                        for i in 0..nx {
                            let (i0, i1) = (i.saturating_sub(1), (i + 1).min(nx - 1));
                            let d = |a: f32, b: f32| f64::from(a) - f64::from(b);
                            let g = glam::DVec3::new(
                                d(self.at(i1, j, k), self.at(i0, j, k)),
                                d(self.at(i, j1, k), self.at(i, j0, k)),
                                d(self.at(i, j, k1), self.at(i, j, k0)),
                            ) * inv;
                            best = best.max(g.length_squared());
                        }
                    }
                    best
                })
                .reduce(|| 0.0, f64::max)
                .sqrt()
                .min(f64::from(f32::MAX)) as f32
        })
    }

    /// Counts of values in `bins` equal-width bins over the value range.
    pub fn histogram(&self, bins: usize) -> Vec<u64> {
        let bins = bins.max(1);
        let (lo, hi) = self.value_range();
        let mut counts = vec![0u64; bins];
        let scale = if hi > lo {
            bins as f32 / (hi - lo)
        } else {
            0.0
        };
        for &v in &self.values {
            let b = (((v - lo) * scale) as usize).min(bins - 1);
            counts[b] += 1;
        }
        counts
    }
}

/// Number of voxels for `dims`, rejecting zero dims and overflow.
pub fn voxel_count(dims: [usize; 3]) -> Result<usize> {
    if dims.contains(&0) {
        return Err(Error::Volume(format!(
            "dims must be positive, got {}x{}x{}",
            dims[0], dims[1], dims[2]
        )));
    }
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| {
            Error::Volume(format!(
                "dims {}x{}x{} overflow the address space",
                dims[0], dims[1], dims[2]
            ))
        })
}

/// The smallest voxel, relative to the box's distance from the world's origin, that f32
/// positions still resolve: 8 of f32's steps (1.2e-7 each) per voxel.
const MIN_RELATIVE_SPACING: f32 = 1e-6;

/// The box [origin - spacing / 2, origin + (dims - 1/2) spacing] must be finite in f32, and
/// voxels wide enough that positions inside them are distinct (a header can claim spacings
/// of 1e38 or 1e-30).
fn check_box(dims: [usize; 3], spacing: Vec3, origin: Vec3) -> Result<()> {
    let d = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let (lo, hi) = (origin - 0.5 * spacing, origin + (d - 0.5) * spacing);
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(Error::Volume(format!(
            "the grid's box {lo} .. {hi} (origin {origin}, spacing {spacing}, dims {dims:?}) \
             overflows single-precision floats; rescale the spacing"
        )));
    }
    let reach = lo.abs().max(hi.abs()).max_element();
    if spacing.min_element() < MIN_RELATIVE_SPACING * reach {
        return Err(Error::Volume(format!(
            "voxels of spacing {spacing} are too small to place {reach:e} from the world's \
             origin in single precision (at least {:e} there); move the origin nearer or \
             rescale the spacing",
            MIN_RELATIVE_SPACING * reach
        )));
    }
    Ok(())
}

fn unflatten(dims: [usize; 3], index: usize) -> [usize; 3] {
    [
        index % dims[0],
        (index / dims[0]) % dims[1],
        index / (dims[0] * dims[1]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Volume {
        // v = 2x + 3y - z, linear, so trilinear sampling and central differences are exact.
        Volume::from_fn(
            [5, 6, 7],
            Vec3::new(0.5, 1.0, 2.0),
            Vec3::new(-1.0, 0.0, 1.0),
            |p| 2.0 * p.x + 3.0 * p.y - p.z,
        )
        .unwrap()
    }

    #[test]
    fn trilinear_reproduces_linear_fields() {
        let v = ramp();
        let p = Vec3::new(0.3, 2.7, 6.1);
        assert!((v.sample(p) - (2.0 * 0.3 + 3.0 * 2.7 - 6.1)).abs() < 1e-5);
        let g = v.gradient(p);
        assert!((g - Vec3::new(2.0, 3.0, -1.0)).length() < 1e-4, "{g}");
    }

    #[test]
    fn max_gradient_matches_the_sampled_gradient() {
        let v = Volume::from_fn([9, 7, 5], Vec3::new(0.5, 1.0, 2.0), Vec3::ZERO, |p| {
            (p.x * 1.3).sin() * p.y + p.z * p.z
        })
        .unwrap();
        let mut best = 0.0f32;
        for k in 0..5 {
            for j in 0..7 {
                for i in 0..9 {
                    let p = Vec3::new(i as f32 * 0.5, j as f32, k as f32 * 2.0);
                    best = best.max(v.gradient(p).length());
                }
            }
        }
        assert!(
            (v.max_gradient_magnitude() - best).abs() <= 1e-5 * best,
            "{best}"
        );
    }

    #[test]
    fn bounds_span_half_a_voxel_beyond_centres() {
        let v = ramp();
        let (lo, hi) = v.bounds();
        assert_eq!(lo, Vec3::new(-1.25, -0.5, 0.0));
        assert_eq!(hi, Vec3::new(-1.0 + 4.5 * 0.5, 5.5, 1.0 + 6.5 * 2.0));
    }

    #[test]
    fn rejects_bad_construction() {
        let bad = Volume::new([2, 2, 2], Vec3::ONE, Vec3::ZERO, vec![0.0; 7]);
        assert!(bad.unwrap_err().to_string().contains("need 8 values"));
        let zero = Volume::new([0, 2, 2], Vec3::ONE, Vec3::ZERO, vec![]);
        assert!(zero.unwrap_err().to_string().contains("positive"));
        let mut vals = vec![0.0; 8];
        vals[5] = f32::NAN;
        let nan = Volume::new([2, 2, 2], Vec3::ONE, Vec3::ZERO, vals);
        assert!(nan.unwrap_err().to_string().contains("[1, 0, 1]"));
        let sp = Volume::new(
            [2, 2, 2],
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::ZERO,
            vec![0.0; 8],
        );
        assert!(sp.unwrap_err().to_string().contains("spacing"));
    }
}
