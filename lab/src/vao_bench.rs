//! `occlux bench-ao`: times VAO volumes (statistics and the estimate; the classification into
//! extinction is done once, untimed) at several radii on the CPU and the GPU, medians after a
//! warm-up, on a crop of a CT to the 256 x 256 x 113. Prints a table with t(r) / t(4)
//! and writes JSON.

use super::bench::{devices, timed, BenchDevices, Timing};
use occlux::ao::vao::{ao_volume, Estimator, FieldKind, ScalarField, VaoParams};
use occlux::error::{Error, Result};
use occlux::progress::NoProgress;
use occlux::scene::{Scene, SourceKind};
use occlux::volume::Volume;
use serde::Serialize;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// The engine scene supplies the classification.
const BENCH_SCENE: &str = include_str!("../../examples/engine.toml");

#[derive(clap::Args, Debug)]
pub struct VaoBenchArgs {
    /// CT volume to crop (classified with the engine scene's transfer function).
    #[arg(long, default_value = "../shared/data/scivis/engine.nrrd")]
    pub volume: PathBuf,
    /// Slices kept along z, from the middle of the volume (the crop is 113).
    #[arg(long, default_value_t = 113)]
    pub slices: usize,
    /// Radii in voxels.
    #[arg(long, value_delimiter = ',', default_value = "4,5,10,16")]
    pub radii: Vec<u32>,
    #[arg(long, default_value = "cdf")]
    pub method: String,
    #[arg(long, default_value_t = 7)]
    pub repeats: usize,
    #[arg(long, default_value = "auto")]
    pub device: BenchDevices,
    #[arg(short, long, default_value = "occlux-bench-ao.json")]
    pub out: PathBuf,
}

#[derive(Serialize, Debug)]
struct Row {
    device: String,
    radius: u32,
    #[serde(flatten)]
    timing: Timing,
    /// Median over the median at the smallest radius timed on the same device.
    ratio_to_smallest_radius: f64,
}

#[derive(Serialize)]
struct Report<'a> {
    volume: String,
    dims: [usize; 3],
    method: &'a str,
    cpu_threads: usize,
    repeats: usize,
    rows: &'a [Row],
}

/// The middle `slices` slices of `volume` along z.
fn crop_z(volume: &Volume, slices: usize) -> Result<Volume> {
    let [nx, ny, nz] = volume.dims();
    if slices == 0 || slices > nz {
        return Err(Error::param(
            "--slices",
            format!("must be in [1, {nz}] for this volume, got {slices}"),
        ));
    }
    let z0 = (nz - slices) / 2;
    let slice = nx * ny;
    let values = volume.values()[z0 * slice..(z0 + slices) * slice].to_vec();
    let origin = volume.origin() + glam::Vec3::new(0.0, 0.0, z0 as f32) * volume.spacing();
    Volume::new([nx, ny, slices], volume.spacing(), origin, values)
}

pub fn run(args: &VaoBenchArgs, quiet: bool) -> Result<()> {
    if args.repeats == 0 || args.radii.is_empty() {
        return Err(Error::param(
            "--repeats/--radii",
            "need at least one repeat and one radius",
        ));
    }
    let estimator: Estimator = args.method.parse()?;
    if estimator == Estimator::Exact {
        return Err(Error::param(
            "--method",
            "the exact count is a reference, not a timed method",
        ));
    }
    let mut scene = Scene::parse(BENCH_SCENE, Path::new("."))?;
    scene.volume.kind = SourceKind::File(args.volume.clone());
    let volume = crop_z(&scene.load_volume()?, args.slices)?;
    let field = ScalarField::new(
        Cow::Borrowed(&volume),
        &scene.classification,
        FieldKind::Extinction,
    )?;
    let mut rows = vec![];
    for compute in devices(args.device, quiet)? {
        let mut first = None;
        for &radius in &args.radii {
            let params = VaoParams {
                radius,
                estimator,
                variance: false,
            };
            let timing = timed(args.repeats, || {
                ao_volume(&compute, Cow::Borrowed(&field), &params, &NoProgress)
            })?;
            let base = *first.get_or_insert(timing.median_ms);
            let row = Row {
                device: compute.describe(),
                radius,
                timing,
                ratio_to_smallest_radius: timing.median_ms / base,
            };
            if !quiet {
                println!(
                    "r = {:>3} {}  x{:.3}  {}",
                    row.radius, row.timing, row.ratio_to_smallest_radius, row.device
                );
            }
            rows.push(row);
        }
    }
    let report = Report {
        volume: args.volume.display().to_string(),
        dims: volume.dims(),
        method: estimator.name(),
        cpu_threads: rayon::current_num_threads(),
        repeats: args.repeats,
        rows: &rows,
    };
    super::write_report(&args.out, &report, quiet)
}
