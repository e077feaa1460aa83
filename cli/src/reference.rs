//! `occlux reference`: a scene's Monte Carlo reference with progress, written as float32 EXR
//! (mean and standard error) and a PNG preview.

use occlux::error::Result;
use occlux::export::atomic::check_writable;
use occlux::pipeline::write_reference;
use occlux::render::reference::{render, ReferenceInput, ReferenceParams};
use occlux::scene::Scene;
use occlux_lab::term::{notice, report_written, say, Bar};
use std::path::Path;
use std::time::Instant;

/// Renders the reference of the scene file `scene_path` and writes
/// `OUT/STEM-ESTIMATOR.{exr,png}`.
pub fn run(
    scene_path: &Path,
    params: &ReferenceParams,
    out: &Path,
    exposure: f32,
    quiet: bool,
) -> Result<()> {
    params.validate()?;
    let scene = Scene::from_file(scene_path)?;
    // A folder that cannot be written is found before the work, not after it.
    check_writable(out)?;
    let loaded = scene.load()?;
    for line in &loaded.notices {
        notice(quiet, line);
    }
    let (scene, volume) = (loaded.scene, loaded.volume);
    let lut = scene.classification.bake(&volume);
    let bar = Bar::new(quiet, scene.camera.height as u64, "sampling");
    let started = Instant::now();
    let input = ReferenceInput {
        volume: &volume,
        lut: &lut,
        camera: &scene.camera,
        lighting: &scene.lighting,
        params,
    };
    let image = render(&input, &bar)?;
    bar.finish();
    say(
        quiet,
        format_args!(
            "{} reference, {} spp, {}x{} in {:.2} s",
            params.estimator.name(),
            params.spp,
            image.width,
            image.height,
            started.elapsed().as_secs_f64()
        ),
    );
    let stem = format!(
        "{}-{}",
        occlux::pipeline::stem(scene_path),
        params.estimator.name()
    );
    let written = write_reference(&image, &scene, params, out, &stem, exposure)?;
    report_written(&written, quiet);
    Ok(())
}
