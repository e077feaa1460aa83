//! The stability suite: every registered method at its known failure modes, on small scenes
//! (volumes <= 32^3, images <= 32 x 32, CPU only). Per case: the count of NaN and infinite
//! values (must be 0), the value range, and where a Monte Carlo reference exists the relative
//! RMSE against it (`design_error`), under bounds set from measurement with a stated margin.
//! A method may refuse a case with an error naming the problem; a panic or a NaN fails.
//!
//! Run: `cargo test --release --test stability -- --nocapture` (prints the measured numbers;
//! docs/failure-modes.md tabulates them).

mod common;

use common::render::{
    check_finite, finite_problems, range_of, reference_of, render, render_on, scene, Range,
};
use glam::Vec3;
use occlux::ao::AoMethod;
use occlux::method::ParamKind;
use occlux::metric::design_error;
use occlux::registry::{find, METHODS};
use occlux::render::reference::{Estimator, ReferenceImage};
use occlux::render::{RenderImage, Rendered};
use occlux::scene::{Method, Scene};
use occlux::volume::Volume;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

// ---- Helpers ----

/// (relative RMSE, the part the reference's noise does not explain, bias, noise).
fn error_against(image: &RenderImage, reference: &ReferenceImage) -> (f64, f64, f64, f64) {
    let mean: Vec<[f32; 3]> = reference.mean.iter().map(|m| [m[0], m[1], m[2]]).collect();
    let (_, rmse, bias, noise) =
        design_error(&image.rgba, &mean, Some(&reference.stderr), 0.0).unwrap();
    let excess = (rmse * rmse - noise * noise).max(0.0).sqrt();
    (rmse, excess, bias, noise)
}

/// A scene on the CT phantom (32^3 in [-1, 1]^3, the ct-bone preset) with `camera`, `lights`
/// and `render` as TOML.
fn ct_scene(camera: &str, lights: &str, render: &str) -> Scene {
    scene(&format!(
        "[volume]\nphantom = \"ct\"\nsize = 32\nfit = 2.0\ncentre = [0, 0, 0]\n\n\
         [camera]\n{camera}\nwidth = 32\nheight = 32\n\n{lights}\n\n[render]\n{render}\n"
    ))
}

/// As [`ct_scene`] with examples/demo.toml's classification (soft tissue, density 0.35), where
/// tests/dos_accuracy.rs measures DOS at theta 50.
fn dos_scene(camera: &str, keys: &str) -> Scene {
    scene(&format!(
        "[volume]\nphantom = \"ct\"\nsize = 32\nfit = 2.0\ncentre = [0, 0, 0]\n\n\
         [classification]\npreset = \"ct-soft-tissue\"\ndensity_scale = 0.35\n\n\
         [camera]\n{camera}\nwidth = 32\nheight = 32\n\n{AMBIENT}\n\n\
         [render]\nmethod = \"dos\"\n{keys}\n"
    ))
}

const EYE: &str = "position = [2.4, -2.6, 1.4]\ntarget = [0, 0, 0]\nfov_deg = 40";
const AMBIENT: &str = "[[lights]]\ntype = \"ambient\"\nradiance = 1.0";

// ---- DOS ----

/// DOS on `s` against the cone reference of `theta` at 64 spp: prints the range and the error
/// and returns the error beyond the reference's noise.
fn dos_against_cone(name: &str, s: &Scene, theta: f32) -> f64 {
    let image = render(s).unwrap();
    let range = check_finite(name, &image);
    let reference = reference_of(
        s,
        Estimator::Cone {
            aperture: theta.to_radians(),
        },
        64,
    );
    let (rmse, excess, bias, noise) = error_against(&image, &reference);
    println!(
        "{name}: {range}; vs cone reference rmse {rmse:.4} (beyond noise {excess:.4}), bias \
         {bias:+.4}, noise {noise:.4}"
    );
    assert!(range.alpha.1 > 0.0, "{name}: nothing drawn");
    excess
}

#[test]
fn dos_at_the_limit_of_theta_stays_finite() {
    // theta 50 is the baseline (tests/dos_accuracy.rs: 0.04 at 48^2, 1024 spp). Towards 90
    // degrees the samples of equal solid angle stay near their pixel, and the error stays at
    // the baseline's (measured 0.10 / 0.045 / 0.052 beyond noise at 50 / 89 / 89.9); with the
    // paper's equal areas of an ever wider base it grew to 0.68 and 1.04 (the failure mode,
    // docs/failure-modes.md). The bounds guard that fix with a margin of 1.5x.
    let mut failures = vec![];
    for (theta, bound) in DOS_THETA_BOUNDS {
        let s = dos_scene(EYE, &format!("theta_deg = {theta}"));
        let name = format!("dos theta {theta}");
        let excess = dos_against_cone(&name, &s, theta);
        if excess >= bound {
            failures.push(format!("{name}: {excess:.4} >= {bound}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// (theta, the error beyond the reference's noise allowed).
const DOS_THETA_BOUNDS: [(f32, f64); 3] = [(50.0, 0.15), (89.0, 0.15), (89.9, 0.15)];

#[test]
fn dos_thin_slices_stay_finite_or_are_refused() {
    // A voxel is 1/16 here: slices of 1/60 and 1/600 of a voxel (grid 1 to keep it short);
    // 1e-6 would take over MAX_SLICES and is refused by name. Thin slices must converge, not
    // drift: each against the cone reference (theta 50).
    let mut failures = vec![];
    for d in [1e-3f32, 1e-4, 1e-6] {
        let s = dos_scene(EYE, &format!("grid = 1\nslice_distance = {d:e}"));
        let name = format!("dos slice_distance {d:e}");
        match s.load_volume().and_then(|v| render_on(&s, &v)) {
            Ok(_) => {
                let excess = dos_against_cone(&name, &s, 50.0);
                if excess >= DOS_THIN_BOUND {
                    failures.push(format!("{name}: {excess:.4} >= {DOS_THIN_BOUND}"));
                }
            }
            Err(e) => {
                println!("{name}: refused: {e}");
                assert!(e.to_string().contains("slice_distance"), "{name}: {e}");
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Error beyond the reference's noise allowed with thin slices (grid 1, theta 50).
const DOS_THIN_BOUND: f64 = 0.3;

#[test]
fn dos_with_the_camera_inside_the_volume_stays_finite() {
    // Likely cause (not verified): DOS's occlusion buffer starts unoccluded at the eye, so the
    // matter behind the camera never occludes, and with the eye inside the phantom's shell
    // the image is far brighter than the cone reference at theta 50 (and darker at 89.9). The bound records that (measured
    // with a margin of about 1.5x); it guards against NaN and regressions, not accuracy.
    let mut failures = vec![];
    for (what, target, up) in [
        ("looking +x", "[1, 0, 0]", "[0, 0, 1]"),
        ("looking -z", "[0, 0, -1]", "[0, 1, 0]"),
    ] {
        let camera = format!("position = [0, 0, 0]\ntarget = {target}\nup = {up}\nfov_deg = 60");
        for theta in [50.0f32, 89.9] {
            let s = dos_scene(&camera, &format!("theta_deg = {theta}"));
            let name = format!("dos camera inside, {what}, theta {theta}");
            let excess = dos_against_cone(&name, &s, theta);
            if excess >= DOS_INSIDE_BOUND {
                failures.push(format!("{name}: {excess:.4} >= {DOS_INSIDE_BOUND}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Error beyond the reference's noise allowed with the eye inside the volume.
const DOS_INSIDE_BOUND: f64 = 2.5;

// ---- AO-shaded DVR ----

/// Every `ao_method` the registry offers.
/// The `ao_method` line with a radius, for the estimators that take one (the others refuse it).
fn ao_method_with_radius(m: &str, radius: u32) -> String {
    match m.parse::<AoMethod>() {
        Ok(AoMethod::Vao(_)) => format!("ao_method = \"{m}\"\nao_radius = {radius}"),
        _ => format!("ao_method = \"{m}\""),
    }
}

fn ao_methods() -> Vec<&'static str> {
    let spec = find("ao").unwrap();
    let param = spec.params.iter().find(|p| p.key == "ao_method").unwrap();
    match &param.kind {
        ParamKind::Choice { options } => options.iter().map(|o| o.name).collect(),
        _ => panic!("ao_method is not a choice"),
    }
}

/// A 16^3 volume in [-1, 1]^3 whose every voxel is `value`.
fn constant_volume(value: f32) -> Volume {
    Volume::new(
        [16; 3],
        Vec3::splat(0.125),
        Vec3::splat(-1.0 + 0.0625),
        vec![value; 16 * 16 * 16],
    )
    .unwrap()
}

/// Renders an AO scene on `volume`; Err(message) for a refusal, "PANIC: ..." for a panic.
fn ao_case(name: &str, s: &Scene, volume: &Volume) -> Result<(Range, Rendered), String> {
    match catch_unwind(AssertUnwindSafe(|| render_on(s, volume))) {
        Ok(Ok(r)) => {
            let problems = finite_problems(&r.image);
            let grid_bad: usize = r
                .grids
                .iter()
                .map(|g| g.volume.values().iter().filter(|v| !v.is_finite()).count())
                .sum();
            if problems.is_empty() && grid_bad == 0 {
                Ok((range_of(&r.image), r))
            } else {
                Err(format!(
                    "FAIL {name}: {problems}; {grid_bad} non-finite grid values"
                ))
            }
        }
        Ok(Err(e)) => Err(format!("refused {name}: {e}")),
        Err(p) => Err(format!("PANIC {name}: {}", panic_text(&p))),
    }
}

fn panic_text(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default()
}

const AO_CAMERA: &str = "position = [2.4, -2.6, 1.4]\ntarget = [0, 0, 0]\nfov_deg = 40";

fn ao_scene(classification: &str, render: &str) -> Scene {
    scene(&format!(
        "[volume]\nphantom = \"sphere\"\nsize = 16\nfit = 2.0\ncentre = [0, 0, 0]\n\n\
         {classification}\n\n[camera]\n{AO_CAMERA}\nwidth = 24\nheight = 24\n\n{AMBIENT}\n\n\
         [render]\nmethod = \"ao\"\n{render}\n"
    ))
}

#[test]
fn ao_on_a_constant_volume_stays_finite_for_every_estimator() {
    // A constant field has no variance and min == max: the CDF and Gauss estimators divide by
    // the spread, and normalised transfer-function units divide by the value range.
    let mut failures = vec![];
    for units in ["raw", "normalized"] {
        let classification = if units == "raw" {
            "[classification]\nunits = \"raw\"\npoints = [{ value = 0, sigma_t = 2 }, \
             { value = 2, sigma_t = 2 }]"
        } else {
            "[classification]\npreset = \"ct-bone\""
        };
        for m in ao_methods() {
            let s = ao_scene(classification, &ao_method_with_radius(m, 4));
            let name = format!("ao {m}, constant volume, {units} units");
            match ao_case(&name, &s, &constant_volume(1.0)) {
                Ok((range, r)) => {
                    let ao = r.grids.iter().find(|g| g.name == "ao").map(|g| {
                        g.volume
                            .values()
                            .iter()
                            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
                                (a.min(*v), b.max(*v))
                            })
                    });
                    println!("{name}: {range}, ao grid range {ao:?}");
                }
                Err(e) if e.starts_with("refused") => println!("{e}"),
                Err(e) => failures.push(e),
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn ao_radii_far_larger_than_the_volume_stay_finite() {
    // A 16^3 sphere with ao_radius 256 (the registry's maximum) and 64 for the O(R^3) exact
    // estimator; only VAO's estimators take a radius (the sweeps reach the whole volume).
    let mut failures = vec![];
    let takes_radius = |m: &&str| matches!(m.parse::<AoMethod>(), Ok(AoMethod::Vao(_)));
    for m in ao_methods().into_iter().filter(takes_radius) {
        let radius = if m == "exact" { 64 } else { 256 };
        let s = ao_scene("", &format!("ao_method = \"{m}\"\nao_radius = {radius}"));
        let volume = s.load_volume().unwrap();
        let name = format!("ao {m}, radius {radius} on 16^3");
        match ao_case(&name, &s, &volume) {
            Ok((range, _)) => println!("{name}: {range}"),
            Err(e) if e.starts_with("refused") => println!("{e}"),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn occlusion_sweeping_diagonal_streaks_are_bounded_on_a_sphere() {
    // A convex sphere's surface is unoccluded from outside: ideally AO = 1 on its whole
    // surface layer. The geometric sweep's three-neighbour average follows the octant
    // diagonals (the paper's streaks), so the AO varies over the surface; the spread (max -
    // min) and the mean are measured here on the 32^3 sphere's surface layer.
    for (m, bound) in [("sweep", SWEEP_SPREAD_BOUND), ("sweep-physical", 0.55)] {
        let s = scene(&format!(
            "[volume]\nphantom = \"sphere\"\nsize = 32\nfit = 2.0\ncentre = [0, 0, 0]\n\n\
             [camera]\n{AO_CAMERA}\nwidth = 24\nheight = 24\n\n{AMBIENT}\n\n\
             [render]\nmethod = \"ao\"\nao_method = \"{m}\"\n"
        ));
        let volume = s.load_volume().unwrap();
        let name = format!("ao {m} on a sphere");
        let (range, r) = ao_case(&name, &s, &volume).unwrap_or_else(|e| panic!("{e}"));
        let ao = &r.grids.iter().find(|g| g.name == "ao").unwrap().volume;
        let (lo, hi) = volume.value_range();
        let surface: Vec<f32> = volume
            .values()
            .iter()
            .zip(ao.values())
            .filter(|(v, _)| {
                let t = (**v - lo) / (hi - lo);
                t > 0.2 && t < 0.8
            })
            .map(|(_, a)| *a)
            .collect();
        assert!(!surface.is_empty(), "{name}: no surface voxels");
        let (min, max) = surface
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let mean = surface.iter().sum::<f32>() / surface.len() as f32;
        println!(
            "{name}: {range}; AO over {} surface voxels {min:.4}..{max:.4} (spread {:.4}), \
             mean {mean:.4}",
            surface.len(),
            max - min
        );
        assert!(
            (0.0..=1.0).contains(&min) && max <= 1.0,
            "{name}: AO outside [0, 1]"
        );
        assert!(max - min < bound, "{name}: spread {}", max - min);
    }
}

/// Largest spread of the geometric sweep's AO over a sphere's surface layer.
const SWEEP_SPREAD_BOUND: f32 = 0.12;

// ---- IPSVI ----

#[test]
fn ipsvi_at_its_light_placements_agrees_with_the_references() {
    // Bounds on the error beyond the reference's noise (256 spp), single and multiple
    // scattering, per case: the measurement (docs/failure-modes.md) with a margin of about
    // 1.5x. Where IPSVI works (sun along the view, volume off screen) single scattering is
    // within 0.1, as in tests/ipsvi.rs; the diffusion term of `multiple` errs by 0.2-0.35 on this
    // 32^3 bone phantom. Backlit (the sun opposite the view, or 12 degrees off it) the light
    // crosses the whole phantom and its transmittance varies by orders of magnitude between
    // cache rays at this image's default texel (0.7 voxel): interpolating their optical depths
    // errs dark by about 20 % (interpolating transmittances erred bright by 75 %; a cache of
    // 256 texels is within 3 %), and the reference itself is noisy there (0.14-0.36). The
    // multiple scattering of a backlit body and of a lamp inside are the diffusion term's
    // failure modes: their bounds record them, not accuracy.
    let ortho = "projection = \"orthographic\"\northo_scale = 2.6\nposition = [2.4, -2.6, 1.4]\n\
                 target = [0, 0, 0]";
    let sun_at =
        |d: &str| format!("[[lights]]\ntype = \"directional\"\ndirection = {d}\nirradiance = 3.0");
    let cases = [
        (
            "sun along the view, perspective",
            EYE.to_owned(),
            sun_at("[2.4, -2.6, 1.4]"),
            [0.1, 0.4],
        ),
        (
            "sun along the view, orthographic",
            ortho.to_owned(),
            sun_at("[2.4, -2.6, 1.4]"),
            [0.1, 0.45],
        ),
        (
            "sun opposite the view, perspective",
            EYE.to_owned(),
            sun_at("[-2.4, 2.6, -1.4]"),
            [0.8, 3.0],
        ),
        (
            // The control: backlit 12 degrees off the view's axis.
            "sun 12 degrees off opposite, perspective",
            EYE.to_owned(),
            sun_at("[-2.4, 2.6, -0.6]"),
            [1.35, 3.0],
        ),
        (
            "sun opposite the view, orthographic",
            ortho.to_owned(),
            sun_at("[-2.4, 2.6, -1.4]"),
            [0.75, 1.6],
        ),
        (
            // In the phantom's air cavity, as tests/ipsvi.rs places it.
            "lamp inside the volume",
            EYE.to_owned(),
            "[[lights]]\ntype = \"point\"\nposition = [0.35, 0.1, 0.1]\nintensity = 3.0".to_owned(),
            [0.1, 1.25],
        ),
        (
            "volume mostly off screen",
            "position = [2.4, -2.6, 1.4]\ntarget = [-0.9, -1.0, 1.0]\nfov_deg = 30".to_owned(),
            sun_at("[-0.9, 0.2, 1.0]"),
            [0.1, 0.5],
        ),
    ];
    let mut failures = vec![];
    for (what, camera, light, bounds) in &cases {
        for (scattering, bound) in ["single", "multiple"].into_iter().zip(bounds) {
            let s = ct_scene(
                camera,
                light,
                &format!("method = \"ipsvi\"\nscattering = \"{scattering}\""),
            );
            let name = format!("ipsvi {what}, {scattering}");
            let image = render(&s).unwrap();
            let range = check_finite(&name, &image);
            let estimator = match scattering {
                "single" => Estimator::Single,
                _ => Estimator::Multiple { bounces: 8 },
            };
            let reference = reference_of(&s, estimator, IPSVI_SPP);
            let (rmse, excess, bias, noise) = error_against(&image, &reference);
            println!(
                "{name}: {range}; vs {scattering} reference rmse {rmse:.4} (beyond noise \
                 {excess:.4}), bias {bias:+.4}, noise {noise:.4}"
            );
            if excess >= *bound {
                failures.push(format!("{name}: {excess:.4} >= {bound}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Samples per pixel of IPSVI's references.
const IPSVI_SPP: u32 = 256;

// ---- Spacing and value range ----

/// Writes a 16 x 16 x 16 float32 raw volume whose values span 1e-6..1e6 (log-spaced along
/// the diagonal, a dense ball of 1e6 in the middle) and returns its path.
fn wide_range_raw() -> std::path::PathBuf {
    let n = 16usize;
    let mut bytes = Vec::with_capacity(n * n * n * 4);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let c = (n as f32 - 1.0) / 2.0;
                let r = Vec3::new(i as f32 - c, j as f32 - c, k as f32 - c).length() / (c * 1.8);
                let t = (1.0 - r).clamp(0.0, 1.0);
                let v = 10f32.powf(-6.0 + 12.0 * t);
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    // The extremes exactly: 1e-6 in a corner, 1e6 at a voxel of the centre.
    bytes[..4].copy_from_slice(&1e-6f32.to_le_bytes());
    let centre = 4 * (8 + n * (8 + n * 8));
    bytes[centre..centre + 4].copy_from_slice(&1e6f32.to_le_bytes());
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("stability-wide-range.raw");
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Every registered method at its defaults, lit by the lights of the kinds it takes, on the
/// volume of `volume` (TOML) viewed from `eye` towards the origin at `scale` world units.
fn every_method_on(what: &str, volume: &str, scale: f32, failures: &mut Vec<String>) {
    let eye = Vec3::new(2.4, -2.6, 1.4) * scale;
    let lamp = Vec3::new(-1.5, -2.5, 2.0) * scale;
    let all_lights = format!(
        "{AMBIENT}\n\n[[lights]]\ntype = \"directional\"\ndirection = [-0.3, -1.0, 1.2]\n\
         irradiance = 3.0\n\n[[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\n\
         intensity = {}",
        lamp.x,
        lamp.y,
        lamp.z,
        3.0 * lamp.length_squared()
    );
    let base = scene(&format!(
        "{volume}\n\n[classification]\nunits = \"raw\"\npoints = [\
         {{ value = 1e-6, sigma_t = 0 }}, {{ value = 1.0, sigma_t = {s1} }}, \
         {{ value = 1e6, sigma_t = {s2}, albedo = [0.8, 0.8, 0.8] }}]\n\n\
         [camera]\nposition = [{}, {}, {}]\ntarget = [0, 0, 0]\nfov_deg = 40\nwidth = 24\n\
         height = 24\n\n{all_lights}\n",
        eye.x,
        eye.y,
        eye.z,
        s1 = 1.0 / scale,
        s2 = 20.0 / scale,
    ));
    let volume = match base.load_volume() {
        Ok(v) => v,
        Err(e) => {
            failures.push(format!("{what}: the volume did not load: {e}"));
            return;
        }
    };
    let (lo, hi) = volume.value_range();
    println!(
        "{what}: spacing {:?}, bounds {:?}, values {lo:e}..{hi:e}",
        volume.spacing(),
        volume.bounds()
    );
    for spec in METHODS {
        let method: Method = spec.at_setting("").unwrap();
        let mut s = base.clone();
        s.lighting = spec.lights_of(&base.lighting);
        s.method = method;
        let name = format!("{what}, {}", spec.name);
        match catch_unwind(AssertUnwindSafe(|| render_on(&s, &volume))) {
            Ok(Ok(r)) => {
                let problems = finite_problems(&r.image);
                let coverage = r.image.rgba.iter().fold(0.0f32, |a, p| a.max(p[3]));
                if !problems.is_empty() {
                    failures.push(format!("FAIL {name}: {problems}"));
                } else if coverage < 0.01 {
                    failures.push(format!("EMPTY {name}: coverage at most {coverage}"));
                } else {
                    println!("{name}: {}", range_of(&r.image));
                }
            }
            // Surviving is rendering: a method that refuses these volumes fails the test.
            Ok(Err(e)) => failures.push(format!("REFUSED {name}: {e}")),
            Err(p) => failures.push(format!("PANIC {name}: {}", panic_text(&p))),
        }
    }
}

#[test]
fn every_method_survives_tiny_anisotropic_spacing_and_values_over_twelve_decades() {
    let raw = wide_range_raw();
    let raw = raw.display();
    let volume = |spacing: &str, placement: &str| {
        format!(
            "[volume]\npath = \"{raw}\"\n{placement}\n\n[volume.raw]\ndims = [16, 16, 16]\n\
             type = \"float32\"\nspacing = {spacing}\n"
        )
    };
    let mut failures = vec![];
    every_method_on(
        "spacing 2e-5 x 2e-5 x 4e-5, no fit",
        &volume("[2e-5, 2e-5, 4e-5]", "centre = [0, 0, 0]"),
        4e-4,
        &mut failures,
    );
    every_method_on(
        "spacing 2e-5 x 2e-5 x 4e-5, fit 2",
        &volume("[2e-5, 2e-5, 4e-5]", "fit = 2.0\ncentre = [0, 0, 0]"),
        1.0,
        &mut failures,
    );
    every_method_on(
        "spacing 1 x 1 x 4, fit 2",
        &volume("[1, 1, 4]", "fit = 2.0\ncentre = [0, 0, 0]"),
        1.0,
        &mut failures,
    );
    assert!(failures.is_empty(), "{failures:#?}");
}

// ---- Monte Carlo deep shadows ----

#[test]
fn the_single_scattering_reference_stays_finite_in_deep_shadow() {
    // A sun behind a slab of optical depth ~ 400 (sigma_t 400 per world unit over a slab about
    // a world unit thick): the light reaching the far side is ~exp(-400).
    let s = scene(&format!(
        "[volume]\nphantom = \"slab\"\nsize = 24\nfit = 2.0\ncentre = [0, 0, 0]\n\n\
         [classification]\nunits = \"normalized\"\npoints = [{{ value = 0, sigma_t = 0 }}, \
         {{ value = 1, sigma_t = 400, albedo = [0.9, 0.9, 0.9] }}]\n\n\
         [camera]\n{EYE}\nwidth = 24\nheight = 24\n\n\
         [[lights]]\ntype = \"directional\"\ndirection = [-2.4, 2.6, -1.4]\nirradiance = 3.0\n\n\
         [render]\nmethod = \"ipsvi\"\n"
    ));
    for estimator in [Estimator::Single, Estimator::Multiple { bounces: 8 }] {
        let reference = reference_of(&s, estimator, 64);
        let name = format!("{} reference, sun behind a dense slab", estimator.name());
        let image = reference.to_render();
        let range = check_finite(&name, &image);
        let bad_stderr = reference
            .stderr
            .iter()
            .flatten()
            .filter(|v| !v.is_finite() || **v < 0.0)
            .count();
        let mean_min = reference
            .mean
            .iter()
            .flat_map(|m| &m[..3])
            .fold(f32::INFINITY, |a, v| a.min(*v));
        let stderr_max = reference
            .stderr
            .iter()
            .flatten()
            .fold(0.0f32, |a, v| a.max(*v));
        println!("{name}: {range}, mean >= {mean_min:e}, stderr <= {stderr_max:e}");
        assert_eq!(bad_stderr, 0, "{name}: non-finite or negative stderr");
        assert!(mean_min >= 0.0, "{name}: mean {mean_min}");
    }
    // The methods lit by the sun, against the single reference: finite. Only ~15 pixels are
    // lit (the slab's grazing edges, a texel wide), so the errors are those of a few edge
    // pixels: IPSVI -71 % at its default texel (beyond noise 2.06), -2 % with 128 texels;
    // half-angle +152 % (8.8). (Against the reference's earlier transmittance estimator,
    // ratio tracking with Russian roulette, whose deep-shadow samples were mostly 0 and rarely
    // large, they read -73 % and -9 %; its estimates along these edges' shadow rays now match
    // quadrature to 1e-4.) The bounds are the measurements with a margin and record the
    // failure mode.
    let reference = reference_of(&s, Estimator::Single, 64);
    for (m, bound) in [("ipsvi", 2.5), ("half-angle", 11.0)] {
        let mut s = s.clone();
        s.method = find(m).unwrap().at_setting("").unwrap();
        let name = format!("{m} behind a dense slab");
        let image = render(&s).unwrap();
        let range = check_finite(&name, &image);
        let peak_ref = reference
            .mean
            .iter()
            .flat_map(|p| &p[..3])
            .fold(0.0f32, |a, v| a.max(*v));
        let (rmse, excess, bias, noise) = error_against(&image, &reference);
        println!(
            "{name}: {range} (reference peak {peak_ref:e}); vs single reference rmse \
             {rmse:.4} (beyond noise {excess:.4}), bias {bias:+.4}, noise {noise:.4}"
        );
        assert!(excess < bound, "{name}: {excess} >= {bound}");
    }
}
