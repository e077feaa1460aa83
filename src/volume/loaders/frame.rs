//! From a header's index-to-world frame (a NIfTI affine, NRRD `space directions`) to the
//! world-aligned grid a [`Volume`](crate::volume::Volume) is.
//!
//! A frame maps stored index i to world `origin + sum_a i_a steps[a]`. Scanners write three
//! kinds:
//! - a signed permutation of the world axes (axis-aligned, possibly flipped or in another axis
//!   order, e.g. an ARS or LPI scan): the values are reordered exactly, without interpolation,
//!   so that every voxel keeps its world position;
//! - an oblique frame (a tilted MRI slab): the values are resampled trilinearly onto a
//!   world-aligned grid over the frame's bounding box, each world axis as fine as the stored
//!   axis nearest to it; outside the stored grid the grid takes the data's lowest value (air in
//!   a CT, background in an MRI). `occlux info` states the rotation;
//! - degenerate ones (parallel or zero-length axes): refused by name.

use crate::error::{Error, Result};
use crate::volume::Volume;
use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;
use std::fmt;
use std::path::Path;

/// Largest sine between a stored axis and its world axis for which the frame counts as
/// axis-aligned (0.006 degrees: across 1000 voxels the positions move by a tenth of a voxel).
/// Scanners write rounding noise of about 1e-7 into aligned frames.
const ALIGNED_SINE: f64 = 1e-4;

/// How a file's grid was brought into the world frame, for reporting (`occlux info`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Frame {
    /// Stored axis a is world axis `axes[a]`, reversed where `flip[a]` (the identity: stored
    /// as it is in the world).
    Reordered { axes: [usize; 3], flip: [bool; 3] },
    /// An oblique frame resampled onto a world-aligned grid; `degrees`: the largest angle
    /// between a stored axis and the world axis it was matched to.
    Resampled { degrees: f64 },
}

impl Frame {
    /// The identity: stored axes are the world's.
    pub const ALIGNED: Frame = Frame::Reordered {
        axes: [0, 1, 2],
        flip: [false; 3],
    };
}

impl fmt::Display for Frame {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match *self {
            Frame::Reordered { .. } if *self == Frame::ALIGNED => {
                write!(f, "world-aligned as stored")
            }
            Frame::Reordered { axes, flip } => {
                let names: Vec<String> = (0..3)
                    .map(|a| {
                        format!(
                            "{}{}",
                            if flip[a] { "-" } else { "+" },
                            ["x", "y", "z"][axes[a]]
                        )
                    })
                    .collect();
                write!(
                    f,
                    "stored axes i, j, k run along world {}: reordered exactly",
                    names.join(", ")
                )
            }
            Frame::Resampled { degrees } => write!(
                f,
                "oblique (rotated {degrees:.2} degrees from the world axes): resampled \
                 trilinearly onto a world-aligned grid"
            ),
        }
    }
}

/// Where a grid sits in world space, and what its values need to get there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Placement {
    /// Spacing of the world-aligned grid.
    pub spacing: Vec3,
    /// World position of the world-aligned grid's voxel (0, 0, 0).
    pub origin: Vec3,
    transform: Transform,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Transform {
    Reorder {
        axes: [usize; 3],
        flip: [bool; 3],
    },
    Resample {
        /// The stored frame: world steps of the index axes and the world position of stored
        /// voxel (0, 0, 0).
        steps: [[f64; 3]; 3],
        origin: [f64; 3],
        /// Voxels of the world-aligned grid.
        dims: [usize; 3],
        degrees: f64,
    },
}

impl Placement {
    /// An axis-aligned grid with the data in stored order; `spacing` is already validated.
    pub fn grid(spacing: Vec3, origin: Vec3) -> Self {
        Self {
            spacing,
            origin,
            transform: Transform::Reorder {
                axes: [0, 1, 2],
                flip: [false; 3],
            },
        }
    }

    /// Placement from an index-to-world frame: `steps[a]` is the world step of index axis `a`
    /// (a column of the affine matrix) and `origin` the world position of voxel (0, 0, 0) of
    /// a grid of `dims`. `field` names the header field for messages.
    pub fn from_frame(
        path: &Path,
        field: &str,
        steps: [[f64; 3]; 3],
        origin: [f64; 3],
        dims: [usize; 3],
    ) -> Result<Self> {
        if origin.iter().any(|o| !o.is_finite()) {
            return Err(Error::format(
                path,
                format!("{field}: origin {origin:?} is not finite"),
            ));
        }
        let mut lengths = [0.0f64; 3];
        for (a, step) in steps.iter().enumerate() {
            let length = step.iter().map(|s| s * s).sum::<f64>().sqrt();
            if !(length.is_finite() && length > 0.0) {
                return Err(Error::format(
                    path,
                    format!(
                        "{field}: axis {a} step {step:?} must be finite and of non-zero length"
                    ),
                ));
            }
            lengths[a] = length;
        }
        let units = [0, 1, 2].map(|a| steps[a].map(|s| s / lengths[a]));
        if DMat3::from_cols_array_2d(&units).determinant().abs() < 1e-6 {
            return Err(Error::format(
                path,
                format!(
                    "{field}: the axis steps {steps:?} do not span space (two axes are \
                     parallel), so the grid has no 3D placement"
                ),
            ));
        }
        let axes = match_axes(&units);
        let world_of = |a: usize| axes[a];
        let sine = |a: usize| (1.0 - units[a][world_of(a)].powi(2)).max(0.0).sqrt();
        let aligned = (0..3).all(|a| sine(a) <= ALIGNED_SINE);
        let mut spacing = Vec3::ZERO;
        for a in 0..3 {
            spacing[axes[a]] = lengths[a] as f32;
        }
        let corner = |index: [usize; 3]| -> [f64; 3] {
            let mut p = origin;
            for a in 0..3 {
                for (w, coordinate) in p.iter_mut().enumerate() {
                    *coordinate += index[a] as f64 * steps[a][w];
                }
            }
            p
        };
        let last = dims.map(|d| d.saturating_sub(1));
        if aligned {
            let flip = [0, 1, 2].map(|a| units[a][axes[a]] < 0.0);
            // The new voxel (0, 0, 0) is the stored voxel at the low end of every world axis.
            let first = [0, 1, 2].map(|a| if flip[a] { last[a] } else { 0 });
            let p = corner(first);
            return Ok(Self {
                spacing,
                origin: Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32),
                transform: Transform::Reorder { axes, flip },
            });
        }
        let degrees = (0..3)
            .map(|a| sine(a).asin().to_degrees())
            .fold(0.0, f64::max);
        // The bounding box of the stored voxel centres, covered by the world-aligned grid
        // centred on it.
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for c in 0..8 {
            let index = [0, 1, 2].map(|a| if c >> a & 1 == 1 { last[a] } else { 0 });
            let p = corner(index);
            for w in 0..3 {
                lo[w] = lo[w].min(p[w]);
                hi[w] = hi[w].max(p[w]);
            }
        }
        let mut new_dims = [0usize; 3];
        let mut new_origin = Vec3::ZERO;
        for w in 0..3 {
            let t = spacing[w] as f64;
            let n = ((hi[w] - lo[w]) / t - 1e-9).ceil().max(0.0) + 1.0;
            if n > u32::MAX as f64 {
                return Err(Error::format(
                    path,
                    format!("{field}: the oblique frame spans {n} voxels along world axis {w}"),
                ));
            }
            new_dims[w] = n as usize;
            new_origin[w] = (0.5 * (lo[w] + hi[w]) - 0.5 * (n - 1.0) * t) as f32;
        }
        Ok(Self {
            spacing,
            origin: new_origin,
            transform: Transform::Resample {
                steps,
                origin,
                dims: new_dims,
                degrees,
            },
        })
    }

    /// What was done to the frame.
    pub fn frame(&self) -> Frame {
        match self.transform {
            Transform::Reorder { axes, flip } => Frame::Reordered { axes, flip },
            Transform::Resample { degrees, .. } => Frame::Resampled { degrees },
        }
    }

    /// Voxels of the world-aligned grid for stored `dims`.
    pub fn world_dims(&self, dims: [usize; 3]) -> [usize; 3] {
        match self.transform {
            Transform::Reorder { axes, .. } => {
                let mut out = [0; 3];
                for a in 0..3 {
                    out[axes[a]] = dims[a];
                }
                out
            }
            Transform::Resample { dims, .. } => dims,
        }
    }

    /// The stored values (x fastest) as the world-aligned grid's.
    pub fn apply(&self, dims: [usize; 3], values: Vec<f32>) -> Vec<f32> {
        if dims.contains(&0) {
            return values; // Volume::new reports the bad dims
        }
        match self.transform {
            Transform::Reorder {
                axes: [0, 1, 2],
                flip,
            } => {
                let mut values = values;
                flip_axes(&mut values, dims, flip);
                values
            }
            Transform::Reorder { axes, flip } => reorder(&values, dims, axes, flip),
            Transform::Resample {
                steps,
                origin,
                dims: out,
                ..
            } => resample(values, dims, steps, origin, out, self.origin, self.spacing),
        }
    }
}

/// Matches each stored axis to a distinct world axis: repeatedly the largest remaining
/// component |units[a][w]| of an unmatched pair.
fn match_axes(units: &[[f64; 3]; 3]) -> [usize; 3] {
    let mut axes = [usize::MAX; 3];
    let mut used = [false; 3];
    for _ in 0..3 {
        let mut best = (0.0f64, 0, 0);
        for (a, unit) in units.iter().enumerate() {
            for (w, component) in unit.iter().enumerate() {
                if axes[a] == usize::MAX && !used[w] && component.abs() >= best.0 {
                    best = (component.abs(), a, w);
                }
            }
        }
        axes[best.1] = best.2;
        used[best.2] = true;
    }
    axes
}

/// Values of a signed permutation: the new grid's voxel with world index n holds the stored
/// voxel with i_a = n[axes[a]] (reversed where `flip[a]`).
fn reorder(values: &[f32], dims: [usize; 3], axes: [usize; 3], flip: [bool; 3]) -> Vec<f32> {
    let mut out_dims = [0; 3];
    for a in 0..3 {
        out_dims[axes[a]] = dims[a];
    }
    let stride = [1, dims[0], dims[0] * dims[1]];
    let [nx, ny, _] = out_dims;
    let mut out = vec![0.0f32; values.len()];
    out.par_chunks_exact_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            for (p, value) in slab.iter_mut().enumerate() {
                let n = [p % nx, p / nx, k];
                let stored: usize = (0..3)
                    .map(|a| {
                        let i = n[axes[a]];
                        stride[a] * if flip[a] { dims[a] - 1 - i } else { i }
                    })
                    .sum();
                *value = values[stored];
            }
        });
    out
}

/// Trilinear samples of the stored grid (as [`Volume::sample_index`] takes them, clamped to
/// the outer centres) at the centres of the world-aligned grid of `out` voxels (`origin`,
/// `spacing`); outside the stored grid's box, its lowest value.
fn resample(
    values: Vec<f32>,
    dims: [usize; 3],
    steps: [[f64; 3]; 3],
    stored_origin: [f64; 3],
    out: [usize; 3],
    origin: Vec3,
    spacing: Vec3,
) -> Vec<f32> {
    let inverse = DMat3::from_cols_array_2d(&steps).inverse();
    let stored_origin = DVec3::from_array(stored_origin);
    // The stored grid in its own index frame; its values are finite (the non-finite policy
    // ran), so only a malformed size could fail, and `finish` reports those.
    let Ok(stored) = Volume::new(dims, Vec3::ONE, Vec3::ZERO, values) else {
        return Vec::new();
    };
    let fill = stored.value_range().0;
    let last = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) - 0.5;
    let [nx, ny, _] = out;
    let mut result = vec![0.0f32; out[0] * out[1] * out[2]];
    result
        .par_chunks_exact_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            for (p, value) in slab.iter_mut().enumerate() {
                let n = Vec3::new((p % nx) as f32, (p / nx) as f32, k as f32);
                let world = (origin + n * spacing).as_dvec3();
                let index = inverse * (world - stored_origin);
                // The stored grid's box reaches half a voxel beyond its outer centres.
                let inside = index.cmpge(DVec3::splat(-0.5)).all() && index.cmple(last).all();
                *value = if inside {
                    stored.sample_index(index.as_vec3())
                } else {
                    fill
                };
            }
        });
    result
}

/// Reverses the data along each flagged axis (x fastest).
fn flip_axes(values: &mut [f32], dims: [usize; 3], flip: [bool; 3]) {
    let [nx, ny, _] = dims;
    if flip[0] {
        values
            .par_chunks_exact_mut(nx)
            .for_each(|row| row.reverse());
    }
    if flip[1] {
        values
            .par_chunks_exact_mut(nx * ny)
            .for_each(|slab| reverse_blocks(slab, nx));
    }
    if flip[2] {
        reverse_blocks(values, nx * ny);
    }
}

/// Reverses the order of the `block`-sized pieces of `data`, keeping each piece intact.
fn reverse_blocks(data: &mut [f32], block: usize) {
    let count = data.len() / block;
    for b in 0..count / 2 {
        let (low, high) = data.split_at_mut((count - 1 - b) * block);
        low[b * block..(b + 1) * block].swap_with_slice(&mut high[..block]);
    }
}
