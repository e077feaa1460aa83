//! Time series (`occlux series`): one classification and camera for every frame, the same files
//! from a rerun, a resume that redoes only what is missing, and refusals before any work.

use occlux::classify::Window;
use occlux::gpu::Compute;
use occlux::progress::Silent;
use occlux::scene::Scene;
use occlux::series::{self, Manifest, Resume, SeriesOptions};
use occlux::volume::{self, LoadOptions, Volume};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Frames in the series.
const FRAMES: usize = 12;
/// Voxels per side.
const SIDE: usize = 20;

/// A raw little-endian float NRRD of `SIDE`^3 voxels.
fn write_nrrd(path: &Path, values: &[f32]) {
    write_nrrd_sized(path, [SIDE; 3], values);
}

/// A raw little-endian float NRRD of `sizes` voxels.
fn write_nrrd_sized(path: &Path, [x, y, z]: [usize; 3], values: &[f32]) {
    let mut bytes = format!(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: {x} {y} {z}\nencoding: raw\n\
         endian: little\nspacings: 1 1 1\n\n"
    )
    .into_bytes();
    bytes.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(path, bytes).unwrap();
}

/// Frame `t` of a moving, brightening ball: its centre travels along x and its values grow by
/// 10 % a frame, so a window settled per frame would differ from frame to frame.
fn ball(t: usize) -> Vec<f32> {
    let centre = [6.0 + 0.7 * t as f32, 10.0, 10.0];
    let mut values = Vec::with_capacity(SIDE * SIDE * SIDE);
    for k in 0..SIDE {
        for j in 0..SIDE {
            for i in 0..SIDE {
                let d = [i, j, k]
                    .iter()
                    .zip(centre)
                    .map(|(&x, c)| (x as f32 - c).powi(2))
                    .sum::<f32>()
                    .sqrt();
                values.push((5.0 - d).max(0.0) * 40.0 * (1.0 + 0.1 * t as f32));
            }
        }
    }
    values
}

const SCENE: &str = r#"
[volume]
frames = "step_*.nrrd"
fit = "auto"
[classification]
preset = "simulation"
[camera]
width = 24
height = 24
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 4.0
[render]
method = "ipsvi"
"#;

/// A folder with the series' frames and its scene file; returns the scene's path.
fn make_series(dir: &Path) -> PathBuf {
    for t in 0..FRAMES {
        write_nrrd(&dir.join(format!("step_{:02}.nrrd", t + 1)), &ball(t));
    }
    let scene = dir.join("ball.toml");
    std::fs::write(&scene, SCENE).unwrap();
    scene
}

fn plan(scene: &Path, out: &Path) -> occlux::Result<(Manifest, Resume)> {
    let (tree, base) = Scene::file_tree(scene)?;
    series::plan(
        tree,
        &base,
        None,
        "ball",
        out,
        &SeriesOptions::default(),
        &Silent,
    )
}

/// What a file holds: its bytes, or for an EXR its decoded image (pixels and header
/// attributes). The exr crate keeps header attributes in a hash map, so their order in the
/// file differs between processes while the image is the same.
#[derive(Debug, PartialEq)]
enum Content {
    Bytes(Vec<u8>),
    Exr(Box<exr::image::AnyImage>),
}

/// Every file in `dir` with its content, by name.
fn contents(dir: &Path) -> Vec<(String, Content)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            let content = if name.ends_with(".exr") {
                Content::Exr(Box::new(exr::prelude::read_all_data_from_file(&p).unwrap()))
            } else {
                Content::Bytes(std::fs::read(&p).unwrap())
            };
            (name, content)
        })
        .collect();
    files.sort_by(|a, b| a.0.cmp(&b.0));
    files
}

/// A grid of a VDB as the reader gives it: dense over its active voxels' box.
fn grid(path: &Path, name: &str) -> Volume {
    let options = LoadOptions {
        grid: Some(name.into()),
        ..LoadOptions::default()
    };
    volume::load(path, &options).unwrap()
}

/// The largest relative difference between a grid read back (its active box) and the volume
/// it was written from, voxel by voxel at the same world positions; the voxels outside the
/// box must be 0 (inactive), which the equal sums check.
fn worst_difference(read: &Volume, written: &Volume) -> f32 {
    let [nx, ny, nz] = read.dims();
    let offset = ((read.origin() - written.origin()) / written.spacing()).round();
    let mut worst = 0.0f32;
    let mut sum = 0.0f64;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let at = offset + glam::Vec3::new(i as f32, j as f32, k as f32);
                let (a, b) = (
                    read.at(i, j, k),
                    written.at(at.x as usize, at.y as usize, at.z as usize),
                );
                worst = worst.max((a - b).abs() / b.abs().max(1e-3));
                sum += a as f64;
            }
        }
    }
    let total: f64 = written.values().iter().map(|&v| v as f64).sum();
    worst.max(((sum - total).abs() / total.max(1e-9)) as f32)
}

#[test]
fn every_frame_shares_one_window_camera_and_stage_and_a_rerun_gives_the_same_bytes() {
    let data = tempfile::tempdir().unwrap();
    let scene = make_series(data.path());
    let (a, b) = (data.path().join("a"), data.path().join("b"));
    let (manifest, resume) = plan(&scene, &a).unwrap();
    assert_eq!(resume, Resume::New);
    assert_eq!(manifest.count, FRAMES);
    let summary = series::run(&manifest, &a, &Compute::Cpu, &Silent).unwrap();
    assert_eq!(summary.written.len(), FRAMES);
    assert!(summary.failed.is_empty());

    // The window is the union of every frame's own robust window, not the first frame's.
    let windows: Vec<Window> = (1..=FRAMES)
        .map(|t| {
            let path = data.path().join(format!("step_{t:02}.nrrd"));
            Window::robust(&volume::load(&path, &LoadOptions::default()).unwrap()).window
        })
        .collect();
    let fixed = manifest.settings.window.unwrap();
    let lo = windows.iter().map(|w| w.lo).fold(f32::INFINITY, f32::min);
    let hi = windows
        .iter()
        .map(|w| w.hi)
        .fold(f32::NEG_INFINITY, f32::max);
    assert_eq!((fixed.lo, fixed.hi), (lo, hi));
    assert!(windows[0].hi < 0.8 * hi, "frames must differ: {windows:?}");

    // Each frame's density is its own values through that one classification: the brightening
    // ball grows denser (normalised per frame, every frame would read alike).
    let template = manifest.frame_scene(&manifest.frames[0]).unwrap();
    let mut peaks = Vec::new();
    for entry in &manifest.frames {
        let vdb = a.join(entry.vdb.as_ref().unwrap());
        let loaded = manifest.frame_scene(entry).unwrap().load().unwrap();
        let expected = template.classification.extinction(&loaded.volume).unwrap();
        let density = grid(&vdb, "density");
        let worst = worst_difference(&density, &expected);
        assert!(
            worst < 1e-5,
            "frame {}: density off by {worst}",
            entry.frame
        );
        peaks.push(density.values().iter().copied().fold(0.0f32, f32::max));
        assert_eq!(loaded.scene.camera, manifest.settings.camera);
    }
    assert!(peaks[FRAMES - 1] > 1.5 * peaks[0], "{peaks:?}");

    // The stage plays the VDBs in frame order (usd-core reads it in tests/python).
    let stage = std::fs::read_to_string(summary.stage.unwrap()).unwrap();
    let samples: Vec<String> = (1..=FRAMES)
        .map(|f| format!("{f}: @./ball_{f:04}.vdb@"))
        .collect();
    assert!(stage.contains(&samples.join(", ")), "{stage}");

    // A second run elsewhere writes the same files.
    let (again, _) = plan(&scene, &b).unwrap();
    series::run(&again, &b, &Compute::Cpu, &Silent).unwrap();
    let reference = contents(&a);
    assert_eq!(
        reference.len(),
        3 * FRAMES + 2,
        "vdb, exr, png per frame, stage, manifest"
    );
    assert!(
        reference == contents(&b),
        "a rerun must write the same files"
    );

    // Resume: only the frame whose VDB went missing is redone, to the same bytes.
    std::fs::remove_file(a.join("ball_0005.vdb")).unwrap();
    let (resumed, resume) = plan(&scene, &a).unwrap();
    assert_eq!(resume, Resume::Resumed);
    let summary = series::run(&resumed, &a, &Compute::Cpu, &Silent).unwrap();
    let redone: Vec<u32> = summary.written.iter().map(|(f, _)| *f).collect();
    assert_eq!(redone, [5]);
    assert_eq!(summary.complete.len(), FRAMES - 1);
    assert!(reference == contents(&a));
}

#[test]
fn bad_series_are_refused_before_any_work() {
    let data = tempfile::tempdir().unwrap();
    let scene = make_series(data.path());
    let out = data.path().join("out");

    // A frame of other dims, named, and nothing written.
    let odd = data.path().join("step_07.nrrd");
    let small: Vec<f32> = ball(6).into_iter().take(SIDE * SIDE * (SIDE - 1)).collect();
    write_nrrd_sized(&odd, [SIDE, SIDE, SIDE - 1], &small);
    let message = plan(&scene, &out).unwrap_err().to_string();
    assert!(
        message.contains("step_07.nrrd") && message.contains("dims [20, 20, 19]"),
        "{message}"
    );
    assert!(!out.exists(), "nothing may be written for a refused series");

    // A missing frame in the numbered sequence, named.
    std::fs::remove_file(&odd).unwrap();
    let message = plan(&scene, &out).unwrap_err().to_string();
    assert!(message.contains("misses step_07.nrrd"), "{message}");
    assert!(!out.exists());

    // A folder holding a series made with other settings is not mixed into.
    write_nrrd(&odd, &ball(6));
    plan(&scene, &out).unwrap();
    let mut tree: Value = toml::from_str(SCENE).unwrap();
    tree["camera"]["width"] = Value::from(32);
    let message = series::plan(
        tree,
        data.path(),
        None,
        "ball",
        &out,
        &SeriesOptions::default(),
        &Silent,
    )
    .unwrap_err()
    .to_string();
    assert!(message.contains("other scene settings"), "{message}");
}

#[test]
fn a_4d_file_is_a_series_of_its_time_steps() {
    let data = tempfile::tempdir().unwrap();
    let steps = 4;
    // The first four frames as 3-D files, and the same as one X Y Z T file.
    let mut all = Vec::new();
    for t in 0..steps {
        write_nrrd(
            &data.path().join(format!("step_{:02}.nrrd", t + 1)),
            &ball(t),
        );
        all.extend(ball(t));
    }
    let mut bytes = format!(
        "NRRD0004\ntype: float\ndimension: 4\nsizes: {SIDE} {SIDE} {SIDE} {steps}\n\
         encoding: raw\nendian: little\nspacings: 1 1 1 NaN\n\n"
    )
    .into_bytes();
    bytes.extend(all.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(data.path().join("steps.nrrd"), bytes).unwrap();
    let scene = data.path().join("ball.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let four_d = data.path().join("four.toml");
    std::fs::write(
        &four_d,
        SCENE.replace("frames = \"step_*.nrrd\"", "path = \"steps.nrrd\""),
    )
    .unwrap();

    let (files, one) = (data.path().join("files"), data.path().join("one"));
    let (manifest, _) = plan(&scene, &files).unwrap();
    series::run(&manifest, &files, &Compute::Cpu, &Silent).unwrap();
    let (manifest, _) = plan(&four_d, &one).unwrap();
    let times: Vec<Option<usize>> = manifest.frames.iter().map(|f| f.time).collect();
    assert_eq!(times, [Some(0), Some(1), Some(2), Some(3)]);
    series::run(&manifest, &one, &Compute::Cpu, &Silent).unwrap();
    // The same frames, the same files; only the manifests' sources differ.
    let without_manifest = |dir: &Path| {
        let mut c = contents(dir);
        c.retain(|(name, _)| !name.ends_with(".series.json"));
        c
    };
    let expected = without_manifest(&files);
    assert_eq!(expected.len(), 3 * steps + 1);
    assert!(expected == without_manifest(&one));
}

#[test]
fn a_scene_lists_its_frames_in_the_order_it_wants() {
    let data = tempfile::tempdir().unwrap();
    make_series(data.path());
    let listed = data.path().join("listed.toml");
    std::fs::write(
        &listed,
        SCENE.replace(
            "frames = \"step_*.nrrd\"",
            "frames = [\"step_03.nrrd\", \"step_01.nrrd\"]",
        ),
    )
    .unwrap();
    let (manifest, _) = plan(&listed, &data.path().join("out")).unwrap();
    let names: Vec<_> = manifest
        .frames
        .iter()
        .map(|f| f.source.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["step_03.nrrd", "step_01.nrrd"]);
    // Without `path`, a single render shows the first listed frame.
    let scene = Scene::from_file(&listed).unwrap();
    assert!(
        matches!(&scene.volume.kind, occlux::scene::SourceKind::File(p) if p.ends_with("step_03.nrrd"))
    );
}
