//! CPU twin of DOS: slabs in order, rayon over image rows within a slab.

use super::{finish, material, DosInput, DosSetup, Formulation, MAX_TAU};
use crate::camera::intersect_box;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::render::raycast::cpu::emitted;
use crate::render::{RenderImage, BACKGROUND_DEPTH};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// One pixel's ray, clipped to the box: t = depth / `depth_rate` (slices), or t itself when
/// marching in lock step (`depth_rate` = 1).
#[derive(Clone, Copy)]
struct PixelRay {
    origin: Vec3,
    dir: Vec3,
    /// Depth gained per unit of t (dir . forward).
    depth_rate: f32,
    /// [t_near, t_far] inside the box; empty (near >= far) when the ray misses it.
    span: (f32, f32),
}

/// The eye buffer: what a pixel has composited so far.
#[derive(Clone, Copy)]
struct Eye {
    radiance: Vec3,
    transmittance: f32,
    depth: f32,
    /// The occlusion factor where the transmittance fell through 0.5.
    occlusion: f32,
}

/// Renders the image on the CPU.
pub fn render(input: &DosInput, progress: &dyn Progress) -> Result<RenderImage> {
    let setup = input.setup()?;
    let cam = input.camera;
    let (width, height) = (cam.width as usize, cam.height as usize);
    let (lo, hi) = input.volume.bounds();
    let lock_step = input.params.formulation == Formulation::Rays;
    let rays: Vec<PixelRay> = (0..width * height)
        .map(|index| {
            let ray = cam.ray((index % width) as u32, (index / width) as u32);
            PixelRay {
                origin: ray.origin,
                dir: ray.dir,
                depth_rate: if lock_step {
                    1.0
                } else {
                    ray.dir.dot(cam.forward)
                },
                span: intersect_box(&ray, lo, hi).unwrap_or((0.0, 0.0)),
            }
        })
        .collect();
    let mut eye = vec![
        Eye {
            radiance: Vec3::ZERO,
            transmittance: 1.0,
            depth: BACKGROUND_DEPTH,
            occlusion: 1.0,
        };
        width * height
    ];
    // The occlusion buffer of the previous slab, (V, tau) per pixel, and the one being written.
    let mut previous = vec![[1.0f32, 0.0]; width * height];
    let mut next = previous.clone();
    for k in 0..setup.slabs {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let radius_px = setup.base_radius_px(cam, k);
        next.par_chunks_mut(width)
            .zip(eye.par_chunks_mut(width))
            .enumerate()
            .for_each(|(j, (next_row, eye_row))| {
                for (i, (out, e)) in next_row.iter_mut().zip(eye_row).enumerate() {
                    let index = i + width * j;
                    let v = if k == 0 {
                        1.0
                    } else {
                        visibility(&setup, &previous, [width, height], [i, j], radius_px)
                    };
                    let tau = slab(input, &setup, &rays[index], k, v, e);
                    *out = [v, tau];
                }
            });
        std::mem::swap(&mut previous, &mut next);
        progress.update(k as u64 + 1, setup.slabs as u64);
    }
    let radiance: Vec<[f32; 4]> = eye
        .iter()
        .map(|e| e.radiance.extend(e.transmittance).to_array())
        .collect();
    let depth: Vec<[f32; 2]> = eye.iter().map(|e| [e.depth, e.occlusion]).collect();
    Ok(finish(cam, input.lighting.background, &radiance, &depth))
}

/// V_k at pixel (i, j): the cone-base average of the previous buffer, each sample attenuated
/// along its path through the previous slab.
#[inline]
fn visibility(
    setup: &DosSetup,
    previous: &[[f32; 2]],
    size: [usize; 2],
    pixel: [usize; 2],
    radius_px: f32,
) -> f32 {
    let centre = Vec2::new(pixel[0] as f32, pixel[1] as f32);
    let mut sum = 0.0;
    for (&q, &length) in setup.offsets.iter().zip(&setup.path_lengths) {
        // Image rows run down while the camera's up runs up.
        let at = centre + Vec2::new(q.x, -q.y) * radius_px;
        let [v, tau] = bilinear(previous, size, at);
        sum += v * (-tau * length).exp();
    }
    sum / setup.offsets.len() as f32
}

/// Bilinear read of an image-sized buffer at pixel coordinates (pixel centres at integers),
/// clamped to the edge pixels.
#[inline]
fn bilinear(buffer: &[[f32; 2]], size: [usize; 2], at: Vec2) -> [f32; 2] {
    let axis = |x: f32, n: usize| {
        let x = x.clamp(0.0, (n - 1) as f32);
        let i0 = x.floor() as usize;
        (i0, (i0 + 1).min(n - 1), x - i0 as f32)
    };
    let (i0, i1, fx) = axis(at.x, size[0]);
    let (j0, j1, fy) = axis(at.y, size[1]);
    let texel = |i: usize, j: usize| buffer[i + size[0] * j];
    let lerp =
        |a: [f32; 2], b: [f32; 2], f: f32| [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f];
    lerp(
        lerp(texel(i0, j0), texel(i1, j0), fx),
        lerp(texel(i0, j1), texel(i1, j1), fx),
        fy,
    )
}

/// Composites slab k of one pixel into its eye buffer, lit with visibility `v`; returns the
/// slab's tau = sigma_t * (fraction of the slab's depth inside the box) for the next slab.
#[inline]
fn slab(input: &DosInput, setup: &DosSetup, ray: &PixelRay, k: u32, v: f32, eye: &mut Eye) -> f32 {
    let d = setup.slice_distance;
    let z0 = setup.first_depth + k as f32 * d;
    let ta = (z0 / ray.depth_rate).max(ray.span.0);
    let tb = ((z0 + d) / ray.depth_rate).min(ray.span.1);
    if tb <= ta {
        return 0.0;
    }
    let dt = tb - ta;
    let p = ray.origin + (0.5 * (ta + tb)) * ray.dir;
    let optical = material(input.volume, input.lut, &input.params.clip_planes, p);
    if optical.sigma_t <= 0.0 && optical.emission == Vec3::ZERO {
        return 0.0;
    }
    let alpha = 1.0 - (-optical.sigma_t * dt).exp();
    let light = alpha * optical.albedo * setup.ambient * v + emitted(&optical, alpha, dt);
    eye.radiance += eye.transmittance * light;
    let next = eye.transmittance * (1.0 - alpha);
    if eye.transmittance > 0.5 && next <= 0.5 {
        eye.depth = ta + (2.0 * eye.transmittance).ln() / optical.sigma_t;
        eye.occlusion = v;
    }
    eye.transmittance = next;
    (optical.sigma_t * dt * ray.depth_rate / d).min(MAX_TAU)
}
