//! The planner (`method = "auto"`) end to end from a scene file, and its scene keys checked;
//! lab/tests/plan_check.rs validates its choices against exhaustive search.

use occlux::export::exr::read_exr;
use occlux::export::vdb::VdbOptions;
use occlux::gpu::Compute;
use occlux::pipeline::{self, OutputOptions};
use occlux::plan::measure::{monte_carlo, Subject, Truth};
use occlux::plan::{truth_estimator, Scattering};
use occlux::progress::NoProgress;
use occlux::scene::Scene;
use std::path::Path;

/// A CT phantom under a sun, small enough to plan in a second.
const CT_SUN: &str = "[volume]\nphantom = \"ct\"\nsize = 32\nfit = 2.0\n\
                      [classification]\npreset = \"ct-soft-tissue\"\ndensity_scale = 0.35\n\
                      [[lights]]\ntype = \"directional\"\ndirection = [-0.3, -1.0, 1.2]\n\
                      irradiance = 3\n[camera]\nposition = [2.4, -2.6, 1.4]\ntarget = [0, 0, 0]\n\
                      fov_deg = 40\nwidth = 40\nheight = 40\n";

#[test]
fn an_auto_scene_renders_its_plan_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let auto = dir.path().join("auto.toml");
    std::fs::write(
        &auto,
        format!("{CT_SUN}[render]\nmethod = \"auto\"\nerror = 0.15\npilot = 20\n"),
    )
    .unwrap();
    let scene = Scene::from_file(&auto).unwrap();
    let out = dir.path().join("out");
    // What `occlux export` does with it: plan, render the plan, write the files.
    let loaded = scene.load().unwrap();
    let settled = pipeline::settle(&loaded.scene, &loaded.volume, &Compute::Cpu, &|_| {}).unwrap();
    let rendered = pipeline::render(&settled, &loaded.volume, &Compute::Cpu, &NoProgress).unwrap();
    let output = OutputOptions::default();
    let vdb = VdbOptions::default();
    pipeline::export(
        &rendered,
        &settled,
        &loaded.volume,
        &out,
        "auto",
        &output,
        &vdb,
    )
    .unwrap();
    // The budget allows half floats, and the phantom's values fit them: OpenVDB's half-float
    // tree type (read back as such by vdb-rs in tests/vdb.rs).
    let vdb = std::fs::read(out.join("auto.vdb")).unwrap();
    let half_type = b"Tree_float_5_4_3_HalfFloat";
    assert!(vdb.windows(half_type.len()).any(|w| w == half_type));
    let exr = read_exr(&out.join("auto.exr")).unwrap();
    let plan: serde_json::Value =
        serde_json::from_str(&exr.metadata["occlux/plan"]).expect("the plan in the header");
    let method: serde_json::Value = serde_json::from_str(&exr.metadata["occlux/method"]).unwrap();
    assert_eq!(plan["method"], method, "the header's method is the plan's");
    assert_eq!(plan["budget"]["error"], 0.15);
    // The image against an independent truth (another seed than any the planner used).
    let loaded = scene.load().unwrap();
    let lut = loaded.scene.classification.bake(&loaded.volume);
    let subject = Subject {
        scene: &loaded.scene,
        volume: &loaded.volume,
        lut: &lut,
        compute: &Compute::Cpu,
    };
    let estimator = truth_estimator(&loaded.scene.lighting, Scattering::Single);
    let camera = loaded.scene.camera;
    let (image, _) = monte_carlo(&subject, &camera, estimator, 4096, 99).unwrap();
    let truth = Truth::new(&subject, camera, &image).unwrap();
    let rgba: Vec<[f32; 4]> = exr
        .rgb()
        .unwrap()
        .iter()
        .map(|c| [c[0], c[1], c[2], 1.0])
        .collect();
    let (error, _) = truth.error(&rgba, 0.0).unwrap();
    assert!(
        error <= 0.15,
        "{} renders at {error} from the truth",
        plan["chosen"]
    );
}

#[test]
fn auto_scene_keys_are_checked() {
    let base = "[volume]\nphantom = \"sphere\"\nsize = 8\n[camera]\nwidth = 8\nheight = 8\n\
                [[lights]]\ntype = \"ambient\"\nradiance = 1\n[render]\nmethod = \"auto\"\n";
    let error_of = |keys: &str| {
        Scene::parse(&format!("{base}{keys}"), Path::new("."))
            .unwrap_err()
            .to_string()
    };
    let missing = error_of("");
    assert!(
        missing.contains("render.error") && missing.contains("budget"),
        "{missing}"
    );
    let negative = error_of("error = -0.1");
    assert!(
        negative.contains("render.error") && negative.contains("(0, 10]"),
        "{negative}"
    );
    let scattering = error_of("error = 0.1\nscattering = \"double\"");
    assert!(scattering.contains("render.scattering"), "{scattering}");
    let foreign = error_of("error = 0.1\ntheta_deg = 30");
    assert!(
        foreign.contains("render.theta_deg") && foreign.contains("planner"),
        "{foreign}"
    );
    let pilot = error_of("error = 0.1\npilot = 2");
    assert!(pilot.contains("render.pilot"), "{pilot}");
    let scene = Scene::parse(
        &format!("{base}error = 0.1\nscattering = \"multiple\""),
        Path::new("."),
    )
    .unwrap();
    let budget = scene.auto.unwrap();
    assert_eq!(
        (budget.error, budget.scattering),
        (0.1, Scattering::Multiple)
    );
}
