//! CPU twin of DOS: slabs in order, rayon over image rows within a slab.

use super::{finish, material, DosInput, DosSetup, Formulation};
use crate::camera::intersect_box;
use crate::error::{Error, Result};
use crate::optics::occupancy::Occupancy;
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
    /// Depth gained per unit of t: dir . forward for slices, 1 for lock-step rays.
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
    /// The occlusion layer's P: the light each sample receives (its lit fraction of the
    /// ambient light) weighted by its contribution `transmittance * alpha`, summed.
    occlusion: f32,
}

/// Renders the image on the CPU.
pub fn render(input: &DosInput, progress: &dyn Progress) -> Result<RenderImage> {
    // Cells where no sample can have matter: their slabs pass the light on unchanged, with no
    // sample taken (the ray caster's empty-space skipping, here per pixel and slab).
    render_skipping(input, &Occupancy::build(input.volume, input.lut), progress)
}

fn render_skipping(
    input: &DosInput,
    occupancy: &Occupancy,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    let setup = input.setup()?;
    // The buffers' camera: the view and its guard band.
    let cam = &setup.camera;
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
            occlusion: 0.0,
        };
        width * height
    ];
    // The occlusion buffers, previous slab's and this one's: per image row, one row of W per
    // plane (so each row of the image owns a contiguous chunk).
    let planes = setup.planes();
    let mut previous = vec![0.0f32; planes * width * height];
    let mut next = previous.clone();
    for k in 0..setup.slabs {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let taps = taps(&setup, setup.base_radius_px(cam, k));
        next.par_chunks_mut(planes * width)
            .zip(eye.par_chunks_mut(width))
            .enumerate()
            .for_each(|(j, (next_rows, eye_row))| {
                let mut visibility = vec![1.0f32; width];
                if k > 0 {
                    cone_average(
                        &previous,
                        [width, height],
                        planes,
                        j,
                        &taps,
                        &mut visibility,
                    );
                }
                for (i, (e, v)) in eye_row.iter_mut().zip(visibility).enumerate() {
                    let tau = slab(input, &setup, occupancy, &rays[i + width * j], k, v, e);
                    for (plane, length) in setup.ring_lengths.iter().enumerate() {
                        // exp(-0) = 1 exactly: empty space passes the light on as it is.
                        next_rows[plane * width + i] = if tau > 0.0 {
                            v * (-tau * length).exp()
                        } else {
                            v
                        };
                    }
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
    Ok(finish(input, setup.band, &radiance, &depth))
}

/// One cone sample's read of the previous buffer, the same for every pixel of a slab: the
/// whole-pixel offset, the bilinear fractions and the plane.
struct Tap {
    di: i64,
    dj: i64,
    fx: f32,
    fy: f32,
    plane: usize,
}

fn taps(setup: &DosSetup, radius_px: f32) -> Vec<Tap> {
    setup
        .offsets
        .iter()
        .zip(&setup.sample_ring)
        .map(|(q, &ring)| {
            // Image rows run down while the camera's up runs up.
            let o = Vec2::new(q.x, -q.y) * radius_px;
            let whole = o.floor();
            let f = o - whole;
            Tap {
                di: whole.x as i64,
                dj: whole.y as i64,
                fx: f.x,
                fy: f.y,
                plane: ring as usize,
            }
        })
        .collect()
}

/// V_k along image row j: the average over the cone's taps of the previous buffer read
/// bilinearly, with indices clamped to the image (which clamps the read to the edge pixels).
/// Row-wise, so that the interior of each tap's pass runs over contiguous memory.
fn cone_average(
    previous: &[f32],
    [width, height]: [usize; 2],
    planes: usize,
    j: usize,
    taps: &[Tap],
    out: &mut [f32],
) {
    let clamp = |x: i64, n: usize| x.clamp(0, n as i64 - 1) as usize;
    let row = |plane: usize, y: usize| {
        let at = (y * planes + plane) * width;
        &previous[at..at + width]
    };
    let mut sum = vec![0.0f32; width];
    let mut mixed = vec![0.0f32; width];
    for tap in taps {
        let top = row(tap.plane, clamp(j as i64 + tap.dj, height));
        let bottom = row(tap.plane, clamp(j as i64 + tap.dj + 1, height));
        for ((m, t), b) in mixed.iter_mut().zip(top).zip(bottom) {
            *m = t + (b - t) * tap.fy;
        }
        // Columns i whose reads i + di and i + di + 1 both lie inside the row.
        let first = (-tap.di).clamp(0, width as i64) as usize;
        let end = (width as i64 - 1 - tap.di).clamp(first as i64, width as i64) as usize;
        for i in (0..first).chain(end..width) {
            let a = mixed[clamp(i as i64 + tap.di, width)];
            let b = mixed[clamp(i as i64 + tap.di + 1, width)];
            sum[i] += a + (b - a) * tap.fx;
        }
        if end > first {
            let start = (first as i64 + tap.di) as usize;
            let a = &mixed[start..start + end - first];
            let b = &mixed[start + 1..start + 1 + end - first];
            for ((s, a), b) in sum[first..end].iter_mut().zip(a).zip(b) {
                *s += a + (b - a) * tap.fx;
            }
        }
    }
    let count = taps.len() as f32;
    for (o, s) in out.iter_mut().zip(sum) {
        *o = s / count;
    }
}

/// Composites slab k of one pixel into its eye buffer, lit with visibility `v`; returns the
/// slab's tau = sigma_t * (fraction of the slab's depth inside the box) for the next slab.
#[inline]
fn slab(
    input: &DosInput,
    setup: &DosSetup,
    occupancy: &Occupancy,
    ray: &PixelRay,
    k: u32,
    v: f32,
    eye: &mut Eye,
) -> f32 {
    let d = setup.slice_distance;
    let z0 = setup.first_depth + k as f32 * d;
    let ta = (z0 / ray.depth_rate).max(ray.span.0);
    let tb = ((z0 + d) / ray.depth_rate).min(ray.span.1);
    if tb <= ta {
        return 0.0;
    }
    let dt = tb - ta;
    let p = ray.origin + (0.5 * (ta + tb)) * ray.dir;
    if !occupancy.occupied(occupancy.cell_of(input.volume.to_index(p))) {
        return 0.0;
    }
    let optical = material(input.volume, input.lut, &input.params.clip_planes, p);
    if optical.sigma_t <= 0.0 && optical.emission == Vec3::ZERO {
        return 0.0;
    }
    let alpha = 1.0 - (-optical.sigma_t * dt).exp();
    let lit = if input.params.self_occlusion {
        v * (-0.5 * optical.sigma_t * dt).exp()
    } else {
        v
    };
    let light = alpha * optical.albedo * setup.ambient * lit + emitted(&optical, alpha, dt);
    eye.radiance += eye.transmittance * light;
    // The same weight as the light's, in the shader's order.
    eye.occlusion += eye.transmittance * alpha * lit;
    let next = eye.transmittance * (1.0 - alpha);
    if eye.transmittance > 0.5 && next <= 0.5 {
        eye.depth = ta + (2.0 * eye.transmittance).ln() / optical.sigma_t;
    }
    eye.transmittance = next;
    optical.sigma_t * dt * ray.depth_rate / d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection};
    use crate::classify::presets::preset;
    use crate::lights::{Light, Lighting};
    use crate::progress::NoProgress;
    use crate::render::dos::DosParams;
    use crate::volume::phantom;

    #[test]
    fn skipping_empty_cells_changes_no_pixel() {
        let volume = phantom::ct(40).unwrap();
        let lut = preset("ct-bone").unwrap().bake(&volume);
        let camera = Camera::look_at(
            Vec3::new(2.5, -3.0, 1.5),
            Vec3::ZERO,
            Vec3::Z,
            Projection::Perspective { fov_y: 0.7 },
            32,
            32,
        )
        .unwrap();
        let lighting = Lighting {
            lights: vec![Light::Ambient {
                radiance: Vec3::ONE,
            }],
            background: Vec3::splat(0.1),
        };
        let params = DosParams::default();
        let input = DosInput {
            volume: &volume,
            lut: &lut,
            camera: &camera,
            lighting: &lighting,
            params: &params,
        };
        let built = Occupancy::build(&volume, &lut);
        assert!(built.flags().contains(&0), "nothing to skip");
        let skipping = render_skipping(&input, &built, &NoProgress).unwrap();
        let everywhere =
            render_skipping(&input, &Occupancy::everywhere(&volume), &NoProgress).unwrap();
        assert_eq!(skipping, everywhere);
    }
}
