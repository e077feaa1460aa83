//! CPU twin of the ray caster: rayon over image rows, one ray per pixel.

use super::{RaycastInput, RaycastSetup, Shading};
use crate::camera::{intersect_box, Ray};
use crate::classify::Optical;
use crate::error::Result;
use crate::lights::{incident, Light};
use crate::optics::occupancy::Occupancy;
use crate::progress::Progress;
use crate::render::steps::{step_offset, ViewSteps};
use crate::render::{RenderImage, BACKGROUND_DEPTH};
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

/// Renders the image on the CPU.
pub fn render(input: &RaycastInput, progress: &dyn Progress) -> Result<RenderImage> {
    let setup = input.setup()?;
    let occupancy = Occupancy::build(input.volume, input.lut);
    let cam = input.camera;
    let mut img = RenderImage::new(cam.width, cam.height);
    let width = cam.width as usize;
    let rows_done = AtomicU64::new(0);
    img.rgba
        .par_chunks_mut(width)
        .zip(img.depth.par_chunks_mut(width))
        .enumerate()
        .for_each(|(j, (rgba_row, depth_row))| {
            for (i, (rgba, depth)) in rgba_row.iter_mut().zip(depth_row).enumerate() {
                let (i, j) = (i as u32, j as u32);
                let offset = step_offset(i, j);
                (*rgba, *depth) = march(input, &setup, &occupancy, &cam.ray(i, j), offset);
            }
            let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            progress.update(done, cam.height as u64);
        });
    Ok(img)
}

/// Marches one ray front to back, its steps shifted back by `offset` of a step (its pixel's
/// [`step_offset`]), jumping over empty cells; returns (RGBA, depth).
pub fn march(
    input: &RaycastInput,
    setup: &RaycastSetup,
    occupancy: &Occupancy,
    ray: &Ray,
    offset: f32,
) -> ([f32; 4], f32) {
    let background = input.lighting.background;
    let (lo, hi) = input.volume.bounds();
    let Some((t_near, t_far)) = intersect_box(ray, lo, hi) else {
        return (
            [background.x, background.y, background.z, 0.0],
            BACKGROUND_DEPTH,
        );
    };
    let volume = input.volume;
    let lut = input.lut;
    // A 2D table needs the gradient to classify; shading needs it only where there is matter.
    let table_2d = lut.gradient_max().is_some();
    let shaded = input.params.shading.gradient().is_some();
    let ambient = input.lighting.ambient();
    let ert = input.params.ert_threshold;
    let steps = ViewSteps::new(t_near, t_far, setup.step, offset);

    let mut radiance = Vec3::ZERO;
    let mut transmittance = 1.0f32;
    let mut depth = BACKGROUND_DEPTH;
    // The ray in index coordinates, for cell exits.
    let march = steps.march(volume.to_index(ray.origin), ray.dir / volume.spacing());
    let mut k = 0;
    while k < steps.count {
        let (ta, dt) = steps.segment(k);
        let p = ray.origin + (ta + 0.5 * dt) * ray.dir;
        if let Some(next) = occupancy.skip(volume.to_index(p), k, &march) {
            k = next;
            continue;
        }
        k += 1;
        let value = volume.sample(p);
        let mut grad = if table_2d {
            volume.gradient(p)
        } else {
            Vec3::ZERO
        };
        let mut optical = lut.lookup(value, grad.length());
        if let Some(opacity) = input.ao.and_then(|ao| ao.opacity) {
            optical.sigma_t *= opacity.sample(p);
        }
        if optical.sigma_t <= 0.0 && optical.emission == Vec3::ZERO {
            continue;
        }
        if shaded && !table_2d {
            grad = volume.gradient(p);
        }
        let alpha = 1.0 - (-optical.sigma_t * dt).exp();
        let light_in = in_scattered(input, setup, &optical, p, grad, ray.dir, ambient);
        radiance += transmittance * (alpha * light_in + emitted(&optical, alpha, dt));
        let next = transmittance * (1.0 - alpha);
        if transmittance > 0.5 && next <= 0.5 {
            depth = ta + (2.0 * transmittance).ln() / optical.sigma_t;
        }
        transmittance = next;
        if transmittance < ert {
            break;
        }
    }
    let c = radiance + transmittance * background;
    ([c.x, c.y, c.z, 1.0 - transmittance], depth)
}

/// Emission integrated over a step of opacity `alpha` and length `dt`.
#[inline]
pub(crate) fn emitted(optical: &Optical, alpha: f32, dt: f32) -> Vec3 {
    if optical.sigma_t > 1e-6 {
        optical.emission * (alpha / optical.sigma_t)
    } else {
        optical.emission * dt
    }
}

/// Radiance scattered towards the eye at `p`, per unit opacity (see the module docs).
#[inline]
fn in_scattered(
    input: &RaycastInput,
    setup: &RaycastSetup,
    optical: &Optical,
    p: Vec3,
    grad: Vec3,
    dir: Vec3,
    ambient: Vec3,
) -> Vec3 {
    let lights = input
        .lighting
        .lights
        .iter()
        .filter_map(|l: &Light| incident(l, p));
    let ambient = match input.ao {
        Some(ao) => ambient * ao.openness.sample(p),
        None => ambient,
    };
    match input.params.shading {
        Shading::Unshaded => {
            let direct: Vec3 = lights.map(|(_, e)| e).sum();
            optical.albedo * (ambient + direct / (4.0 * PI))
        }
        Shading::AmbientOcclusion { direct: None } => optical.albedo * ambient,
        Shading::Gradient(g) | Shading::AmbientOcclusion { direct: Some(g) } => {
            let gm = grad.length();
            let w = (gm / setup.normal_threshold).min(1.0);
            let mut n = if gm > 0.0 { -grad / gm } else { Vec3::ZERO };
            if n.dot(dir) > 0.0 {
                n = -n;
            }
            let to_eye = -dir;
            let mut diffuse = ambient;
            let mut specular = Vec3::ZERO;
            for (l, e) in lights {
                let facing = n.dot(l).max(0.0);
                diffuse += e * (w * facing / PI + (1.0 - w) / (4.0 * PI));
                // Normalised Blinn-Phong, ks (p + 8) / (8 pi) (n.h)^p, times the irradiance's
                // cosine as the diffuse term: a surface turned away from the light has no
                // highlight, though its half vector may still face the eye.
                let h = (l + to_eye).normalize_or_zero();
                let lobe = n.dot(h).max(0.0).powf(g.shininess) * (g.shininess + 8.0) / (8.0 * PI);
                specular += e * (w * g.specular * lobe * facing);
            }
            optical.albedo * diffuse + specular
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection};
    use crate::classify::presets::preset;
    use crate::lights::Lighting;
    use crate::render::raycast::{GradientShading, RaycastParams};
    use crate::volume::phantom;

    #[test]
    fn skipping_empty_cells_changes_no_pixel() {
        let camera = Camera::look_at(
            Vec3::new(2.5, -3.0, 1.5),
            Vec3::ZERO,
            Vec3::Z,
            Projection::Perspective { fov_y: 0.7 },
            40,
            40,
        )
        .unwrap();
        let lighting = Lighting {
            lights: vec![Light::Ambient {
                radiance: Vec3::ONE,
            }],
            background: Vec3::splat(0.1),
        };
        for (volume, name) in [
            (phantom::ct(40).unwrap(), "ct-bone"),
            (phantom::shells(40).unwrap(), "boundary-2d"),
        ] {
            let lut = preset(name).unwrap().bake(&volume);
            let params = RaycastParams {
                shading: Shading::Gradient(GradientShading::default()),
                ..RaycastParams::default()
            };
            let input = RaycastInput {
                volume: &volume,
                lut: &lut,
                camera: &camera,
                lighting: &lighting,
                params: &params,
                ao: None,
            };
            let setup = input.setup().unwrap();
            let built = Occupancy::build(&volume, &lut);
            let full = Occupancy::everywhere(&volume);
            assert!(built.flags().contains(&0), "{name}: nothing to skip");
            for j in 0..40 {
                for i in 0..40 {
                    let ray = camera.ray(i, j);
                    let offset = step_offset(i, j);
                    assert_eq!(
                        march(&input, &setup, &built, &ray, offset),
                        march(&input, &setup, &full, &ray, offset),
                        "{name}: pixel ({i}, {j})"
                    );
                }
            }
        }
    }
}
