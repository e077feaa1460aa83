//! The multiple-scattering solver against closed forms: the light scattered once in a wide
//! homogeneous slab under a sun at normal incidence, and its bad input.

use glam::Vec3;
use occlux::lights::Light;
use occlux::progress::NoProgress;
use occlux::transport::medium::Medium;
use occlux::transport::scattering::{ambient_in_scattered, in_scattered, ScatteringParams};
use occlux::volume::Volume;

/// A slab of `n` x `n` cells across and `depth` cells deep, of extinction `sigma` per world
/// unit and scattering `albedo * sigma`, cells of side `h`.
fn slab(n: usize, depth: usize, h: f32, sigma: f32, albedo: f32) -> Medium {
    let cells = n * n * depth;
    Medium {
        extinction: Volume::new(
            [n, n, depth],
            Vec3::splat(h),
            Vec3::ZERO,
            vec![sigma; cells],
        )
        .unwrap(),
        scattering: vec![Vec3::splat(albedo * sigma); cells],
    }
}

fn sun() -> Light {
    Light::Directional {
        to_light: Vec3::Z,
        irradiance: Vec3::ONE,
    }
}

/// The mean radiance (1 / 4 pi of the integral over the sphere) of light scattered once and
/// isotropically, at depth `z` of a slab `thickness` deep under unit irradiance at normal
/// incidence: light from above (mu > 0, travelling deeper) and from below, each the source
/// s(z') = albedo sigma e^(-sigma z') / (4 pi) attenuated along the slant path, integrated in
/// z' in closed form and in mu by the midpoint rule.
fn once_scattered_mean(z: f64, thickness: f64, sigma: f64, albedo: f64) -> f64 {
    let steps = 200_000;
    let mut sum = 0.0;
    for s in 0..steps {
        let mu = (s as f64 + 0.5) / steps as f64;
        let b = sigma / mu;
        // From above: (e^(-sigma z) - e^(-b z)) / (mu (b - sigma)).
        let above = ((-sigma * z).exp() - (-b * z).exp()) / (mu * (b - sigma));
        // From below: (e^(-sigma z) - e^(-sigma T - b (T - z))) / (mu (sigma + b)).
        let below = ((-sigma * z).exp() - (-sigma * thickness - b * (thickness - z)).exp())
            / (mu * (sigma + b));
        sum += above + below;
    }
    // (1/2) int over mu in [-1, 1] of L, L = albedo sigma / (4 pi) * the integrals.
    0.5 * sum / steps as f64 * albedo * sigma / (4.0 * std::f64::consts::PI)
}

/// The root mean square relative error of the in-scattered light of once-scattered light
/// down the slab's central column (largest in the face cells, where the field bends most
/// within a cell).
fn slab_error(n: usize, depth: usize, h: f32, sigma: f32) -> f64 {
    let albedo = 0.8;
    let medium = slab(n, depth, h, sigma, albedo);
    let params = ScatteringParams {
        directions: 1024,
        bounces: 1,
        g: 0.0,
    };
    let j = in_scattered(None, &medium, &sun(), &params, &NoProgress).unwrap();
    assert_eq!(j.bounces, 1);
    let mut squares = 0.0f64;
    for k in 0..depth {
        let cell = n / 2 + n * (n / 2 + n * k);
        // The light enters at the top face, half a cell above the last centre.
        let z = (depth as f64 - 0.5 - k as f64) * h as f64;
        let want = once_scattered_mean(z, depth as f64 * h as f64, sigma as f64, albedo as f64);
        let got = j.bands.mean(cell).x as f64;
        squares += ((got - want) / want).powi(2);
        // With g = 0 the in-scattered light is isotropic: band 0 alone.
        assert_eq!(j.bands.per_channel(), 1);
    }
    (squares / depth as f64).sqrt()
}

#[test]
fn once_scattered_light_in_a_slab_meets_its_closed_form_and_converges_with_the_grid() {
    // Optical depth 0.5 per cell, then the same slab on cells half as wide.
    let coarse = slab_error(40, 8, 1.0, 0.5);
    let fine = slab_error(80, 16, 0.5, 0.5);
    println!("relative RMSE: {coarse:.4} (h = 1), {fine:.4} (h = 1/2)");
    assert!(coarse < 0.03, "{coarse}");
    assert!(fine < 0.6 * coarse, "{fine} vs {coarse}");
}

#[test]
fn optically_thick_cells_are_bounded_by_their_source_model() {
    // Optical depth 2 per cell: the sun's light falls by e^-2 from cell to cell, and a source
    // taken linear between the ends of a segment lies above that curve (a chord above a
    // convex function): measured +23 % to +42 % in the cells below the first, -7 % in the lit
    // face cell, which is what a viewer on the light's side sees. Bounded here so that a
    // change to the segment's rule shows; the source's log-linear form would remove it
    // (docs/transport.md, "Multiple scattering").
    let error = slab_error(24, 6, 1.0, 2.0);
    println!("relative RMSE at tau = 2 per cell: {error:.4}");
    assert!(error < 0.4, "{error}");
}

#[test]
fn more_bounces_add_light_and_stop_where_nothing_is_absorbed() {
    let medium = slab(12, 12, 1.0, 0.4, 1.0);
    let run = |bounces| {
        let params = ScatteringParams {
            directions: 32,
            bounces,
            g: 0.6,
        };
        in_scattered(None, &medium, &sun(), &params, &NoProgress).unwrap()
    };
    let (one, eight) = (run(1), run(8));
    assert_eq!(eight.bounces, 8);
    let total = |j: &occlux::transport::scattering::InScattered| -> f32 {
        (0..medium.scattering.len())
            .map(|cell| j.bands.mean(cell).x)
            .sum()
    };
    assert!(total(&eight) > 1.5 * total(&one));
    assert!(eight.bands.values().iter().all(|v| v.is_finite()));
    assert!((0..medium.scattering.len()).all(|cell| eight.bands.mean(cell).min_element() >= 0.0));
    // Forward scattering from a sun overhead: the light scattered once more leaves mostly
    // downwards (band 1's z coefficient is negative: the sun's light travels along -z).
    let centre = 6 + 12 * (6 + 12 * 9);
    assert!(one.bands.cell(centre)[3] < 0.0);
    assert!(one.at(medium.centre(centre), -Vec3::Z).x > one.at(medium.centre(centre), Vec3::Z).x);
}

#[test]
fn a_lamp_inside_the_medium_stays_finite_and_ambient_light_is_refused() {
    let medium = slab(8, 8, 1.0, 0.5, 0.9);
    let params = ScatteringParams {
        directions: 32,
        bounces: 2,
        g: 0.0,
    };
    let lamp = Light::Point {
        position: Vec3::splat(3.0),
        intensity: Vec3::splat(10.0),
    };
    let j = in_scattered(None, &medium, &lamp, &params, &NoProgress).unwrap();
    assert!((0..medium.scattering.len()).all(|cell| {
        let mean = j.bands.mean(cell);
        mean.is_finite() && mean.x > 0.0
    }));
    let e = in_scattered(
        None,
        &medium,
        &Light::Ambient {
            radiance: Vec3::ONE,
        },
        &params,
        &NoProgress,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("ambient"), "{e}");
    for directions in [0, 4] {
        let p = ScatteringParams {
            directions,
            ..params
        };
        let e = in_scattered(None, &medium, &lamp, &p, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(e.contains("directions"), "{e}");
    }
    let p = ScatteringParams { g: 1.0, ..params };
    assert!(in_scattered(None, &medium, &lamp, &p, &NoProgress).is_err());
}

#[test]
fn the_solver_grid_keeps_enough_cells_along_the_longest_axis() {
    use occlux::render::ipsvi::transport_coarsen;
    assert_eq!(transport_coarsen([48; 3]), 1);
    assert_eq!(transport_coarsen([255, 40, 40]), 1);
    assert_eq!(transport_coarsen([256, 256, 128]), 2);
    assert_eq!(transport_coarsen([41, 512, 512]), 4);
    assert_eq!(transport_coarsen([1024, 1024, 1024]), 8);
}

/// Ambient light whose light scattered once is J_1 = 1 everywhere (a visibility of ones) in a
/// homogeneous cube: the light scattered into its centre once more is
/// J_2 = albedo E_w[1 - e^(-sigma d(w))], d(w) = h / max_i |w_i| the distance to the cube's
/// surface along w (h its half side), the mean taken over many Fibonacci directions here and
/// over the solver's ordinates there (the difference is its angular and spatial error).
#[test]
fn ambient_light_scattered_again_at_a_cubes_centre_meets_its_closed_form() {
    let (n, h, sigma, albedo) = (25, 0.1f32, 0.8f32, 0.9f32);
    let medium = slab(n, n, h, sigma, albedo);
    let ones = Volume::new([n; 3], Vec3::splat(h), Vec3::ZERO, vec![1.0; n * n * n]).unwrap();
    let params = ScatteringParams {
        directions: 128,
        bounces: 1,
        g: 0.0,
    };
    let j = ambient_in_scattered(None, &medium, &ones, &params, &NoProgress).unwrap();
    assert_eq!(j.bounces, 1);
    let half = 0.5 * n as f64 * h as f64; // the medium ends at the box's faces
    let directions = occlux::transport::directions::fibonacci(200_000);
    let expected = albedo as f64
        * directions
            .iter()
            .map(|w| {
                let d = half / w.abs().max_element();
                1.0 - (-(sigma as f64) * d).exp()
            })
            .sum::<f64>()
        / directions.len() as f64;
    let centre = (n / 2) * (n * n + n + 1);
    let got = j.bands.mean(centre);
    assert!((got.x - got.z).abs() < 1e-6, "a white medium: {got}");
    let error = (got.x as f64 / expected - 1.0).abs();
    println!(
        "J_2 at the centre {} against {expected:.5}: {error:.2e}",
        got.x
    );
    assert!(error < 0.02, "J_2 {} against {expected}", got.x);
}
