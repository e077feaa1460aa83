//! The view the renderers share (shaders/shared/view.wgsl's `View`): camera, image and the volume's
//! placement, laid out as WGSL lays out a uniform (vec3 at 16-byte alignment; the padding
//! fields fill what WGSL leaves implicit).

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, UVec3, Vec2, Vec3};

use crate::camera::Camera;
use crate::volume::Volume;

/// shaders/shared/view.wgsl's `View`, field for field.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ViewUniform {
    position: Vec3,
    /// 1 perspective, 0 orthographic.
    perspective: u32,
    forward: Vec3,
    _pad0: u32,
    right: Vec3,
    _pad1: u32,
    up: Vec3,
    _pad2: u32,
    half_extent: Vec2,
    /// Width and height in pixels.
    size: UVec2,
    box_lo: Vec3,
    _pad3: u32,
    box_hi: Vec3,
    _pad4: u32,
    origin: Vec3,
    _pad5: u32,
    spacing: Vec3,
    _pad6: u32,
    dims: UVec3,
    _pad7: u32,
}

impl ViewUniform {
    pub fn new(cam: &Camera, volume: &Volume) -> Self {
        let (hx, hy) = cam.half_extent();
        let (lo, hi) = volume.bounds();
        let [nx, ny, nz] = volume.dims();
        Self {
            position: cam.position,
            perspective: u32::from(cam.is_perspective()),
            forward: cam.forward,
            right: cam.right,
            up: cam.up,
            half_extent: Vec2::new(hx, hy),
            size: UVec2::new(cam.width, cam.height),
            box_lo: lo,
            box_hi: hi,
            origin: volume.origin(),
            spacing: volume.spacing(),
            dims: UVec3::new(nx as u32, ny as u32, nz as u32),
            ..Self::zeroed()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors;

    #[test]
    fn view_matches_the_shader() {
        assert_mirrors!(
            ViewUniform,
            crate::gpu::shader::VIEW,
            "View",
            [
                position,
                perspective,
                forward,
                right,
                up,
                half_extent,
                size,
                box_lo,
                box_hi,
                origin,
                spacing,
                dims
            ]
        );
    }
}
