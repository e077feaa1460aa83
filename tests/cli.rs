//! The `occlux` binary end to end: the demo's EXR read back with the exr crate equals the
//! library's render; `info` describes a real volume; bad input fails cleanly and writes nothing.

use occlux::gpu::Compute;
use occlux::pipeline;
use occlux::progress::NoProgress;
use occlux::scene::Scene;
use std::path::Path;
use std::process::{Command, Output};

fn occlux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_occlux"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("the occlux binary runs")
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

    let scene = Scene::parse(include_str!("../examples/demo.toml"), Path::new(".")).unwrap();
    let volume = scene.load_volume().unwrap();
    let img = pipeline::render(&scene, &volume, &Compute::Cpu, &NoProgress).unwrap();

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
        "/../shared/data/scivis/engine.nrrd"
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
