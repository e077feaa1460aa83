//! The classified volume as a participating medium for Monte Carlo: free-flight sampling by
//! delta tracking and transmittance by ratio tracking, both unbiased, against one majorant (the
//! largest extinction in the table).

use crate::camera::{intersect_box, Ray};
use crate::classify::{Lut, Optical};
use crate::volume::Volume;
use glam::Vec3;
use rand::Rng;

/// Below this transmittance, ratio tracking plays Russian roulette (survivors are reweighted,
/// so the estimate stays unbiased) instead of marching on for ever-smaller contributions.
const ROULETTE_BELOW: f32 = 0.05;

/// The medium: optical properties anywhere in the volume's box, zero outside.
pub struct Medium<'a> {
    volume: &'a Volume,
    lut: &'a Lut,
    table_2d: bool,
    majorant: f32,
    lo: Vec3,
    hi: Vec3,
}

/// A real collision: where, and the medium there.
pub struct Collision {
    pub position: Vec3,
    pub optical: Optical,
}

impl<'a> Medium<'a> {
    pub fn new(volume: &'a Volume, lut: &'a Lut) -> Self {
        let (lo, hi) = volume.bounds();
        Self {
            volume,
            lut,
            table_2d: lut.gradient_max().is_some(),
            majorant: lut.max_sigma_t(),
            lo,
            hi,
        }
    }

    /// Optical properties at `p` (inside the box): the trilinear value, then the table.
    #[inline]
    pub fn optical(&self, p: Vec3) -> Optical {
        let g = if self.table_2d {
            self.volume.gradient(p).length()
        } else {
            0.0
        };
        self.lut.lookup(self.volume.sample(p), g)
    }

    /// Extinction at `p` (inside the box).
    #[inline]
    pub fn sigma_t(&self, p: Vec3) -> f32 {
        let g = if self.table_2d {
            self.volume.gradient(p).length()
        } else {
            0.0
        };
        self.lut.sigma_t(self.volume.sample(p), g)
    }

    /// Optical properties anywhere: the medium inside the box, nothing outside it.
    #[inline]
    pub fn optical_or_empty(&self, p: Vec3) -> Optical {
        if p.cmpge(self.lo).all() && p.cmple(self.hi).all() {
            self.optical(p)
        } else {
            Optical::default()
        }
    }

    /// The part of `ray` inside the box, as [t_near, t_far].
    #[inline]
    pub fn clip(&self, ray: &Ray) -> Option<(f32, f32)> {
        intersect_box(ray, self.lo, self.hi)
    }

    /// Samples the first real collision along `ray` before distance `t_max` (delta tracking):
    /// its density is T(0, t) sigma_t(t). None: the ray got through.
    pub fn collide(&self, ray: &Ray, t_max: f32, rng: &mut impl Rng) -> Option<Collision> {
        let (t0, t1) = self.clip(ray)?;
        let t1 = t1.min(t_max);
        if self.majorant <= 0.0 {
            return None;
        }
        let mut t = t0;
        loop {
            t += free_path(self.majorant, rng);
            if t >= t1 {
                return None;
            }
            let position = ray.origin + t * ray.dir;
            let optical = self.optical(position);
            if rng.random::<f32>() * self.majorant < optical.sigma_t {
                return Some(Collision { position, optical });
            }
        }
    }

    /// An unbiased estimate of the transmittance along `ray` up to distance `t_max` (ratio
    /// tracking with Russian roulette).
    pub fn transmittance(&self, ray: &Ray, t_max: f32, rng: &mut impl Rng) -> f32 {
        let Some((t0, t1)) = self.clip(ray) else {
            return 1.0;
        };
        let t1 = t1.min(t_max);
        if self.majorant <= 0.0 {
            return 1.0;
        }
        let mut t = t0;
        let mut transmittance = 1.0f32;
        loop {
            t += free_path(self.majorant, rng);
            if t >= t1 {
                return transmittance;
            }
            let sigma = self.optical(ray.origin + t * ray.dir).sigma_t;
            transmittance *= 1.0 - sigma / self.majorant;
            if transmittance < ROULETTE_BELOW {
                if rng.random::<f32>() < 0.5 {
                    return 0.0;
                }
                transmittance *= 2.0;
            }
        }
    }
}

/// A free path of the majorant medium: exponential with rate `majorant`.
#[inline]
fn free_path(majorant: f32, rng: &mut impl Rng) -> f32 {
    // 1 - u lies in (0, 1], so the logarithm is finite.
    -(1.0 - rng.random::<f32>()).ln() / majorant
}
