//! `occlux render`, `export` and `demo`: a scene rendered on the chosen device with a progress
//! bar, and its outputs written.

use occlux::error::Result;
use occlux::export::atomic::check_writable;
use occlux::export::exr::Precision;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{export, render, settle, write_render, OutputOptions, Outputs};
use occlux::scene::Scene;
use occlux_lab::term::{notice, report_written, say, Bar};
use std::path::Path;
use std::time::Instant;

#[derive(clap::Args)]
pub struct OutputArgs {
    /// Where to compute: auto picks a hardware GPU adapter if one opens, else the CPU.
    #[arg(long, default_value = "auto")]
    pub device: DeviceChoice,
    /// Write EXR channels as float32 rather than float16.
    #[arg(long)]
    pub float32: bool,
    /// Exposure multiplier for the PNG preview.
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f32,
}

impl OutputArgs {
    /// Renders `scene` and writes its outputs as these arguments ask.
    pub fn run(
        &self,
        scene: &Scene,
        stem: &str,
        out: &Path,
        outputs: &Outputs,
        quiet: bool,
    ) -> Result<()> {
        let options = OutputOptions {
            precision: if self.float32 {
                Precision::Float
            } else {
                Precision::Half
            },
            exposure: self.exposure,
        };
        render_scene(scene, stem, out, self.device, &options, outputs, quiet)
    }
}

/// Loads a scene's volume, renders it on `device` with a progress bar, and writes the outputs
/// into `out_dir` named after `stem`; says what it did unless `quiet`.
pub fn render_scene(
    scene: &Scene,
    stem: &str,
    out_dir: &Path,
    device: DeviceChoice,
    options: &OutputOptions,
    outputs: &Outputs,
    quiet: bool,
) -> Result<()> {
    options.validate()?;
    // A folder that cannot be written is found before the work, not after it.
    check_writable(out_dir)?;
    let (compute, device_notice) = Compute::resolve(device)?;
    if let Some(line) = device_notice {
        notice(quiet, line);
    }
    let started = Instant::now();
    let loaded = scene.load()?;
    for line in &loaded.notices {
        notice(quiet, line);
    }
    let volume = &loaded.volume;
    let scene = &settle(&loaded.scene, volume, &compute, &|line: &str| {
        say(quiet, line)
    })?;
    let [nx, ny, nz] = volume.dims();
    say(
        quiet,
        format_args!(
            "volume {nx}x{ny}x{nz} loaded in {:.2} s; rendering on {}",
            started.elapsed().as_secs_f64(),
            compute.describe()
        ),
    );
    let bar = Bar::new(quiet, scene.camera.height as u64, "rendering");
    let started = Instant::now();
    let rendered = render(scene, volume, &compute, &bar)?;
    bar.finish();
    let image = &rendered.image;
    say(
        quiet,
        format_args!(
            "rendered {}x{} in {:.2} s",
            image.width,
            image.height,
            started.elapsed().as_secs_f64()
        ),
    );
    let written = match outputs {
        Outputs::Render => write_render(image, scene, out_dir, stem, options)?,
        Outputs::Export(vdb) => export(&rendered, scene, volume, out_dir, stem, options, vdb)?,
    };
    report_written(&written, quiet);
    Ok(())
}
