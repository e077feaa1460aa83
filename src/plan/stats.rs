//! Cheap statistics of a loaded scene, for the planner's explanation: which lights, how much
//! light the medium scatters rather than absorbs, and how deep it is along the view and
//! towards the lights. They cost a coarse grid of rays, milliseconds, and say why a scene
//! needs shadows or multiple scattering; the errors themselves come from the pilot.

use crate::camera::{Camera, Ray};
use crate::classify::Lut;
use crate::lights::{Light, Lighting};
use crate::optics::medium::Medium;
use crate::volume::Volume;
use glam::Vec3;
use serde::Serialize;

/// Rays per image side of the coarse grid.
const GRID: u32 = 16;
/// Optical depth below which a ray counts as passing through empty space.
const SEEN: f32 = 0.01;

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SceneStats {
    /// Lights by kind: ambient, directional, point.
    pub ambient: usize,
    pub directional: usize,
    pub point: usize,
    /// The mean single-scattering albedo weighted by extinction over the voxels: the share of
    /// each interaction that scatters (0: absorbing, multiple scattering needless).
    pub albedo: f32,
    /// Median optical depth through the volume along the view, over coarse rays that meet
    /// matter (0 if none do).
    pub view_depth: f32,
    /// Median optical depth from where those rays are half opaque towards the suns and lamps
    /// (the shadows' depth); None without suns or lamps.
    pub light_depth: Option<f32>,
}

impl SceneStats {
    pub fn measure(volume: &Volume, lut: &Lut, camera: &Camera, lighting: &Lighting) -> Self {
        let count = |kind| lighting.lights.iter().filter(|l| l.kind() == kind).count();
        let medium = Medium::new(volume, lut);
        let step = volume.spacing().min_element();
        let mut view = vec![];
        let mut towards = vec![];
        for j in 0..GRID {
            for i in 0..GRID {
                let (x, y) = (
                    (i * camera.width / GRID).min(camera.width - 1),
                    (j * camera.height / GRID).min(camera.height - 1),
                );
                let ray = camera.ray(x, y);
                let (depth, half) = march(&medium, &ray, f32::INFINITY, step);
                if depth < SEEN {
                    continue;
                }
                view.push(depth);
                let Some(p) = half else { continue };
                for light in &lighting.lights {
                    let (dir, reach) = match *light {
                        Light::Ambient { .. } => continue,
                        Light::Directional { to_light, .. } => (to_light, f32::INFINITY),
                        Light::Point { position, .. } => {
                            ((position - p).normalize_or_zero(), (position - p).length())
                        }
                    };
                    let shadow = Ray { origin: p, dir };
                    towards.push(march(&medium, &shadow, reach, step).0);
                }
            }
        }
        use crate::lights::LightKind as K;
        Self {
            ambient: count(K::Ambient),
            directional: count(K::Directional),
            point: count(K::Point),
            albedo: mean_albedo(volume, &medium),
            view_depth: median(&mut view).unwrap_or(0.0),
            light_depth: if count(K::Directional) + count(K::Point) == 0 {
                None
            } else {
                Some(median(&mut towards).unwrap_or(0.0))
            },
        }
    }

    /// One line for people.
    pub fn describe(&self) -> String {
        let light = self
            .light_depth
            .map_or(String::new(), |d| format!(", towards the lights {d:.2}"));
        format!(
            "lights: {} ambient, {} sun, {} lamp; albedo {:.2}; optical depth along the view \
             {:.2}{light} (medians)",
            self.ambient, self.directional, self.point, self.albedo, self.view_depth
        )
    }
}

/// Optical depth along `ray` up to `reach` (midpoint rule at `step`), and where the view's
/// opacity passes one half.
fn march(medium: &Medium, ray: &Ray, reach: f32, step: f32) -> (f32, Option<Vec3>) {
    let Some((near, far)) = medium.clip(ray) else {
        return (0.0, None);
    };
    let (near, far) = (near.max(0.0), far.min(reach));
    let (mut depth, mut half) = (0.0f32, None);
    let mut t = near + 0.5 * step;
    while t < far {
        let p = ray.origin + t * ray.dir;
        depth += medium.sigma_t(p) * step;
        if half.is_none() && depth > std::f32::consts::LN_2 {
            half = Some(p);
        }
        t += step;
    }
    (depth, half)
}

/// Most points per axis [`mean_albedo`] reads.
const ALBEDO_POINTS: usize = 64;

/// The extinction-weighted mean of the albedo's channels over voxel centres (every voxel of
/// a volume up to 64 per axis, a strided subset beyond), gradient included for 2D tables.
fn mean_albedo(volume: &Volume, medium: &Medium) -> f32 {
    let dims = volume.dims();
    let stride = dims.map(|n| n.div_ceil(ALBEDO_POINTS).max(1));
    let (origin, spacing) = (volume.origin(), volume.spacing());
    let (mut weighted, mut total) = (0.0f64, 0.0f64);
    for k in (0..dims[2]).step_by(stride[2]) {
        for j in (0..dims[1]).step_by(stride[1]) {
            for i in (0..dims[0]).step_by(stride[0]) {
                let p = origin + Vec3::new(i as f32, j as f32, k as f32) * spacing;
                let optical = medium.optical(p);
                let s = optical.sigma_t as f64;
                weighted += s * optical.albedo.element_sum() as f64 / 3.0;
                total += s;
            }
        }
    }
    if total > 0.0 {
        (weighted / total) as f32
    } else {
        0.0
    }
}

fn median(values: &mut [f32]) -> Option<f32> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f32::total_cmp);
    Some(values[values.len() / 2])
}
