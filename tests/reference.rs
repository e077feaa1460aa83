//! The Monte Carlo references against closed forms in a homogeneous box, where transmittance
//! along any segment is exp(-sigma * length) and each estimator's integral reduces to
//! deterministic quadrature: every pixel's error, in units of its own standard error, must look
//! like unit noise. Also: the white furnace for multiple scattering, consistency between
//! estimators, 1/sqrt(n) convergence, and determinism.

use glam::Vec3;
use occlux::camera::{Camera, Projection, Ray};
use occlux::classify::{
    Classification, ControlPoint, Lut, TransferFunction, TransferFunction1D, ValueUnits,
};
use occlux::lights::{Light, Lighting};
use occlux::optics::phase::henyey_greenstein;
use occlux::progress::NoProgress;
use occlux::render::reference::{
    render, Estimator, ReferenceImage, ReferenceInput, ReferenceParams,
};
use occlux::volume::Volume;

mod common;
use common::quadrature::{chord, gauss_legendre, mean_over_directions};

const SIGMA: f32 = 1.5;
const ALBEDO: f32 = 0.8;
const BACKGROUND: f32 = 0.25;

/// The cube [-1, 1]^3 filled with a homogeneous medium.
fn cube() -> Volume {
    Volume::new(
        [8, 8, 8],
        Vec3::splat(0.25),
        Vec3::splat(-0.875),
        vec![1.0; 512],
    )
    .unwrap()
}

fn constant_lut(volume: &Volume, sigma: f32, albedo: f32) -> Lut {
    let tf = TransferFunction1D::new(vec![
        ControlPoint::new(0.0, sigma, [albedo; 3], [0.0; 3]),
        ControlPoint::new(2.0, sigma, [albedo; 3], [0.0; 3]),
    ])
    .unwrap();
    Classification::new(TransferFunction::OneD(tf), ValueUnits::Raw, 1.0)
        .unwrap()
        .bake(volume)
}

fn camera() -> Camera {
    Camera::look_at(
        Vec3::new(2.6, -2.2, 1.7),
        Vec3::new(0.1, 0.0, -0.1),
        Vec3::Z,
        Projection::Perspective { fov_y: 0.75 },
        6,
        6,
    )
    .unwrap()
}

fn run(
    lighting: &Lighting,
    lut: &Lut,
    estimator: Estimator,
    spp: u32,
    seed: u64,
) -> ReferenceImage {
    let volume = cube();
    let params = ReferenceParams {
        estimator,
        spp,
        seed,
        g: 0.0,
    };
    run_with(&volume, lut, lighting, &params)
}

fn run_with(
    volume: &Volume,
    lut: &Lut,
    lighting: &Lighting,
    params: &ReferenceParams,
) -> ReferenceImage {
    try_run(volume, lut, lighting, params, &NoProgress).unwrap()
}

fn try_run(
    volume: &Volume,
    lut: &Lut,
    lighting: &Lighting,
    params: &ReferenceParams,
    progress: &dyn occlux::progress::Progress,
) -> occlux::Result<ReferenceImage> {
    let input = ReferenceInput {
        volume,
        lut,
        camera: &camera(),
        lighting,
        params,
    };
    render(&input, progress)
}

/// The pixel value: `int_0^len e^{-sigma s} sigma albedo L_s(x_s) ds + e^{-sigma len} B` along
/// the pixel's ray, or B where it misses the cube.
fn exact_pixel(ray: &Ray, scattered: impl Fn([f64; 3]) -> f64) -> f64 {
    let Some((t0, t1)) = occlux::camera::intersect_box(ray, Vec3::splat(-1.0), Vec3::splat(1.0))
    else {
        return BACKGROUND as f64;
    };
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (t0, len, sigma) = (t0 as f64, (t1 - t0) as f64, SIGMA as f64);
    let inside: f64 = gauss_legendre(48)
        .iter()
        .map(|&(u, w)| {
            let s = u * len;
            let x = o + d * (t0 + s);
            w * len * (-sigma * s).exp() * sigma * ALBEDO as f64 * scattered(x.to_array())
        })
        .sum();
    inside + (-sigma * len).exp() * BACKGROUND as f64
}

/// Every pixel's error in units of its standard error: RMS near 1, none far out.
fn assert_unit_noise(image: &ReferenceImage, exact: impl Fn(&Ray) -> f64, what: &str) {
    let cam = camera();
    let mut z2 = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            let p = (j * cam.width + i) as usize;
            let want = exact(&cam.ray(i, j));
            let (got, se) = (image.mean[p][0] as f64, image.stderr[p][0] as f64);
            if se == 0.0 {
                // Only a pixel whose every path missed the volume is noiseless.
                assert_eq!(
                    got, want,
                    "{what}: pixel ({i}, {j}) has no noise but is off"
                );
                continue;
            }
            let z = (got - want) / se;
            assert!(
                z.abs() < 4.5,
                "{what}: pixel ({i}, {j}) {got} vs {want} ({z:.1} se)"
            );
            z2.push(z * z);
        }
    }
    let rms = (z2.iter().sum::<f64>() / z2.len() as f64).sqrt();
    assert!(z2.len() >= 20, "{what}: too few pixels see the volume");
    assert!((0.6..1.5).contains(&rms), "{what}: RMS z {rms:.2}");
    println!("{what}: RMS z {rms:.2} over {} pixels", z2.len());
}

fn lighting(lights: Vec<Light>) -> Lighting {
    Lighting {
        lights,
        background: Vec3::splat(BACKGROUND),
    }
}

#[test]
fn ambient_occlusion_matches_quadrature() {
    let l_amb = 1.3;
    let lit = lighting(vec![Light::Ambient {
        radiance: Vec3::splat(l_amb),
    }]);
    let lut = constant_lut(&cube(), SIGMA, ALBEDO);
    let image = run(&lit, &lut, Estimator::Ambient, 4000, 1);
    let sigma = SIGMA as f64;
    assert_unit_noise(
        &image,
        |ray| {
            exact_pixel(ray, |x| {
                l_amb as f64
                    * mean_over_directions([0.0, 0.0, 1.0], -1.0, |w| (-sigma * chord(x, w)).exp())
            })
        },
        "ambient",
    );
}

#[test]
fn the_cone_phase_function_matches_quadrature() {
    let aperture = 40f32.to_radians();
    let lit = lighting(vec![Light::Ambient {
        radiance: Vec3::ONE,
    }]);
    let lut = constant_lut(&cube(), SIGMA, ALBEDO);
    let image = run(&lit, &lut, Estimator::Cone { aperture }, 4000, 2);
    let sigma = SIGMA as f64;
    assert_unit_noise(
        &image,
        |ray| {
            let to_eye = (-ray.dir.as_dvec3()).to_array();
            exact_pixel(ray, |x| {
                mean_over_directions(to_eye, (aperture as f64).cos(), |w| {
                    (-sigma * chord(x, w)).exp()
                })
            })
        },
        "cone",
    );
}

#[test]
fn single_scattering_matches_quadrature_for_any_phase_asymmetry() {
    let to_light = Vec3::new(-0.4, 0.3, 1.0).normalize();
    let irradiance = 2.5;
    let lit = lighting(vec![
        Light::Directional {
            to_light,
            irradiance: Vec3::splat(irradiance),
        },
        // Ambient light is not the single-scattering estimator's: it must be ignored.
        Light::Ambient {
            radiance: Vec3::splat(5.0),
        },
    ]);
    let volume = cube();
    let lut = constant_lut(&volume, SIGMA, ALBEDO);
    for g in [0.0f32, 0.6] {
        let params = ReferenceParams {
            estimator: Estimator::Single,
            spp: 4000,
            seed: 3,
            g,
        };
        let image = run_with(&volume, &lut, &lit, &params);
        let sigma = SIGMA as f64;
        let l = to_light.as_dvec3().to_array();
        assert_unit_noise(
            &image,
            |ray| {
                let p = henyey_greenstein(g, to_light.dot(ray.dir)) as f64;
                exact_pixel(ray, |x| {
                    p * irradiance as f64 * (-sigma * chord(x, l)).exp()
                })
            },
            &format!("single, g = {g}"),
        );
    }
}

#[test]
fn multiple_scattering_passes_the_white_furnace() {
    // Albedo 1 inside an environment of radiance L that is also the background: with enough
    // bounces every pixel sees exactly L, whatever the phase function.
    let l = 0.7;
    let lit = Lighting {
        lights: vec![Light::Ambient {
            radiance: Vec3::splat(l),
        }],
        background: Vec3::splat(l),
    };
    let volume = cube();
    let lut = constant_lut(&volume, 1.0, 1.0);
    for g in [0.0f32, 0.5] {
        let params = ReferenceParams {
            estimator: Estimator::Multiple { bounces: 400 },
            spp: 400,
            seed: 4,
            g,
        };
        let image = run_with(&volume, &lut, &lit, &params);
        for (m, se) in image.mean.iter().zip(&image.stderr) {
            // Each path returns exactly L (every path ends in the environment), so the noise
            // is zero up to float rounding.
            assert!(
                (m[0] - l).abs() < 1e-5 && se[0] < 1e-5,
                "g {g}: {m:?} {se:?}"
            );
        }
    }
    // With absorption the furnace loses energy: albedo 0.9 must come out darker.
    let lut = constant_lut(&volume, 1.0, 0.9);
    let params = ReferenceParams {
        estimator: Estimator::Multiple { bounces: 400 },
        spp: 400,
        seed: 4,
        g: 0.0,
    };
    let image = run_with(&volume, &lut, &lit, &params);
    let hit: Vec<_> = image.mean.iter().filter(|m| m[3] > 0.5).collect();
    assert!(
        !hit.is_empty() && hit.iter().all(|m| m[0] < l - 0.02),
        "{hit:?}"
    );
}

#[test]
fn zero_bounces_is_ambient_plus_single_scattering() {
    let lit = lighting(vec![
        Light::Ambient {
            radiance: Vec3::splat(0.6),
        },
        Light::Directional {
            to_light: Vec3::new(0.5, -0.2, 0.8).normalize(),
            irradiance: Vec3::splat(3.0),
        },
    ]);
    let lut = constant_lut(&cube(), SIGMA, ALBEDO);
    let multiple = run(&lit, &lut, Estimator::Multiple { bounces: 0 }, 3000, 5);
    let ambient = run(&lit, &lut, Estimator::Ambient, 3000, 6);
    let single = run(&lit, &lut, Estimator::Single, 3000, 7);
    let cam = camera();
    let mut z2 = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            let p = (j * cam.width + i) as usize;
            // Each side sees the background through the volume once: the sum counts it twice.
            let ray = cam.ray(i, j);
            let through = occlux::camera::intersect_box(&ray, Vec3::splat(-1.0), Vec3::ONE)
                .map_or(1.0, |(t0, t1)| (-SIGMA * (t1 - t0)).exp());
            let sum = ambient.mean[p][0] + single.mean[p][0] - BACKGROUND * through;
            let se = (multiple.stderr[p][0].powi(2)
                + ambient.stderr[p][0].powi(2)
                + single.stderr[p][0].powi(2))
            .sqrt();
            if se > 0.0 {
                let z = (multiple.mean[p][0] - sum) / se;
                assert!(z.abs() < 4.5, "pixel ({i}, {j}): {z}");
                z2.push(z * z);
            }
        }
    }
    let rms = (z2.iter().sum::<f32>() / z2.len() as f32).sqrt();
    assert!((0.5..1.6).contains(&rms), "RMS z {rms}");
}

#[test]
fn noise_falls_as_one_over_the_square_root_of_samples() {
    let lit = lighting(vec![Light::Ambient {
        radiance: Vec3::ONE,
    }]);
    let lut = constant_lut(&cube(), SIGMA, ALBEDO);
    let mean_se = |spp| {
        let img = run(&lit, &lut, Estimator::Ambient, spp, 8);
        let se: Vec<f32> = img
            .stderr
            .iter()
            .map(|s| s[0])
            .filter(|&s| s > 0.0)
            .collect();
        se.iter().sum::<f32>() / se.len() as f32
    };
    let ratio = mean_se(4000) / mean_se(250);
    assert!(
        (ratio - 0.25).abs() < 0.03,
        "16x the samples: noise x{ratio}"
    );
}

#[test]
fn renders_are_deterministic_per_seed_and_parameters_are_checked() {
    let lit = lighting(vec![Light::Ambient {
        radiance: Vec3::ONE,
    }]);
    let lut = constant_lut(&cube(), SIGMA, ALBEDO);
    let a = run(&lit, &lut, Estimator::Ambient, 16, 9);
    let b = run(&lit, &lut, Estimator::Ambient, 16, 9);
    let c = run(&lit, &lut, Estimator::Ambient, 16, 10);
    assert_eq!(a, b);
    assert_ne!(a.mean, c.mean);

    let volume = cube();
    for (params, key) in [
        (
            ReferenceParams {
                estimator: Estimator::Ambient,
                spp: 1,
                seed: 0,
                g: 0.0,
            },
            "spp",
        ),
        (
            ReferenceParams {
                estimator: Estimator::Single,
                spp: 8,
                seed: 0,
                g: 1.0,
            },
            "g",
        ),
        (
            ReferenceParams {
                estimator: Estimator::Single,
                spp: 8,
                seed: 0,
                g: f32::NAN,
            },
            "g",
        ),
        (
            ReferenceParams {
                estimator: Estimator::Cone { aperture: 1.6 },
                spp: 8,
                seed: 0,
                g: 0.0,
            },
            "aperture",
        ),
    ] {
        let err = try_run(&volume, &lut, &lit, &params, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(err.contains(key), "{err}");
    }
}

#[test]
fn a_cancelled_render_stops_without_a_result() {
    use occlux::progress::Progress;
    use std::sync::atomic::{AtomicU64, Ordering};
    /// Asks to stop once the first row is done, and counts the rows that still report.
    struct StopAfterFirstRow(AtomicU64);
    impl Progress for StopAfterFirstRow {
        fn update(&self, _done: u64, _total: u64) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
        fn cancelled(&self) -> bool {
            self.0.load(Ordering::Relaxed) > 0
        }
    }
    let lit = lighting(vec![Light::Ambient {
        radiance: Vec3::ONE,
    }]);
    let volume = cube();
    let lut = constant_lut(&volume, SIGMA, ALBEDO);
    let params = ReferenceParams {
        estimator: Estimator::Ambient,
        spp: 64,
        seed: 1,
        g: 0.0,
    };
    // Rows already running when the first one finishes may finish too, one per thread at
    // most; no row starts after. Held for pools of several sizes, so the bound does not lean
    // on this machine's cores (the image has 6 rows).
    for threads in [1, 2, 4] {
        let stop = StopAfterFirstRow(AtomicU64::new(0));
        let err = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| try_run(&volume, &lut, &lit, &params, &stop))
            .unwrap_err();
        assert!(matches!(err, occlux::Error::Cancelled), "{err}");
        let reported = stop.0.load(Ordering::Relaxed);
        assert!(
            (1..=threads as u64).contains(&reported),
            "{reported} rows reported on {threads} threads"
        );
    }
}

#[test]
fn tracking_cell_by_cell_is_unbiased_where_the_majorants_differ() {
    // The CT phantom: air, soft tissue and bone side by side, so cells' majorants range from
    // zero to the table's largest. Along rays through it, the mean of ratio tracking's
    // estimates and the fraction of delta tracking's collisions must match the transmittance
    // found by fine quadrature, within their noise.
    use occlux::optics::medium::Medium;
    use rand_pcg::Pcg32;
    let volume = occlux::volume::phantom::ct(32).unwrap();
    let mut classification = occlux::classify::presets::preset("ct-bone").unwrap();
    // Optical depths of order one along the rays, where both estimators are informative.
    classification.density_scale = 0.1;
    let lut = classification.bake(&volume);
    let medium = Medium::tracking(&volume, &lut).unwrap();
    let (lo, hi) = volume.bounds();
    let centre = 0.5 * (lo + hi);
    let mut rng = Pcg32::new(7, 11);
    let trials = 20_000;
    let mut depths = vec![];
    for (k, dir) in [
        Vec3::new(1.0, 0.2, 0.1),
        Vec3::new(-0.3, 1.0, 0.4),
        Vec3::new(0.5, -0.6, -1.0),
        Vec3::new(1.0, 1.0, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let dir = dir.normalize();
        let ray = Ray {
            origin: centre - 2.0 * dir + 0.05 * k as f32 * Vec3::Y,
            dir,
        };
        let depth = optical_depth(&medium, &ray);
        depths.push(depth);
        let exact = (-depth).exp();
        let (mean, stderr) = transmittance_estimates(&medium, &ray, trials, &mut rng);
        let through = (0..trials)
            .filter(|_| medium.collide(&ray, f32::INFINITY, &mut rng).is_none())
            .count() as f64
            / trials as f64;
        let binomial = (exact * (1.0 - exact) / trials as f64).sqrt();
        println!(
            "optical depth {depth:.3}: T {exact:.4}, ratio tracking {mean:.4} +- {stderr:.4}, \
             delta tracking {through:.4} +- {binomial:.4}"
        );
        assert!(
            (mean - exact).abs() < 4.0 * stderr + 1e-4,
            "ratio {mean} vs {exact}"
        );
        assert!(
            (through - exact).abs() < 4.0 * binomial + 1e-4,
            "delta {through} vs {exact}"
        );
    }
    // The rays cross matter: the check is not of empty space.
    assert!(depths.iter().all(|&d| d > 0.1), "{depths:?}");
}

/// The mean of `n` transmittance estimates along `ray` and its standard error.
fn transmittance_estimates(
    medium: &occlux::optics::medium::Medium,
    ray: &Ray,
    n: usize,
    rng: &mut rand_pcg::Pcg32,
) -> (f64, f64) {
    let estimates: Vec<f64> = (0..n)
        .map(|_| medium.transmittance(ray, f32::INFINITY, rng) as f64)
        .collect();
    let mean = estimates.iter().sum::<f64>() / n as f64;
    let variance = estimates.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, (variance / n as f64).sqrt())
}

/// The optical depth of `medium` across its box along `ray`, by fine midpoint quadrature.
fn optical_depth(medium: &occlux::optics::medium::Medium, ray: &Ray) -> f64 {
    let (t0, t1) = medium.clip(ray).unwrap();
    let steps = 20_000;
    let h = (t1 - t0) / steps as f32;
    (0..steps)
        .map(|i| medium.sigma_t(ray.origin + (t0 + (i as f32 + 0.5) * h) * ray.dir) as f64)
        .sum::<f64>()
        * h as f64
}

#[test]
fn deep_shadow_estimates_carry_their_own_noise() {
    // Through a dense sphere (transmittance ~1e-5), every batch of a few transmittance
    // estimates must state its noise honestly: its mean lies within its own standard error
    // of the exact value as often as a normal variable would. Ratio tracking with Russian
    // roulette at transmittance 0.05 read 0 +- 0 in nearly every batch here.
    use occlux::optics::medium::Medium;
    use rand_pcg::Pcg32;
    let volume = occlux::volume::phantom::sphere(32, 0.8).unwrap();
    let mut classification = occlux::classify::presets::preset("simulation").unwrap();
    classification.density_scale = 0.36;
    let lut = classification.bake(&volume);
    let medium = Medium::tracking(&volume, &lut).unwrap();
    let dir = Vec3::new(1.0, 0.3, -0.2).normalize();
    let ray = Ray {
        origin: Vec3::new(0.02, -0.03, 0.01) - 2.0 * dir,
        dir,
    };
    let exact = (-optical_depth(&medium, &ray)).exp();
    assert!((1e-6..1e-4).contains(&exact), "transmittance {exact}");
    let mut rng = Pcg32::new(3, 5);
    let (batches, size) = (400, 16);
    let mut z = vec![];
    let mut all = 0.0;
    for _ in 0..batches {
        let (mean, stderr) = transmittance_estimates(&medium, &ray, size, &mut rng);
        assert!(stderr > 0.0, "a batch read {mean} +- 0 where T = {exact}");
        z.push((mean - exact) / stderr);
        all += mean / batches as f64;
    }
    let rms_z = (z.iter().map(|z| z * z).sum::<f64>() / batches as f64).sqrt();
    let beyond_3 = z.iter().filter(|z| z.abs() > 3.0).count();
    println!("T {exact:.3e}, mean {all:.3e}, RMS z {rms_z:.3}, |z| > 3: {beyond_3}");
    assert!((0.8..1.25).contains(&rms_z), "RMS z {rms_z}");
    assert!(
        beyond_3 <= batches / 50,
        "{beyond_3} batches beyond 3 standard errors"
    );
    assert!(
        (all - exact).abs() < 0.05 * exact,
        "mean {all:e} vs {exact:e}"
    );
}

#[test]
fn extinction_too_large_to_track_is_refused_before_any_sampling() {
    // 1e9 per world unit across a cube of diagonal 3.5: billions of tracking steps per path.
    let lut = constant_lut(&cube(), 1e9, ALBEDO);
    let lighting = lighting(vec![Light::Ambient {
        radiance: Vec3::ONE,
    }]);
    let params = ReferenceParams {
        estimator: Estimator::Ambient,
        spp: 4,
        seed: 1,
        g: 0.0,
    };
    let err = try_run(&cube(), &lut, &lighting, &params, &NoProgress)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("classification") && err.contains("density_scale"),
        "{err}"
    );
}
