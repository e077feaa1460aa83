//! The image-plane sweep: in which order lines of pixels are rendered so that, along every light
//! ray, the pixels nearer the light come first.
//!
//! A light ray is a line in space, so its image is a line (or a point). Every light ray's image
//! passes through one image point P, the projection of the light: the light's position, or for
//! a directional light the vanishing point of its direction. Rays move away from P on the image
//! when the light is in front of the camera (P is a source) and towards it when the light is
//! behind the camera plane (P is a sink: light travelling away from the camera converges on
//! its vanishing point). Lines are square rings around P, ordered by Chebyshev distance: along
//! any straight line through P that distance changes monotonically, so every light ray's image
//! crosses the rings in order. The four sides of a ring are the paper's four zones with their
//! 45-degree borders, swept at once. When P is at infinity (an orthographic camera under a
//! directional light, or a light in the camera's plane) the images are parallel and the lines
//! are columns or rows, whichever the images cross more steeply. When every light ray's image
//! is a point (an orthographic camera looking along a directional light) no order helps and all
//! pixels form one line: each ray then carries its own light (see `cpu`).

use crate::camera::{Camera, Projection};
use crate::lights::Light;
use glam::{Vec2, Vec3};

/// How light rays cross the image (pixel coordinates, x right, y down, pixel (i, j) centred at
/// (i + 0.5, j + 0.5)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The rays' images radiate from `centre`, away from it when `outward`, else towards it.
    Radial { centre: Vec2, outward: bool },
    /// Parallel images, moving along the unit vector `dir`.
    Parallel { dir: Vec2 },
    /// Every ray's image is a point.
    Degenerate,
}

/// Beyond this distance from the image (in image sizes) a radial centre is treated as at
/// infinity: the rings are then straight over the image anyway, and f32 keys stay exact.
const FAR: f32 = 1.0e4;

impl Shape {
    /// How the rays of `light` cross the image of `camera`; None for ambient light.
    pub fn of(light: &Light, camera: &Camera) -> Option<Self> {
        // The light as a homogeneous point: its position, or its direction at infinity.
        let (point, w) = match *light {
            Light::Ambient { .. } => return None,
            Light::Directional { to_light, .. } => (to_light, 0.0),
            Light::Point { position, .. } => (position, 1.0),
        };
        let (hx, hy) = camera.half_extent();
        let (width, height) = (camera.width as f32, camera.height as f32);
        // Image-plane units to pixels (y flips: rows go down).
        let scale = Vec2::new(0.5 * width / hx, -0.5 * height / hy);
        let centre_px = 0.5 * Vec2::new(width, height);
        let frame =
            |v: Vec3| Vec3::new(v.dot(camera.right), v.dot(camera.up), v.dot(camera.forward));
        let size = width.max(height);
        match camera.projection {
            Projection::Perspective { .. } => {
                let c = frame(point - w * camera.position);
                let on_plane = Vec2::new(c.x, c.y) * scale;
                // P = centre + on_plane / c.z; when that is far off the image, the rings are
                // parallel lines moving away from the side the light is on.
                if c.z.abs() * FAR * size > on_plane.length() {
                    Some(Shape::Radial {
                        centre: centre_px + on_plane / c.z,
                        outward: c.z > 0.0,
                    })
                } else {
                    let dir = -on_plane.normalize_or_zero();
                    Some(if dir == Vec2::ZERO {
                        Shape::Degenerate
                    } else {
                        Shape::Parallel { dir }
                    })
                }
            }
            Projection::Orthographic { .. } => {
                let c = frame(point - w * camera.position);
                let on_plane = Vec2::new(c.x, c.y) * scale;
                if w == 0.0 {
                    // A directional light: every ray's image moves against the light's side.
                    let dir = -on_plane;
                    Some(if dir.length() <= 1e-6 * scale.abs().max_element() {
                        Shape::Degenerate
                    } else {
                        Shape::Parallel {
                            dir: dir.normalize(),
                        }
                    })
                } else {
                    Some(Shape::Radial {
                        centre: centre_px + on_plane,
                        outward: true,
                    })
                }
            }
        }
    }
}

/// Pixels grouped into lines, in sweep order: line `l` holds the pixel indices (`x + width * y`)
/// `pixels[starts[l]..starts[l + 1]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Lines {
    pub pixels: Vec<u32>,
    pub starts: Vec<u32>,
}

impl Lines {
    /// The lines of a `width` x `height` image for `shape`. The first line is one pixel wide
    /// (the ring or column nearest the light's side); after it, `line_width` rings or columns
    /// form one line.
    pub fn new(shape: Shape, width: u32, height: u32, line_width: u32) -> Self {
        let line_width = line_width.max(1) as i64;
        let key = |x: u32, y: u32| -> i64 {
            let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            match shape {
                Shape::Radial { centre, outward } => {
                    let d = (p - centre).abs().max_element().floor() as i64;
                    if outward {
                        d
                    } else {
                        -d
                    }
                }
                Shape::Parallel { dir } => {
                    if dir.x.abs() >= dir.y.abs() {
                        (p.x * dir.x.signum()).floor() as i64
                    } else {
                        (p.y * dir.y.signum()).floor() as i64
                    }
                }
                Shape::Degenerate => 0,
            }
        };
        let mut keyed: Vec<(i64, u32)> = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| (key(x, y), x + width * y))
            .collect();
        keyed.sort_unstable();
        let first = keyed.first().map_or(0, |k| k.0);
        let line = |k: i64| match k - first {
            0 => 0,
            r => 1 + (r - 1) / line_width,
        };
        let mut starts = Vec::new();
        let mut previous = None;
        for (index, &(k, _)) in keyed.iter().enumerate() {
            let l = line(k);
            if previous != Some(l) {
                starts.push(index as u32);
                previous = Some(l);
            }
        }
        starts.push(keyed.len() as u32);
        Self {
            pixels: keyed.into_iter().map(|(_, p)| p).collect(),
            starts,
        }
    }

    pub fn count(&self) -> usize {
        self.starts.len() - 1
    }

    /// The pixels of line `l`.
    pub fn line(&self, l: usize) -> &[u32] {
        &self.pixels[self.starts[l] as usize..self.starts[l + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(projection: Projection) -> Camera {
        Camera::look_at(
            Vec3::new(0.0, -4.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            projection,
            40,
            30,
        )
        .unwrap()
    }

    /// Where a world point lands on the image, in pixels (perspective: in front of the camera).
    fn project(camera: &Camera, p: Vec3) -> Vec2 {
        let (hx, hy) = camera.half_extent();
        let v = p - camera.position;
        let (x, y) = match camera.projection {
            Projection::Perspective { .. } => {
                let z = v.dot(camera.forward);
                (v.dot(camera.right) / z, v.dot(camera.up) / z)
            }
            Projection::Orthographic { .. } => (v.dot(camera.right), v.dot(camera.up)),
        };
        Vec2::new(
            (x / hx + 1.0) * 0.5 * camera.width as f32,
            (1.0 - y / hy) * 0.5 * camera.height as f32,
        )
    }

    /// Along sampled light rays through the volume's region, the image moves from line to line
    /// in sweep order: the line index never decreases away from the light.
    fn assert_light_rays_cross_lines_in_order(light: Light, projection: Projection) {
        let camera = camera(projection);
        let shape = Shape::of(&light, &camera).unwrap();
        let lines = Lines::new(shape, camera.width, camera.height, 1);
        let mut line_of = vec![0usize; (camera.width * camera.height) as usize];
        for l in 0..lines.count() {
            for &p in lines.line(l) {
                line_of[p as usize] = l;
            }
        }
        let pixel = |q: Vec2| {
            let (i, j) = (q.x.floor(), q.y.floor());
            (i >= 0.0 && j >= 0.0 && i < camera.width as f32 && j < camera.height as f32)
                .then(|| line_of[(i as u32 + camera.width * j as u32) as usize])
        };
        let mut checked = 0;
        for start in [
            Vec3::new(-0.7, 0.3, 0.2),
            Vec3::new(0.4, -0.5, -0.6),
            Vec3::new(0.1, 0.6, 0.5),
        ] {
            let travel = match light {
                Light::Directional { to_light, .. } => -to_light,
                Light::Point { position, .. } => (start - position).normalize(),
                Light::Ambient { .. } => unreachable!(),
            };
            let mut last = None;
            for step in -40..40 {
                let p = start + travel * (step as f32 * 0.02);
                if (p - camera.position).dot(camera.forward) <= 0.1 {
                    continue;
                }
                if let Some(l) = pixel(project(&camera, p)) {
                    if let Some(before) = last {
                        assert!(l >= before, "{light:?} {shape:?}: line {before} then {l}");
                    }
                    last = Some(l);
                    checked += 1;
                }
            }
        }
        assert!(checked > 20, "{light:?}: the rays missed the image");
    }

    #[test]
    fn light_rays_cross_the_lines_in_sweep_order() {
        let perspective = Projection::Perspective { fov_y: 0.6 };
        let orthographic = Projection::Orthographic { scale: 2.5 };
        let lights = [
            // A sun behind the viewer (a sink), in front of it (a source), beside it (parallel).
            Vec3::new(0.3, -1.0, 0.5),
            Vec3::new(-0.4, 1.0, 0.3),
            Vec3::new(1.0, 0.0, 0.4),
        ]
        .map(|d| Light::Directional {
            to_light: d.normalize(),
            irradiance: Vec3::ONE,
        });
        let lamps = [
            Vec3::new(1.5, -2.0, 1.0),
            Vec3::new(-0.5, 3.0, 0.5),
            Vec3::new(0.2, 0.1, 0.0),
            Vec3::new(2.0, -6.0, 1.0),
        ]
        .map(|position| Light::Point {
            position,
            intensity: Vec3::ONE,
        });
        for light in lights.iter().chain(&lamps) {
            assert_light_rays_cross_lines_in_order(*light, perspective);
            assert_light_rays_cross_lines_in_order(*light, orthographic);
        }
    }

    #[test]
    fn a_sun_along_an_orthographic_view_is_degenerate() {
        let camera = camera(Projection::Orthographic { scale: 2.0 });
        for to_light in [Vec3::Y, Vec3::NEG_Y] {
            let light = Light::Directional {
                to_light,
                irradiance: Vec3::ONE,
            };
            let shape = Shape::of(&light, &camera).unwrap();
            assert_eq!(shape, Shape::Degenerate);
            assert_eq!(Lines::new(shape, 40, 30, 1).count(), 1);
        }
    }

    #[test]
    fn the_first_line_is_one_pixel_wide_and_the_rest_line_width() {
        let shape = Shape::Parallel { dir: Vec2::X };
        let lines = Lines::new(shape, 10, 3, 4);
        let widths: Vec<usize> = (0..lines.count())
            .map(|l| lines.line(l).len() / 3)
            .collect();
        assert_eq!(widths, [1, 4, 4, 1]);
        let mut all = lines.pixels.clone();
        all.sort_unstable();
        assert_eq!(all, (0..30).collect::<Vec<u32>>());
        let ring = Lines::new(
            Shape::Radial {
                centre: Vec2::new(5.0, 5.0),
                outward: true,
            },
            10,
            10,
            1,
        );
        assert_eq!(ring.line(0).len(), 4, "the 2 x 2 pixels around a corner");
    }
}
