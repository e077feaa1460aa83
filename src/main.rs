//! The `occlux` command line: thin; parses arguments and calls the library.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use occlux::ao::reference::{ao_reference, AoReferenceParams, AoVariant};
use occlux::ao::vao::{self, FieldKind, ScalarField, VaoParams};
use occlux::eval::{bench, dos_accuracy, vao_accuracy, vao_bench};
use occlux::export::exr::Precision;
use occlux::export::vdb::{write_vdb, Compression, VdbGrid, VdbOptions};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{self, OutputOptions, Rendered};
use occlux::render::reference::{Estimator, ReferenceInput, ReferenceParams};
use occlux::scene::Scene;
use occlux::volume::{self, LoadOptions, RawSpec, ScalarType, Volume};
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
    /// Render a scene file into OUT/ (EXR with layers beauty and depth, plus dos and occlusion
    /// for method = "dos", and a PNG preview).
    Render {
        scene: PathBuf,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        #[command(flatten)]
        output: OutputArgs,
    },
    /// Render a scene and write its exchange files into OUT/: the render (EXR + PNG), the grids
    /// (VDB: `density` = extinction per scene unit, `value` = the volume's values) and a USD stage
    /// pointing at them with the scene's camera and lights.
    Export {
        scene: PathBuf,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        #[command(flatten)]
        output: OutputArgs,
        /// VDB value compression on top of active-mask compression.
        #[arg(long, value_enum, default_value = "zip")]
        compression: VdbCompression,
        /// Store VDB values as half floats.
        #[arg(long)]
        half: bool,
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
    /// Time unshaded and gradient DVR and DOS (n = 2, 5, 13) on CPU and GPU (median after
    /// warm-up), as ratios to gradient DVR; table and JSON.
    Bench(bench::BenchArgs),
    /// Time VAO volumes at several radii on CPU and GPU (median after warm-up); table and JSON.
    BenchAo(vao_bench::VaoBenchArgs),
    /// Accuracy of the fast VAO estimates against the exact count and Monte Carlo, over
    /// sampled voxels of each scene's volume; Markdown table and JSON.
    AoAccuracy(vao_accuracy::AccuracyArgs),
    /// Directional occlusion shading against the cone-phase and ambient Monte Carlo references
    /// (relative RMSE over the volume's pixels) for scenes x theta x n; table and JSON.
    DosAccuracy(dos_accuracy::AccuracyArgs),
    /// Monte Carlo reference of the scene (CPU): OUT/STEM-ESTIMATOR.exr (float32 layers beauty
    /// = per-pixel mean, stderr = its standard error) and a PNG preview.
    Reference {
        scene: PathBuf,
        /// ambient: AO, isotropic; cone: the DOS cone phase function; single: directional and
        /// point lights with exact shadows; multiple: all lights, random walk.
        #[arg(long, value_enum)]
        estimator: EstimatorName,
        /// Samples per pixel.
        #[arg(long, default_value_t = 256)]
        spp: u32,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Scatterings after the first (multiple only; Cycles' volume bounces).
        #[arg(long, default_value_t = 8)]
        bounces: u32,
        /// Henyey-Greenstein asymmetry (single and multiple).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        g: f32,
        /// Half-angle of the cone in degrees (cone only).
        #[arg(long, default_value_t = 30.0)]
        aperture_deg: f32,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        /// Exposure multiplier for the PNG preview.
        #[arg(long, default_value_t = 1.0)]
        exposure: f32,
    },
    /// Monte Carlo reference AO volume of the scene's classified volume: OUT/STEM-ao-VARIANT.vdb
    /// with grids `ao` (openness, 1 = unoccluded) and `ao_stderr` (its standard error).
    AoReference {
        scene: PathBuf,
        #[arg(long, value_enum, default_value = "sphere")]
        variant: AoVariantName,
        /// Samples per voxel.
        #[arg(long, default_value_t = 64)]
        samples: u32,
        /// Reach of occluders, or the tangent sphere's radius, in voxels of the smallest spacing.
        #[arg(long)]
        radius: Option<f32>,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
    },
    /// AO volume of the scene's classified volume (VAO: Ruiz, Szirmay-Kalos et al.):
    /// OUT/STEM-ao.vdb (grid `ao`, openness 1 = unoccluded; `ao_variance` with --variance),
    /// OUT/STEM-ao.png (the middle z slice) and OUT/STEM-ao.json (parameters and timing).
    Ao {
        scene: PathBuf,
        /// cdf, gauss (Winitzki's erf), gauss-exact, penner, or exact (the voxel count: slow).
        #[arg(long, default_value = "cdf")]
        method: String,
        /// Tangent-sphere radius in voxels.
        #[arg(long, default_value_t = 10)]
        radius: u32,
        /// extinction (the classified sigma_t) or value (the raw values).
        #[arg(long, default_value = "extinction")]
        field: String,
        /// Also write the local variance (grid `ao_variance`).
        #[arg(long)]
        variance: bool,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        /// Where to compute: auto picks a hardware GPU adapter if one opens, else the CPU.
        #[arg(long, value_enum, default_value = "auto")]
        device: DeviceChoice,
        /// VDB value compression on top of active-mask compression.
        #[arg(long, value_enum, default_value = "zip")]
        compression: VdbCompression,
        /// Store VDB values as half floats.
        #[arg(long)]
        half: bool,
    },
    /// Compare the scene's Monte Carlo reference with Cycles (runs the Python harness
    /// `occlux.cycles` in the venv that .ci/run creates: .venv, or $OCCLUX_PYTHON).
    CheckCycles {
        scene: PathBuf,
        #[arg(long, value_enum, default_value = "single")]
        estimator: EstimatorName,
        /// Samples per pixel, for Occlux and for Cycles.
        #[arg(long, default_value_t = 256)]
        spp: u32,
        #[arg(short, long, default_value = "occlux-check")]
        out: PathBuf,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum AoVariantName {
    Sphere,
    Hemisphere,
    TangentSphere,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum EstimatorName {
    Ambient,
    Cone,
    Single,
    Multiple,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum VdbCompression {
    None,
    Zip,
}

impl From<VdbCompression> for Compression {
    fn from(c: VdbCompression) -> Self {
        match c {
            VdbCompression::None => Compression::None,
            VdbCompression::Zip => Compression::Zip,
        }
    }
}

#[derive(clap::Args)]
struct OutputArgs {
    /// Where to compute: auto picks a hardware GPU adapter if one opens, else the CPU.
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
            let parsed = Scene::from_file(&scene)?;
            let options = output.options()?;
            let (rendered, _) = render_scene(&parsed, &output, quiet)?;
            let written =
                pipeline::write_render(&rendered.image, &parsed, &out, &stem(&scene), &options)?;
            report_written(&written, quiet);
            Ok(())
        }
        Command::Export {
            scene,
            out,
            output,
            compression,
            half,
        } => {
            let parsed = Scene::from_file(&scene)?;
            let options = output.options()?;
            let vdb = VdbOptions {
                compression: compression.into(),
                half,
            };
            let (rendered, volume) = render_scene(&parsed, &output, quiet)?;
            let written = pipeline::export(
                &rendered,
                &parsed,
                &volume,
                &out,
                &stem(&scene),
                &options,
                &vdb,
            )?;
            report_written(&written, quiet);
            Ok(())
        }
        Command::Demo { out, output } => {
            let scene = Scene::parse(DEMO_SCENE, Path::new("."))?;
            let options = output.options()?;
            let (rendered, _) = render_scene(&scene, &output, quiet)?;
            let written = pipeline::write_render(&rendered.image, &scene, &out, "demo", &options)?;
            report_written(&written, quiet);
            Ok(())
        }
        Command::Info {
            file,
            raw_dims,
            raw_type,
            raw_spacing,
            grid,
        } => info(&file, raw_dims, raw_type, raw_spacing, grid),
        Command::Bench(args) => bench::run(&args, quiet),
        Command::BenchAo(args) => vao_bench::run(&args, quiet),
        Command::AoAccuracy(args) => vao_accuracy::run(&args, quiet),
        Command::DosAccuracy(args) => dos_accuracy::run(&args, quiet),
        Command::Reference {
            scene,
            estimator,
            spp,
            seed,
            bounces,
            g,
            aperture_deg,
            out,
            exposure,
        } => {
            let estimator = match estimator {
                EstimatorName::Ambient => Estimator::Ambient,
                EstimatorName::Cone => Estimator::Cone {
                    aperture: aperture_deg.to_radians(),
                },
                EstimatorName::Single => Estimator::Single,
                EstimatorName::Multiple => Estimator::Multiple { bounces },
            };
            let params = ReferenceParams {
                estimator,
                spp,
                seed,
                g,
            };
            reference(&scene, &params, &out, exposure, quiet)
        }
        Command::AoReference {
            scene,
            variant,
            samples,
            radius,
            seed,
            out,
        } => ao_reference_volume(&scene, variant, samples, radius, seed, &out, quiet),
        Command::Ao {
            scene,
            method,
            radius,
            field,
            variance,
            out,
            device,
            compression,
            half,
        } => {
            let params = VaoParams {
                radius,
                estimator: method.parse()?,
                variance,
            };
            let vdb = VdbOptions {
                compression: compression.into(),
                half,
            };
            let field = field.parse()?;
            ao_volume_command(&scene, &params, field, device, &out, &vdb, quiet)
        }
        Command::CheckCycles {
            scene,
            estimator,
            spp,
            out,
        } => occlux::eval::cycles::run(&scene, estimator.as_str(), spp, &out),
    }
}

/// Computes a VAO volume with progress and timing, and writes it.
fn ao_volume_command(
    scene: &Path,
    params: &VaoParams,
    field: FieldKind,
    device: DeviceChoice,
    out: &Path,
    vdb: &VdbOptions,
    quiet: bool,
) -> occlux::Result<()> {
    params.validate()?;
    let parsed = Scene::from_file(scene)?;
    let (compute, notice) = Compute::resolve(device)?;
    if let (Some(notice), false) = (notice, quiet) {
        eprintln!("{notice}");
    }
    let volume = parsed.load_volume()?;
    let started = Instant::now();
    let scalar = ScalarField::new(&volume, &parsed.classification, field)?;
    let field_ms = started.elapsed().as_secs_f64() * 1e3;
    // The exact count is a CPU reference whatever the device.
    let on = if params.estimator == vao::Estimator::Exact {
        Compute::Cpu.describe()
    } else {
        compute.describe()
    };
    let bar = progress_bar(quiet, 1, "ao volume");
    let started = Instant::now();
    let ao = vao::ao_volume(&compute, &scalar, params, &bar)?;
    let ao_ms = started.elapsed().as_secs_f64() * 1e3;
    bar.0.finish_and_clear();
    if !quiet {
        println!(
            "{} AO volume, radius {} voxels: field in {field_ms:.1} ms, AO in {ao_ms:.1} ms on {on}",
            params.estimator.name(),
            params.radius
        );
    }
    let record = serde_json::json!({
        "scene": scene.display().to_string(),
        "method": params.estimator.name(),
        "radius_voxels": params.radius,
        "field": match field { FieldKind::Extinction => "extinction", FieldKind::Value => "value" },
        "dims": volume.dims(),
        "device": on,
        "field_ms": field_ms,
        "ao_ms": ao_ms,
    });
    let written = pipeline::write_ao(&ao, &record, out, &stem(scene), vdb)?;
    report_written(&written, quiet);
    Ok(())
}

/// Estimates a reference AO volume and writes it as OUT/STEM-ao-VARIANT.vdb.
fn ao_reference_volume(
    scene: &Path,
    variant: AoVariantName,
    samples: u32,
    radius: Option<f32>,
    seed: u64,
    out: &Path,
    quiet: bool,
) -> occlux::Result<()> {
    let (variant, name) = match variant {
        AoVariantName::Sphere => (AoVariant::Sphere, "sphere"),
        AoVariantName::Hemisphere => (AoVariant::Hemisphere, "hemisphere"),
        AoVariantName::TangentSphere => (AoVariant::TangentSphere, "tangent-sphere"),
    };
    let parsed = Scene::from_file(scene)?;
    let volume = parsed.load_volume()?;
    let params = AoReferenceParams {
        variant,
        samples,
        seed,
        radius: radius.map(|r| r * volume.spacing().min_element()),
    };
    let lut = parsed.classification.bake(&volume);
    let bar = progress_bar(quiet, volume.dims()[2] as u64, "sampling");
    let started = Instant::now();
    let ao = ao_reference(&volume, &lut, &params, &bar)?;
    bar.0.finish_and_clear();
    if !quiet {
        println!(
            "{name} AO reference, {samples} samples per voxel, in {:.2} s",
            started.elapsed().as_secs_f64()
        );
    }
    std::fs::create_dir_all(out).map_err(|e| occlux::Error::io(out, e))?;
    let path = out.join(format!("{}-ao-{name}.vdb", stem(scene)));
    let mut grids = vec![VdbGrid::from_volume("ao", &ao.openness)];
    // A noiseless estimate (e.g. every tangent-sphere sample tied) has no error grid.
    if ao.stderr.values().iter().any(|&e| e > 0.0) {
        grids.push(VdbGrid::from_volume("ao_stderr", &ao.stderr));
    }
    write_vdb(&path, &grids, &VdbOptions::default())?;
    report_written(&[path], quiet);
    Ok(())
}

/// Renders a Monte Carlo reference with progress, and writes it.
fn reference(
    scene_path: &Path,
    params: &ReferenceParams,
    out: &Path,
    exposure: f32,
    quiet: bool,
) -> occlux::Result<()> {
    params.validate()?;
    let scene = Scene::from_file(scene_path)?;
    let volume = scene.load_volume()?;
    let lut = scene.classification.bake(&volume);
    let bar = progress_bar(quiet, scene.camera.height as u64, "sampling");
    let started = Instant::now();
    let input = ReferenceInput {
        volume: &volume,
        lut: &lut,
        camera: &scene.camera,
        lighting: &scene.lighting,
        params,
    };
    let image = occlux::render::reference::render(&input, &bar)?;
    bar.0.finish_and_clear();
    if !quiet {
        println!(
            "{} reference, {} spp, {}x{} in {:.2} s",
            params.estimator.name(),
            params.spp,
            image.width,
            image.height,
            started.elapsed().as_secs_f64()
        );
    }
    let stem = format!("{}-{}", stem(scene_path), params.estimator.name());
    let written = pipeline::write_reference(&image, &scene, params, out, &stem, exposure)?;
    report_written(&written, quiet);
    Ok(())
}

/// Output files are named after the scene file.
fn stem(scene: &Path) -> String {
    scene
        .file_stem()
        .map_or("render".into(), |s| s.to_string_lossy().into_owned())
}

fn report_written(paths: &[PathBuf], quiet: bool) {
    if !quiet {
        for path in paths {
            println!("wrote {}", path.display());
        }
    }
}

impl OutputArgs {
    fn options(&self) -> occlux::Result<OutputOptions> {
        let options = OutputOptions {
            precision: if self.float32 {
                Precision::Float
            } else {
                Precision::Half
            },
            exposure: self.exposure,
        };
        options.validate()?;
        Ok(options)
    }
}

/// Loads the scene's volume and renders it on the chosen device, with progress.
fn render_scene(
    scene: &Scene,
    output: &OutputArgs,
    quiet: bool,
) -> occlux::Result<(Rendered, Volume)> {
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
    let render_start = Instant::now();
    let rendered = pipeline::render(scene, &volume, &compute, &bar)?;
    let img = &rendered.image;
    bar.0.finish_and_clear();
    say(format!(
        "rendered {}x{} in {:.2} s",
        img.width,
        img.height,
        render_start.elapsed().as_secs_f64()
    ));
    Ok((rendered, volume))
}

/// An indicatif bar (hidden when quiet) that the library's work reports to.
struct Bar(ProgressBar);

impl occlux::progress::Progress for Bar {
    fn update(&self, done: u64, total: u64) {
        self.0.set_length(total);
        self.0.set_position(done);
    }
}

fn progress_bar(quiet: bool, len: u64, label: &'static str) -> Bar {
    if quiet {
        return Bar(ProgressBar::hidden());
    }
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(label);
    Bar(bar)
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

impl EstimatorName {
    fn as_str(self) -> &'static str {
        match self {
            EstimatorName::Ambient => "ambient",
            EstimatorName::Cone => "cone",
            EstimatorName::Single => "single",
            EstimatorName::Multiple => "multiple",
        }
    }
}
