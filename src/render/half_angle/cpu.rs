//! Half-angle slicing on the CPU: slabs in order along the half vector, each slab's eye samples
//! and light-buffer rays in parallel (rayon); no pixel or ray depends on another within a slab,
//! so images do not depend on threads.

use super::HalfAngleInput;
use crate::camera::Ray;
use crate::classify::Optical;
use crate::error::{Error, Result};
use crate::lights::{incident, Light};
use crate::optics::medium::Medium;
use crate::optics::phase::henyey_greenstein;
use crate::progress::Progress;
use crate::render::ipsvi::cache::{CacheMap, Resolution};
use crate::render::raycast::cpu::emitted;
use crate::render::{Factor, RenderImage, BACKGROUND_DEPTH};
use glam::Vec3;
use rayon::prelude::*;

/// One pixel's eye state.
#[derive(Clone, Copy, Debug)]
struct Eye {
    /// The pixel's view ray.
    ray: Ray,
    /// Light scattered towards the eye by the lights done, by the current one, and emission
    /// (gathered in the first light's pass).
    scattered: Vec3,
    this_light: Vec3,
    emitted: Vec3,
    /// Transmittance so far: in front of the slab (front to back) or behind it (back to front).
    transmittance: f32,
    /// The whole ray's transmittance (back to front: from the extinction-only pre-pass).
    total: f32,
    depth: f32,
    /// The shadow layer: the current light's transmittance at each sample weighted by the
    /// sample's contribution (composited as the colour is), its P, and the light's grey
    /// irradiance weighted the same way, its weight; over the lights done, each P times its
    /// weight, and the weights.
    this_lit: f32,
    this_weight: f32,
    lit: f32,
    irradiance: f32,
}

/// The slicing of one light: the half vector, the slabs' range along it and the light buffer.
struct Slicing {
    light: Light,
    h: Vec3,
    front_to_back: bool,
    first: f32,
    slabs: u32,
    map: CacheMap,
    /// Each light-buffer ray's origin and the unit direction it travels (a sun's rays all
    /// along one direction, a lamp's from the lamp), with `dir . h` > 0 where it crosses the
    /// volume; rays that run along the slices or back are None.
    rays: Vec<Option<(Vec3, Vec3)>>,
}

impl Slicing {
    /// The slicing of `light`; None for light that casts no shadow here (ambient light). A
    /// lamp's rays fan out, so the slices serve them only if every one crosses them in order:
    /// the whole box must lie on the far side of the plane through the lamp across the half
    /// vector (refused by name otherwise).
    fn new(input: &HalfAngleInput, index: usize, light: &Light, d: f32) -> Result<Option<Self>> {
        let camera = input.camera;
        let (lo, hi) = input.volume.bounds();
        let corners: Vec<Vec3> = (0..8)
            .map(|c| Vec3::select(glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0), hi, lo))
            .collect();
        // The direction the light travels through the volume: a lamp's towards the box's
        // centre, where its rays fan out from.
        let travel = match *light {
            Light::Ambient { .. } => return Ok(None),
            Light::Directional { to_light, .. } => -to_light,
            Light::Point { position, .. } => (0.5 * (lo + hi) - position).normalize_or_zero(),
        };
        let view = camera.forward;
        let front_to_back = view.dot(travel) >= 0.0;
        // |v + w| >= sqrt(2) when v . w >= 0, and |w - v| >= sqrt(2) otherwise: never zero
        // (a lamp at the box's centre has no travel and is refused below).
        let h = if front_to_back {
            (view + travel).normalize_or_zero()
        } else {
            (travel - view).normalize_or_zero()
        };
        let along: Vec<f32> = corners.iter().map(|corner| corner.dot(h)).collect();
        let first = along.iter().copied().fold(f32::INFINITY, f32::min);
        let last = along.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        if let Light::Point { position, .. } = *light {
            if h == Vec3::ZERO || position.dot(h) >= first {
                return Err(Error::param(
                    format!("lights[{index}]"),
                    format!(
                        "the point light at {position} is too close to the volume for                          half-angle slicing: its rays cross slices along the half vector in                          order only when the whole box lies beyond the plane through the lamp                          across that vector; move it further out or render with                          method = \"ipsvi\", which takes lamps anywhere"
                    ),
                ));
            }
        }
        let resolution =
            Resolution::for_view(input.params.light_buffer, input.volume, input.camera);
        let Some(map) = CacheMap::new(light, lo, hi, resolution) else {
            return Ok(None);
        };
        let rays = (0..map.texels() as u32)
            .map(|texel| {
                let (origin, dir) = map.ray(texel);
                (dir.dot(h) > 1e-6).then_some((origin, dir))
            })
            .collect();
        Ok(Some(Self {
            light: *light,
            h,
            front_to_back,
            first,
            slabs: ((last - first) / d).ceil().max(1.0) as u32,
            map,
            rays,
        }))
    }

    /// The h-coordinate of slab k's middle plane; slabs run along +h, away from the light.
    fn middle(&self, k: u32, d: f32) -> f32 {
        self.first + (k as f32 + 0.5) * d
    }
}

/// A view ray's sample in a slab.
#[derive(Clone, Copy)]
struct Sample {
    x: Vec3,
    /// Distance from the ray's origin, and the length of its crossing of the slab.
    t: f32,
    dt: f32,
    dir: Vec3,
}

/// Where `ray` crosses the plane at h-coordinate `c`, with the length of its crossing of a
/// slab `d` thick there; None behind the camera or outside the box.
#[inline]
fn view_sample(ray: &Ray, h: Vec3, c: f32, d: f32, bounds: (Vec3, Vec3)) -> Option<Sample> {
    let across = ray.dir.dot(h);
    if across.abs() < 1e-6 {
        return None;
    }
    let t = (c - ray.origin.dot(h)) / across;
    let x = ray.origin + t * ray.dir;
    (t > 0.0 && x.cmpge(bounds.0).all() && x.cmple(bounds.1).all()).then(|| Sample {
        x,
        t,
        dt: d / across.abs(),
        dir: ray.dir,
    })
}

/// Renders the image and its `shadow` layer ([`Factor`]: the suns' transmittance at each
/// sample weighted by its contribution, summed along the ray, the suns' weighted by their
/// irradiance, beside the coverage) on the CPU.
pub fn render(input: &HalfAngleInput, progress: &dyn Progress) -> Result<RenderImage> {
    let d = input.setup()?;
    let camera = input.camera;
    let medium = Medium::new(input.volume, input.lut);
    let (lo, hi) = input.volume.bounds();
    let pixels = (camera.width * camera.height) as usize;
    let mut eyes: Vec<Eye> = (0..pixels as u32)
        .map(|p| Eye {
            ray: camera.ray(p % camera.width, p / camera.width),
            scattered: Vec3::ZERO,
            this_light: Vec3::ZERO,
            emitted: Vec3::ZERO,
            transmittance: 1.0,
            total: 1.0,
            depth: BACKGROUND_DEPTH,
            this_lit: 0.0,
            this_weight: 0.0,
            lit: 0.0,
            irradiance: 0.0,
        })
        .collect();
    let mut slicings = Vec::new();
    for (index, light) in input.lighting.lights.iter().enumerate() {
        slicings.extend(Slicing::new(input, index, light, d)?);
    }
    let work: u64 = slicings.iter().map(|s| s.slabs as u64).sum();
    let mut done = 0;
    for (pass, slicing) in slicings.iter().enumerate() {
        if !slicing.front_to_back {
            // The eye's transmittance through the whole ray, for finding the depth on the way
            // back to front.
            eyes.par_iter_mut().for_each(|eye| {
                eye.transmittance = 1.0;
                eye.total = (0..slicing.slabs).fold(1.0, |t, k| {
                    match view_sample(&eye.ray, slicing.h, slicing.middle(k, d), d, (lo, hi)) {
                        Some(s) => t * (-medium.optical(s.x).sigma_t * s.dt).exp(),
                        None => t,
                    }
                });
            });
        } else {
            eyes.iter_mut().for_each(|eye| eye.transmittance = 1.0);
        }
        eyes.iter_mut().for_each(|eye| {
            eye.this_light = Vec3::ZERO;
            eye.this_lit = 0.0;
            eye.this_weight = 0.0;
        });
        // The light buffer holds the optical depth each light ray has crossed: interpolated
        // between rays it errs far less than the transmittance where that falls by orders of
        // magnitude across a texel (a backlit body; IPSVI interpolates the same way).
        let mut depth = vec![0.0f32; slicing.map.texels()];
        for k in 0..slicing.slabs {
            let c = slicing.middle(k, d);
            let buffer = &depth;
            eyes.par_iter_mut().for_each(|eye| {
                let Some(sample) = view_sample(&eye.ray, slicing.h, c, d, (lo, hi)) else {
                    return;
                };
                let optical = medium.optical(sample.x);
                if optical.sigma_t <= 0.0 && optical.emission == Vec3::ZERO {
                    return;
                }
                let place = slicing.map.place(sample.x);
                let crossed: f32 = place
                    .corners
                    .iter()
                    .zip(place.weights)
                    .map(|(&texel, w)| w * buffer[texel as usize])
                    .sum();
                let lit = (-crossed).exp();
                shade(
                    eye,
                    slicing,
                    &optical,
                    &sample,
                    lit,
                    input.params.g,
                    pass == 0,
                );
            });
            // Each light ray crosses the slab's middle plane once, over d / (dir . h).
            depth
                .par_iter_mut()
                .zip(&slicing.rays)
                .for_each(|(tau, ray)| {
                    let Some((origin, dir)) = *ray else {
                        return;
                    };
                    let across = dir.dot(slicing.h);
                    let p = origin + dir * ((c - origin.dot(slicing.h)) / across);
                    if p.cmpge(lo).all() && p.cmple(hi).all() {
                        *tau += medium.optical(p).sigma_t * d / across;
                    }
                });
            done += 1;
            progress.update(done, work);
        }
        // Each light's P weighs by its irradiance at the samples, weighted as they are
        // composited (for a sun its grey irradiance times the coverage).
        eyes.iter_mut().for_each(|eye| {
            eye.scattered += eye.this_light;
            eye.lit += eye.this_weight * eye.this_lit;
            eye.irradiance += eye.this_weight;
        });
    }
    let background = input.lighting.background;
    let mut image = RenderImage::new(camera.width, camera.height);
    for (p, eye) in eyes.iter().enumerate() {
        let t = eye.total.min(eye.transmittance);
        let c = eye.scattered + eye.emitted + t * background;
        image.rgba[p] = [c.x, c.y, c.z, 1.0 - t];
        image.depth[p] = eye.depth;
    }
    let coverage: Vec<f32> = image.rgba.iter().map(|p| p[3]).collect();
    let premultiplied: Vec<f32> = eyes
        .iter()
        .zip(&coverage)
        .map(|(e, &a)| {
            if e.irradiance > 0.0 {
                e.lit / e.irradiance
            } else {
                a
            }
        })
        .collect();
    image.factor = Some(Factor::new("shadow", &premultiplied, &coverage));
    Ok(image)
}

/// Adds one slab's sample (the light's transmittance there `lit`) to the pixel's eye state,
/// front to back or back to front, and finds the depth.
#[inline]
fn shade(
    eye: &mut Eye,
    slicing: &Slicing,
    optical: &Optical,
    sample: &Sample,
    lit: f32,
    g: f32,
    first_pass: bool,
) {
    let alpha = 1.0 - (-optical.sigma_t * sample.dt).exp();
    let (to_light, irradiance) = incident(&slicing.light, sample.x).unwrap_or_default();
    // Light travels along -to_light and leaves along -dir: cos = to_light . dir.
    let phase = henyey_greenstein(g, to_light.dot(sample.dir));
    let scattered = optical.albedo * phase * irradiance * lit * alpha;
    let grey = irradiance.element_sum() / 3.0;
    let own = emitted(optical, alpha, sample.dt);
    // The transmittance in front of this sample, for the depth.
    let in_front = if slicing.front_to_back {
        eye.this_light += eye.transmittance * scattered;
        eye.this_lit += eye.transmittance * alpha * lit;
        eye.this_weight += eye.transmittance * alpha * grey;
        if first_pass {
            eye.emitted += eye.transmittance * own;
        }
        eye.transmittance
    } else {
        eye.this_light = scattered + (1.0 - alpha) * eye.this_light;
        eye.this_lit = alpha * lit + (1.0 - alpha) * eye.this_lit;
        eye.this_weight = alpha * grey + (1.0 - alpha) * eye.this_weight;
        if first_pass {
            eye.emitted = own + (1.0 - alpha) * eye.emitted;
        }
        eye.total / (eye.transmittance * (1.0 - alpha)).max(f32::MIN_POSITIVE)
    };
    let behind = in_front * (1.0 - alpha);
    if first_pass && in_front > 0.5 && behind <= 0.5 {
        eye.depth = sample.t - 0.5 * sample.dt + (2.0 * in_front).ln() / optical.sigma_t;
    }
    eye.transmittance *= 1.0 - alpha;
}
