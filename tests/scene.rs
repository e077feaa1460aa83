//! Scene files: the examples parse, placement follows `fit` and `centre`, and bad keys or values
//! are errors naming the key and the file.

use glam::Vec3;
use occlux::render::raycast::Shading;
use occlux::scene::{Method, Scene};
use std::path::Path;

const MINIMAL: &str = r#"
[volume]
phantom = "sphere"
size = 16

[camera]
position = [0, -4, 0]
"#;

fn parse(text: &str) -> occlux::Result<Scene> {
    Scene::parse(text, Path::new("."))
}

fn error_of(text: &str) -> String {
    parse(text).unwrap_err().to_string()
}

#[test]
fn defaults_fill_a_minimal_scene() {
    let scene = parse(MINIMAL).unwrap();
    assert_eq!((scene.camera.width, scene.camera.height), (512, 512));
    assert!(matches!(
        scene.method,
        Method::Gradient(p) if matches!(p.raycast().shading, Shading::Gradient(_))
    ));
    assert!((scene.camera.forward - Vec3::Y).length() < 1e-6);
}

#[test]
fn engine_example_matches_the_cycles_benchmark_placement() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/engine.toml"));
    let scene = Scene::from_file(path).unwrap();
    let volume = scene.load_volume().unwrap_or_else(|e| {
        panic!("needs ../shared/data/scivis/engine.nrrd beside the checkout: {e}")
    });
    // shared/bench/engine-cycles/README.md: voxel size 1/128, box [-1,1]^2 x [-0.5,0.5].
    assert!((volume.spacing() - Vec3::splat(1.0 / 128.0)).length() < 1e-7);
    let (lo, hi) = volume.bounds();
    assert!((lo - Vec3::new(-1.0, -1.0, -0.5)).length() < 1e-5, "{lo}");
    assert!((hi - Vec3::new(1.0, 1.0, 0.5)).length() < 1e-5, "{hi}");
    // 65 mm lens on a 36 mm sensor.
    let fov = match scene.camera.projection {
        occlux::camera::Projection::Perspective { fov_y } => fov_y,
        _ => panic!("perspective expected"),
    };
    assert!((fov - 2.0 * (18.0f32 / 65.0).atan()).abs() < 1e-6);
}

#[test]
fn fit_and_centre_place_the_volume() {
    let scene =
        parse(&MINIMAL.replace("size = 16", "size = 16\nfit = 4.0\ncentre = [1, 2, 3]")).unwrap();
    let (lo, hi) = scene.load_volume().unwrap().bounds();
    assert!((lo - Vec3::new(-1.0, 0.0, 1.0)).length() < 1e-5, "{lo}");
    assert!((hi - Vec3::new(3.0, 4.0, 5.0)).length() < 1e-5, "{hi}");
}

#[test]
fn unknown_keys_are_named() {
    let err = error_of(&MINIMAL.replace("position", "fov = 30\nposition"));
    assert!(err.contains("fov"), "{err}");
    let err = error_of(&format!(
        "{MINIMAL}\n[render]\nmethod = \"gradient\"\nspecularity = 2\n"
    ));
    assert!(err.contains("specularity"), "{err}");
}

#[test]
fn out_of_range_values_are_named() {
    let cases = [
        ("position", "fov_deg = 180\nposition", "camera.fov_deg"),
        ("position", "width = 0\nposition", "camera.width"),
        ("position", "target = [0, -4, 0]\nposition", "camera.target"),
        ("size = 16", "size = 1", "volume.size"),
        ("size = 16", "size = 16\nfit = -1", "volume.fit"),
        (
            "phantom = \"sphere\"",
            "phantom = \"teapot\"",
            "volume.phantom",
        ),
        (
            "phantom = \"sphere\"",
            "phantom = \"sphere\"\npath = \"x.nrrd\"",
            "volume",
        ),
    ];
    for (from, to, key) in cases {
        let err = error_of(&MINIMAL.replace(from, to));
        assert!(err.contains(key), "{to}: {err}");
    }
    let tail_cases = [
        ("[classification]\ndensity_scale = -2", "density_scale"),
        (
            "[classification]\npreset = \"nope\"",
            "classification.preset",
        ),
        ("[render]\nmethod = \"magic\"", "render.method"),
        ("[render]\nstep = 0", "render.step"),
        ("[render]\nert_threshold = 1.5", "render.ert_threshold"),
        ("[render]\nshininess = 0", "render.shininess"),
        (
            "[[lights]]\ntype = \"directional\"\ndirection = [0, 0, 0]\nirradiance = 1",
            "lights[0].direction",
        ),
        ("[[lights]]\ntype = \"ambient\"\nradiance = -1", "lights[0]"),
        (
            "[classification]\npoints = [{ value = 0, sigma_t = 1, albedo = [2, 0, 0] }]",
            "points[0].albedo",
        ),
    ];
    for (tail, key) in tail_cases {
        let err = error_of(&format!("{MINIMAL}\n{tail}\n"));
        assert!(err.contains(key), "{tail}: {err}");
    }
}

#[test]
fn colours_name_the_key_and_the_value_and_never_become_zero() {
    // Issue 38: `background = nan` became 0 unnoticed and an infinite irradiance was
    // refused with serde's "data did not match any variant of untagged enum Colour".
    let lamp = |irradiance: &str| {
        format!("{MINIMAL}\n[[lights]]\ntype = \"directional\"\ndirection = [0, 0, 1]\nirradiance = {irradiance}\n")
    };
    for value in [
        "nan",
        "inf",
        "-inf",
        "-1",
        "1e39",
        "[nan, 0, 0]",
        "[0.1, inf, 1]",
    ] {
        let err = error_of(&format!("background = {value}\n{MINIMAL}"));
        assert!(err.contains("background"), "{value}: {err}");
        assert!(!err.contains("untagged"), "{value}: {err}");
        let err = error_of(&lamp(value));
        assert!(err.contains("lights[0]"), "{value}: {err}");
        assert!(err.contains("finite"), "{value}: {err}");
    }
    let err = error_of(&format!("background = [1, 2]\n{MINIMAL}"));
    assert!(err.contains("3 values [r, g, b], got 2"), "{err}");
    let err = error_of(&format!("background = \"white\"\n{MINIMAL}"));
    assert!(err.contains("a grey level or [r, g, b]"), "{err}");
    let scene = parse(&format!("background = [0.25, 1, 0]\n{MINIMAL}")).unwrap();
    assert_eq!(scene.lighting.background, Vec3::new(0.25, 1.0, 0.0));
    let scene = parse(&lamp("3")).unwrap();
    assert!(matches!(
        scene.lighting.lights[..],
        [occlux::lights::Light::Directional { irradiance, .. }] if irradiance == Vec3::splat(3.0)
    ));
}

#[test]
fn file_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.toml");
    std::fs::write(&path, MINIMAL.replace("position", "fov_deg = -5\nposition")).unwrap();
    let err = Scene::from_file(&path).unwrap_err().to_string();
    assert!(
        err.contains("broken.toml") && err.contains("camera.fov_deg"),
        "{err}"
    );
    let missing = Scene::from_file(&dir.path().join("missing.toml"))
        .unwrap_err()
        .to_string();
    assert!(missing.contains("missing.toml"), "{missing}");
    std::fs::write(&path, "[volume\nphantom = 3").unwrap();
    let err = Scene::from_file(&path).unwrap_err().to_string();
    assert!(err.contains("broken.toml"), "{err}");
}

#[test]
fn ao_method_reads_its_keys_and_refuses_them_elsewhere() {
    use occlux::ao::vao::{Estimator, FieldKind};
    let scene = parse(&format!(
        "{MINIMAL}\n[render]\nmethod = \"ao\"\nao_method = \"penner\"\nao_radius = 6\n\
         ao_field = \"value\"\nopacity_modulation = true\nvariance_max = 2.5\ndirect = false\n"
    ))
    .unwrap();
    let Method::Ao(p) = scene.method else {
        panic!("{:?}", scene.method)
    };
    assert_eq!(p.vao().unwrap().estimator, Estimator::Penner);
    assert_eq!(p.vao().unwrap().radius, 6);
    assert_eq!(p.ao_field, FieldKind::Value);
    assert!(p.opacity_modulation && p.variance_max == Some(2.5));
    assert_eq!(
        p.raycast().shading,
        Shading::AmbientOcclusion { direct: None }
    );
    // Defaults: the visibility by discrete ordinates in 64 directions, extinction,
    // gradient-shaded direct light.
    let scene = parse(&format!("{MINIMAL}\n[render]\nmethod = \"ao\"\n")).unwrap();
    let Method::Ao(p) = scene.method else {
        panic!()
    };
    assert_eq!(p.ao_method, occlux::ao::AoMethod::Ordinates);
    assert_eq!(p.ao_volume().directions, 64);
    assert!(p.vao().is_none());
    assert!(matches!(
        p.raycast().shading,
        Shading::AmbientOcclusion { direct: Some(_) }
    ));
    for (render, key) in [
        ("method = \"gradient\"\nao_radius = 4", "render.ao_radius"),
        (
            "method = \"ao\"\nao_method = \"median\"",
            "render.ao_method",
        ),
        ("method = \"ao\"\nao_radius = 0", "render.ao_radius"),
        ("method = \"ao\"\nao_field = \"colour\"", "render.ao_field"),
        ("method = \"ao\"\nvariance_max = 1.0", "render.variance_max"),
        (
            "method = \"ao\"\ndirect = false\nspecular = 0.5",
            "render.specular",
        ),
        ("method = \"ao\"\nao_gamma = 3", "render.ao_gamma"),
        (
            "method = \"ao\"\nao_method = \"sweep-physical\"\nao_light = \"sky\"",
            "render.ao_light",
        ),
        (
            "method = \"ao\"\nao_method = \"sweep\"\nao_alpha = 0",
            "render.ao_alpha",
        ),
        (
            "method = \"ao\"\nao_method = \"sweep\"\nao_field = \"value\"",
            "render.ao_field",
        ),
    ] {
        let err = error_of(&format!("{MINIMAL}\n[render]\n{render}\n"));
        assert!(err.contains(key), "{render}: {err}");
    }
}

#[test]
fn occlusion_sweeping_keys_reach_the_ao_volume() {
    use occlux::ao::AoMethod;
    let scene = parse(&format!(
        "{MINIMAL}\n[render]\nmethod = \"ao\"\nao_method = \"sweep\"\nao_iso = 0.4\n\
         ao_gamma = 1.5\nao_alpha = 0.5\nao_light = \"sky\"\n"
    ))
    .unwrap();
    let Method::Ao(p) = scene.method else {
        panic!("{:?}", scene.method)
    };
    let ao = p.ao_volume();
    assert_eq!(ao.method, AoMethod::Sweep);
    assert_eq!(ao.iso, Some(0.4));
    assert_eq!((ao.geometric.gamma, ao.geometric.alpha), (1.5, 0.5));
    assert_eq!(ao.geometric.intensities, occlux::ao::sweep::geometric::SKY);
    assert!(p.vao().is_none());
}

#[test]
fn dos_method_takes_its_parameters() {
    use occlux::render::dos::{ClipPlane, ConeDistance, ConeSampling, DosParams, Formulation};
    let text = format!(
        "{MINIMAL}[render]\nmethod = \"dos\"\ntheta_deg = 30\ngrid = 13\nslice_distance = 0.01\n\
         distance = \"approximate\"\nsampling = \"area\"\nformulation = \"rays\"\nself_occlusion = true\nclip_planes = [{{ point = [0, 0, 1], normal = [0, 0, 2] }}]\n"
    );
    let scene = parse(&text).unwrap();
    assert_eq!(
        scene.method,
        Method::Dos(DosParams {
            theta_deg: 30.0,
            grid: 13,
            slice_distance: Some(0.01),
            distance: ConeDistance::Approximate,
            sampling: ConeSampling::Area,
            formulation: Formulation::Rays,
            self_occlusion: true,
            clip_planes: vec![ClipPlane {
                point: Vec3::Z,
                normal: Vec3::Z,
            }],
        })
    );
    let defaults = parse(&format!("{MINIMAL}[render]\nmethod = \"dos\"\n")).unwrap();
    assert_eq!(defaults.method, Method::Dos(DosParams::default()));
}

#[test]
fn dos_errors_name_the_key() {
    for (tail, key) in [
        ("method = \"dos\"\ntheta_deg = 90", "render.theta_deg"),
        ("method = \"dos\"\ngrid = 0", "render.grid"),
        (
            "method = \"dos\"\nslice_distance = -1",
            "render.slice_distance",
        ),
        ("method = \"dos\"\ndistance = \"near\"", "render.distance"),
        ("method = \"dos\"\nstep = 0.1", "render.step"),
        (
            "method = \"dos\"\nformulation = \"cones\"",
            "render.formulation",
        ),
        (
            "method = \"dos\"\nclip_planes = [{ point = [0, 0, 0], normal = [0, 0, 0] }]",
            "render.clip_planes[0].normal",
        ),
        ("method = \"gradient\"\ntheta_deg = 30", "render.theta_deg"),
    ] {
        let err = error_of(&format!("{MINIMAL}[render]\n{tail}\n"));
        assert!(err.contains(key), "{tail}: {err}");
    }
}

#[test]
fn every_example_scene_parses() {
    // The shipped examples use only keys, methods and lights the registry takes (their
    // volumes are loaded where the data is, by the CLI and benchmark tests).
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/examples"));
    let mut parsed = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            Scene::from_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            parsed += 1;
        }
    }
    assert!(parsed >= 9, "{parsed} examples");
}

/// The keys that let the data decide: `fit = "auto"`, `centre = "content"`, a camera without a
/// position (framed from a direction), `frame = "content"` with a position, `margin`; preset
/// units and `range`. Misuses are errors naming the key.
#[test]
fn data_driven_keys_parse_and_misuses_name_the_key() {
    use occlux::classify::{ValueRange, ValueUnits, Window};
    use occlux::scene::{Centre, Framing, AUTO_FIT, DEFAULT_MARGIN};
    let scene = parse(
        r#"
[volume]
phantom = "ct"
fit = "auto"
centre = "content"
[classification]
preset = "ct-bone"
range = [10, 200]
[camera]
width = 64
height = 32
"#,
    )
    .unwrap();
    assert_eq!(scene.volume.fit, Some(AUTO_FIT));
    assert_eq!(scene.volume.centre, Some(Centre::Content));
    assert_eq!(
        scene.framing,
        Some(Framing {
            margin: DEFAULT_MARGIN
        })
    );
    assert_eq!(
        scene.classification.range,
        ValueRange::Window(Window {
            lo: 10.0,
            hi: 200.0,
            cut: None
        })
    );
    // A preset without units may become its HU form; with units it is what it says.
    assert_eq!(scene.units_from_data.as_deref(), Some("ct-bone"));
    let hu = parse(
        "[volume]\nphantom = \"ct\"\n[classification]\npreset = \"ct-soft-tissue\"\nunits = \"hu\"\n\
         [camera]\nposition = [0, -4, 0]\n",
    )
    .unwrap();
    assert_eq!(hu.classification.units, ValueUnits::Hu);
    assert_eq!(hu.units_from_data, None);
    assert!(hu.framing.is_none());
    let framed = parse(
        "[volume]\nphantom = \"ct\"\n[camera]\nposition = [0, -4, 0]\nframe = \"content\"\nmargin = 0.2\n",
    )
    .unwrap();
    assert_eq!(framed.framing, Some(Framing { margin: 0.2 }));
    assert!((framed.camera.forward - Vec3::Y).length() < 1e-6);

    for (text, key) in [
        ("[volume]\nphantom = \"ct\"\nfit = \"big\"\n[camera]\n", "volume.fit"),
        ("[volume]\nphantom = \"ct\"\ncentre = \"middle\"\n[camera]\n", "volume.centre"),
        ("[volume]\nphantom = \"ct\"\n[camera]\nframe = \"none\"\n", "camera.position"),
        ("[volume]\nphantom = \"ct\"\n[camera]\nframe = \"box\"\n", "camera.frame"),
        (
            "[volume]\nphantom = \"ct\"\n[camera]\nposition = [0, -4, 0]\ndirection = [0, 1, 0]\n",
            "camera.direction",
        ),
        ("[volume]\nphantom = \"ct\"\n[camera]\ndirection = [0, 0, 0]\n", "camera.direction"),
        ("[volume]\nphantom = \"ct\"\n[camera]\nmargin = 0.5\n", "camera.margin"),
        (
            "[volume]\nphantom = \"ct\"\n[camera]\nposition = [0, -4, 0]\nmargin = 0.1\n",
            "camera.margin",
        ),
        (
            "[volume]\nphantom = \"ct\"\n[classification]\npreset = \"mri\"\nunits = \"hu\"\n[camera]\n",
            "classification.units",
        ),
        (
            "[volume]\nphantom = \"ct\"\n[classification]\npreset = \"ct-bone\"\nunits = \"raw\"\n[camera]\n",
            "classification.units",
        ),
        (
            "[volume]\nphantom = \"ct\"\n[classification]\npreset = \"ct-bone\"\nrange = [5, 1]\n[camera]\n",
            "classification.range",
        ),
        (
            "[volume]\nphantom = \"ct\"\n[classification]\npreset = \"ct-bone\"\nunits = \"hu\"\nrange = \"full\"\n[camera]\n",
            "classification.range",
        ),
    ] {
        let err = error_of(text);
        assert!(err.contains(key), "{key}: {err}");
    }
}

/// A preset without units reads a file's Hounsfield units when the file says so; the window of
/// normalised units is resolved into the loaded scene (and so into the EXR header).
#[test]
fn loading_settles_hounsfield_presets_and_the_window() {
    use occlux::classify::{ValueRange, ValueUnits};
    let dir = tempfile::tempdir().unwrap();
    // An int16 NRRD in HU: air -1000, water 0, bone 1200.
    let values: Vec<i16> = (0..4096)
        .map(|i| match i % 8 {
            0..=4 => -1000,
            5 | 6 => 0,
            _ => 1200,
        })
        .collect();
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let path = dir.path().join("ct.nrrd");
    let header = "NRRD0004\ntype: short\ndimension: 3\nsizes: 16 16 16\nencoding: raw\n\
                  endian: little\nsample units: HU\n\n";
    std::fs::write(&path, [header.as_bytes(), &bytes].concat()).unwrap();
    let scene = |units: &str| {
        Scene::parse(
            &format!(
                "[volume]\npath = {path:?}\n[classification]\npreset = \"ct-bone\"\n{units}\n\
                 [camera]\nposition = [0, -40, 0]\ntarget = [8, 8, 8]\n"
            ),
            dir.path(),
        )
        .unwrap()
    };
    let loaded = scene("").load().unwrap();
    assert_eq!(loaded.scene.classification.units, ValueUnits::Hu);
    assert!(
        loaded
            .notices
            .iter()
            .any(|n| n.contains("Hounsfield") && n.contains("sample units")),
        "{:?}",
        loaded.notices
    );
    let lut = loaded.scene.classification.bake(&loaded.volume);
    assert_eq!(
        lut.lookup(0.0, 0.0).sigma_t,
        0.0,
        "water is clear under ct-bone"
    );
    assert!(lut.lookup(1200.0, 0.0).sigma_t > 10.0);
    // Normalised units stated: the robust window, resolved into the scene.
    let normalised = scene("units = \"normalized\"").load().unwrap();
    match normalised.scene.classification.range {
        ValueRange::Window(w) => assert_eq!((w.lo, w.hi), (-1000.0, 1200.0)),
        other => panic!("{other:?}"),
    }
    assert!(normalised
        .notices
        .iter()
        .any(|n| n.contains("units = \"hu\"")));
}

/// A volume that cannot fit beside what its command holds is refused before it is made, with
/// the need, the command's multiple and the bytes available named; the same volume fits a
/// lighter command.
#[test]
fn the_memory_check_weighs_the_command_before_loading() {
    // A 64^3 phantom: 1.0 MiB as f32, under a cap of 2 MiB.
    let scene = parse(
        "[volume]\nphantom = \"ct\"\nsize = 64\nmemory_budget_gib = 0.001953125\n\
         [camera]\nposition = [0, -4, 0]\n\
         [render]\nmethod = \"ao\"\nao_method = \"sweep-physical\"\n",
    )
    .unwrap();
    let err = scene.load_volume().unwrap_err().to_string();
    let peak = scene.peak_volumes();
    assert!(
        peak >= occlux::ao::AoMethod::SweepPhysical.peak_volumes(),
        "{peak}"
    );
    for part in [
        "64x64x64 need 1.0 MiB as f32".to_owned(),
        format!("method = \"ao\" holds about {peak:.1} such volumes"),
        "more than the 2.0 MiB available (volume.memory_budget_gib)".to_owned(),
    ] {
        assert!(err.contains(&part), "{part:?} not in {err}");
    }
    assert_eq!(
        scene
            .load_volume_holding(1.5, "a lighter command")
            .unwrap()
            .dims(),
        [64; 3]
    );
}
