//! What the CPU/GPU twin tests share: the adapter (a test fails without one), the cameras and
//! the image comparison.

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::gpu::{shared_context, GpuContext};
use occlux::render::{RenderImage, BACKGROUND_DEPTH};
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

/// The largest difference, relative to the peak radiance, that an outlier pixel may have.
pub const OUTLIER_CAP: f32 = 0.01;

/// Checks that the twins' images agree: per pixel, RGBA within `relative` times the peak
/// radiance (at least 1), depth within 1e-3 world units (both or neither background), and the
/// occlusion layers' P and A each within `occlusion` when given; pixels beyond that (a
/// transmittance crossing 0.5 or the early-termination threshold in one twin only, within
/// rounding) may be up to 0.5 % of the image, and even these must be within [`OUTLIER_CAP`]
/// of the peak in RGBA and in the layer: a depth flip moves no colour, and a ray terminated
/// one sample earlier drops at most the threshold's share (0.01 at most in the tests) of
/// light, so a larger difference is a defect however rare. Every pixel of `b` must be finite.
/// Returns the worst RGBA difference among the pixels within tolerance.
pub fn assert_same(a: &RenderImage, b: &RenderImage, relative: f32, occlusion: Option<f32>) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let peak = a
        .rgba
        .iter()
        .flat_map(|p| p[..3].iter().copied())
        .fold(1.0f32, f32::max);
    let tolerance = relative * peak;
    let layers = occlusion.map(|limit| {
        let layer = |img: &RenderImage| {
            img.factor("occlusion")
                .expect("an occlusion layer")
                .values
                .clone()
        };
        (limit, layer(a), layer(b))
    });
    let mut worst = 0.0f32;
    let mut worst_occlusion = 0.0f32;
    let mut outliers = 0;
    let mut worst_outlier = 0.0f32;
    for (i, (pa, pb)) in a.rgba.iter().zip(&b.rgba).enumerate() {
        let diff = pa
            .iter()
            .zip(pb)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        let depth_ok = (a.depth[i] == BACKGROUND_DEPTH) == (b.depth[i] == BACKGROUND_DEPTH)
            && (a.depth[i] - b.depth[i]).abs() <= 1e-3;
        assert!(pb.iter().all(|x| x.is_finite()), "pixel {i}: {pb:?}");
        let (occlusion_diff, occlusion_ok) = match &layers {
            Some((limit, oa, ob)) => {
                assert!(
                    ob[i].iter().all(|v| v.is_finite()),
                    "pixel {i}: occlusion {:?}",
                    ob[i]
                );
                let d = (oa[i][0] - ob[i][0]).abs().max((oa[i][1] - ob[i][1]).abs());
                (d, d <= *limit)
            }
            None => (0.0, true),
        };
        if diff > tolerance || !depth_ok || !occlusion_ok {
            outliers += 1;
            worst_outlier = worst_outlier.max(diff / peak).max(occlusion_diff);
        } else {
            worst = worst.max(diff);
            worst_occlusion = worst_occlusion.max(occlusion_diff);
        }
    }
    let allowed = a.rgba.len() / 200;
    assert!(
        outliers <= allowed,
        "{outliers} pixels differ beyond tolerance {tolerance} (allowed {allowed})"
    );
    assert!(
        worst_outlier <= OUTLIER_CAP,
        "an outlier differs by {worst_outlier} of the peak (cap {OUTLIER_CAP})"
    );
    println!(
        "worst RGBA difference {worst:.3e} (peak {peak:.3}), worst occlusion difference \
         {worst_occlusion:.3e}, {outliers} outliers (worst {worst_outlier:.3e} of the peak)"
    );
    worst
}

/// An orthographic view from the side, 40 x 32.
pub fn orthographic() -> Camera {
    Camera::look_at(
        Vec3::new(0.3, -4.0, 0.2),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Orthographic { scale: 2.5 },
        40,
        32,
    )
    .unwrap()
}

/// A wide perspective view from inside the unit box, 32 x 40.
pub fn inside() -> Camera {
    Camera::look_at(
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(1.0, 1.0, 0.3),
        Vec3::Z,
        Projection::Perspective {
            fov_y: 70f32.to_radians(),
        },
        32,
        40,
    )
    .unwrap()
}
