//! Monte Carlo references of the optical model: unbiased, seeded and deterministic estimators
//! with a per-pixel standard error, against which the fast methods and Cycles are measured.
//!
//! Every estimator follows the camera ray through its pixel's centre and samples where it first
//! interacts (delta tracking: density T(0, t) sigma_t(t)). A ray that gets through sees the
//! background. At the interaction x, the sample is `e(x) / sigma_t(x) + albedo(x) * L_s(x)`, an
//! unbiased estimate of `int T(0,t) (e + sigma_s L_s) dt` whatever L_s is; the estimators differ
//! in the light they scatter, `L_s`:
//! - `Ambient` (AO, the DOS paper's Fig. 2a): the ambient lights' radiance L_amb from every
//!   direction, isotropic phase, visibility by transmittance: `L_amb T(x, w)`, w uniform on the
//!   sphere (phase and sampling density cancel).
//! - `Cone` (the DOS paper's Eq. 6-10, Fig. 2b): the same, with a phase function uniform inside
//!   the cone of half-angle `aperture` around the direction towards the viewer.
//! - `Single` (IPSVI's I_ss): directional and point lights, Henyey-Greenstein(g) phase,
//!   `sum_l p(l . d) E_l T(x, l)` with the exact shadow transmittance.
//! - `Multiple`: the full random walk under every light: at each interaction, emission, then
//!   throughput *= albedo, next-event estimation of the directional and point lights, and a
//!   Henyey-Greenstein scattering direction; a scattered path that leaves the volume sees L_amb.
//!   `bounces` counts scatterings after the first, as Cycles' volume bounces do (0 = single
//!   scattering under every light).
//!
//! Transmittance is estimated by ratio tracking (unbiased). Alpha is the fraction of camera
//! paths that interact. The standard error is that of each pixel's mean over its samples.
//! Each pixel draws from its own PCG stream, so images do not depend on thread scheduling.

use crate::camera::{Camera, Ray};
use crate::classify::Lut;
use crate::error::{Error, Result};
use crate::export::exr::ExrLayer;
use crate::lights::{incident, Light, Lighting};
use crate::optics::medium::Medium;
use crate::optics::phase;
use crate::progress::Progress;
use crate::render::RenderImage;
use crate::volume::Volume;
use glam::Vec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Which integral to estimate (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimator {
    Ambient,
    /// Half-angle of the cone, in radians, in (0, pi/2).
    Cone {
        aperture: f32,
    },
    Single,
    Multiple {
        bounces: u32,
    },
}

impl Estimator {
    /// The CLI's name for it.
    pub fn name(&self) -> &'static str {
        match self {
            Estimator::Ambient => "ambient",
            Estimator::Cone { .. } => "cone",
            Estimator::Single => "single",
            Estimator::Multiple { .. } => "multiple",
        }
    }
}

/// Volume bounces of the `multiple` estimator unless told otherwise (`occlux reference`,
/// the chart's multiple-scattering lighting, the Cycles harness's DEFAULT_BOUNCES).
pub const DEFAULT_BOUNCES: u32 = 8;

/// Most samples per pixel accepted, and most bounces.
pub const MAX_SPP: u32 = 1 << 20;
pub const MAX_BOUNCES: u32 = 1024;

/// Parameters of a reference render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceParams {
    pub estimator: Estimator,
    /// Samples per pixel (at least 2, for a standard error).
    pub spp: u32,
    pub seed: u64,
    /// Henyey-Greenstein asymmetry for `Single` and `Multiple`, in (-1, 1).
    pub g: f32,
}

impl ReferenceParams {
    pub fn validate(&self) -> Result<()> {
        if !(2..=MAX_SPP).contains(&self.spp) {
            return Err(Error::param(
                "spp",
                format!("must be in [2, {MAX_SPP}], got {}", self.spp),
            ));
        }
        if self.g.is_nan() || self.g.abs() >= 1.0 {
            return Err(Error::param(
                "g",
                format!("must be in (-1, 1), got {}", self.g),
            ));
        }
        match self.estimator {
            Estimator::Cone { aperture }
                if !(aperture > 0.0 && aperture < 0.5 * std::f32::consts::PI) =>
            {
                Err(Error::param(
                    "aperture",
                    format!(
                        "the cone's half-angle must be in (0, 90) degrees, got {} degrees",
                        aperture.to_degrees()
                    ),
                ))
            }
            Estimator::Multiple { bounces } if bounces > MAX_BOUNCES => Err(Error::param(
                "bounces",
                format!("must be at most {MAX_BOUNCES}, got {bounces}"),
            )),
            _ => Ok(()),
        }
    }
}

/// What a reference render needs.
pub struct ReferenceInput<'a> {
    pub volume: &'a Volume,
    pub lut: &'a Lut,
    pub camera: &'a Camera,
    pub lighting: &'a Lighting,
    pub params: &'a ReferenceParams,
}

/// A reference image: per-pixel mean RGBA (alpha: fraction of camera paths that interact) and
/// the standard error of the mean RGB, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceImage {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub mean: Vec<[f32; 4]>,
    pub stderr: Vec<[f32; 3]>,
}

impl ReferenceImage {
    /// The mean as a render (no depth: references do not estimate one).
    pub fn to_render(&self) -> RenderImage {
        let mut img = RenderImage::new(self.width, self.height);
        img.rgba.clone_from(&self.mean);
        img
    }

    /// EXR layers `beauty` (R, G, B, A: the mean) and `stderr` (R, G, B).
    pub fn layers(&self) -> Vec<ExrLayer> {
        vec![
            ExrLayer {
                name: "beauty".into(),
                channels: ["R", "G", "B", "A"].map(String::from).to_vec(),
                pixels: self.mean.iter().flatten().copied().collect(),
            },
            ExrLayer {
                name: "stderr".into(),
                channels: ["R", "G", "B"].map(String::from).to_vec(),
                pixels: self.stderr.iter().flatten().copied().collect(),
            },
        ]
    }
}

/// Renders the reference on the CPU (rayon over rows).
pub fn render(input: &ReferenceInput, progress: &dyn Progress) -> Result<ReferenceImage> {
    input.params.validate()?;
    input.lighting.validate()?;
    if input.lut.emits_without_extinction() {
        return Err(Error::param(
            "classification",
            "the Monte Carlo references sample emission where light interacts, so they need \
             sigma_t > 0 wherever the transfer function emits",
        ));
    }
    let cam = input.camera;
    let width = cam.width as usize;
    let pixels = width * cam.height as usize;
    let mut mean = vec![[0.0f32; 4]; pixels];
    let mut stderr = vec![[0.0f32; 3]; pixels];
    let medium = Medium::tracking(input.volume, input.lut)?;
    let rows_done = AtomicU64::new(0);
    mean.par_chunks_mut(width)
        .zip(stderr.par_chunks_mut(width))
        .enumerate()
        .for_each(|(j, (mean_row, err_row))| {
            if progress.cancelled() {
                return;
            }
            for (i, (m, e)) in mean_row.iter_mut().zip(err_row).enumerate() {
                let pixel = (j * width + i) as u64;
                (*m, *e) = estimate_pixel(input, &medium, &cam.ray(i as u32, j as u32), pixel);
            }
            let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            progress.update(done, cam.height as u64);
        });
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    Ok(ReferenceImage {
        width: cam.width,
        height: cam.height,
        spp: input.params.spp,
        mean,
        stderr,
    })
}

/// Mean and standard error of one pixel's samples.
fn estimate_pixel(
    input: &ReferenceInput,
    medium: &Medium,
    ray: &Ray,
    pixel: u64,
) -> ([f32; 4], [f32; 3]) {
    let params = input.params;
    // One PCG stream per pixel: the seed picks the sequence, the pixel the stream.
    let mut rng = Pcg32::new(params.seed ^ 0x853c_49e6_748f_ea9b, pixel);
    let ambient = input.lighting.ambient();
    let mut sum = glam::DVec3::ZERO;
    let mut sum_sq = glam::DVec3::ZERO;
    let mut hits = 0u32;
    let crossings = medium.crossings(ray, f32::INFINITY);
    for _ in 0..params.spp {
        let (radiance, hit) = sample_path(input, medium, ray, &crossings, ambient, &mut rng);
        let r = radiance.as_dvec3();
        sum += r;
        sum_sq += r * r;
        hits += hit as u32;
    }
    let n = params.spp as f64;
    let m = sum / n;
    let variance = ((sum_sq - n * m * m) / (n - 1.0)).max(glam::DVec3::ZERO);
    let se = (variance / n).map(f64::sqrt).as_vec3();
    let m = m.as_vec3();
    ([m.x, m.y, m.z, hits as f32 / n as f32], se.to_array())
}

/// One camera path along `ray` (whose cells are `crossings`): its radiance, and whether it
/// interacted with the volume.
fn sample_path(
    input: &ReferenceInput,
    medium: &Medium,
    ray: &Ray,
    crossings: &[[f32; 3]],
    ambient: Vec3,
    rng: &mut Pcg32,
) -> (Vec3, bool) {
    let Some(hit) = medium.collide_through(ray, crossings, rng) else {
        return (input.lighting.background, false);
    };
    let o = hit.optical;
    let x = hit.position;
    let emitted = o.emission / o.sigma_t;
    let radiance = match input.params.estimator {
        Estimator::Ambient => {
            let w = phase::sample_sphere(rng);
            emitted + o.albedo * ambient * shadow(medium, x, w, f32::INFINITY, rng)
        }
        Estimator::Cone { aperture } => {
            let w = phase::sample_cone(-ray.dir, aperture.cos(), rng);
            emitted + o.albedo * ambient * shadow(medium, x, w, f32::INFINITY, rng)
        }
        Estimator::Single => emitted + o.albedo * direct(input, medium, x, ray.dir, rng),
        Estimator::Multiple { bounces } => {
            walk(input, medium, x, o, ray.dir, bounces, ambient, rng)
        }
    };
    (radiance, true)
}

/// Transmittance from `x` along `w` over `distance`, by ratio tracking.
#[inline]
fn shadow(medium: &Medium, x: Vec3, w: Vec3, distance: f32, rng: &mut Pcg32) -> f32 {
    medium.transmittance(&Ray { origin: x, dir: w }, distance, rng)
}

/// Light from the directional and point lights scattered at `x` into the direction opposite
/// to `w_in` (the propagation direction of the path arriving at `x`), with exact shadows.
fn direct(input: &ReferenceInput, medium: &Medium, x: Vec3, w_in: Vec3, rng: &mut Pcg32) -> Vec3 {
    let g = input.params.g;
    let mut sum = Vec3::ZERO;
    for light in &input.lighting.lights {
        let distance = match *light {
            Light::Ambient { .. } => continue,
            Light::Directional { .. } => f32::INFINITY,
            Light::Point { position, .. } => (position - x).length(),
        };
        if let Some((to_light, irradiance)) = incident(light, x) {
            // Light travels along -to_light and leaves along -w_in: cos = to_light . w_in.
            let p = phase::henyey_greenstein(g, to_light.dot(w_in));
            sum += p * irradiance * shadow(medium, x, to_light, distance, rng);
        }
    }
    sum
}

/// The random walk of the `Multiple` estimator from the first interaction `x` (see the module
/// docs); returns the path's radiance.
#[allow(clippy::too_many_arguments)]
fn walk(
    input: &ReferenceInput,
    medium: &Medium,
    mut x: Vec3,
    mut o: crate::classify::Optical,
    mut w: Vec3,
    bounces: u32,
    ambient: Vec3,
    rng: &mut Pcg32,
) -> Vec3 {
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    let mut scatterings = 0;
    loop {
        radiance += throughput * o.emission / o.sigma_t;
        throughput *= o.albedo;
        radiance += throughput * direct(input, medium, x, w, rng);
        w = phase::sample_henyey_greenstein(input.params.g, w, rng);
        match medium.collide(&Ray { origin: x, dir: w }, f32::INFINITY, rng) {
            None => return radiance + throughput * ambient,
            Some(_) if scatterings == bounces => return radiance,
            Some(hit) => {
                x = hit.position;
                o = hit.optical;
                scatterings += 1;
            }
        }
        if throughput.max_element() <= 0.0 {
            return radiance;
        }
    }
}
