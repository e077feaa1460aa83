//! Directional occlusion shading (CPU twin) against closed forms, and its stability cases.
//!
//! On a box of homogeneous material seen face on by an orthographic camera, every pixel of a
//! slab holds the same (V, tau), so bilinear reads and edge clamping change nothing and the
//! slice recursion has a closed form: with a = exp(-sigma d) the slab transmittance and
//! m = 1/n^2 sum_s exp(-sigma l_s) the cone's mean attenuation per slab (m = a for theta = 0
//! or the approximated distance), slab k is lit by V_k = m^k and seen through T_k = a^k, so
//! `L = L_a albedo (1 - a) sum_{k<N} (a m)^k + a^N L_b`; self-occlusion multiplies the lit
//! term by sqrt(a), the light's transmittance through the front half of the sample's slab.

mod common;
use common::layers::{assert_continuous, linear_extinction, premultiplied, soft_sphere_scene};

use glam::Vec3;
use occlux::camera::{Camera, Projection};
use occlux::classify::{
    presets, Classification, ControlPoint, Lut, TransferFunction, TransferFunction1D, ValueUnits,
    LUT_STRIDE,
};
use occlux::lights::{Light, Lighting};
use occlux::progress::{NoProgress, Progress};
use occlux::render::dos::{
    cpu, disc_grid, ClipPlane, ConeDistance, ConeSampling, DosInput, DosParams, Formulation,
};
use occlux::render::{RenderImage, BACKGROUND_DEPTH};
use occlux::volume::{phantom, Volume};
use occlux::Error;

const AMBIENT: f32 = 0.8;
const ALBEDO: f32 = 0.7;
const BACKGROUND: f32 = 0.25;

/// A constant volume filling [-1, 1]^3 (8^3 voxels of spacing 0.25).
fn cube() -> Volume {
    Volume::new(
        [8; 3],
        Vec3::splat(0.25),
        Vec3::splat(-0.875),
        vec![1.0; 512],
    )
    .unwrap()
}

/// Extinction `sigma` everywhere, grey albedo.
fn homogeneous(volume: &Volume, sigma: f32) -> Lut {
    let tf = TransferFunction1D::new(vec![
        ControlPoint::new(0.0, sigma, [ALBEDO; 3], [0.0; 3]),
        ControlPoint::new(1.0, sigma, [ALBEDO; 3], [0.0; 3]),
    ])
    .unwrap();
    Classification::new(TransferFunction::OneD(tf), ValueUnits::Normalized, 1.0)
        .unwrap()
        .bake(volume)
}

fn lighting() -> Lighting {
    Lighting {
        lights: vec![Light::Ambient {
            radiance: Vec3::splat(AMBIENT),
        }],
        background: Vec3::splat(BACKGROUND),
    }
}

/// Orthographic, looking down -Z from z = 3 at the middle of the cube's top face.
fn top_camera(side: u32) -> Camera {
    Camera::look_at(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { scale: 1.0 },
        side,
        side,
    )
    .unwrap()
}

fn render(volume: &Volume, lut: &Lut, camera: &Camera, params: &DosParams) -> RenderImage {
    let lighting = lighting();
    let input = DosInput {
        volume,
        lut,
        camera,
        lighting: &lighting,
        params,
    };
    cpu::render(&input, &NoProgress).unwrap()
}

/// The closed form of the module docs for the cube's depth of 2.
fn slab_closed_form(sigma: f32, params: &DosParams) -> f32 {
    let d = params.slice_distance.unwrap() as f64;
    let n = (2.0 / d).round() as i32;
    let a = (-(sigma as f64) * d).exp();
    let lit = (AMBIENT * ALBEDO) as f64 * slab_occlusion_closed_form(sigma, params);
    (lit + a.powi(n) * BACKGROUND as f64) as f32
}

/// Each cone sample's path length through a slab of depth d, from the sample's radius rho on
/// the unit disc (the n x n grid): with area sampling it lands rho d tan(theta) from the pixel,
/// a path of sqrt(d^2 + r^2); with solid-angle sampling it looks along cos(phi) =
/// 1 - rho^2 (1 - cos(theta)), a path of d / cos(phi).
fn sample_lengths(params: &DosParams) -> Vec<f64> {
    let d = params.slice_distance.unwrap() as f64;
    let theta = (params.theta_deg as f64).to_radians();
    disc_grid(params.grid)
        .iter()
        .map(|q| {
            let rho = q.length() as f64;
            match params.sampling {
                ConeSampling::Area => (d * d + (rho * d * theta.tan()).powi(2)).sqrt(),
                ConeSampling::SolidAngle => d / (1.0 - rho * rho * (1.0 - theta.cos())),
            }
        })
        .collect()
}

/// The cone's mean attenuation per slab, m (module docs), for extinction `sigma`.
fn cone_attenuation(sigma: f64, params: &DosParams) -> f64 {
    let d = params.slice_distance.unwrap() as f64;
    match params.distance {
        ConeDistance::Approximate => (-sigma * d).exp(),
        ConeDistance::Exact => {
            let lengths = sample_lengths(params);
            lengths.iter().map(|l| (-sigma * l).exp()).sum::<f64>() / lengths.len() as f64
        }
    }
}

/// The occlusion layer's P for the cube's depth of 2: the same sum without L_a albedo,
/// `own (1 - a) sum_{k<N} (a m)^k`, slab k weighted by T_k (1 - a) and lit by own V_k.
fn slab_occlusion_closed_form(sigma: f32, params: &DosParams) -> f64 {
    let d = params.slice_distance.unwrap() as f64;
    let n = (2.0 / d).round() as i32;
    let sigma = sigma as f64;
    let a = (-sigma * d).exp();
    let m = cone_attenuation(sigma, params);
    let own = if params.self_occlusion { a.sqrt() } else { 1.0 };
    own * (1.0 - a) * (1.0 - (a * m).powi(n)) / (1.0 - a * m)
}

fn assert_finite_and_bounded(img: &RenderImage, lut: &Lut, what: &str) {
    // Premultiplied: 0 <= P <= A, A the alpha.
    let (occlusion, _) = premultiplied(img, "occlusion");
    // Without emission the image is a convex combination of the lit medium (at most
    // L_a * albedo) and the background.
    let entries: Vec<&[f32]> = lut.data().chunks_exact(LUT_STRIDE).collect();
    assert!(entries.iter().all(|e| e[4..7] == [0.0; 3]), "{what}: emits");
    let albedo = entries
        .iter()
        .flat_map(|e| e[1..4].to_vec())
        .fold(0.0, f32::max);
    let bound = (AMBIENT * albedo).max(BACKGROUND) * (1.0 + 1e-5);
    for (p, (rgba, occ)) in img.rgba.iter().zip(occlusion).enumerate() {
        assert!(
            rgba.iter().all(|c| c.is_finite() && *c >= 0.0),
            "{what}: pixel {p}: {rgba:?}"
        );
        assert!(
            rgba[..3].iter().all(|c| *c <= bound),
            "{what}: pixel {p}: {rgba:?}"
        );
        assert!(rgba[3] <= 1.0, "{what}: pixel {p}: {rgba:?}");
        assert!(occ.is_finite(), "{what}: pixel {p}: occlusion {occ}");
    }
    assert!(img.depth.iter().all(|z| z.is_finite()), "{what}: depth");
}

#[test]
fn homogeneous_cube_matches_the_slice_recursion_closed_form() {
    let volume = cube();
    let sigma = 1.1;
    let lut = homogeneous(&volume, sigma);
    let camera = top_camera(12);
    let (mut worst, mut worst_p) = (0.0f32, 0.0f32);
    let (solid, area) = (ConeSampling::SolidAngle, ConeSampling::Area);
    for (theta_deg, grid, distance, sampling, self_occlusion) in [
        (0.0, 1, ConeDistance::Exact, solid, false),
        (0.0, 5, ConeDistance::Exact, solid, false),
        (30.0, 5, ConeDistance::Exact, solid, false),
        (60.0, 13, ConeDistance::Exact, solid, false),
        (60.0, 5, ConeDistance::Approximate, solid, false),
        (85.0, 2, ConeDistance::Exact, solid, false),
        (89.99, 5, ConeDistance::Exact, solid, false),
        (0.0, 1, ConeDistance::Exact, solid, true),
        (60.0, 5, ConeDistance::Exact, solid, true),
        (30.0, 5, ConeDistance::Exact, area, false),
        (60.0, 13, ConeDistance::Exact, area, false),
        (85.0, 2, ConeDistance::Exact, area, false),
    ] {
        let params = DosParams {
            theta_deg,
            grid,
            slice_distance: Some(0.125),
            distance,
            sampling,
            self_occlusion,
            ..DosParams::default()
        };
        let img = render(&volume, &lut, &camera, &params);
        let want = slab_closed_form(sigma, &params);
        let want_p = slab_occlusion_closed_form(sigma, &params) as f32;
        let (p, a) = premultiplied(&img, "occlusion");
        for (i, rgba) in img.rgba.iter().enumerate() {
            let err = (rgba[0] - want).abs() / want;
            worst = worst.max(err);
            assert!(
                err < 2e-5,
                "theta {theta_deg}, n {grid}, {distance:?}, self {self_occlusion}: {} vs {want}",
                rgba[0]
            );
            assert!((rgba[3] - (1.0 - (-2.0 * sigma).exp())).abs() < 1e-5);
            // The occlusion layer: the same sum, and under A (the slabs behind the first are
            // occluded).
            let err_p = (p[i] - want_p).abs() / want_p;
            worst_p = worst_p.max(err_p);
            assert!(
                err_p < 2e-5,
                "theta {theta_deg}, n {grid}, {distance:?}, self {self_occlusion}: P {} vs \
                 {want_p}",
                p[i]
            );
            assert!(p[i] < a[i] - 0.05, "P {} vs A {}", p[i], a[i]);
        }
    }
    println!("closed form: worst relative error {worst:.2e}, of P {worst_p:.2e}");
}

#[test]
fn theta_zero_converges_to_the_ambient_lit_slab_attenuated_along_the_view() {
    // Continuous limit of the recursion at theta = 0: V(s) = T(s) = exp(-sigma s), so
    // L = L_a albedo (1 - exp(-2 sigma L)) / 2 + exp(-sigma L) L_b; the slices' error is O(d).
    let volume = cube();
    let sigma = 1.1f32;
    let lut = homogeneous(&volume, sigma);
    let camera = top_camera(4);
    let want =
        AMBIENT * ALBEDO * (1.0 - (-4.0 * sigma).exp()) / 2.0 + (-2.0 * sigma).exp() * BACKGROUND;
    let mut last = f32::INFINITY;
    for d in [0.25, 0.0625, 0.015625] {
        let params = DosParams {
            theta_deg: 0.0,
            slice_distance: Some(d),
            ..DosParams::default()
        };
        let err = (render(&volume, &lut, &camera, &params).rgba[0][0] - want).abs();
        println!("d = {d}: error {err:.2e}");
        assert!(err < 0.5 * sigma * d * want, "d = {d}: error {err}");
        assert!(err < last, "error must fall with d");
        last = err;
    }
}

#[test]
fn empty_volume_shows_exactly_the_background() {
    let volume = cube();
    let lut = homogeneous(&volume, 0.0);
    let perspective = Camera::look_at(
        Vec3::new(2.0, -3.0, 1.5),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.8 },
        10,
        10,
    )
    .unwrap();
    for camera in [top_camera(10), perspective] {
        let img = render(&volume, &lut, &camera, &DosParams::default());
        assert!(img
            .rgba
            .iter()
            .all(|p| *p == [BACKGROUND, BACKGROUND, BACKGROUND, 0.0]));
        assert!(img.depth.iter().all(|z| *z == BACKGROUND_DEPTH));
        // Nothing covered, nothing occluded: P = A = 0.
        let layer = img.factor("occlusion").unwrap();
        assert!(layer.values.iter().all(|v| *v == [0.0, 0.0]));
    }
}

#[test]
fn a_sheet_one_slab_deep_is_unoccluded_so_its_layer_equals_its_coverage() {
    // The cube's voxels of the top layer (z = 0.875) hold 1, the rest 0, under an extinction
    // proportional to the value: with slices 0.25 apart from the top face, slab 0's midpoint
    // lies on the layer's voxel centres and slab 1's on the next layer's (value 0), so all the
    // material lies in slab 0, which receives V_0 = 1. So P = A at every pixel, for any cone.
    let volume = Volume::from_fn([8; 3], Vec3::splat(0.25), Vec3::splat(-0.875), |p| {
        if p.z > 0.8 {
            1.0
        } else {
            0.0
        }
    })
    .unwrap();
    let lut = linear_extinction(&volume, 3.0);
    for theta_deg in [0.0, 50.0, 85.0] {
        let params = DosParams {
            theta_deg,
            slice_distance: Some(0.25),
            ..DosParams::default()
        };
        let img = render(&volume, &lut, &top_camera(6), &params);
        let (p, a) = premultiplied(&img, "occlusion");
        for (p, a) in p.iter().zip(&a) {
            assert!((a - (1.0 - (-0.75f32).exp())).abs() < 1e-5, "A {a}");
            assert!((p - a).abs() <= 1e-5, "theta {theta_deg}: P {p} vs A {a}");
        }
    }
}

#[test]
fn the_occlusion_layer_is_continuous_across_a_soft_silhouette() {
    // A sphere whose density falls smoothly over 6 voxels, framed whole: the layer steps
    // between neighbouring pixels at most 1.25 times as far as the image's alpha does.
    // Measured: 0.68 (theta 30) and 0.52 (theta 70) times (largest steps 0.203 and 0.156
    // against alpha's 0.299), where a layer thresholded at opacity 0.5 steps 2.5 and 1.9 times
    // as far (0.76, 0.56).
    let (volume, lut, camera) = soft_sphere_scene();
    for theta_deg in [30.0, 70.0] {
        let params = DosParams {
            theta_deg,
            ..DosParams::default()
        };
        let img = render(&volume, &lut, &camera, &params);
        assert_continuous(&img, "occlusion", 1.25);
    }
}

#[test]
fn clipped_material_neither_shows_nor_occludes() {
    // Clipping the cube's upper half (the side towards the camera) leaves a cube of depth 1,
    // lit as if the removed half were not there: the closed form for half the slices.
    let volume = cube();
    let sigma = 0.9;
    let lut = homogeneous(&volume, sigma);
    let params = DosParams {
        theta_deg: 40.0,
        grid: 5,
        slice_distance: Some(0.125),
        distance: ConeDistance::Exact,
        sampling: ConeSampling::SolidAngle,
        formulation: Formulation::Slices,
        self_occlusion: false,
        clip_planes: vec![ClipPlane {
            point: Vec3::ZERO,
            normal: Vec3::Z,
        }],
    };
    let img = render(&volume, &lut, &top_camera(8), &params);
    // The closed form for a depth of 1 is the one for a depth of 2 at twice the slice distance
    // with the extinction halved in the exponent: compute it directly instead.
    let d = 0.125f64;
    let a = (-(sigma as f64) * d).exp();
    let m = cone_attenuation(sigma as f64, &params);
    let n = 8;
    let want = ((AMBIENT * ALBEDO) as f64 * (1.0 - a) * (1.0 - (a * m).powi(n)) / (1.0 - a * m)
        + a.powi(n) * BACKGROUND as f64) as f32;
    for rgba in &img.rgba {
        assert!(
            (rgba[0] - want).abs() < 2e-5 * want,
            "{} vs {want}",
            rgba[0]
        );
    }
}

#[test]
fn stability_cases_give_bounded_finite_images() {
    let cube = cube();
    let ct = phantom::ct(24).unwrap();
    let ct_lut = presets::preset("ct-bone").unwrap().bake(&ct);
    let inside = Camera::look_at(
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(1.0, 1.0, 0.3),
        Vec3::Z,
        Projection::Perspective { fov_y: 1.2 },
        12,
        12,
    )
    .unwrap();
    let outside = Camera::look_at(
        Vec3::new(2.5, -3.0, 1.5),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.7 },
        12,
        12,
    )
    .unwrap();
    let near_90 = DosParams {
        theta_deg: 89.999,
        grid: 5,
        ..DosParams::default()
    };
    let tiny_slices = DosParams {
        slice_distance: Some(1e-3),
        grid: 2,
        ..DosParams::default()
    };
    let opaque = homogeneous(&cube, 3.0e38);
    let dense = homogeneous(&cube, 2.0);
    let cases: [(&str, &Volume, &Lut, &Camera, &DosParams); 6] = [
        ("theta near 90", &ct, &ct_lut, &outside, &near_90),
        ("tiny slice distance", &ct, &ct_lut, &outside, &tiny_slices),
        (
            "camera inside",
            &cube,
            &dense,
            &inside,
            &DosParams::default(),
        ),
        (
            "camera inside, theta near 90",
            &cube,
            &dense,
            &inside,
            &near_90,
        ),
        ("fully opaque", &cube, &opaque, &outside, &near_90),
        (
            "fully opaque, inside",
            &cube,
            &opaque,
            &inside,
            &DosParams::default(),
        ),
    ];
    for (what, volume, lut, camera, params) in cases {
        let img = render(volume, lut, camera, params);
        assert_finite_and_bounded(&img, lut, what);
    }
    // An opaque cube: the first slab hides everything behind it and is fully lit.
    let img = render(&cube, &opaque, &top_camera(6), &DosParams::default());
    for rgba in &img.rgba {
        assert!(
            (rgba[0] - AMBIENT * ALBEDO).abs() < 1e-6 && rgba[3] == 1.0,
            "{rgba:?}"
        );
    }
}

#[test]
fn occlusion_darkens_the_inside_and_stays_in_unit_range() {
    // The CT phantom under a wide cone: factors stay in [0, 1] and visible surfaces behind
    // other material are occluded.
    let volume = phantom::ct(32).unwrap();
    let lut = presets::preset("ct-bone").unwrap().bake(&volume);
    let camera = Camera::look_at(
        Vec3::new(2.5, -3.0, 1.5),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.7 },
        24,
        24,
    )
    .unwrap();
    let params = DosParams {
        theta_deg: 60.0,
        ..DosParams::default()
    };
    let img = render(&volume, &lut, &camera, &params);
    assert_finite_and_bounded(&img, &lut, "ct");
    let layer = img.factor("occlusion").unwrap();
    let covered: Vec<f32> = layer
        .unpremultiplied()
        .into_iter()
        .zip(&img.depth)
        .filter(|(_, z)| **z < BACKGROUND_DEPTH)
        .map(|(o, _)| o)
        .collect();
    assert!(!covered.is_empty());
    let least = covered.iter().copied().fold(1.0, f32::min);
    assert!(
        least < 0.9,
        "some visible surface is occluded: least {least}"
    );
}

#[test]
fn bad_inputs_are_named_errors() {
    let volume = cube();
    let lut = homogeneous(&volume, 1.0);
    let camera = top_camera(4);
    let mut lighting = lighting();
    lighting.lights.push(Light::Directional {
        to_light: Vec3::Z,
        irradiance: Vec3::ONE,
    });
    let params = DosParams::default();
    let input = DosInput {
        volume: &volume,
        lut: &lut,
        camera: &camera,
        lighting: &lighting,
        params: &params,
    };
    let err = cpu::render(&input, &NoProgress).unwrap_err().to_string();
    assert!(err.contains("lights[1]"), "{err}");
    let too_many = DosParams {
        slice_distance: Some(1e-6),
        ..DosParams::default()
    };
    let lighting = self::lighting();
    let input = DosInput {
        params: &too_many,
        lighting: &lighting,
        ..input
    };
    let err = cpu::render(&input, &NoProgress).unwrap_err().to_string();
    assert!(err.contains("render.slice_distance"), "{err}");
}

struct CancelAfter(std::sync::atomic::AtomicU64);

impl Progress for CancelAfter {
    fn update(&self, done: u64, _total: u64) {
        self.0.store(done, std::sync::atomic::Ordering::Relaxed);
    }
    fn cancelled(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::Relaxed) >= 3
    }
}

#[test]
fn cancelling_stops_between_slices() {
    let volume = cube();
    let lut = homogeneous(&volume, 1.0);
    let lighting = lighting();
    let params = DosParams::default();
    let camera = top_camera(4);
    let input = DosInput {
        volume: &volume,
        lut: &lut,
        camera: &camera,
        lighting: &lighting,
        params: &params,
    };
    let progress = CancelAfter(0.into());
    assert!(matches!(
        cpu::render(&input, &progress),
        Err(Error::Cancelled)
    ));
    assert_eq!(progress.0.into_inner(), 3, "stopped after the third slice");
}

#[test]
fn ray_casting_formulation_equals_the_slices_for_orthographic_cameras() {
    // Lock-step steps of length d along parallel rays are the view-aligned slabs themselves;
    // the images differ only by the rounding of dir . forward = 1 (measured 2.5e-6).
    let volume = phantom::ct(32).unwrap();
    let lut = presets::preset("ct-bone").unwrap().bake(&volume);
    let ortho = Camera::look_at(
        Vec3::new(2.5, -3.0, 1.5),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Orthographic { scale: 2.2 },
        20,
        20,
    )
    .unwrap();
    let slices = DosParams {
        theta_deg: 60.0,
        ..DosParams::default()
    };
    let rays = DosParams {
        formulation: Formulation::Rays,
        ..slices.clone()
    };
    let a = render(&volume, &lut, &ortho, &slices);
    let b = render(&volume, &lut, &ortho, &rays);
    let worst = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs()))
        .fold(0.0f32, f32::max);
    println!("orthographic: worst difference {worst:.2e}");
    assert!(worst < 1e-5, "{worst}");
    assert!(a.rgba.iter().any(|p| p[3] > 0.5));
    // Perspective: shells instead of planes sample the same integral; the images stay close.
    let perspective = Camera::look_at(
        Vec3::new(2.5, -3.0, 1.5),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.7 },
        20,
        20,
    )
    .unwrap();
    let a = render(&volume, &lut, &perspective, &slices);
    let b = render(&volume, &lut, &perspective, &rays);
    assert_finite_and_bounded(&b, &lut, "rays, perspective");
    let (mut sq, mut sum) = (0.0f64, 0.0f64);
    for (p, q) in a.rgba.iter().zip(&b.rgba) {
        sq += ((p[0] - q[0]) as f64).powi(2);
        sum += p[0] as f64;
    }
    let rel = (sq / a.rgba.len() as f64).sqrt() / (sum / a.rgba.len() as f64);
    println!("perspective: relative RMS difference {rel:.3e}");
    assert!(rel < 0.05, "{rel}");
}

/// The 48^3 CT phantom under examples/demo.toml's classification and unit ambient light, seen
/// at 48^2 by the scene's camera: the mean occlusion of what a camera sees (the occlusion
/// layer's sum P / sum A) for given parameters.
struct LitPhantom {
    volume: Volume,
    lut: Lut,
    camera: Camera,
    lighting: Lighting,
}

impl LitPhantom {
    fn new() -> Self {
        let scene = occlux::scene::Scene::parse(
            include_str!("../examples/demo.toml"),
            std::path::Path::new("."),
        )
        .unwrap();
        let volume = phantom::ct(48).unwrap().with_centre(Vec3::ZERO);
        let lut = scene.classification.bake(&volume);
        let lighting = Lighting {
            lights: vec![Light::Ambient {
                radiance: Vec3::ONE,
            }],
            background: Vec3::ZERO,
        };
        let camera = Camera {
            width: 48,
            height: 48,
            ..scene.camera
        };
        Self {
            volume,
            lut,
            camera,
            lighting,
        }
    }

    fn occlusion(&self, camera: &Camera, params: &DosParams) -> f64 {
        let input = DosInput {
            volume: &self.volume,
            lut: &self.lut,
            camera,
            lighting: &self.lighting,
            params,
        };
        let image = cpu::render(&input, &NoProgress).unwrap();
        image.factor("occlusion").unwrap().mean()
    }
}

/// The paper's Figure 5 as numbers (with its sampling, equal areas of the cone's base): a wider
/// cone and a finer grid let more distant occluders count, so the mean occlusion of what is
/// seen (the occlusion layer's sum P / sum A) falls.
/// Measured here (48^3 CT phantom, 48^2): theta 30 / 50 / 80 gives 0.658 / 0.624 / 0.468 at
/// n = 5, and at theta 50 n = 2 / 5 / 13 gives 0.644 / 0.624 / 0.621 (the grid matters up to
/// n = 5, then saturates).
#[test]
fn wider_cones_and_finer_grids_see_more_occluders() {
    let lit = LitPhantom::new();
    let occlusion = |theta_deg: f32, grid: u32| {
        let params = DosParams {
            theta_deg,
            grid,
            sampling: ConeSampling::Area,
            ..DosParams::default()
        };
        lit.occlusion(&lit.camera, &params)
    };
    let by_theta: Vec<f64> = [30.0, 50.0, 80.0].map(|t| occlusion(t, 5)).to_vec();
    let by_grid: Vec<f64> = [2, 5, 13].map(|n| occlusion(50.0, n)).to_vec();
    println!("theta 30/50/80: {by_theta:?}; n 2/5/13 at theta 50: {by_grid:?}");
    assert!(by_theta[0] > by_theta[1] + 0.02 && by_theta[1] > by_theta[2] + 0.1);
    assert!(by_grid[0] > by_grid[1] + 0.01 && by_grid[1] >= by_grid[2] - 1e-3);
}

/// Material outside the view still occludes what is in it (the occlusion buffers' guard band):
/// a view cropped at x = 0 of a floor shaded by a wall at x > 0.125 shows the wall's occlusion
/// as the wide view of both does. Without the band the cropped view's cone samples beyond its
/// edge read its edge pixels, and the wall's occlusion was lost (the cropped view equalled the
/// view without the wall).
#[test]
fn occluders_outside_the_view_still_occlude() {
    // x in [-1, 0.5], y in [-0.25, 0.25], z in [-0.5, 0.5]: a floor below z = -0.25 and, with
    // `wall`, a block at x > 0.125 above z = 0.
    let volume = |wall: bool| {
        Volume::from_fn(
            [24, 8, 16],
            Vec3::splat(0.0625),
            Vec3::new(-1.0, -0.25, -0.5) + 0.03125,
            move |p| f32::from(p.z < -0.25 || (wall && p.x > 0.125 && p.z > 0.0)),
        )
        .unwrap()
    };
    let camera = |x: f32, width: u32, scale: f32| {
        Camera::look_at(
            Vec3::new(x, 0.0, 3.0),
            Vec3::new(x, 0.0, 0.0),
            Vec3::Y,
            Projection::Orthographic { scale },
            width,
            16,
        )
        .unwrap()
    };
    // The same pixel pitch, 1/16: the wide view spans x in [-1, 1], the cropped one [-1, 0].
    let (wide, cropped) = (camera(0.0, 32, 2.0), camera(-0.5, 16, 1.0));
    let params = DosParams {
        theta_deg: 70.0,
        ..DosParams::default()
    };
    let red = |volume: &Volume, camera: &Camera| -> Vec<f32> {
        let lut = common::layers::linear_extinction(volume, 20.0);
        let img = render(volume, &lut, camera, &params);
        img.rgba.iter().map(|p| p[0]).collect()
    };
    let (walled, open) = (volume(true), volume(false));
    let (wide_walled, wide_open) = (red(&walled, &wide), red(&open, &wide));
    let cropped_walled = red(&walled, &cropped);
    // Cropped column i is wide column i + offset (the image's x runs along the camera's right).
    let offset = if wide.right.x > 0.0 { 0 } else { 16 };
    // The four columns of the cropped view next to its cut, over the volume's rows.
    let columns: Vec<usize> = if offset == 0 {
        (12..16).collect()
    } else {
        (0..4).collect()
    };
    let (mut shade, mut miss) = (0.0f32, 0.0f32);
    for j in 4..12 {
        for &i in &columns {
            let w = j * 32 + i + offset;
            shade += wide_open[w] - wide_walled[w];
            miss += (cropped_walled[j * 16 + i] - wide_walled[w]).abs();
        }
    }
    println!("the wall's occlusion next to the cut: {shade:.4}; cropped view misses {miss:.4}");
    assert!(
        shade > 0.05 * 32.0,
        "the wall should shade the floor there: {shade}"
    );
    assert!(miss < 0.1 * shade, "cropped {miss} of {shade}");
}

/// With samples of equal solid angle, a wider cone only adds directions further from the view
/// axis, whose light crosses longer paths: the CT phantom darkens monotonically up to theta
/// just below 90 degrees and settles there, framed or cropped (so that material lies beyond
/// the image). Measured (48^3, 48^2, n 5): mean occlusion 0.659 at theta 30 to 0.529 at 89.99
/// framed. With equal areas (the paper) it fell to 0.47 at 80, then rose to 0.62 at 88 and 1.0
/// at 89.9 as samples flew beyond the volume.
#[test]
fn wider_cones_darken_monotonically_up_to_90_degrees() {
    let lit = LitPhantom::new();
    let framed = lit.camera;
    let cropped = Camera::look_at(
        framed.position,
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.25 },
        48,
        48,
    )
    .unwrap();
    let thetas = [30.0, 50.0, 70.0, 80.0, 85.0, 88.0, 89.0, 89.9, 89.99];
    for (name, camera) in [("framed", framed), ("cropped", cropped)] {
        let occlusion: Vec<f64> = thetas
            .iter()
            .map(|&theta_deg| {
                let params = DosParams {
                    theta_deg,
                    ..DosParams::default()
                };
                lit.occlusion(&camera, &params)
            })
            .collect();
        println!("{name}: mean occlusion at theta {thetas:?}: {occlusion:.3?}");
        for (pair, theta) in occlusion.windows(2).zip(&thetas[1..]) {
            assert!(
                pair[1] <= pair[0],
                "{name}: brighter at theta {theta}: {occlusion:?}"
            );
        }
        assert!(occlusion[0] - occlusion[8] > 0.1, "{name}: {occlusion:?}");
    }
}
