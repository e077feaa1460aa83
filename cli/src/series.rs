//! `occlux series`: a series of volumes planned (every frame read once), rendered and exported
//! in order on this machine, and its stage written; every failed frame named.

use occlux::error::Result;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::scene::Scene;
use occlux::series::{self, FrameSpec, Resume, SeriesOptions};
use occlux_lab::term::{notice, report_written, say, Terminal};
use std::path::{Path, PathBuf};

/// `occlux series`: plans the series (every frame read once), runs its frames in order on
/// this machine and writes the stage; names every failed frame.
pub fn run(
    scene: &Path,
    frames: Option<Vec<String>>,
    out: &Path,
    name: &str,
    options: &SeriesOptions,
    device: DeviceChoice,
    quiet: bool,
) -> Result<()> {
    let (tree, base) = Scene::file_tree(scene)?;
    let frames = frames.map(|specs| frame_files(&specs)).transpose()?;
    let (compute, device_notice) = Compute::resolve(device)?;
    if let Some(line) = device_notice {
        notice(quiet, line);
    }
    let (manifest, resume) =
        series::plan(tree, &base, frames, name, out, options, &Terminal { quiet })?;
    if resume == Resume::Resumed {
        say(
            quiet,
            format_args!("resuming series '{name}' in {}", out.display()),
        );
    }
    say(
        quiet,
        format_args!("{} frames on {}", manifest.count, compute.describe()),
    );
    let summary = series::run(&manifest, out, &compute, &Terminal { quiet })?;
    if !summary.complete.is_empty() {
        say(
            quiet,
            format_args!(
                "{} frames already complete, skipped",
                summary.complete.len()
            ),
        );
    }
    let summary = summary.into_result()?;
    for (_, files) in &summary.written {
        report_written(files, quiet);
    }
    if let Some(stage) = &summary.stage {
        report_written(std::slice::from_ref(stage), quiet);
    }
    Ok(())
}

/// `--frames` as files: one argument may be a pattern or a folder (read in natural order), or
/// several name the files (the shell expanded a pattern).
fn frame_files(specs: &[String]) -> Result<Vec<PathBuf>> {
    let spec = match specs {
        [one] => FrameSpec::Pattern(one.clone()),
        many => FrameSpec::List(many.iter().map(PathBuf::from).collect()),
    };
    spec.resolve(Path::new(""))
}
