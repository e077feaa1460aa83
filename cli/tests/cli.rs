//! The `occlux` binary end to end: the demo's EXR read back with the exr crate equals the
//! library's render; `info` describes a real volume; bad input fails cleanly and writes nothing.

use occlux::gpu::Compute;
use occlux::pipeline::{self, Settled};
use occlux::progress::NoProgress;
use occlux::scene::Scene;
use std::borrow::Cow;
use std::path::Path;
use std::process::{Command, Output};

#[path = "../../tests/common/mod.rs"]
mod common;

fn occlux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_occlux"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("the occlux binary runs")
}

/// `occlux render SCENE -o OUT --device cpu` with `extra` arguments.
fn render_on_cpu(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--device",
        "cpu",
    ];
    args.extend(extra);
    occlux(&args)
}

/// Runs a command that writes a JSON report to `json` (`-o`), and reads the report.
fn report_of(args: &[&str], json: &Path) -> serde_json::Value {
    let mut all = args.to_vec();
    all.extend(["-o", json.to_str().unwrap()]);
    succeeds_with_report(&all, json)
}

/// Runs a command that must succeed, and reads the JSON report it wrote at `json`.
fn succeeds_with_report(args: &[&str], json: &Path) -> serde_json::Value {
    let run = occlux(args);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

/// The channels `LAYER.*` of an EXR as (channel, values), read with the exr crate itself.
fn exr_layer(path: &Path, layer: &str) -> Vec<(String, Vec<f32>)> {
    let image = exr::prelude::read_first_flat_layer_from_file(path).unwrap();
    let prefix = format!("{layer}.");
    image
        .layer_data
        .channel_data
        .list
        .iter()
        .filter_map(|c| {
            let name = c.name.to_string();
            let channel = name.strip_prefix(&prefix)?.to_string();
            Some((channel, c.sample_data.values_as_f32().collect()))
        })
        .collect()
}

#[test]
fn demo_writes_the_render_the_library_computes() {
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().to_str().unwrap();
    let run = occlux(&["demo", "--device", "cpu", "--out", dir]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        stdout.contains("demo.exr") && stdout.contains("demo.png"),
        "{stdout}"
    );

    let scene = Scene::parse(include_str!("../../examples/demo-lit.toml"), Path::new(".")).unwrap();
    // Settled as the CLI settles it: the camera framed on the visible content.
    let loaded = scene.load().unwrap();
    let img = pipeline::render(
        &Settled::named(&loaded.scene),
        &loaded.volume,
        &Compute::Cpu,
        &NoProgress,
    )
    .unwrap()
    .image;

    let beauty = exr_layer(&out.path().join("demo.exr"), "beauty");
    let names: Vec<&str> = beauty.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["A", "B", "G", "R"], "channels are stored sorted");
    let n = (img.width * img.height) as usize;
    for (name, values) in &beauty {
        let c = ["R", "G", "B", "A"].iter().position(|x| x == name).unwrap();
        assert_eq!(values.len(), n);
        for (i, v) in values.iter().enumerate() {
            let want = img.rgba[i][c];
            // float16 keeps 11 significant bits.
            assert!(
                (v - want).abs() <= 1e-3 * want.abs().max(1e-2),
                "{name}[{i}]: {v} vs {want}"
            );
        }
    }
    let lit = img.rgba.iter().filter(|p| p[3] > 0.5).count();
    assert!(
        lit > n / 10,
        "the phantom covers part of the image ({lit} of {n})"
    );
    let depth = exr_layer(&out.path().join("demo.exr"), "depth");
    assert_eq!(depth.len(), 1);
    assert_eq!(depth[0].0, "Z");
    for (i, d) in depth[0].1.iter().enumerate() {
        assert!(
            (d - img.depth[i]).abs() <= 1e-3 * img.depth[i].abs(),
            "Z[{i}]"
        );
    }
}

#[test]
fn info_describes_a_real_volume() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/scivis/engine.nrrd"
    );
    assert!(
        Path::new(path).exists(),
        "needs ../shared beside the checkout"
    );
    let run = occlux(&["info", path]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(text.contains("256 x 256 x 128"), "{text}");
    assert!(text.contains("uint8"), "{text}");
    assert!(text.contains("histogram"), "{text}");
    assert!(text.contains("units     not stated by the file"), "{text}");
    assert!(text.contains("window    0 .. "), "{text}");
}

/// `occlux info --suggest` prints a classification that a scene takes as it is, and that
/// shows the volume when rendered with the defaults (framed, fit = "auto").
#[test]
fn info_suggests_a_classification_a_scene_takes() {
    let dir = tempfile::tempdir().unwrap();
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/scivis/tooth.nrrd"
    );
    let run = occlux(&["info", path, "--suggest"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = String::from_utf8_lossy(&run.stdout);
    let block = &text[text.find("[classification]").expect("a suggestion")..];
    let scene = dir.path().join("suggested.toml");
    std::fs::write(
        &scene,
        format!(
            "[volume]\npath = {path:?}\nfit = \"auto\"\n{block}\n[camera]\nwidth = 48\n\
             height = 48\n[[lights]]\ntype = \"ambient\"\nradiance = 1\n[render]\n\
             method = \"unshaded\"\n"
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = render_on_cpu(&scene, &out, &[]);
    let notices = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{notices}");
    assert!(
        notices.contains("classification: on raw values"),
        "{notices}"
    );
    assert!(
        notices.contains("camera: frames the visible content"),
        "{notices}"
    );
    let alpha: Vec<f32> = exr_layer(&out.join("suggested.exr"), "beauty")
        .into_iter()
        .find(|(c, _)| c.ends_with('A'))
        .unwrap()
        .1;
    let covered = alpha.iter().filter(|a| **a > 0.05).count() as f64 / alpha.len() as f64;
    assert!(covered > 0.05 && covered < 0.9, "{covered}");
}

#[test]
fn info_reports_non_finite_values_and_quantiles_instead_of_refusing() {
    // 4 x 3 x 2 floats: a NaN at [1, 1, 0], +inf at [3, 2, 1], -inf at [0, 0, 1], an outlier.
    let dir = tempfile::tempdir().unwrap();
    let mut values: Vec<f32> = (0..24).map(|v| v as f32).collect();
    values[5] = f32::NAN;
    values[23] = f32::INFINITY;
    values[12] = f32::NEG_INFINITY;
    values[7] = 5008.0;
    let path = dir.path().join("bad.nrrd");
    let mut file = b"NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n\
                     endian: little\n\n"
        .to_vec();
    file.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(&path, &file).unwrap();
    let run = occlux(&["info", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        text.contains("NOT FINITE 3 of 24 voxels (1 NaN, 1 +inf, 1 -inf)"),
        "{text}"
    );
    assert!(
        text.contains("first at voxel [1, 1, 0], all within voxels [0, 0, 0] .. [3, 2, 1]"),
        "{text}"
    );
    // Over the 21 finite voxels: 0..22 less the three, and the outlier.
    assert!(text.contains("values    0 .. 5008"), "{text}");
    assert!(text.contains("quantiles p0.1"), "{text}");
    // The outlier's bin shows a bar of its own.
    let last = text.lines().rfind(|l| l.contains('#')).unwrap();
    assert!(last.contains(" 1 ") && last.ends_with('#'), "{last}");
    // A render of the same file is refused, naming the first bad voxel.
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        "[volume]\npath = \"bad.nrrd\"\n[camera]\nposition = [40, -40, 30]\n\
         target = [1.5, 1, 0.5]\nwidth = 8\nheight = 8\n[[lights]]\ntype = \"ambient\"\n\
         radiance = 1.0\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = occlux(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("voxel [1, 1, 0] holds NaN"), "{err}");
    assert!(!out.exists());
}

#[test]
fn info_counts_the_time_steps_of_a_series_and_describes_the_first() {
    // 2 x 2 x 1 voxels in 3 frames: frame t holds 10 t + 0..3.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("series.nrrd");
    let mut file =
        b"NRRD0004\ntype: uint8\ndimension: 4\nsizes: 2 2 1 3\nencoding: raw\n\n".to_vec();
    file.extend((0..3u8).flat_map(|t| (0..4u8).map(move |v| 10 * t + v)));
    std::fs::write(&path, &file).unwrap();
    let run = occlux(&["info", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        text.contains("time steps 3 (occlux series reads each; info describes the first)"),
        "{text}"
    );
    assert!(text.contains("dims      2 x 2 x 1 (4 voxels"), "{text}");
    assert!(text.contains("values    0 .. 3"), "{text}");
}

#[test]
fn info_reads_raw_dims_as_the_help_writes_them_and_ends_quietly_into_a_closed_pipe() {
    // Issue 38: `--raw-dims 32,32,32`, the form of README and of the raw loader's own error,
    // was refused by the argument parser; `occlux info F | head -1` panicked (rc 101).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scan.raw");
    std::fs::write(&path, (0..4 * 3 * 2).map(|v| v as u8).collect::<Vec<u8>>()).unwrap();
    let file = path.to_str().unwrap();
    let run = occlux(&[
        "info",
        file,
        "--raw-dims",
        "4,3,2",
        "--raw-type",
        "uint8",
        "--raw-spacing",
        "1,1,2.5",
    ]);
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(text.contains("dims      4 x 3 x 2"), "{text}");
    assert!(text.contains("values    0 .. 23"), "{text}");
    let run = occlux(&["info", file, "--raw-dims", "4,3", "--raw-type", "uint8"]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        err.contains("--raw-dims") && err.contains("three values"),
        "{err}"
    );
    // The reader goes before occlux writes a line.
    let mut child = Command::new(env!("CARGO_BIN_EXE_occlux"))
        .args(["info", file, "--raw-dims", "4,3,2", "--raw-type", "uint8"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let ended = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&ended.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_ne!(ended.status.code(), Some(101), "{err}");
}

#[test]
fn a_missing_relative_path_says_where_it_was_looked_for() {
    let run = occlux(&["info", "no/such/volume.nrrd"]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    let full = std::env::current_dir().unwrap().join("no/such/volume.nrrd");
    assert!(
        err.contains(&format!("looked for at {}", full.display())),
        "{err}"
    );
}

#[test]
fn bad_input_fails_with_the_file_named_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out_str = out.to_str().unwrap();

    let missing = dir.path().join("missing.toml");
    let run = occlux(&["render", missing.to_str().unwrap(), "-o", out_str]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("missing.toml"));

    // A truncated gzip NRRD referenced by a valid scene.
    let nrrd = dir.path().join("cut.nrrd");
    let mut bytes =
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: gzip\n\n".to_vec();
    bytes.extend_from_slice(&[0x1f, 0x8b, 8, 0, 0, 0]);
    std::fs::write(&nrrd, bytes).unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        "[volume]\npath = \"cut.nrrd\"\n[camera]\nposition = [0, -4, 0]\nwidth = 8\nheight = 8\n",
    )
    .unwrap();
    let run = occlux(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out_str,
        "--device",
        "cpu",
    ]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("cut.nrrd"), "{err}");
    assert!(!out.exists() || std::fs::read_dir(&out).unwrap().next().is_none());

    std::fs::write(
        &scene,
        "[volume]\nphantom = \"ct\"\n[camera]\nposition = [0, -4, 0]\n",
    )
    .unwrap();
    let run = occlux(&[
        "render",
        scene.to_str().unwrap(),
        "--exposure=-1",
        "-o",
        out_str,
    ]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("exposure"));
    assert!(!out.exists());
}

/// A small scene file beside `dir`: the sphere phantom, lit by the sky and a sun.
fn small_scene(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("ball.toml");
    std::fs::write(
        &path,
        r#"
background = 0.1
[volume]
phantom = "sphere"
size = 16
[classification]
points = [{ value = 0, sigma_t = 0, albedo = [0.8, 0.8, 0.8] }, { value = 1, sigma_t = 4, albedo = [0.8, 0.8, 0.8] }]
[camera]
position = [3, -2, 1]
target = [0, 0, 0]
fov_deg = 40
width = 12
height = 10
[[lights]]
type = "ambient"
radiance = 0.5
[[lights]]
type = "directional"
direction = [0, -1, 1]
irradiance = 2
"#,
    )
    .unwrap();
    path
}

#[test]
fn reference_writes_mean_and_standard_error_the_library_computes() {
    use occlux::export::exr::read_exr;
    use occlux::render::reference::{render, Estimator, ReferenceInput, ReferenceParams};
    let dir = tempfile::tempdir().unwrap();
    let scene_path = small_scene(dir.path());
    let out = dir.path().join("out");
    let run = occlux(&[
        "reference",
        scene_path.to_str().unwrap(),
        "--estimator",
        "multiple",
        "--bounces",
        "2",
        "--g",
        "-0.3",
        "--spp",
        "8",
        "--seed",
        "5",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let exr = read_exr(&out.join("ball-multiple.exr")).unwrap();
    let header = &exr.metadata["occlux/reference"];
    assert!(
        header.contains("\"bounces\":2") && header.contains("\"spp\":8"),
        "{header}"
    );

    let scene = Scene::from_file(&scene_path).unwrap();
    let volume = scene.load_volume().unwrap();
    let lut = scene.classification.bake(&volume);
    let params = ReferenceParams {
        estimator: Estimator::Multiple { bounces: 2 },
        spp: 8,
        seed: 5,
        g: -0.3,
    };
    let input = ReferenceInput {
        volume: &volume,
        lut: &lut,
        camera: &scene.camera,
        lighting: &scene.lighting,
        params: &params,
    };
    let image = render(&input, &NoProgress).unwrap();
    // float32 layers: the file holds exactly the library's estimate.
    let want_mean: Vec<f32> = image.mean.iter().map(|m| m[1]).collect();
    let want_se: Vec<f32> = image.stderr.iter().map(|s| s[1]).collect();
    assert_eq!(
        exr.layer("beauty").unwrap().channel("G").unwrap(),
        want_mean
    );
    assert_eq!(exr.layer("stderr").unwrap().channel("G").unwrap(), want_se);
    assert!(want_se.iter().any(|&s| s > 0.0), "the estimate is noisy");
}

#[test]
fn reference_and_check_cycles_refuse_bad_requests() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = small_scene(dir.path());
    let scene = scene_path.to_str().unwrap();
    let out = dir.path().join("out");
    let run = occlux(&[
        "reference",
        scene,
        "--estimator",
        "cone",
        "--aperture-deg",
        "95",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && err.contains("aperture"), "{err}");
    assert!(!out.exists(), "nothing is written");

    let run = Command::new(env!("CARGO_BIN_EXE_occlux"))
        .args(["check-cycles", scene, "--spp", "4"])
        .env("OCCLUX_PYTHON", dir.path().join("no-such-python"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && err.contains("no-such-python"),
        "{err}"
    );
}

#[test]
fn ao_writes_the_grids_slice_and_timing_the_library_computes() {
    use occlux::ao::vao::{self, Estimator, FieldKind, ScalarField, VaoParams};
    let out = tempfile::tempdir().unwrap();
    let scene_path = small_scene(out.path());
    let dir = out.path().join("ao");
    let run = occlux(&[
        "ao",
        scene_path.to_str().unwrap(),
        "--method",
        "gauss",
        "--radius",
        "3",
        "--variance",
        "--device",
        "cpu",
        "--compression",
        "none",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let scene = Scene::from_file(&scene_path).unwrap();
    let volume = scene.load_volume().unwrap();
    let field = ScalarField::new(
        Cow::Borrowed(&volume),
        &scene.classification,
        FieldKind::Extinction,
    )
    .unwrap();
    let params = VaoParams {
        radius: 3,
        estimator: Estimator::Gauss,
        variance: true,
    };
    let ao = vao::ao_volume(&Compute::Cpu, Cow::Borrowed(&field), &params, &NoProgress).unwrap();
    // The grid means 1 = unoccluded: VAO's raw openness doubled up to 1.
    let openness = occlux::ao::unoccluded(ao.openness.clone()).unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(dir.join("ball-ao.vdb")).unwrap());
    let mut reader = vdb_rs::VdbReader::new(file).unwrap();
    for (name, want) in [
        ("ao", &openness),
        ("ao_variance", ao.variance.as_ref().unwrap()),
    ] {
        let grid = reader.read_grid::<f32>(name).unwrap();
        let mut active = 0;
        for (p, v, _) in grid.iter() {
            let expected = common::padded_at(want, [p.x as i32, p.y as i32, p.z as i32]);
            assert_eq!(v, expected, "{name} at {p:?}");
            active += 1;
        }
        let nonzero = common::padded_nonzero(want);
        assert_eq!(active, nonzero, "{name}: every non-zero voxel is active");
    }
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("ball-ao.json")).unwrap()).unwrap();
    assert_eq!(record["method"], "gauss");
    assert_eq!(record["convention"], "unoccluded");
    assert_eq!(record["radius_voxels"], 3);
    assert!(record["ao_ms"].as_f64().unwrap() > 0.0);
    let png = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(dir.join("ball-ao.png")).unwrap(),
    ))
    .read_info()
    .unwrap();
    let [nx, ny, _] = volume.dims();
    assert_eq!(
        (png.info().width, png.info().height),
        (nx as u32, ny as u32)
    );

    // Bad requests: named, and nothing written.
    let bad = out.path().join("bad");
    for (args, key) in [
        (vec!["--method", "median"], "median"),
        (vec!["--method", "cdf", "--radius", "0"], "radius"),
        (vec!["--field", "colour"], "colour"),
        (vec!["--convention", "blender"], "convention"),
        (
            vec!["--method", "sweep", "--convention", "raw"],
            "convention",
        ),
    ] {
        let mut all = vec![
            "ao",
            scene_path.to_str().unwrap(),
            "-o",
            bad.to_str().unwrap(),
        ];
        all.extend(args);
        let run = occlux(&all);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && stderr.contains(key), "{stderr}");
        assert!(!bad.exists());
    }
}

#[test]
fn ao_by_occlusion_sweeping_writes_the_level_set_and_octants_the_library_computes() {
    use occlux::ao::{ao_volume, AoMethod, AoVolumeParams};
    let out = tempfile::tempdir().unwrap();
    let scene_path = small_scene(out.path());
    let dir = out.path().join("swept");
    let args = |extra: &[&'static str], to: &std::path::Path| {
        let mut all = vec![
            "ao".to_owned(),
            scene_path.display().to_string(),
            "--method".into(),
            "sweep".into(),
            "--compression".into(),
            "none".into(),
            "-o".into(),
            to.display().to_string(),
        ];
        all.extend(extra.iter().map(|s| s.to_string()));
        all
    };
    let run = occlux(
        &args(
            &[
                "--octants",
                "--gamma",
                "1.5",
                "--octant-intensities",
                "1,1,1,1,0,0,0,0",
            ],
            &dir,
        )
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>(),
    );
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let scene = Scene::from_file(&scene_path).unwrap();
    let volume = scene.load_volume().unwrap();
    let mut params = AoVolumeParams {
        method: AoMethod::Sweep,
        octants: true,
        ..Default::default()
    };
    params.geometric.gamma = 1.5;
    params.geometric.intensities = occlux::ao::sweep::geometric::SKY;
    let ao = ao_volume(
        &Compute::Cpu,
        Cow::Borrowed(&volume),
        &scene.classification,
        &params,
        &NoProgress,
    )
    .unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(dir.join("ball-ao.vdb")).unwrap());
    let mut reader = vdb_rs::VdbReader::new(file).unwrap();
    let sdf = ao.sdf.as_ref().unwrap();
    let mut expected: Vec<(String, &occlux::volume::Volume)> =
        vec![("ao".into(), &ao.openness), ("sdf".into(), sdf)];
    for (s, octant) in ao.octants.iter().enumerate() {
        expected.push((format!("ao_oct{s}"), octant));
    }
    assert_eq!(expected.len(), 10);
    for (name, want) in &expected {
        let grid = reader.read_grid::<f32>(name).unwrap();
        let mut active = 0;
        for (p, v, _) in grid.iter() {
            assert_eq!(
                v,
                common::padded_at(want, [p.x as i32, p.y as i32, p.z as i32]),
                "{name} at {p:?}"
            );
            active += 1;
        }
        assert!(active > 0, "{name}");
    }
    // The level set's inside is negative; its outside beyond the narrow band is inactive.
    assert!(sdf.values().iter().any(|&d| d < 0.0) && sdf.values().iter().any(|&d| d > 0.0));

    // No surface, or the physical sweep asked for octants: named, and nothing written.
    let bad = out.path().join("bad");
    for (extra, key) in [
        (&["--iso", "7"][..], "never crosses"),
        (&["--gamma", "0"][..], "gamma"),
        (&["--octant-intensities", "1,1"][..], "eight values"),
    ] {
        let all = args(extra, &bad);
        let run = occlux(&all.iter().map(String::as_str).collect::<Vec<_>>());
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && stderr.contains(key), "{stderr}");
        assert!(!bad.exists());
    }
}

#[test]
fn ao_shaded_scenes_render_and_export_the_ao_grid() {
    let out = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(small_scene(out.path())).unwrap();
    let scene_path = out.path().join("ball-ao.toml");
    std::fs::write(
        &scene_path,
        format!("{base}\n[render]\nmethod = \"ao\"\nao_method = \"cdf\"\nao_radius = 3\nao_variance = true\nopacity_modulation = true\n"),
    )
    .unwrap();
    let dir = out.path().join("export");
    let run = occlux(&[
        "export",
        scene_path.to_str().unwrap(),
        "--device",
        "cpu",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let scene = Scene::from_file(&scene_path).unwrap();
    let volume = scene.load_volume().unwrap();
    let rendered =
        pipeline::render(&Settled::named(&scene), &volume, &Compute::Cpu, &NoProgress).unwrap();
    let ao = &rendered
        .grids
        .iter()
        .find(|g| g.name == "ao")
        .unwrap()
        .volume;
    let file = std::io::BufReader::new(std::fs::File::open(dir.join("ball-ao.vdb")).unwrap());
    let mut reader = vdb_rs::VdbReader::new(file).unwrap();
    let grid = reader.read_grid::<f32>("ao").unwrap();
    for (p, v, _) in grid.iter() {
        assert_eq!(
            v,
            common::padded_at(ao, [p.x as i32, p.y as i32, p.z as i32])
        );
    }
    assert!(reader.read_grid::<f32>("ao_variance").is_ok());
    let usda = std::fs::read_to_string(dir.join("ball-ao.usda")).unwrap();
    assert!(
        usda.contains("\"ao\"") && usda.contains("\"ao_variance\""),
        "{usda}"
    );
    let beauty = exr_layer(&dir.join("ball-ao.exr"), "beauty");
    let red = &beauty.iter().find(|(c, _)| c == "R").unwrap().1;
    for (got, want) in red.iter().zip(&rendered.image.rgba) {
        assert!((got - want[0]).abs() <= 1e-3 * want[0].abs().max(1.0));
    }
}

#[test]
fn sweep_accuracy_measures_either_mode_against_the_ambient_reference() {
    let out = tempfile::tempdir().unwrap();
    let scene = small_scene(out.path());
    let scene = scene.to_str().unwrap();
    let json = out.path().join("accuracy.json");
    let mut errors = vec![];
    for method in ["sweep-physical", "sweep"] {
        let report = report_of(
            &[
                "sweep-accuracy",
                "--scenes",
                scene,
                "--method",
                method,
                "--size",
                "16",
                "--spp",
                "256",
                "--device",
                "cpu",
            ],
            &json,
        );
        assert_eq!(report["method"], method);
        let row = &report["rows"][0];
        assert!(row["pixels"].as_u64().unwrap() > 0, "{row}");
        errors.push(row["rel_rmse"].as_f64().unwrap());
    }
    // The physical mode is the exact image up to its visibility's error and the reference's
    // noise; the geometric mode shades a surface, not the medium, and is further off.
    assert!(errors[0] < 0.15 && errors[0] < errors[1], "{errors:?}");
    let run = occlux(&["sweep-accuracy", "--scenes", scene, "--method", "cdf"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("--method"),
        "{stderr}"
    );
}

#[test]
fn bench_ao_times_each_radius_on_a_crop_and_refuses_bad_requests() {
    let out = tempfile::tempdir().unwrap();
    let json = out.path().join("bench.json");
    let engine = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/scivis/engine.nrrd"
    );
    let report = report_of(
        &[
            "bench-ao",
            "--volume",
            engine,
            "--slices",
            "6",
            "--radii",
            "2,3",
            "--repeats",
            "1",
            "--device",
            "cpu",
        ],
        &json,
    );
    assert_eq!(report["dims"], serde_json::json!([256, 256, 6]));
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["ratio_to_smallest_radius"], 1.0);
    assert!(rows.iter().all(|r| r["median_ms"].as_f64().unwrap() > 0.0));
    for (args, key) in [
        (vec!["--slices", "0"], "--slices"),
        (vec!["--method", "exact"], "--method"),
        (vec!["--radii", "0"], "radius"),
    ] {
        let mut all = vec!["bench-ao", "--volume", engine, "--device", "cpu", "-o"];
        let bad = out.path().join("bad.json");
        all.push(bad.to_str().unwrap());
        all.extend(args);
        let run = occlux(&all);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && stderr.contains(key), "{stderr}");
        assert!(!bad.exists());
    }
}

/// `occlux render` of a small CT phantom scene with `lights` and `render`: the EXR has the
/// layers `beauty`, `depth` and the factor's layer `factor` (channels A and V: the render's
/// coverage, equal to beauty's alpha, and its premultiplied factor, below the coverage
/// somewhere), and nothing else: no copy of the shaded image under the method's name.
fn assert_render_writes_factor_layers(lights: &str, render: &str, factor: &str) {
    use occlux::export::exr::read_exr;
    let dir = tempfile::tempdir().unwrap();
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(
        &scene_path,
        format!(
            r#"
background = 0.1
[volume]
phantom = "ct"
size = 24
[camera]
position = [3, -2, 1]
target = [0, 0, 0]
fov_deg = 40
width = 12
height = 10
{lights}
[render]
{render}
"#
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = render_on_cpu(&scene_path, &out, &["--float32"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let scene = Scene::from_file(&scene_path).unwrap();
    let volume = scene.load_volume().unwrap();
    let img = pipeline::render(&Settled::named(&scene), &volume, &Compute::Cpu, &NoProgress)
        .unwrap()
        .image;
    let exr = read_exr(&out.join("scene.exr")).unwrap();
    let names: Vec<&str> = exr.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["beauty", "depth", factor]);
    let beauty = exr.layer("beauty").unwrap();
    let want: Vec<f32> = img.rgba.iter().flatten().copied().collect();
    // Channels come back in the file's (sorted) order: match them by name.
    for name in ["R", "G", "B", "A"] {
        let k = ["R", "G", "B", "A"]
            .iter()
            .position(|x| *x == name)
            .unwrap();
        let got = beauty.channel(name).unwrap();
        for (p, got) in got.iter().enumerate() {
            assert_eq!(*got, want[4 * p + k], "{name}[{p}]");
        }
    }
    let layer = exr.layer(factor).expect("the factor's layer");
    assert_eq!(layer.channels, ["A", "V"]);
    let values = &img.factor(factor).unwrap().values;
    let (p, a) = (layer.channel("V").unwrap(), layer.channel("A").unwrap());
    assert_eq!(p, values.iter().map(|v| v[0]).collect::<Vec<_>>());
    assert_eq!(a, values.iter().map(|v| v[1]).collect::<Vec<_>>());
    assert_eq!(a, beauty.channel("A").unwrap(), "the coverage is the alpha");
    assert!(p.iter().zip(&a).all(|(p, a)| *p <= *a));
    assert!(p.iter().zip(&a).any(|(p, a)| *p < *a - 0.01));
    assert!(a.contains(&0.0) && a.iter().any(|a| *a > 0.5));
}

#[test]
fn render_with_method_dos_writes_the_occlusion_layer() {
    assert_render_writes_factor_layers(
        "[[lights]]\ntype = \"ambient\"\nradiance = 0.5",
        "method = \"dos\"\ntheta_deg = 60\ngrid = 2",
        "occlusion",
    );
}

#[test]
fn render_with_method_ipsvi_writes_the_shadow_layer() {
    assert_render_writes_factor_layers(
        "[[lights]]\ntype = \"directional\"\ndirection = [-0.3, -1.0, 1.2]\nirradiance = 3.0\n\
         [[lights]]\ntype = \"point\"\nposition = [1.5, -2.5, 2.0]\nintensity = 30.0",
        "method = \"ipsvi\"\nline_width = 2",
        "shadow",
    );
}

#[test]
fn ipsvi_accuracy_measures_against_the_reference_and_names_bad_lamps() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("ipsvi.json");
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/demo.toml");
    let report = report_of(
        &[
            "ipsvi-accuracy",
            "--scenes",
            demo,
            "--lamp",
            "1.5,-2.5,2.0,40",
            "--size",
            "24",
            "--spp",
            "64",
            "--piecewise",
            "on,off",
            "--scattering",
            "single,multiple",
            "--repeats",
            "1",
        ],
        &json,
    );
    let rows = report["rows"].as_array().unwrap();
    // The demo's sun (its ambient light left out) and the lamp; per light piecewise on and off
    // against the `single` reference, the same with multiple scattering against `multiple`,
    // and single scattering and the transport solve against `multiple` beside them.
    assert_eq!(rows.len(), 12, "{rows:?}");
    for row in rows {
        let method = row["method"].as_str().unwrap();
        let reference = row["reference"].as_str().unwrap();
        let against_multiple = reference.starts_with("occlux-multiple-");
        assert!(
            against_multiple || reference.starts_with("occlux-single-"),
            "{row}"
        );
        let multiple = method.contains("multiple") || method.contains("transport");
        assert!(!multiple || against_multiple, "{row}");
    }
    let counted = |name: &str| {
        rows.iter()
            .filter(|r| {
                let against_multiple = r["reference"]
                    .as_str()
                    .unwrap()
                    .starts_with("occlux-multiple-");
                let method = r["method"].as_str().unwrap();
                let kind = if method.contains("transport") {
                    "transport"
                } else if method.contains("multiple") {
                    "multiple"
                } else {
                    "single"
                };
                against_multiple && kind == name
            })
            .count()
    };
    // Per light one single-scattering baseline and one transport solve.
    assert_eq!(counted("single"), 2, "{rows:?}");
    assert_eq!(counted("transport"), 2, "{rows:?}");
    for row in rows {
        let error = row["rel_rmse"].as_f64().unwrap();
        assert!(error.is_finite() && error > 0.0, "{row}");
        assert!(row["ms"].as_f64().unwrap() > 0.0 && row["dvr_ms"].as_f64().unwrap() > 0.0);
    }
    let lights: Vec<&str> = rows.iter().map(|r| r["light"].as_str().unwrap()).collect();
    assert_eq!(lights, [["scene"; 6], ["lamp"; 6]].concat());
    let run = occlux(&["ipsvi-accuracy", "--scenes", demo, "--lamp", "1,2,3"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("--lamp"),
        "{stderr}"
    );
}

#[test]
fn bench_times_the_registered_methods_and_records_their_parameters() {
    use occlux::registry::Method;
    let out = tempfile::tempdir().unwrap();
    let json = out.path().join("bench.json");
    let engine = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/scivis/engine.nrrd"
    );
    let report = report_of(
        &[
            "bench",
            "--volume",
            engine,
            "--sizes",
            "8",
            "--repeats",
            "3",
            // Any render outlasts a microsecond: one timed run each, not three.
            "--case-seconds",
            "1e-6",
            "--device",
            "cpu",
        ],
        &json,
    );
    let rows = report["rows"].as_array().unwrap();
    assert!(rows.iter().all(|r| r["repeats"] == 1), "{rows:?}");
    let cases: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(
        cases,
        [
            "unshaded",
            "gradient",
            "ao",
            "dos-n2",
            "dos-n5",
            "dos-n13",
            "ipsvi",
            "half-angle"
        ]
    );
    for row in rows {
        // Each row's parameters are a method as a scene's [render] gives it.
        let method: Method = serde_json::from_value(row["params"].clone()).unwrap();
        assert!(row["method"]
            .as_str()
            .unwrap()
            .starts_with(method.spec().name));
        assert_eq!(row["volume_dims"], serde_json::json!([256, 256, 128]));
    }
    assert_eq!(rows[4]["params"]["grid"], 5);
    assert_eq!(rows[1]["ratio_to_gradient"], 1.0);
    assert!(report["adapter"].is_null(), "the CPU alone has no adapter");
}

/// The GPU check's run (bench/gpu-check.sh), tiny: `occlux bench` on the CT phantom at two sides,
/// two image sizes, both devices (lavapipe in CI) holds the adapter as wgpu describes it, the
/// machine's cores, and a row for every registered method x device x image size x volume, each
/// with a finite positive median of the repeats asked for. No time is asserted.
#[test]
fn bench_on_phantoms_times_every_method_device_and_size_and_names_the_gpu() {
    use occlux::registry::METHODS;
    let out = tempfile::tempdir().unwrap();
    let json = out.path().join("bench.json");
    let report = succeeds_with_report(
        &[
            "bench",
            "--volume-sizes",
            "12,16",
            "--sizes",
            "8,10",
            "--repeats",
            "2",
            "--device",
            "both",
            "--json",
            json.to_str().unwrap(),
        ],
        &json,
    );
    let adapter = &report["adapter"];
    for key in ["name", "driver", "driver_info", "backend", "device_type"] {
        assert!(adapter[key].is_string(), "adapter.{key} in {adapter}");
    }
    assert!(!adapter["name"].as_str().unwrap().is_empty());
    assert!(adapter["software"].is_boolean());
    assert!(report["cpu_count"].as_u64().unwrap() >= 1);
    assert_eq!(report["volume"], "phantom ct");
    assert_eq!(report["warmup_runs"], 1);
    let rows = report["rows"].as_array().unwrap();
    let devices = ["CPU", "GPU"];
    let methods: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    for spec in METHODS {
        assert!(
            methods.iter().any(|m| m.starts_with(spec.name)),
            "{}",
            spec.name
        );
    }
    // The first device, volume and size's cases: every other group has the same.
    let cases = rows.len() / (devices.len() * 2 * 2);
    assert_eq!(rows.len(), cases * devices.len() * 2 * 2);
    for device in devices {
        for side in [12, 16] {
            for size in [8, 10] {
                let here: Vec<&serde_json::Value> = rows
                    .iter()
                    .filter(|r| {
                        r["device"].as_str().unwrap().starts_with(device)
                            && r["volume_dims"] == serde_json::json!([side, side, side])
                            && r["size"] == size
                    })
                    .collect();
                let named: Vec<&str> = here.iter().map(|r| r["method"].as_str().unwrap()).collect();
                assert_eq!(named, methods[..cases], "{device} {side}^3 {size}^2");
                for row in here {
                    let median = row["median_ms"].as_f64().unwrap();
                    assert!(median.is_finite() && median > 0.0, "{row}");
                    assert_eq!(row["repeats"], 2);
                }
            }
        }
    }
}

/// `--methods` times the cases it names and gradient DVR, the ratios' baseline, and no others.
#[test]
fn bench_times_only_the_methods_named_and_the_baseline() {
    let out = tempfile::tempdir().unwrap();
    let json = out.path().join("bench.json");
    let report = succeeds_with_report(
        &[
            "bench",
            "--volume-sizes",
            "12",
            "--sizes",
            "8",
            "--repeats",
            "1",
            "--device",
            "cpu",
            "--methods",
            "dos-n5,ipsvi",
            "--json",
            json.to_str().unwrap(),
        ],
        &json,
    );
    let rows = report["rows"].as_array().unwrap();
    let methods: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(methods, ["gradient", "dos-n5", "ipsvi"]);
    assert_eq!(rows[0]["ratio_to_gradient"], 1.0);
}

#[test]
fn bench_refuses_bad_options_by_name_before_timing_anything() {
    let out = tempfile::tempdir().unwrap();
    let bad = out.path().join("bad.json");
    for (args, key) in [
        (vec!["--sizes", "0"], "--sizes"),
        (vec!["--sizes", "100000"], "--sizes"),
        (vec!["--volume-sizes", "0"], "--volume-sizes"),
        (vec!["--volume-sizes", "64,5000"], "--volume-sizes"),
        (vec!["--repeats", "0"], "--repeats"),
        (vec!["--repeats", "1000000"], "--repeats"),
        (vec!["--case-seconds", "0"], "--case-seconds"),
        (vec!["--case-seconds", "nan"], "--case-seconds"),
        (vec!["--device", "tpu"], "--device"),
        (vec!["--methods", "ipsvi,dvr"], "--methods"),
        (
            vec!["--volume", "x.nrrd", "--volume-sizes", "64"],
            "--volume",
        ),
    ] {
        let mut all = vec!["bench", "--device", "cpu", "-o", bad.to_str().unwrap()];
        all.extend(args);
        let run = occlux(&all);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success() && stderr.contains(key),
            "{all:?}: {stderr}"
        );
        assert!(!bad.exists());
    }
}

/// `occlux adapter` describes the adapter as the bench records it; `--hardware` refuses a
/// software rasterizer (lavapipe in CI) with an error naming it and writes nothing, and lets a
/// hardware GPU through.
#[test]
fn adapter_describes_the_gpu_and_hardware_refuses_a_software_one() {
    let out = tempfile::tempdir().unwrap();
    let json = out.path().join("adapter.json");
    let adapter = report_of(&["adapter"], &json);
    for key in ["name", "driver", "driver_info", "backend", "device_type"] {
        assert!(adapter[key].is_string(), "{key} in {adapter}");
    }
    let software = adapter["software"].as_bool().unwrap();
    assert_eq!(software, adapter["device_type"] == "Cpu");
    let refused = out.path().join("refused.json");
    let run = occlux(&["adapter", "--hardware", "-o", refused.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    if software {
        assert!(
            !run.status.success() && stderr.contains("software rasterizer"),
            "{stderr}"
        );
        assert!(!refused.exists());
    } else {
        assert!(run.status.success(), "{stderr}");
    }
}

#[test]
fn chart_measures_every_registered_method_and_writes_tables_and_figures() {
    use occlux::registry::METHODS;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("chart");
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/demo.toml");
    let report = succeeds_with_report(
        &[
            "chart",
            "--scenes",
            demo,
            "--lightings",
            "ambient,sun",
            "--size",
            "20",
            "--spp",
            "32",
            "--mc-spp",
            "2,8",
            "--no-peers",
            "--repeats",
            "1",
            "-o",
            out.to_str().unwrap(),
        ],
        &out.join("chart.json"),
    );
    let panels = report["panels"].as_array().unwrap();
    assert_eq!(panels.len(), 2);
    let mut rows = 0;
    for panel in panels {
        let lighting = panel["lighting"].as_str().unwrap();
        let points = panel["points"].as_array().unwrap();
        // Every setting of every method made for this lighting's lights, and no other.
        for spec in METHODS {
            let takes = match lighting {
                "ambient" => spec.for_lights.iter().any(|l| l.name() == "ambient"),
                _ => spec.for_lights.iter().any(|l| l.name() == "directional"),
            };
            let measured = points.iter().filter(|p| p["method"] == spec.name).count();
            let want = if takes { spec.chart.len() } else { 0 };
            assert_eq!(measured, want, "{lighting} {}", spec.name);
        }
        // Each point against its own model's reference too: the same as the truth where the
        // model is the lighting's (AO under ambient light, IPSVI's single scattering under the
        // sun), another reference for the DOS cone, none for gradient shading.
        for p in points {
            let (own, truth) = (p["model_rel_rmse"].as_f64(), p["rel_rmse"].as_f64());
            match (
                p["method"].as_str().unwrap(),
                p["setting"].as_str().unwrap(),
            ) {
                ("gradient" | "unshaded", _) => assert!(own.is_none(), "{p}"),
                ("ao", _) | ("ipsvi", "") | ("half-angle", _) => assert_eq!(own, truth, "{p}"),
                ("dos", _) => {
                    let own = own.unwrap();
                    assert!(own.is_finite() && own > 0.0 && own != truth.unwrap(), "{p}");
                }
                _ => assert!(own.is_some_and(f64::is_finite), "{p}"),
            }
        }
        // The front: each point on it is beaten by no other, each point off it by some other.
        let pairs: Vec<(f64, f64, bool)> = points
            .iter()
            .map(|p| {
                let error = p["rel_rmse"].as_f64().unwrap();
                assert!(error.is_finite() && error > 0.0, "{p}");
                (
                    p["seconds"].as_f64().unwrap(),
                    error,
                    p["pareto"].as_bool().unwrap(),
                )
            })
            .collect();
        for &(t, e, front) in &pairs {
            let beaten = pairs
                .iter()
                .any(|&(u, f, _)| u <= t && f <= e && (u < t || f < e));
            assert_eq!(front, !beaten, "{lighting}: ({t}, {e})");
        }
        let curve = panel["monte_carlo"].as_array().unwrap();
        assert_eq!(curve.len(), 2);
        // Four times the samples: about half the error (Monte Carlo's law), far from equal.
        let (e2, e8) = (
            curve[0]["rel_rmse"].as_f64().unwrap(),
            curve[1]["rel_rmse"].as_f64().unwrap(),
        );
        assert!(e8 < 0.8 * e2 && e8 > 0.3 * e2, "{e2} -> {e8}");
        assert!(panel["cycles"].as_array().unwrap().is_empty());
        rows += points.len() + curve.len();
    }
    // The CSV: a header and a row per point and per curve sample.
    let csv = std::fs::read_to_string(out.join("chart.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(lines[0].starts_with("scene,lighting,method,setting,spp,seconds,rel_rmse"));
    assert_eq!(lines.len(), 1 + rows);
    // The equal-error table: per panel a heading and a row per measured method (its most
    // accurate setting), the most accurate first.
    let table = std::fs::read_to_string(out.join("chart.md")).unwrap();
    for panel in panels {
        let heading = format!("### demo, {} (truth", panel["lighting"].as_str().unwrap());
        let section = table.split(&heading).nth(1).expect(&heading);
        let section = section.split("###").next().unwrap();
        let rows: Vec<&str> = section
            .lines()
            .filter(|l| l.starts_with("| ") && !l.starts_with("| method"))
            .collect();
        let mut methods: Vec<&str> = panel["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["method"].as_str().unwrap())
            .collect();
        methods.dedup();
        assert_eq!(rows.len(), methods.len(), "{section}");
        let errors: Vec<f64> = rows
            .iter()
            .map(|r| r.split(" | ").nth(2).unwrap().parse().unwrap())
            .collect();
        assert!(errors.windows(2).all(|w| w[0] <= w[1]), "{section}");
    }
    // The figure: a panel title per panel in the SVG, and a PNG of the SVG's size.
    let svg = std::fs::read_to_string(out.join("chart.svg")).unwrap();
    assert!(svg.contains("demo, ambient") && svg.contains("demo, sun"));
    let png = std::fs::File::open(out.join("chart.png")).unwrap();
    let info = png::Decoder::new(std::io::BufReader::new(png))
        .read_info()
        .unwrap();
    let (width, height) = occlux_lab::chart::plot::figure_size(2);
    assert_eq!((info.info().width, info.info().height), (width, height));
    // Bad input is named.
    for (flag, value) in [("--mc-spp", "1"), ("--cycles-spp", "0")] {
        let bad = occlux(&[
            "chart",
            "--scenes",
            demo,
            flag,
            value,
            "-o",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&bad.stderr);
        assert!(!bad.status.success() && stderr.contains(flag), "{stderr}");
    }
}

#[test]
fn an_export_lands_whole_or_leaves_the_folder_as_it_was() {
    // A folder where the stage should go: the export fails, naming it, and writes none of its
    // files (the VDB would come first); an earlier export's files keep their content.
    let out = tempfile::tempdir().unwrap();
    let scene_path = small_scene(out.path());
    let stem = scene_path.file_stem().unwrap().to_str().unwrap().to_owned();
    let dir = out.path().join("export");
    let export = |dir: &Path| {
        occlux(&[
            "export",
            scene_path.to_str().unwrap(),
            "--device",
            "cpu",
            "-o",
            dir.to_str().unwrap(),
        ])
    };
    std::fs::create_dir_all(dir.join(format!("{stem}.usda"))).unwrap();
    let run = export(&dir);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains(&format!("{stem}.usda")), "{stderr}");
    let mut left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, vec![format!("{stem}.usda")], "a half export");
    // A whole export, then one that fails: the first one's files stay as they were.
    std::fs::remove_dir(dir.join(format!("{stem}.usda"))).unwrap();
    assert!(export(&dir).status.success());
    let vdb = std::fs::read(dir.join(format!("{stem}.vdb"))).unwrap();
    std::fs::remove_file(dir.join(format!("{stem}.png"))).unwrap();
    std::fs::create_dir(dir.join(format!("{stem}.png"))).unwrap();
    assert!(!export(&dir).status.success());
    assert_eq!(std::fs::read(dir.join(format!("{stem}.vdb"))).unwrap(), vdb);
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        4,
        "exr, png folder, usda, vdb"
    );
}

#[test]
fn a_folder_that_cannot_be_made_is_refused_before_rendering() {
    let out = tempfile::tempdir().unwrap();
    let scene_path = small_scene(out.path());
    let blocked = out.path().join("blocked");
    std::fs::write(&blocked, b"a file").unwrap();
    for command in ["render", "export"] {
        let run = occlux(&[
            command,
            scene_path.to_str().unwrap(),
            "--device",
            "cpu",
            "-o",
            blocked.join("out").to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success() && stderr.contains("blocked"),
            "{stderr}"
        );
        // Refused before the volume was loaded: nothing was said of loading or rendering.
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            !stdout.contains("loaded") && !stdout.contains("rendered"),
            "{stdout}"
        );
    }
}

#[test]
fn series_refuses_a_gap_or_an_impossible_request_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        "[volume]\nphantom = \"sphere\"\nsize = 8\n[camera]\nwidth = 8\nheight = 8\n",
    )
    .unwrap();
    for n in [1, 2, 4] {
        let raw = dir.path().join(format!("f{n}.raw"));
        std::fs::write(raw, [0u8; 8]).unwrap();
    }
    let out = dir.path().join("out");
    let pattern = dir.path().join("f*.raw");
    let run = occlux(&[
        "series",
        scene.to_str().unwrap(),
        "--frames",
        pattern.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("misses f3.raw"),
        "{stderr}"
    );
    let run = occlux(&[
        "series",
        scene.to_str().unwrap(),
        "--render",
        "--ao",
        "cdf",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("needs the export"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn plan_says_what_it_chose_and_why() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("sun.toml");
    std::fs::write(
        &scene,
        "[volume]\nphantom = \"ct\"\nsize = 24\n[camera]\nwidth = 32\nheight = 24\n\
         [[lights]]\ntype = \"directional\"\ndirection = [-0.3, -1.0, 1.2]\nirradiance = 3\n\
         [render]\nmethod = \"dos\"\n",
    )
    .unwrap();
    let json = dir.path().join("plan.json");
    let run = occlux(&[
        "plan",
        scene.to_str().unwrap(),
        "--error",
        "0.2",
        "--pilot",
        "16",
        "--device",
        "cpu",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("chose ") && stdout.contains("budget: relative RMSE 0.2"),
        "{stdout}"
    );
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let chosen = &plan["estimates"][plan["chosen"].as_u64().unwrap() as usize];
    assert_eq!(chosen["meets"], true, "{plan}");
    assert!(chosen["error"].as_f64().unwrap() <= 0.2);
    // What to paste: a method's [render], or the reference command.
    assert!(
        stdout.contains("[render]\nmethod = ") || stdout.contains("occlux reference SCENE"),
        "{stdout}"
    );
    // The scene's own method (DOS, ambient light only) does not stop the plan; a bad budget does.
    let bad = occlux(&[
        "plan",
        scene.to_str().unwrap(),
        "--error",
        "0",
        "--device",
        "cpu",
    ]);
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && stderr.contains("error budget"),
        "{stderr}"
    );
}

#[test]
fn gallery_shows_every_method_beside_the_truth_with_its_time_and_error() {
    use occlux::registry::METHODS;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("gallery");
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/demo.toml");
    let small = "--size 128 --spp 16 --mc-spp 4 --repeats 1 --lightings ambient,sun";
    let mut args = vec!["gallery", demo, "-o", out.to_str().unwrap()];
    args.extend(small.split(' '));
    let report = succeeds_with_report(&args, &out.join("gallery.json"));
    let groups = report["groups"].as_array().unwrap();
    let mut rows = 0;
    for group in groups {
        let tiles = group["tiles"].as_array().unwrap();
        let lights = if group["lighting"] == "ambient" {
            "ambient"
        } else {
            "directional"
        };
        let settings: usize = METHODS
            .iter()
            .filter(|m| m.for_lights.iter().any(|l| l.name() == lights))
            .map(|m| m.chart.len())
            .sum();
        // Every setting made for the lighting, Monte Carlo, and the truth (no error: it is
        // what the others are measured against).
        assert_eq!(tiles.len(), settings + 2, "{group}");
        for tile in &tiles[..tiles.len() - 1] {
            let error = tile["rel_rmse"].as_f64().unwrap();
            assert!(error.is_finite() && error >= 0.0, "{tile}");
            assert!(tile["seconds"].as_f64().unwrap() > 0.0, "{tile}");
        }
        assert!(tiles.last().unwrap()["rel_rmse"].is_null());
        rows += tiles.len().div_ceil(4);
    }
    // The picture: four tiles across, each group starting a row, a caption under each tile.
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(out.join("gallery.png")).unwrap(),
    ));
    let info = decoder.read_info().unwrap().info().clone();
    assert_eq!(
        (info.width, info.height),
        (4 * 128, rows as u32 * (128 + 40))
    );
}

#[test]
fn methods_json_is_the_registry_with_defaults() {
    let run = Command::new(env!("CARGO_BIN_EXE_occlux"))
        .args(["methods", "--json"])
        .output()
        .unwrap();
    assert!(run.status.success());
    let printed: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(printed, occlux::registry::describe());
    let dos = printed
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "dos")
        .unwrap();
    let theta = dos["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["key"] == "theta_deg")
        .unwrap();
    assert_eq!(theta["default"], serde_json::json!(50.0));
    assert_eq!(theta["range"]["max"], serde_json::json!(90.0));
    assert_eq!(theta["range"]["max_inclusive"], serde_json::json!(false));
    assert_eq!(dos["lights"], serde_json::json!(["ambient"]));
    let text = Command::new(env!("CARGO_BIN_EXE_occlux"))
        .arg("methods")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&text.stdout);
    for spec in occlux::registry::METHODS {
        assert!(
            text.contains(&format!("{}: {}", spec.name, spec.summary)),
            "{text}"
        );
    }
}

/// The hidden staging folders in `dir`.
fn staging_folders(dir: &Path) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with(".occlux-staging-"))
                })
                .collect()
        })
        .unwrap_or_default()
}

/// Starts `occlux export SCENE -o OUT --device cpu` and, once its staging folder is there (it
/// is writing), sends `signal`; None if the export ended first.
fn signal_while_staging(scene: &Path, out: &Path, signal: i32) -> Option<std::process::Output> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_occlux"))
        .args(["--quiet", "export", scene.to_str().unwrap(), "-o"])
        .arg(out)
        .args(["--device", "cpu"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    loop {
        if child.try_wait().unwrap().is_some() {
            return None;
        }
        if !staging_folders(out).is_empty() {
            // SAFETY: kill(2) on our own child's pid.
            unsafe { libc::kill(child.id() as i32, signal) };
            return Some(child.wait_with_output().unwrap());
        }
        std::thread::sleep(std::time::Duration::from_micros(200));
    }
}

/// The export's four files, where they are whole (its stage, the marker, is there).
fn export_files(out: &Path) -> Option<Vec<Vec<u8>>> {
    out.join("kill.usda").is_file().then(|| {
        ["kill.vdb", "kill.exr", "kill.png", "kill.usda"]
            .map(|name| std::fs::read(out.join(name)).unwrap())
            .to_vec()
    })
}

#[test]
fn an_interrupted_or_killed_export_leaves_no_partial_set_and_the_next_run_cleans_up() {
    // Issue 38: killed or interrupted during `export`, a `.occlux-staging-*` folder with partial
    // files stayed, no rerun removed it, and a kill between the final renames left the VDB
    // without its stage.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("kill.toml");
    std::fs::write(
        &scene,
        "background = 0.1\n[volume]\nphantom = \"ct\"\nsize = 128\n[camera]\n\
         position = [3, -2, 1]\ntarget = [0, 0, 0]\nwidth = 64\nheight = 64\n\
         [[lights]]\ntype = \"ambient\"\nradiance = 1\n[render]\nmethod = \"ao\"\n",
    )
    .unwrap();
    let whole = dir.path().join("whole");
    let run = occlux(&[
        "--quiet",
        "export",
        scene.to_str().unwrap(),
        "-o",
        whole.to_str().unwrap(),
        "--device",
        "cpu",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let reference = export_files(&whole).expect("a whole export");

    // SIGTERM (and Ctrl-C's SIGINT alike) while writing: the staging folder goes, nothing half
    // written stays, and the status says it was interrupted.
    let interrupted = dir.path().join("interrupted");
    let mut seen = 0;
    for _ in 0..5 {
        if seen == 2 {
            break;
        }
        std::fs::remove_dir_all(&interrupted).ok();
        std::fs::create_dir_all(&interrupted).unwrap();
        let Some(ended) = signal_while_staging(&scene, &interrupted, libc::SIGTERM) else {
            continue;
        };
        seen += 1;
        let err = String::from_utf8_lossy(&ended.stderr);
        assert!(staging_folders(&interrupted).is_empty(), "{err}");
        match export_files(&interrupted) {
            // The signal came as the commit ran: it finished first.
            Some(files) => assert_eq!(files, reference),
            None => {
                assert_eq!(ended.status.code(), Some(130), "{err}");
                assert!(err.contains("interrupted"), "{err}");
                assert_eq!(std::fs::read_dir(&interrupted).unwrap().count(), 0);
            }
        }
    }
    assert!(seen > 0, "no export was caught while writing");

    // SIGKILL at points spread over the writing: no handler runs, the staging folder stays;
    // the folder holds either the whole set (stage present) or no stage, and the next export
    // removes the left-over staging and lands the whole set.
    let killed = dir.path().join("killed");
    let mut left_over = 0;
    for delay_us in [0u64, 500, 2_000, 8_000, 20_000, 50_000] {
        std::fs::remove_dir_all(&killed).ok();
        std::fs::create_dir_all(&killed).unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_occlux"))
            .args(["--quiet", "export", scene.to_str().unwrap(), "-o"])
            .arg(&killed)
            .args(["--device", "cpu"])
            .spawn()
            .unwrap();
        while staging_folders(&killed).is_empty() && child.try_wait().unwrap().is_none() {
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
        std::thread::sleep(std::time::Duration::from_micros(delay_us));
        child.kill().unwrap();
        child.wait().unwrap();
        if let Some(files) = export_files(&killed) {
            assert_eq!(
                files, reference,
                "a stage beside a partial set, {delay_us} us"
            );
        }
        left_over += staging_folders(&killed).len();
        let rerun = occlux(&[
            "--quiet",
            "export",
            scene.to_str().unwrap(),
            "-o",
            killed.to_str().unwrap(),
            "--device",
            "cpu",
        ]);
        assert!(
            rerun.status.success(),
            "{}",
            String::from_utf8_lossy(&rerun.stderr)
        );
        assert!(staging_folders(&killed).is_empty(), "{delay_us} us");
        assert_eq!(
            export_files(&killed).as_ref(),
            Some(&reference),
            "{delay_us} us"
        );
    }
    assert!(left_over > 0, "no kill left a staging folder to clean up");
}
