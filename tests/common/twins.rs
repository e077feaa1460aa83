//! What the CPU/GPU twin tests share: the adapter (a test fails without one) and the camera.

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::gpu::{shared_context, GpuContext};
use std::sync::Arc;

/// The shared GPU context; panics with the way to get a driver when no adapter opens.
pub fn ctx() -> Arc<GpuContext> {
    shared_context().unwrap_or_else(|e| {
        panic!("GPU tests need an adapter (apt-get install mesa-vulkan-drivers): {e}")
    })
}

/// A square perspective view of the unit box from above a corner.
pub fn perspective(side: u32) -> Camera {
    Camera::look_at(
        Vec3::new(3.2, -3.2, 2.6),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective {
            fov_y: 36f32.to_radians(),
        },
        side,
        side,
    )
    .unwrap()
}
