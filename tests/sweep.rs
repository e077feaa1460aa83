//! The occlusion sweep's visibility (the mean transmittance over all directions) against closed
//! forms and against the Monte Carlo sphere reference on phantoms and a real CT, and as the
//! AO of AO-shaded DVR (`ao_method = "sweep-physical"`).

#[path = "common/visibility.rs"]
mod visibility_common;
use visibility_common::{against_reference, ball, scene_for};

use occlux::ao::sweep::physical::cpu::visibility;
use occlux::ao::{ao_volume, AoMethod, AoVolumeParams};
use occlux::gpu::Compute;
use occlux::pipeline::Settled;
use occlux::progress::NoProgress;
use occlux::scene::Scene;
use occlux::volume::phantom;
use std::borrow::Cow;
use std::path::Path;

#[test]
fn the_centre_of_a_uniform_ball_sees_exp_of_minus_sigma_r() {
    // Every direction from the centre crosses exactly r of matter: V = exp(-sigma r). The
    // lattice walk crosses about 19 % more optical depth (the known bias in the sweep's module
    // docs): never less than the straight line, and by the same factor at every depth.
    for (sigma, r) in [
        (1.0f32, 0.8f32),
        (3.0, 0.6),
        (0.3, 0.9),
        (8.0, 0.8),
        (0.05, 0.9),
    ] {
        let n = 64;
        let v = visibility(&ball(n, r, sigma), &NoProgress).unwrap();
        let centre = 0.25
            * (v.at(n / 2, n / 2, n / 2)
                + v.at(n / 2 - 1, n / 2, n / 2)
                + v.at(n / 2, n / 2 - 1, n / 2)
                + v.at(n / 2, n / 2, n / 2 - 1));
        let want = (-sigma * r).exp();
        let ratio = (centre.ln() / want.ln()) as f64;
        println!("sigma {sigma} r {r}: {centre} vs {want} (optical depth ratio {ratio:.4})");
        assert!(
            (1.15..1.22).contains(&ratio),
            "sigma {sigma} r {r}: {centre} vs {want}"
        );
    }
}

#[test]
fn visibility_matches_the_sphere_reference_on_a_phantom_and_the_engine() {
    let ct = scene_for(
        "[volume]\nphantom = \"ct\"\nsize = 48\n[classification]\npreset = \"ct-bone\"\ndensity_scale = 0.05",
    );
    let engine = scene_for(
        "[volume]\npath = \"../../shared/data/scivis/engine.nrrd\"\nfit = 2.0\ncentre = [0, 0, 0]\n\
         [classification]\nunits = \"raw\"\npoints = [{ value = 60, sigma_t = 0 }, { value = 120, sigma_t = 20 }]",
    );
    for (name, scene, limit) in [("ct phantom", ct, 0.05), ("engine", engine, 0.05)] {
        let volume = scene.load_volume().unwrap();
        let (rmse, bias, noise) = against_reference(&volume, &scene, 300, |e| {
            visibility(e, &NoProgress).unwrap()
        });
        println!("{name}: RMSE {rmse:.4}, mean difference {bias:+.4}, reference noise {noise:.4}");
        assert!(rmse < limit, "{name}: RMSE {rmse}");
    }
}

#[test]
fn ao_volumes_by_sweep_refuse_what_they_cannot_compute() {
    let volume = phantom::by_name("sphere", 8).unwrap();
    let scene = scene_for("[volume]\nphantom = \"sphere\"\nsize = 8");
    let base = AoVolumeParams {
        method: AoMethod::SweepPhysical,
        ..Default::default()
    };
    let ao = ao_volume(
        &Compute::Cpu,
        Cow::Borrowed(&volume),
        &scene.classification,
        &base,
        &NoProgress,
    )
    .unwrap();
    assert!(ao.variance.is_none());
    assert!(ao.openness.values().iter().all(|v| (0.0..=1.0).contains(v)));
    for (params, key) in [
        (
            AoVolumeParams {
                field: occlux::ao::vao::FieldKind::Value,
                ..base
            },
            "field",
        ),
        (
            AoVolumeParams {
                variance: true,
                ..base
            },
            "variance",
        ),
        (
            AoVolumeParams {
                octants: true,
                ..base
            },
            "octants",
        ),
        (
            AoVolumeParams {
                convention: occlux::ao::AoConvention::Raw,
                ..base
            },
            "convention",
        ),
        // Issue 38: another method's parameters were ignored without a word.
        (
            AoVolumeParams {
                iso: Some(5.0),
                ..base
            },
            "iso",
        ),
        (AoVolumeParams { radius: 3, ..base }, "radius"),
        (
            AoVolumeParams {
                directions: 128,
                ..base
            },
            "directions",
        ),
        (
            AoVolumeParams {
                method: AoMethod::Vao(occlux::ao::vao::Estimator::Cdf),
                iso: Some(5.0),
                ..base
            },
            "iso",
        ),
        (
            AoVolumeParams {
                method: AoMethod::Ordinates,
                geometric: occlux::ao::sweep::geometric::GeometricParams {
                    gamma: 1.0,
                    ..Default::default()
                },
                ..base
            },
            "gamma",
        ),
    ] {
        let err = ao_volume(
            &Compute::Cpu,
            Cow::Borrowed(&volume),
            &scene.classification,
            &params,
            &NoProgress,
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(err.contains(key), "{err}");
    }
    assert_eq!("sweep".parse::<AoMethod>().unwrap(), AoMethod::Sweep);
    assert_eq!(
        "sweep-physical".parse::<AoMethod>().unwrap(),
        AoMethod::SweepPhysical
    );
    assert!("median"
        .parse::<AoMethod>()
        .unwrap_err()
        .to_string()
        .contains("sweep, sweep-physical"));
}

#[test]
fn ao_shaded_dvr_with_occlusion_sweeping_exports_its_signed_distance() {
    // The geometric mode through a scene file: the ao grid darkens where the surface is
    // enclosed, and the signed distance goes out with it (a level set in the VDB).
    let text = "[volume]\nphantom = \"ct\"\nsize = 32\n[classification]\npreset = \"ct-bone\"\n\
                [camera]\nposition = [3.2, -3.2, 2.6]\nwidth = 24\nheight = 24\n[[lights]]\n\
                type = \"ambient\"\nradiance = 1\n[render]\nmethod = \"ao\"\nao_method = \"sweep\"\n\
                ao_light = \"sky\"\n";
    let scene = Scene::parse(text, Path::new(".")).unwrap();
    let volume = scene.load_volume().unwrap();
    let rendered =
        occlux::pipeline::render(&Settled::named(&scene), &volume, &Compute::Cpu, &NoProgress)
            .unwrap();
    let names: Vec<&str> = rendered.grids.iter().map(|g| g.name).collect();
    assert_eq!(names, ["ao", "sdf"]);
    let (ao, sdf) = (&rendered.grids[0].volume, &rendered.grids[1].volume);
    assert!(ao.values().iter().all(|a| (0.0..=1.0).contains(a)));
    // Some of the surface is lit and some is shadowed under the sky.
    let surface: Vec<f32> = ao
        .values()
        .iter()
        .zip(sdf.values())
        .filter(|(_, d)| d.abs() < volume.spacing().x)
        .map(|(a, _)| *a)
        .collect();
    let lit = surface.iter().filter(|&&a| a > 0.8).count();
    let dark = surface.iter().filter(|&&a| a < 0.5).count();
    assert!(
        lit > 0 && dark > 0,
        "{lit} lit, {dark} dark of {}",
        surface.len()
    );
    assert!(rendered
        .image
        .rgba
        .iter()
        .all(|p| p.iter().all(|c| c.is_finite())));
}
