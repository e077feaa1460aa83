//! The `occlux` command line: thin; parses arguments and calls the library.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use occlux::eval::bench;
use occlux::export::exr::Precision;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{self, OutputOptions};
use occlux::scene::Scene;
use occlux::volume::{self, LoadOptions, RawSpec, ScalarType};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// The built-in demo scene: the CT-like phantom, soft-tissue preset, gradient shading.
const DEMO_SCENE: &str = include_str!("../examples/demo.toml");

#[derive(Parser)]
#[command(
    name = "occlux",
    version,
    about = "Illumination for scientific volumes"
)]
struct Cli {
    /// Print nothing but errors.
    #[arg(long, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file into OUT/ (EXR with layers beauty and depth, plus a PNG preview).
    Render {
        scene: PathBuf,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        #[command(flatten)]
        output: OutputArgs,
    },
    /// Describe a volume file: dims, type, spacing, value range, histogram.
    Info {
        file: PathBuf,
        /// For .raw files: dims as X,Y,Z.
        #[arg(long, value_delimiter = ',', num_args = 3)]
        raw_dims: Option<Vec<usize>>,
        /// For .raw files: uint8, int8, uint16, int16, uint32, int32, float, double.
        #[arg(long)]
        raw_type: Option<String>,
        /// For .raw files: spacing as X,Y,Z.
        #[arg(long, value_delimiter = ',', num_args = 3)]
        raw_spacing: Option<Vec<f32>>,
        /// For .vdb files: the grid to read.
        #[arg(long)]
        grid: Option<String>,
    },
    /// Render the built-in CT-like phantom into ./occlux-demo/ (no files, network or GPU needed).
    Demo {
        #[arg(short, long, default_value = "occlux-demo")]
        out: PathBuf,
        #[command(flatten)]
        output: OutputArgs,
    },
    /// Time unshaded and gradient DVR on CPU and GPU (median after warm-up); table and JSON.
    Bench(bench::BenchArgs),
}

#[derive(clap::Args)]
struct OutputArgs {
    /// Where to compute: auto picks a GPU adapter if one opens, else the CPU.
    #[arg(long, value_enum, default_value = "auto")]
    device: DeviceChoice,
    /// Write EXR channels as float32 rather than float16.
    #[arg(long)]
    float32: bool,
    /// Exposure multiplier for the PNG preview.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> occlux::Result<()> {
    let quiet = cli.quiet;
    match cli.command {
        Command::Render { scene, out, output } => {
            let stem = scene
                .file_stem()
                .map_or("render".into(), |s| s.to_string_lossy().into_owned());
            let parsed = Scene::from_file(&scene)?;
            render_scene(&parsed, &out, &stem, &output, quiet)
        }
        Command::Demo { out, output } => {
            let scene = Scene::parse(DEMO_SCENE, Path::new("."))?;
            render_scene(&scene, &out, "demo", &output, quiet)
        }
        Command::Info {
            file,
            raw_dims,
            raw_type,
            raw_spacing,
            grid,
        } => info(&file, raw_dims, raw_type, raw_spacing, grid),
        Command::Bench(args) => bench::run(&args, quiet),
    }
}

fn render_scene(
    scene: &Scene,
    out: &Path,
    stem: &str,
    output: &OutputArgs,
    quiet: bool,
) -> occlux::Result<()> {
    let options = OutputOptions {
        precision: if output.float32 {
            Precision::Float
        } else {
            Precision::Half
        },
        exposure: output.exposure,
    };
    options.validate()?;
    let (compute, notice) = Compute::resolve(output.device)?;
    if let (Some(notice), false) = (notice, quiet) {
        eprintln!("{notice}");
    }
    let say = |msg: String| {
        if !quiet {
            println!("{msg}");
        }
    };
    let started = Instant::now();
    let volume = scene.load_volume()?;
    let [nx, ny, nz] = volume.dims();
    say(format!(
        "volume {nx}x{ny}x{nz} loaded in {:.2} s; rendering on {}",
        started.elapsed().as_secs_f64(),
        compute.describe()
    ));
    let bar = progress_bar(quiet, scene.camera.height as u64, "rendering");
    let report = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let render_start = Instant::now();
    let img = pipeline::render(scene, &volume, &compute, &report)?;
    bar.finish_and_clear();
    say(format!(
        "rendered {}x{} in {:.2} s",
        img.width,
        img.height,
        render_start.elapsed().as_secs_f64()
    ));
    for path in pipeline::write_render(&img, scene, out, stem, &options)? {
        say(format!("wrote {}", path.display()));
    }
    Ok(())
}

fn progress_bar(quiet: bool, len: u64, label: &'static str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(label);
    bar
}

fn info(
    file: &Path,
    raw_dims: Option<Vec<usize>>,
    raw_type: Option<String>,
    raw_spacing: Option<Vec<f32>>,
    grid: Option<String>,
) -> occlux::Result<()> {
    let mut options = LoadOptions {
        grid,
        ..LoadOptions::default()
    };
    if let Some(dims) = raw_dims {
        let name =
            raw_type.ok_or_else(|| occlux::Error::param("--raw-type", "needed with --raw-dims"))?;
        let scalar = ScalarType::from_name(&name)
            .ok_or_else(|| occlux::Error::param("--raw-type", format!("unknown type '{name}'")))?;
        let spacing = raw_spacing.unwrap_or_else(|| vec![1.0; 3]);
        options.raw = Some(RawSpec {
            dims: [dims[0], dims[1], dims[2]],
            scalar,
            spacing: glam::Vec3::new(spacing[0], spacing[1], spacing[2]),
            origin: glam::Vec3::ZERO,
            big_endian: false,
            header_bytes: 0,
        });
    }
    let (vol, source) = volume::load_with_info(file, &options)?;
    let [nx, ny, nz] = vol.dims();
    let (lo, hi) = vol.value_range();
    let (blo, bhi) = vol.bounds();
    println!("file      {}", file.display());
    println!(
        "format    {} ({}{})",
        source.format,
        source.scalar,
        source
            .grid
            .map_or(String::new(), |g| format!(", grid '{g}'"))
    );
    println!(
        "dims      {nx} x {ny} x {nz} ({} voxels, {:.1} MiB as f32)",
        vol.values().len(),
        vol.values().len() as f64 * 4.0 / (1 << 20) as f64
    );
    println!("spacing   {}", vol.spacing());
    println!("origin    {}", vol.origin());
    println!("bounds    {blo} .. {bhi}");
    println!("values    {lo} .. {hi}");
    println!("histogram (16 bins over the value range, % of voxels)");
    let hist = vol.histogram(16);
    let total = vol.values().len() as f64;
    let width = (hi - lo) / 16.0;
    for (b, count) in hist.iter().enumerate() {
        let pct = *count as f64 / total * 100.0;
        println!(
            "  {:>12.4} .. {:<12.4} {:6.2}% {}",
            lo + b as f32 * width,
            lo + (b + 1) as f32 * width,
            pct,
            "#".repeat((pct / 2.0).ceil() as usize)
        );
    }
    Ok(())
}
