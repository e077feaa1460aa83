//! What the tests of the compositing layers (`occlusion`, `shadow`: render::Factor) share: a
//! sphere with a soft edge, and the checks that a layer is premultiplied by the image's
//! coverage and as continuous as it.

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::classify::{
    Classification, ControlPoint, Lut, TransferFunction, TransferFunction1D, ValueUnits,
};
use occlux::render::RenderImage;
use occlux::volume::Volume;

/// A sphere of radius 0.55 in [-1, 1]^3 (n^3 voxels) whose value falls from 1 to 0 smoothly
/// (smoothstep) over the shell 0.35 < r < 0.75: at n = 32, 6.4 voxels wide.
pub fn soft_sphere(n: usize) -> Volume {
    let h = 2.0 / n as f32;
    Volume::from_fn([n; 3], Vec3::splat(h), Vec3::splat(-1.0 + 0.5 * h), |p| {
        let t = ((0.75 - p.length()) / 0.4).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    })
    .unwrap()
}

/// The soft sphere at 32^3 under an extinction of 12 per unit at its centre, and a 48 x 48
/// perspective camera that frames it whole.
pub fn soft_sphere_scene() -> (Volume, Lut, Camera) {
    let volume = soft_sphere(32);
    let lut = linear_extinction(&volume, 12.0);
    let camera = Camera::look_at(
        Vec3::new(2.0, -3.0, 1.2),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.5 },
        48,
        48,
    )
    .unwrap();
    (volume, lut, camera)
}

/// Extinction `sigma` times the value, grey albedo 0.8.
pub fn linear_extinction(volume: &Volume, sigma: f32) -> Lut {
    let tf = TransferFunction1D::new(vec![
        ControlPoint::new(0.0, 0.0, [0.8; 3], [0.0; 3]),
        ControlPoint::new(1.0, sigma, [0.8; 3], [0.0; 3]),
    ])
    .unwrap();
    Classification::new(TransferFunction::OneD(tf), ValueUnits::Raw, 1.0)
        .unwrap()
        .bake(volume)
}

/// The largest difference between horizontally or vertically neighbouring pixels.
pub fn largest_jump(values: &[f32], width: usize) -> f32 {
    let mut jump = 0.0f32;
    for (i, v) in values.iter().enumerate() {
        if i % width + 1 < width {
            jump = jump.max((v - values[i + 1]).abs());
        }
        if let Some(below) = values.get(i + width) {
            jump = jump.max((v - below).abs());
        }
    }
    jump
}

/// Checks the layer `name` of `img` is premultiplied: A is the beauty's alpha to the bit and
/// 0 <= P <= A. Returns (P, A).
pub fn premultiplied(img: &RenderImage, name: &str) -> (Vec<f32>, Vec<f32>) {
    let factor = img.factor(name).expect("the method's layer");
    let (p, a) = (factor.premultiplied(), factor.coverage());
    for (i, rgba) in img.rgba.iter().enumerate() {
        assert_eq!(
            a[i], rgba[3],
            "{name}: pixel {i}: coverage is not the alpha"
        );
        assert!(
            (0.0..=a[i]).contains(&p[i]),
            "{name}: pixel {i}: P {} outside [0, A = {}]",
            p[i],
            a[i]
        );
    }
    (p, a)
}

/// The layer is as continuous as the image: no step between neighbouring pixels of P exceeds
/// `k` times the largest step of the image's alpha. A layer built with a threshold (the factor
/// only where the opacity reaches 0.5, the old at-depth layer) steps by the whole factor at the
/// threshold; the same check on such a layer, made from this one, must fail, or the scene
/// cannot tell the two apart. Returns the two largest steps.
pub fn assert_continuous(img: &RenderImage, name: &str, k: f32) -> (f32, f32) {
    let (p, a) = premultiplied(img, name);
    let width = img.width as usize;
    let (jump_p, jump_a) = (largest_jump(&p, width), largest_jump(&a, width));
    let stepped: Vec<f32> = p
        .iter()
        .zip(&a)
        .map(|(p, a)| if *a >= 0.5 { p / a } else { 0.0 })
        .collect();
    let jump_stepped = largest_jump(&stepped, width);
    println!(
        "{name}: largest step of P {jump_p:.4}, of alpha {jump_a:.4} (ratio {:.2}); \
         thresholded at 0.5: {jump_stepped:.4} (ratio {:.2})",
        jump_p / jump_a,
        jump_stepped / jump_a
    );
    assert!(
        a.iter().any(|a| *a > 0.99) && a.contains(&0.0),
        "{name}: the image shows the whole silhouette"
    );
    assert!(
        jump_p <= k * jump_a,
        "{name}: P steps by {jump_p}, over {k} x alpha's largest step {jump_a}"
    );
    assert!(
        jump_stepped > k * jump_a,
        "{name}: a thresholded layer would pass too ({jump_stepped} vs alpha {jump_a})"
    );
    (jump_p, jump_a)
}
