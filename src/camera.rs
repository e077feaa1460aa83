//! Cameras, with Blender's conventions so that images line up with Cycles pixel for pixel.
//!
//! World space is Blender's: Z up, right-handed. A camera looks from `position` at `target`;
//! `up` fixes the roll (Blender's track-to with -Z forward and Y up). Pixel (i, j), row 0 at the
//! top, is sampled through its centre. Sensor fit is Blender's AUTO: the field of view given as
//! lens and sensor spans the larger image dimension.

use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Perspective or orthographic projection; as JSON `{"type": "perspective", "fov_y": ...}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Projection {
    /// Vertical field of view in radians.
    Perspective { fov_y: f32 },
    /// Extent of the view along the larger image dimension, in world units (Blender's Orthographic Scale).
    Orthographic { scale: f32 },
}

/// A camera and its image size.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub position: Vec3,
    /// Unit vectors of the camera frame: `forward` into the scene, `right` and `up` on the image.
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub projection: Projection,
    pub width: u32,
    pub height: u32,
}

/// A ray with a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// `v` scaled to unit length, or zero for a zero vector: scaled by its largest component
/// first, since the squared length of a vector longer than about 1.8e19 overflows an f32 (a
/// camera 3e30 away from its target would have had no direction).
fn unit(v: Vec3) -> Vec3 {
    let largest = v.abs().max_element();
    if largest > 0.0 {
        (v / largest).normalize_or_zero()
    } else {
        Vec3::ZERO
    }
}

/// Largest image side accepted (keeps buffers within reason: 16384^2 RGBA f32 is 4 GiB).
pub const MAX_IMAGE_SIDE: u32 = 16384;

impl Camera {
    /// A camera at `position` looking at `target`, with `up` giving the roll.
    pub fn look_at(
        position: Vec3,
        target: Vec3,
        up: Vec3,
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        if !position.is_finite() || !target.is_finite() || !up.is_finite() {
            return Err(Error::param(
                "camera",
                "position, target and up must be finite",
            ));
        }
        let towards = target - position;
        if !towards.is_finite() {
            return Err(Error::param(
                "camera",
                format!(
                    "position {position} and target {target} are too far apart for 32-bit \
                     floats: move them closer"
                ),
            ));
        }
        if towards == Vec3::ZERO {
            return Err(Error::param(
                "camera.target",
                "must differ from camera.position",
            ));
        }
        let forward = unit(towards);
        let right = unit(forward.cross(unit(up)));
        if right == Vec3::ZERO {
            return Err(Error::param(
                "camera.up",
                "must not be parallel to the viewing direction",
            ));
        }
        for (key, side) in [("camera.width", width), ("camera.height", height)] {
            if side == 0 || side > MAX_IMAGE_SIDE {
                return Err(Error::param(
                    key,
                    format!("must be in 1..={MAX_IMAGE_SIDE}, got {side}"),
                ));
            }
        }
        match projection {
            Projection::Perspective { fov_y } if !(fov_y > 0.0 && fov_y < std::f32::consts::PI) => {
                return Err(Error::param(
                    "camera.fov_deg",
                    format!("must be in (0, 180) degrees, got {}", fov_y.to_degrees()),
                ))
            }
            Projection::Orthographic { scale } if !(scale > 0.0 && scale.is_finite()) => {
                return Err(Error::param(
                    "camera.ortho_scale",
                    format!("must be positive, got {scale}"),
                ))
            }
            _ => {}
        }
        Ok(Self {
            position,
            forward,
            right,
            up: right.cross(forward),
            projection,
            width,
            height,
        })
    }

    /// This camera moved (and for an orthographic one, scaled) so that the box [lo, hi] fills
    /// the frame with `margin` of each half of the frame left free, seen along the same
    /// direction with the same roll, projection and image size, aimed at the box's centre.
    /// Every corner of the box projects inside the margin, and one touches it.
    pub fn framing(&self, lo: Vec3, hi: Vec3, margin: f32) -> Result<Camera> {
        let centre = 0.5 * (lo + hi);
        let corners = box_corners(lo, hi).map(|c| c - centre);
        let (fx, fy) = self.half_extent();
        let keep = 1.0 - margin;
        // How far the box reaches towards the camera, and past it at the far side.
        let near_reach = corners
            .iter()
            .map(|q| -q.dot(self.forward))
            .fold(0.0, f32::max);
        let size = (hi - lo).length().max(f32::MIN_POSITIVE);
        let (distance, projection) = match self.projection {
            Projection::Perspective { .. } => {
                // Corner q at depth d + q.f must satisfy |q.r| <= fx keep (d + q.f), and the
                // same for up; the nearest distance meeting all eight.
                let d = corners
                    .iter()
                    .map(|q| {
                        let need = (q.dot(self.right).abs() / (fx * keep))
                            .max(q.dot(self.up).abs() / (fy * keep));
                        need - q.dot(self.forward)
                    })
                    .fold(0.0, f32::max);
                // In front of the box even for a box seen edge-on.
                (d.max(near_reach + 1e-3 * size), self.projection)
            }
            Projection::Orthographic { scale } => {
                let reach = |axis: Vec3| {
                    corners
                        .iter()
                        .map(|q| q.dot(axis).abs())
                        .fold(0.0, f32::max)
                };
                let grow = (reach(self.right) / (fx * keep)).max(reach(self.up) / (fy * keep));
                let scale = (scale * grow).max(1e-6 * size);
                (near_reach + 0.5 * size, Projection::Orthographic { scale })
            }
        };
        Camera::look_at(
            centre - self.forward * distance,
            centre,
            self.up,
            projection,
            self.width,
            self.height,
        )
    }

    /// The vertical field of view for Blender's lens and sensor width with sensor fit AUTO
    /// (the sensor spans the larger image dimension).
    pub fn fov_y_from_lens(lens_mm: f32, sensor_mm: f32, width: u32, height: u32) -> Result<f32> {
        if !(lens_mm > 0.0 && lens_mm.is_finite()) {
            return Err(Error::param(
                "camera.lens_mm",
                format!("must be positive, got {lens_mm}"),
            ));
        }
        if !(sensor_mm > 0.0 && sensor_mm.is_finite()) {
            return Err(Error::param(
                "camera.sensor_mm",
                format!("must be positive, got {sensor_mm}"),
            ));
        }
        let tan_large = 0.5 * sensor_mm / lens_mm;
        let tan_y = if width >= height {
            tan_large * height as f32 / width as f32
        } else {
            tan_large
        };
        Ok(2.0 * tan_y.atan())
    }

    /// The camera as JSON: its fields and the image plane's half extents (`half_extent`), what
    /// the EXR header's `occlux/camera` and the Python package's scene description hold.
    pub fn describe(&self) -> serde_json::Value {
        let mut value = crate::json::tree(self);
        let (hx, hy) = self.half_extent();
        value["half_extent"] = serde_json::json!([hx, hy]);
        value
    }

    /// Half extents of the image plane: tangents of the half angles (perspective) or half sizes
    /// in world units (orthographic), as (x, y).
    pub fn half_extent(&self) -> (f32, f32) {
        let aspect = self.width as f32 / self.height as f32;
        match self.projection {
            Projection::Perspective { fov_y } => {
                let ty = (0.5 * fov_y).tan();
                (ty * aspect, ty)
            }
            Projection::Orthographic { scale } => {
                let half = 0.5 * scale;
                if aspect >= 1.0 {
                    (half, half / aspect)
                } else {
                    (half * aspect, half)
                }
            }
        }
    }

    /// The ray through the centre of pixel (i, j), row 0 at the top.
    pub fn ray(&self, i: u32, j: u32) -> Ray {
        let (hx, hy) = self.half_extent();
        let sx = ((i as f32 + 0.5) / self.width as f32 * 2.0 - 1.0) * hx;
        let sy = (1.0 - (j as f32 + 0.5) / self.height as f32 * 2.0) * hy;
        match self.projection {
            Projection::Perspective { .. } => Ray {
                origin: self.position,
                dir: (self.forward + sx * self.right + sy * self.up).normalize(),
            },
            Projection::Orthographic { .. } => Ray {
                origin: self.position + sx * self.right + sy * self.up,
                dir: self.forward,
            },
        }
    }

    /// The side of a pixel in world units at `p`: at its depth for a perspective camera.
    pub fn pixel_footprint(&self, p: Vec3) -> f32 {
        let (_, hy) = self.half_extent();
        let span = 2.0 * hy / self.height as f32;
        match self.projection {
            Projection::Perspective { .. } => span * (p - self.position).dot(self.forward).abs(),
            Projection::Orthographic { .. } => span,
        }
    }

    /// Whether rays share one origin (perspective) rather than one direction.
    pub fn is_perspective(&self) -> bool {
        matches!(self.projection, Projection::Perspective { .. })
    }
}

/// The eight corners of the axis-aligned box [lo, hi] (bit 0 of the index picks x, bit 1 y,
/// bit 2 z).
pub fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|c| {
        let pick = |bit: usize, a: f32, b: f32| if c & bit == 0 { a } else { b };
        Vec3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        )
    })
}

/// Distances (t_near, t_far) where a ray enters and leaves an axis-aligned box, if it hits it
/// in front of the origin; t_near is clamped to 0 when the origin is inside.
pub fn intersect_box(ray: &Ray, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let inv = ray.dir.recip();
    let t0 = (lo - ray.origin) * inv;
    let t1 = (hi - ray.origin) * inv;
    // min/max with NaN (0 * inf for a ray in a face plane) fall back to the other operand.
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element();
    (far > near).then_some((near, far))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blender_lens_to_fov() {
        // The benchmark camera: 65 mm lens, 36 mm sensor, square image.
        let fov = Camera::fov_y_from_lens(65.0, 36.0, 256, 256).unwrap();
        assert!((fov - 2.0 * (18.0f32 / 65.0).atan()).abs() < 1e-6);
        // Landscape: the sensor spans the width, so the vertical angle shrinks by the aspect.
        let fov = Camera::fov_y_from_lens(50.0, 36.0, 200, 100).unwrap();
        assert!(((0.5 * fov).tan() - 0.18).abs() < 1e-6);
    }

    #[test]
    fn centre_pixel_looks_at_target_and_corners_span_the_fov() {
        let fov = 60f32.to_radians();
        let cam = Camera::look_at(
            Vec3::new(0.0, -5.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            Projection::Perspective { fov_y: fov },
            3,
            3,
        )
        .unwrap();
        assert!((cam.ray(1, 1).dir - Vec3::Y).length() < 1e-6);
        // Row 0 is the top: its rays point up (+Z); column 0 is the left (-X seen from -Y).
        let top_left = cam.ray(0, 0).dir;
        assert!(top_left.z > 0.0 && top_left.x < 0.0);
        let edge = (0.5 * fov).tan() * 2.0 / 3.0;
        assert!((top_left.z / top_left.y - edge).abs() < 1e-5);
    }

    #[test]
    fn box_intersection() {
        let ray = Ray {
            origin: Vec3::new(-3.0, 0.5, 0.5),
            dir: Vec3::X,
        };
        let (a, b) = intersect_box(&ray, Vec3::ZERO, Vec3::ONE).unwrap();
        assert!((a - 3.0).abs() < 1e-6 && (b - 4.0).abs() < 1e-6);
        let inside = Ray {
            origin: Vec3::splat(0.5),
            dir: Vec3::Z,
        };
        assert_eq!(
            intersect_box(&inside, Vec3::ZERO, Vec3::ONE),
            Some((0.0, 0.5))
        );
        let miss = Ray {
            origin: Vec3::new(-3.0, 2.0, 0.5),
            dir: Vec3::X,
        };
        assert!(intersect_box(&miss, Vec3::ZERO, Vec3::ONE).is_none());
    }

    #[test]
    fn rejects_degenerate_cameras() {
        let persp = Projection::Perspective { fov_y: 1.0 };
        assert!(Camera::look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Z, persp, 8, 8).is_err());
        let err = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Z, persp, 8, 8).unwrap_err();
        assert!(err.to_string().contains("camera.up"));
        let err = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Z, persp, 0, 8).unwrap_err();
        assert!(err.to_string().contains("camera.width"));
        // Far but finite: a direction (was "target must differ from position", the squared
        // length having overflowed), and a named error where the difference overflows.
        let far = Camera::look_at(
            Vec3::new(3.2e30, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            persp,
            8,
            8,
        );
        assert!((far.unwrap().forward + Vec3::X).length() < 1e-6);
        let err = Camera::look_at(Vec3::splat(3e38), Vec3::splat(-3e38), Vec3::Z, persp, 8, 8)
            .unwrap_err()
            .to_string();
        assert!(err.contains("too far apart"), "{err}");
        let tiny_up = Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 0.0, 1e-30), persp, 8, 8);
        assert!((tiny_up.unwrap().up - Vec3::Z).length() < 1e-6);
    }
}
