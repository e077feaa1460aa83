//! Directional occlusion shading (Schott, Pegoraro, Hansen, Boulanger, Bouatouch 2009), slice
//! based: `cpu` and `gpu` are twins that produce the same image.
//!
//! The light is ambient radiance L_a arriving inside a cone of half-angle theta around the
//! direction towards the viewer (the paper's cone phase function; the Monte Carlo `Cone`
//! reference estimates the same integral without the approximations below).
//!
//! Slices are planes perpendicular to the camera's forward axis, `d` apart in depth, from the
//! nearest point of the volume's box (or the camera, when it is inside) to the farthest. Slab
//! k lies between slices k and k + 1. Every pixel's ray is clipped to the box and to the slab;
//! the slab is sampled at the clipped segment's midpoint (one material sample per pixel and
//! slab, classified as the ray caster does, with clipping planes removing material).
//!
//! With `Formulation::Rays` (the ray-casting formulation) slab k is instead the k-th step of
//! length d along every ray, marched in lock step from the volume's nearest distance to the
//! camera: spherical shells around a perspective camera, the same planes for an orthographic
//! one (so there both formulations give the same image). The cone base's pixel radius then
//! uses the previous step's mid-distance in place of its depth.
//!
//! Two image-sized buffers run through the slabs front to back:
//! - the occlusion buffer: with `V_k` the fraction of the cone's light that reaches slab k
//!   (`V_0 = 1`) and `tau_k = sigma_t * f` the slab's extinction times the fraction `f` of its
//!   depth inside the box, it holds per pixel the light that slab k - 1 passes on,
//!   `W(l) = V_{k-1} exp(-tau_{k-1} l)`, for each path length l a cone sample can take. Then
//!   (the paper's Algorithm 2) `V_k(x) = 1/n^2 sum_s W(l_s)(x + q_s)` over n x n samples q_s
//!   on the cone's base on slab k - 1 (world offsets: "Sampling the cone", below),
//!   converted to pixels at that slab's depth, which corrects the base for perspective
//!   (Eq. 12-15: a world length w at depth z covers `w * width / (2 z tan(fov_x / 2))` pixels).
//!   `l_s` is the exact distance `sqrt(d^2 + |q_s|^2)` or, approximated (Algorithm 3), `d` for
//!   every sample. The buffer is read bilinearly and clamped to its edges. The grid's samples
//!   lie on ceil(n/2) rings (below), so the exact distance takes that many values, and the
//!   buffer holds one plane per value: exponentials per pixel and slab are that many, not n^2.
//! - the eye buffer composites each slab front to back: with alpha = 1 - exp(-sigma_t dt) for
//!   the clipped segment length dt, `L += T (alpha albedo L_a V_k + emission)` (albedo is
//!   sigma_s / sigma_t, so `alpha albedo` is the paper's `sigma_s alpha` per unit extinction),
//!   `T *= 1 - alpha`; the background adds `T L_b` at the end. With `self_occlusion` (not in
//!   the paper) the light is also attenuated through the half of the pixel's own segment in
//!   front of its sample, `V_k exp(-sigma_t dt / 2)`, as the light reaching the sample point;
//!   measured against the cone reference at 96^2 (theta 30, n 5) it cut the dense engine's
//!   relative RMSE from 0.139 to 0.082 (bias +12 % to +4 %). Depth is where T falls through
//!   0.5 (as the ray caster finds it). The `occlusion` layer ([`crate::render::Factor`]) sums
//!   each sample's lit fraction of the ambient light (`V_k`, or with self-occlusion the light
//!   after the front half of its segment) with the sample's contribution weight
//!   `T alpha`: P = sum T alpha V, beside its coverage A = 1 - T at the end. So P = A where
//!   nothing occludes (every sample with V = 1), P = 0 where the ray meets nothing, and with a
//!   grey albedo and no emission the lit image is `L_a albedo P` plus the background.
//!
//! Sampling the cone: the n x n grid covers the unit disc through the concentric (Shirley-Chiu)
//! map of the grid's cell centres, so every sample carries the same area of the disc; cell
//! (i, j) lands on the ring of radius rho = max(|2i + 1 - n|, |2j + 1 - n|) / n. From there:
//! - `sampling = "solid-angle"` (the default): the sample looks along the direction at angle
//!   phi from the view axis with cos(phi) = 1 - rho^2 (1 - cos(theta)), and lands
//!   `d tan(phi)` from the pixel. The map takes equal areas of the disc to equal solid angles
//!   of the cone (both grow as rho^2), so every sample stands for the same share of the cone
//!   phase function's light, as the `Cone` reference weighs it; the path is `d / cos(phi)`.
//!   As theta nears 90 degrees every sample stays within `d tan(phi)` of its pixel (n = 5:
//!   at most 2.6 d, n = 32: 16 d), so the image settles instead of blowing up.
//! - `sampling = "area"` (the paper): the base is a disc of radius `d tan(theta)`, the sample
//!   lands `rho d tan(theta)` away. Grazing directions then weigh far more than their solid
//!   angle, and at wide cones most samples land far beyond the volume.
//!
//! Measured on the 48^3 CT phantom at 48^2 (n 5) against the cone reference (512 spp, noise
//! 0.034), relative RMSE solid-angle / area: theta 30 0.047 / 0.046, 50 0.043 / 0.040,
//! 70 0.046 / 0.128, 80 0.073 / 0.276, 85 0.099 / 0.354, 89.9 0.128 / 0.677; against the
//! ambient reference (the whole sky) the best is 0.061 (solid-angle, theta 80) against 0.077
//! (area, theta 70). The mean occlusion falls monotonically with theta with solid-angle
//! sampling (0.659 at 30 to 0.529 at 89.99), while with area sampling it fell to 0.47 at 80,
//! then rose to 1.0 by 89.9 (tests/dos.rs, tests/dos_accuracy.rs).
//!
//! Limits (documented behaviour):
//! - theta = 0 is the line towards the viewer: V is the transmittance back along the view axis.
//!   With area sampling tan(theta) is capped at [`MAX_TAN_THETA`] (theta ~ 89.994 degrees),
//!   and the base's pixel radius at [`MAX_RADIUS_PX`]: past them every sample off the centre
//!   lands beyond the buffers and clamping to their edges decides, as without the caps.
//! - material outside the view still occludes: the buffers cover the image and a guard band
//!   as wide as the volume box's projection reaches beyond it ([`guard_band`]: 0 when the box
//!   is in view, at most half the image's larger side, the most when the box reaches behind a
//!   perspective camera), traced like the image's pixels; samples beyond the band read its
//!   edge. Cropping a view at x = 0 of a floor shaded by a wall just outside it kept 98 % of
//!   the wall's occlusion next to the cut (tests/dos.rs), where reading the image's edge lost
//!   all of it. The band costs nothing for a framed volume and at most 4x the pixels.
//! - a camera inside the volume starts the slices at depth 0; the base's pixel radius uses the
//!   previous slab's mid-depth, at least d / 2, so it stays finite.
//! - an opaque slab (sigma_t d overflowing to infinity) passes on exp(-inf) = 0: no light.
//! - the slice count is capped at [`MAX_SLICES`] (a clear error names `render.slice_distance`).
//! - only ambient lights light DOS; other lights are an error naming them.

pub mod cpu;
pub mod gpu;
mod method;

use crate::camera::{box_corners, Camera, Projection};
use crate::classify::{Lut, Optical};
use crate::error::{Error, Result};
use crate::lights::Lighting;
use crate::method::RenderMethod;
use crate::volume::Volume;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// How a cone sample's path through the previous slab is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ConeDistance {
    /// sqrt(d^2 + |q|^2): the slanted path (the paper's Algorithm 2).
    #[default]
    Exact,
    /// d for every sample (Algorithm 3).
    Approximate,
}

/// How the n x n samples spread over the cone's base.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ConeSampling {
    /// Each sample stands for an equal solid angle of the cone, as the cone phase function
    /// weighs directions: the sample at radius rho of the unit disc looks along
    /// cos(phi) = 1 - rho^2 (1 - cos(theta)), and lands d tan(phi) from the pixel.
    #[default]
    SolidAngle,
    /// Each sample stands for an equal area of the base, a disc of radius d tan(theta) (the
    /// paper): grazing directions weigh far more than their solid angle as theta grows.
    Area,
}

/// How the volume is cut into slabs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Formulation {
    /// View-aligned planes d apart in depth (the paper's slice-based algorithm).
    #[default]
    Slices,
    /// Lock-step ray marching: steps of length d along every ray.
    Rays,
}

/// A clipping plane: material on the side the normal points to is removed, for the eye and
/// for the occlusion (clipped material casts no occlusion).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipPlane {
    pub point: Vec3,
    /// Unit normal, pointing into the removed half-space.
    pub normal: Vec3,
}

impl ClipPlane {
    /// Whether `p` is removed.
    #[inline]
    pub fn clips(&self, p: Vec3) -> bool {
        (p - self.point).dot(self.normal) > 0.0
    }
}

/// Parameters of DOS: `method = "dos"` in a scene, one key per field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DosParams {
    /// Cone half-angle in degrees, in [0, 90).
    pub theta_deg: f32,
    /// n: the cone base is sampled on an n x n grid, n in 1..=[`MAX_GRID`].
    pub grid: u32,
    /// Distance between slices in world units; None: the smallest voxel spacing.
    pub slice_distance: Option<f32>,
    /// Exact or approximated path lengths of the cone samples.
    pub distance: ConeDistance,
    /// Samples of equal solid angle or of equal area on the cone's base.
    pub sampling: ConeSampling,
    /// View-aligned slices or lock-step rays.
    pub formulation: Formulation,
    /// Attenuate each sample's light through the front half of its own segment (off: the
    /// paper's algorithm, lit by the previous slab's buffer alone).
    pub self_occlusion: bool,
    /// At most [`MAX_CLIP_PLANES`].
    pub clip_planes: Vec<ClipPlane>,
}

impl Default for DosParams {
    fn default() -> Self {
        Self {
            theta_deg: 50.0,
            grid: 5,
            slice_distance: None,
            distance: ConeDistance::Exact,
            sampling: ConeSampling::SolidAngle,
            formulation: Formulation::Slices,
            self_occlusion: false,
            clip_planes: Vec::new(),
        }
    }
}

/// Largest grid side n (n^2 samples per pixel and slice).
pub const MAX_GRID: u32 = 32;
/// Most clipping planes (the GPU keeps them in a fixed uniform array).
pub const MAX_CLIP_PLANES: usize = 6;
/// Most slices a render may take.
pub const MAX_SLICES: f32 = 1.0e5;
/// Cap on tan(theta), so that theta near 90 degrees keeps every length finite.
pub const MAX_TAN_THETA: f32 = 1.0e4;
/// Cap on the cone base's radius in pixels: times the smallest non-zero ring radius (1/32) it
/// still exceeds twice the largest image side, so the cap changes no sample's clamped position.
pub const MAX_RADIUS_PX: f32 = 2_097_152.0;

impl DosParams {
    /// Checks every parameter against the ranges of the registry's `dos` entry.
    pub fn validate(&self) -> Result<()> {
        method::THETA_DEG.check(self.theta_deg as f64)?;
        method::GRID.check(self.grid as f64)?;
        method::SLICE_DISTANCE.check_optional(self.slice_distance)?;
        if self.clip_planes.len() > MAX_CLIP_PLANES {
            return Err(method::CLIP_PLANES.error(format!(
                "at most {MAX_CLIP_PLANES} planes, got {}",
                self.clip_planes.len()
            )));
        }
        for (i, plane) in self.clip_planes.iter().enumerate() {
            if !plane.point.is_finite() || !plane.normal.is_normalized() {
                return Err(Error::param(
                    format!("render.clip_planes[{i}]"),
                    "needs a finite point and a unit normal",
                ));
            }
        }
        Ok(())
    }

    /// tan(theta), capped at [`MAX_TAN_THETA`]; computed in f64 so that theta just below 90
    /// degrees does not round past pi/2 (where f32's tan turns negative).
    pub fn tan_theta(&self) -> f32 {
        (self.theta_deg as f64)
            .to_radians()
            .tan()
            .min(MAX_TAN_THETA as f64) as f32
    }
}

/// What DOS reads.
#[derive(Clone, Copy)]
pub struct DosInput<'a> {
    pub volume: &'a Volume,
    pub lut: &'a Lut,
    pub camera: &'a Camera,
    pub lighting: &'a Lighting,
    pub params: &'a DosParams,
}

/// Values derived once per render and shared by both twins.
#[derive(Clone, Debug, PartialEq)]
pub struct DosSetup {
    /// The buffers' camera: the view widened by `band` pixels on every side, at the same pixel
    /// pitch, so that its pixel (i + band, j + band) is the view's pixel (i, j).
    pub camera: Camera,
    /// The guard band's width in pixels ([`guard_band`]).
    pub band: u32,
    /// d, world units.
    pub slice_distance: f32,
    /// Depth (along the camera's forward axis) of slice 0; for `Formulation::Rays`, its
    /// distance along the rays.
    pub first_depth: f32,
    /// Number of slabs (0 when the volume lies behind the camera).
    pub slabs: u32,
    /// The unit of the offsets on the previous slab, world units: d tan(theta) for area
    /// sampling, d tan(phi) of the outermost ring for solid-angle sampling ([`ConeGrid`]).
    pub base_radius: f32,
    /// Pixels per world unit at depth 1 (perspective) or anywhere (orthographic).
    pub pixels_per_unit: f32,
    /// The n x n samples within the unit disc, in units of `base_radius`.
    pub offsets: Vec<Vec2>,
    /// Each sample's index into `ring_lengths`.
    pub sample_ring: Vec<u32>,
    /// The path lengths through the previous slab that samples take (one per ring for the
    /// exact distance, d alone for the approximated one): the occlusion buffer's planes.
    pub ring_lengths: Vec<f32>,
    /// Total ambient radiance L_a.
    pub ambient: Vec3,
}

impl DosInput<'_> {
    /// Validates the inputs and derives the per-render values.
    pub fn setup(&self) -> Result<DosSetup> {
        self.params.validate()?;
        self.lighting.validate()?;
        <DosParams as RenderMethod>::SPEC.check_lights(self.lighting)?;
        let d = self
            .params
            .slice_distance
            .unwrap_or(self.volume.spacing().min_element());
        let cam = self.camera;
        let (lo, hi) = self.volume.bounds();
        let corners = box_corners(lo, hi).map(|c| c - cam.position).into_iter();
        let (near, far) = if self.params.formulation == Formulation::Rays && cam.is_perspective() {
            // Distances along rays from the eye: the box's nearest point, its farthest corner.
            let nearest = (cam.position.clamp(lo, hi) - cam.position).length();
            (nearest, corners.map(Vec3::length).fold(0.0, f32::max))
        } else {
            corners
                .map(|c| c.dot(cam.forward))
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), z| {
                    (a.min(z), b.max(z))
                })
        };
        let first_depth = near.max(0.0);
        let count = ((far - first_depth) / d).ceil().max(0.0);
        if count > MAX_SLICES {
            return Err(Error::param(
                "render.slice_distance",
                format!("{d} would take over {MAX_SLICES} slices through the volume"),
            ));
        }
        let band = guard_band(cam, lo, hi);
        let camera = widened(cam, band)?;
        let (hx, _) = camera.half_extent();
        let n = self.params.grid;
        let cone = ConeGrid::new(self.params);
        let base_radius = d * cone.unit_tan;
        let (ring_lengths, sample_ring) = match self.params.distance {
            ConeDistance::Exact => {
                let lengths = cone
                    .ring_tan
                    .iter()
                    .map(|t| {
                        let r = d * t;
                        (d * d + r * r).sqrt()
                    })
                    .collect();
                (lengths, disc_rings(n))
            }
            ConeDistance::Approximate => (vec![d], vec![0; (n * n) as usize]),
        };
        Ok(DosSetup {
            pixels_per_unit: camera.width as f32 / (2.0 * hx),
            camera,
            band,
            slice_distance: d,
            first_depth,
            slabs: count as u32,
            base_radius,
            offsets: cone.offsets,
            sample_ring,
            ring_lengths,
            ambient: self.lighting.ambient(),
        })
    }
}

impl DosSetup {
    /// The cone base's radius in pixels on slab `k - 1`, seen from slab k (k >= 1).
    #[inline]
    pub fn base_radius_px(&self, camera: &Camera, k: u32) -> f32 {
        let scale = if camera.is_perspective() {
            // Mid-depth of slab k - 1: at least d / 2 even when slicing starts at the camera.
            self.first_depth + (k as f32 - 0.5) * self.slice_distance
        } else {
            1.0
        };
        (self.base_radius * self.pixels_per_unit / scale).min(MAX_RADIUS_PX)
    }

    /// Planes of the occlusion buffer.
    pub fn planes(&self) -> usize {
        self.ring_lengths.len()
    }
}

/// Widest guard band, as a fraction of the image's larger side: the buffers hold at most
/// (1 + 2 * 0.5)^2 = 4 times the image's pixels.
pub const MAX_BAND_FRACTION: f32 = 0.5;

/// Pixels the occlusion buffers reach beyond each side of the image so that material outside
/// the view still occludes what is in it: as far as the volume box's projection reaches out
/// of the image (0 when the box is in view), at most [`MAX_BAND_FRACTION`] of the larger
/// side, and that much when the box reaches behind a perspective camera's image plane.
pub fn guard_band(camera: &Camera, lo: Vec3, hi: Vec3) -> u32 {
    let cap = (MAX_BAND_FRACTION * camera.width.max(camera.height) as f32).floor();
    let (hx, hy) = camera.half_extent();
    let (w, h) = (camera.width as f32, camera.height as f32);
    let mut reach = 0.0f32;
    for corner in box_corners(lo, hi).map(|c| c - camera.position) {
        let (x, y) = if camera.is_perspective() {
            let z = corner.dot(camera.forward);
            if z <= 1e-6 * corner.length() {
                return cap as u32;
            }
            (corner.dot(camera.right) / z, corner.dot(camera.up) / z)
        } else {
            (corner.dot(camera.right), corner.dot(camera.up))
        };
        // Pixels beyond the image's edge: |x| / hx of the half width, less the half width.
        reach = reach
            .max((x.abs() / hx - 1.0) * 0.5 * w)
            .max((y.abs() / hy - 1.0) * 0.5 * h);
    }
    if reach.is_finite() {
        reach.max(0.0).ceil().min(cap) as u32
    } else {
        cap as u32
    }
}

/// `camera` with `band` more pixels on every side at the same pixel pitch.
pub fn widened(camera: &Camera, band: u32) -> Result<Camera> {
    let (width, height) = (camera.width + 2 * band, camera.height + 2 * band);
    let projection = match camera.projection {
        Projection::Perspective { .. } => {
            let (_, hy) = camera.half_extent();
            Projection::Perspective {
                fov_y: 2.0 * (hy * height as f32 / camera.height as f32).atan(),
            }
        }
        // The scale spans the larger side, which stays the larger one.
        Projection::Orthographic { scale } => Projection::Orthographic {
            scale: scale * width.max(height) as f32 / camera.width.max(camera.height) as f32,
        },
    };
    if width > crate::camera::MAX_IMAGE_SIDE || height > crate::camera::MAX_IMAGE_SIDE {
        return Err(Error::param(
            "camera.width",
            format!(
                "{width} x {height} with the occlusion buffers' guard band is over {} pixels \
                 a side",
                crate::camera::MAX_IMAGE_SIDE
            ),
        ));
    }
    Ok(Camera {
        projection,
        width,
        height,
        ..*camera
    })
}

/// The n x n samples of the cone's base as directions seen from a pixel: each offset times
/// `d unit_tan` is where the sample lands on the previous slab.
#[derive(Clone, Debug, PartialEq)]
pub struct ConeGrid {
    /// In [`disc_grid`]'s order, within the unit disc.
    pub offsets: Vec<Vec2>,
    /// tan(phi) of each ring's direction ([`disc_rings`]'s rings).
    pub ring_tan: Vec<f32>,
    /// The tangent the offsets are in units of: tan(theta) for area sampling, the outermost
    /// ring's tan(phi) for solid-angle sampling (0 when every sample looks along the axis).
    pub unit_tan: f32,
}

impl ConeGrid {
    pub fn new(params: &DosParams) -> Self {
        let n = params.grid;
        let disc = disc_grid(n);
        let rings: Vec<f64> = (0..n.div_ceil(2))
            .map(|m| ring_radius(n, m) as f64)
            .collect();
        match params.sampling {
            ConeSampling::Area => {
                let tan = params.tan_theta();
                ConeGrid {
                    offsets: disc,
                    ring_tan: rings.iter().map(|r| (r * tan as f64) as f32).collect(),
                    unit_tan: tan,
                }
            }
            ConeSampling::SolidAngle => {
                // 1 - cos(theta) = 2 sin^2(theta / 2), exact near theta = 0.
                let spread = 2.0 * (0.5 * (params.theta_deg as f64).to_radians()).sin().powi(2);
                let tan_at = |rho: f64| {
                    let u = 1.0 - rho * rho * spread;
                    (1.0 - u * u).max(0.0).sqrt() / u
                };
                let ring_tan: Vec<f64> = rings.iter().map(|&r| tan_at(r)).collect();
                let unit = ring_tan.iter().copied().fold(0.0, f64::max);
                let offsets = disc
                    .iter()
                    .map(|q| {
                        let rho = q.length() as f64;
                        if rho == 0.0 || unit == 0.0 {
                            Vec2::ZERO
                        } else {
                            *q * (tan_at(rho) / (rho * unit)) as f32
                        }
                    })
                    .collect();
                ConeGrid {
                    offsets,
                    ring_tan: ring_tan.iter().map(|&t| t as f32).collect(),
                    unit_tan: unit as f32,
                }
            }
        }
    }
}

/// The ring of each cell of the n x n grid (as [`disc_grid`] orders them): ring m has radius
/// [`ring_radius`]`(n, m)`.
pub fn disc_rings(n: u32) -> Vec<u32> {
    let half = |i: u32| (2 * i + 1).abs_diff(n) / 2;
    (0..n)
        .flat_map(|j| (0..n).map(move |i| half(i).max(half(j))))
        .collect()
}

/// Radius of ring m of the n x n grid on the unit disc: max(|2i + 1 - n|, |2j + 1 - n|) / n,
/// where that maximum is 2m + 1 for even n and 2m for odd n.
pub fn ring_radius(n: u32, m: u32) -> f32 {
    (2 * m + 1 - n % 2) as f32 / n as f32
}

/// The n x n grid's cell centres mapped onto the unit disc by the concentric map
/// (Shirley and Chiu 1997), which keeps equal areas: each sample stands for 1/n^2 of the disc.
pub fn disc_grid(n: u32) -> Vec<Vec2> {
    let mut out = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = 2.0 * (i as f32 + 0.5) / n as f32 - 1.0;
            let b = 2.0 * (j as f32 + 0.5) / n as f32 - 1.0;
            let q = if a == 0.0 && b == 0.0 {
                Vec2::ZERO
            } else if a.abs() > b.abs() {
                let phi = std::f32::consts::FRAC_PI_4 * b / a;
                a * Vec2::new(phi.cos(), phi.sin())
            } else {
                let phi = std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * a / b;
                b * Vec2::new(phi.cos(), phi.sin())
            };
            out.push(q);
        }
    }
    out
}

/// Optical properties at `p`, with clipped material removed (extinction and emission zero).
#[inline]
pub fn material(volume: &Volume, lut: &Lut, clip_planes: &[ClipPlane], p: Vec3) -> Optical {
    if clip_planes.iter().any(|c| c.clips(p)) {
        return Optical::default();
    }
    let g = if lut.gradient_max().is_some() {
        volume.gradient(p).length()
    } else {
        0.0
    };
    lut.lookup(volume.sample(p), g)
}

/// The finished image of the input camera's view from the eye buffer of the buffers' camera
/// (`band` pixels wider on every side): per pixel (radiance, transmittance) and (depth, the
/// occlusion layer's P), with the background seen through the remaining transmittance.
pub fn finish(
    input: &DosInput,
    band: u32,
    eye: &[[f32; 4]],
    depth: &[[f32; 2]],
) -> crate::render::RenderImage {
    let (camera, background) = (input.camera, input.lighting.background);
    let (width, band) = (camera.width as usize, band as usize);
    let buffer_width = width + 2 * band;
    let inside = |index: usize| (index % width + band) + (index / width + band) * buffer_width;
    let mut img = crate::render::RenderImage::new(camera.width, camera.height);
    let mut premultiplied = vec![0.0f32; img.rgba.len()];
    for (index, ((rgba, z), p)) in img
        .rgba
        .iter_mut()
        .zip(&mut img.depth)
        .zip(&mut premultiplied)
        .enumerate()
    {
        let (e, dz) = (eye[inside(index)], depth[inside(index)]);
        let c = Vec3::new(e[0], e[1], e[2]) + e[3] * background;
        *rgba = [c.x, c.y, c.z, 1.0 - e[3]];
        *z = dz[0];
        *p = dz[1];
    }
    let coverage: Vec<f32> = img.rgba.iter().map(|p| p[3]).collect();
    img.factor = Some(crate::render::Factor::new(
        "occlusion",
        &premultiplied,
        &coverage,
    ));
    img
}

/// Renders on the chosen device.
pub fn render(
    compute: &crate::gpu::Compute,
    input: &DosInput,
    progress: &dyn crate::progress::Progress,
) -> Result<crate::render::RenderImage> {
    match compute {
        crate::gpu::Compute::Cpu => cpu::render(input, progress),
        crate::gpu::Compute::Gpu(ctx) => gpu::render(ctx, input, progress),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_grid_is_symmetric_inside_the_disc_and_centred() {
        for n in [1, 2, 5, 13] {
            let q = disc_grid(n);
            assert_eq!(q.len(), (n * n) as usize);
            assert!(q.iter().all(|p| p.length() <= 1.0 + 1e-6));
            let mean: Vec2 = q.iter().copied().sum::<Vec2>() / q.len() as f32;
            assert!(mean.length() < 1e-5, "n={n}: mean {mean}");
        }
        assert_eq!(disc_grid(1), vec![Vec2::ZERO]);
        // Equal areas: the mean squared radius of a uniform disc is 1/2.
        let q = disc_grid(32);
        let r2 = q.iter().map(|p| p.length_squared()).sum::<f32>() / q.len() as f32;
        assert!((r2 - 0.5).abs() < 2e-3, "{r2}");
    }

    #[test]
    fn the_guard_band_reaches_the_box_and_keeps_every_pixel_s_ray() {
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        for projection in [
            Projection::Perspective { fov_y: 0.6 },
            Projection::Orthographic { scale: 3.0 },
        ] {
            let view = |distance: f32| {
                Camera::look_at(
                    Vec3::new(0.3, -distance, 0.5),
                    Vec3::ZERO,
                    Vec3::Z,
                    projection,
                    40,
                    30,
                )
                .unwrap()
            };
            // Far enough, the box is in view (a wide perspective frame at distance 12).
            let framed = view(12.0);
            if framed.is_perspective() {
                assert_eq!(guard_band(&framed, lo, hi), 0);
            }
            let close = view(3.0);
            let band = guard_band(&close, lo, hi);
            assert!(band > 0 && band <= 20, "{band}");
            let wide = widened(&close, band).unwrap();
            assert_eq!((wide.width, wide.height), (40 + 2 * band, 30 + 2 * band));
            // The box's corners project inside the widened image (or the band is capped).
            assert_eq!(guard_band(&wide, lo, hi) == 0, band < 20, "{projection:?}");
            for (i, j) in [(0, 0), (39, 29), (17, 4)] {
                let (a, b) = (close.ray(i, j), wide.ray(i + band, j + band));
                assert!((a.dir - b.dir).length() < 1e-5, "{projection:?} {i} {j}");
                assert!(
                    (a.origin - b.origin).length() < 1e-5,
                    "{projection:?} {i} {j}"
                );
            }
            // From inside the box a perspective camera gets the widest band (corners lie
            // behind it); an orthographic one still sees the box's extent across the view.
            let inside = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Z, projection, 40, 30);
            let expected = if close.is_perspective() { 20 } else { 0 };
            assert_eq!(guard_band(&inside.unwrap(), lo, hi), expected);
        }
    }

    #[test]
    fn rings_match_the_mapped_radii() {
        for n in [1, 2, 5, 13, 32] {
            let rings = disc_rings(n);
            assert_eq!(*rings.iter().max().unwrap() + 1, n.div_ceil(2));
            for (q, m) in disc_grid(n).iter().zip(rings) {
                assert!(
                    (q.length() - ring_radius(n, m)).abs() < 1e-6,
                    "n={n}: {q} ring {m}"
                );
            }
        }
    }

    #[test]
    fn rejects_out_of_range_parameters_by_name() {
        let bad = [
            (
                DosParams {
                    theta_deg: 90.0,
                    ..DosParams::default()
                },
                "render.theta_deg",
            ),
            (
                DosParams {
                    grid: 0,
                    ..DosParams::default()
                },
                "render.grid",
            ),
            (
                DosParams {
                    slice_distance: Some(f32::NAN),
                    ..DosParams::default()
                },
                "render.slice_distance",
            ),
            (
                DosParams {
                    clip_planes: vec![ClipPlane {
                        point: Vec3::ZERO,
                        normal: Vec3::new(0.0, 0.0, 2.0),
                    }],
                    ..DosParams::default()
                },
                "render.clip_planes[0]",
            ),
        ];
        for (params, key) in bad {
            let err = params.validate().unwrap_err().to_string();
            assert!(err.contains(key), "{err}");
        }
        let near_90 = DosParams {
            theta_deg: 89.999_99,
            ..DosParams::default()
        };
        assert!(near_90.tan_theta() > 0.0 && near_90.tan_theta() <= MAX_TAN_THETA);
    }
}
