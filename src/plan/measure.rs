//! What the planner and its validation measure on a scene at one image size: the path-traced
//! truth with its own noise, a method setting's time and its error beyond that noise, and
//! the Monte Carlo estimators' cost per sample.

use crate::camera::Camera;
use crate::classify::Lut;
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::metric::design_error;
use crate::progress::{NoProgress, Progress};
use crate::registry::Method;
use crate::render::reference::{self, Estimator, ReferenceImage, ReferenceInput, ReferenceParams};
use crate::render::{MethodInput, RenderImage, Rendered};
use crate::scene::Scene;
use crate::volume::Volume;
use std::time::Instant;

/// The scene's camera at another image size, longest side `long_side` (never above the
/// scene's own), the same view: a perspective field of view is vertical and an orthographic
/// scale spans the longer side, so keeping the aspect keeps the view.
pub fn resized(camera: &Camera, long_side: u32) -> Camera {
    let longest = camera.width.max(camera.height);
    let side = long_side.clamp(1, longest);
    let scale = |n: u32| ((n as u64 * side as u64).div_ceil(longest as u64) as u32).max(1);
    Camera {
        width: scale(camera.width),
        height: scale(camera.height),
        ..*camera
    }
}

/// A loaded scene and everything a render of it reads.
pub struct Subject<'a> {
    pub scene: &'a Scene,
    pub volume: &'a Volume,
    pub lut: &'a Lut,
    pub compute: &'a Compute,
}

/// The truth of one camera: the mean image, its standard error and the relative noise.
pub struct Truth {
    pub camera: Camera,
    pub mean: Vec<[f32; 3]>,
    pub background: f32,
    /// Relative RMSE of the mean from its own noise (docs/architecture.md#error-measure).
    pub noise: f64,
    /// The same for one sample per pixel: `noise * sqrt(spp)`.
    pub noise_per_sample: f64,
    pub spp: u32,
}

/// A Monte Carlo render of the subject through `camera`, timed.
pub fn monte_carlo(
    subject: &Subject,
    camera: &Camera,
    estimator: Estimator,
    spp: u32,
    seed: u64,
) -> Result<(ReferenceImage, f64)> {
    let params = ReferenceParams {
        estimator,
        spp,
        seed,
        g: 0.0,
    };
    let started = Instant::now();
    let image = reference::render(
        &ReferenceInput {
            volume: subject.volume,
            lut: subject.lut,
            camera,
            lighting: &subject.scene.lighting,
            params: &params,
        },
        &NoProgress,
    )?;
    Ok((image, started.elapsed().as_secs_f64()))
}

impl Truth {
    /// A Monte Carlo image as the truth of its camera.
    pub fn new(subject: &Subject, camera: Camera, image: &ReferenceImage) -> Result<Self> {
        let background = subject.scene.lighting.background.element_sum() / 3.0;
        let mean: Vec<[f32; 3]> = image.mean.iter().map(|m| [m[0], m[1], m[2]]).collect();
        let (_, _, _, noise) = design_error(&image.mean, &mean, Some(&image.stderr), background)?;
        Ok(Self {
            camera,
            mean,
            background,
            noise,
            noise_per_sample: noise * (image.spp as f64).sqrt(),
            spp: image.spp,
        })
    }

    /// Relative RMSE of `image` beyond the truth's own noise, sqrt(rmse^2 - noise^2), and its
    /// relative bias. `other_noise`: the image's own relative noise, when it has one (a Monte
    /// Carlo image), taken out as well.
    pub fn error(&self, image: &[[f32; 4]], other_noise: f64) -> Result<(f64, f64)> {
        let (_, rmse, bias, _) = design_error(image, &self.mean, None, self.background)?;
        let beyond = rmse * rmse - self.noise * self.noise - other_noise * other_noise;
        Ok((beyond.max(0.0).sqrt(), bias))
    }
}

/// A method rendered through `camera`, lit by the scene's lights that it renders.
pub fn render_through(
    subject: &Subject,
    method: &Method,
    camera: &Camera,
    progress: &dyn Progress,
) -> Result<Rendered> {
    let lighting = method.spec().lights_of(&subject.scene.lighting);
    method.render(&MethodInput {
        volume: subject.volume,
        classification: &subject.scene.classification,
        lut: subject.lut,
        camera,
        lighting: &lighting,
        compute: subject.compute,
        progress,
    })
}

/// A method setting rendered through `camera`: its image and wall time.
pub fn render_method(
    subject: &Subject,
    method: &Method,
    camera: &Camera,
) -> Result<(RenderImage, f64)> {
    let started = Instant::now();
    let rendered = render_through(subject, method, camera, &NoProgress)?;
    Ok((rendered.image, started.elapsed().as_secs_f64()))
}

/// Wall time as a fixed cost plus a cost per unit of work (pixels, or pixel-samples), fitted
/// through two measurements.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CostLaw {
    pub fixed: f64,
    pub per_unit: f64,
}

impl CostLaw {
    /// Through (work, seconds) at two amounts of work; a slope that noise made negative is 0.
    pub fn through(a: (f64, f64), b: (f64, f64)) -> Result<Self> {
        let ((wa, ta), (wb, tb)) = if a.0 <= b.0 { (a, b) } else { (b, a) };
        if wb <= wa {
            return Err(Error::param("plan", "a cost law needs two amounts of work"));
        }
        let per_unit = ((tb - ta) / (wb - wa)).max(0.0);
        Ok(Self {
            fixed: (ta - per_unit * wa).max(0.0),
            per_unit,
        })
    }

    pub fn seconds(&self, work: f64) -> f64 {
        self.fixed + self.per_unit * work
    }
}

/// Pixels of a camera's image.
pub fn pixels(camera: &Camera) -> f64 {
    camera.width as f64 * camera.height as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use glam::Vec3;

    #[test]
    fn resizing_keeps_the_aspect_and_the_rays() {
        let camera = Camera::look_at(
            Vec3::new(3.0, -3.0, 2.0),
            Vec3::ZERO,
            Vec3::Z,
            Projection::Perspective { fov_y: 0.6 },
            400,
            200,
        )
        .unwrap();
        let small = resized(&camera, 64);
        assert_eq!((small.width, small.height), (64, 32));
        // The centre ray of both is the same ray.
        let (a, b) = (camera.ray(199, 99), small.ray(31, 15));
        let (c, d) = (camera.ray(200, 100), small.ray(32, 16));
        let mid = |p: Vec3, q: Vec3| (p + q).normalize();
        assert!((mid(a.dir, c.dir) - mid(b.dir, d.dir)).length() < 1e-4);
        assert_eq!(
            resized(&camera, 4000).width,
            400,
            "never above its own size"
        );
    }

    #[test]
    fn cost_laws_go_through_their_points() {
        let law = CostLaw::through((100.0, 0.3), (1000.0, 1.2)).unwrap();
        assert!((law.fixed - 0.2).abs() < 1e-12 && (law.per_unit - 0.001).abs() < 1e-12);
        assert!((law.seconds(10000.0) - 10.2).abs() < 1e-9);
        let flat = CostLaw::through((1000.0, 0.5), (100.0, 0.6)).unwrap();
        assert_eq!(flat.per_unit, 0.0);
        assert!(CostLaw::through((5.0, 1.0), (5.0, 2.0)).is_err());
    }
}
