//! The `occlux` command line: parses arguments and runs each command, one module per family
//! (the measuring commands' bodies are the lab's).

mod ao;
mod bake;
mod plan;
mod reference;
mod render;
mod series;

use crate::ao::{ao_reference_volume, ao_volume};
use crate::render::OutputArgs;
use clap::{Parser, Subcommand};
use occlux::ao::reference::AoVariant;
use occlux::ao::sweep::geometric::GeometricParams;
use occlux::ao::AoVolumeParams;
use occlux::export::vdb::{Compression, VdbOptions};
use occlux::gpu::DeviceChoice;
use occlux::pipeline::{self, Outputs};
use occlux::render::reference::{Estimator, ReferenceParams};
use occlux::scene::Scene;
use occlux::series::SeriesOptions;
use occlux::volume::{self, LoadOptions, RawSpec, ScalarType};
use occlux_lab::{
    adapter, bench, chart, dos_accuracy, gallery, ipsvi_accuracy, plan_check, sweep_accuracy,
    sweep_bench, vao_accuracy, vao_bench,
};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The built-in demo scene: the CT-like phantom, bone and soft tissue, lit by a sun with IPSVI
/// (shadows and multiple scattering).
const DEMO_SCENE: &str = include_str!("../../examples/demo-lit.toml");

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
    /// Render a scene file into OUT/ (EXR with layers beauty and depth, plus occlusion for
    /// method = "dos" or shadow for "ipsvi" and "half-angle": channels V, the factor
    /// premultiplied by coverage, and A, the coverage; and a PNG preview).
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
        #[arg(long, default_value = "zip")]
        compression: VdbCompression,
        /// Store VDB values as half floats.
        #[arg(long)]
        half: bool,
    },
    /// Render and export a series of volumes (time steps, a batch) with one scene, lit and
    /// classified the same in every frame: OUT/NAME_0001.vdb, OUT/NAME_0001.exr (+ .png), ...,
    /// one USD stage OUT/NAME.usda with the grids as time samples, and the manifest
    /// OUT/NAME.series.json. Rerun to resume: complete frames are skipped.
    Series {
        scene: PathBuf,
        /// The frames: a shell pattern ('data/step_*.nrrd', quoted), a folder, or files;
        /// default: the scene's volume.frames.
        #[arg(long, num_args = 1..)]
        frames: Option<Vec<String>>,
        #[arg(short, long, default_value = "occlux-series")]
        out: PathBuf,
        /// The files' stem (default: the scene file's).
        #[arg(long)]
        name: Option<String>,
        /// Write the renders (EXR + PNG per frame); without --render or --export, both.
        #[arg(long)]
        render: bool,
        /// Write the grids (VDB per frame) and the USD stage.
        #[arg(long)]
        export: bool,
        /// Also an AO volume per frame into the VDB's `ao` grid, by this method (as `occlux ao
        /// --method`: sweep-physical, the visibility, is exact for ambient light).
        #[arg(long)]
        ao: Option<String>,
        /// Tangent-sphere radius in voxels (--ao with a VAO method).
        #[arg(long, default_value_t = 10)]
        ao_radius: u32,
        #[command(flatten)]
        output: OutputArgs,
        /// VDB value compression on top of active-mask compression.
        #[arg(long, default_value = "zip")]
        compression: VdbCompression,
        /// Store VDB values as half floats.
        #[arg(long)]
        half: bool,
    },
    /// Describe a volume file: dims, type, spacing, value range, histogram.
    Info {
        file: PathBuf,
        /// For .raw files: dims as X,Y,Z.
        #[arg(long, value_delimiter = ',')]
        raw_dims: Option<Vec<usize>>,
        /// For .raw files: uint8, int8, uint16, int16, uint32, int32, float, double.
        #[arg(long)]
        raw_type: Option<String>,
        /// For .raw files: spacing as X,Y,Z.
        #[arg(long, value_delimiter = ',')]
        raw_spacing: Option<Vec<f32>>,
        /// For .vdb files: the grid to read.
        #[arg(long)]
        grid: Option<String>,
        /// Also print a `[classification]` a scene can take: the CT presets in Hounsfield
        /// units when the file says so, else a ramp on the robust window's raw values.
        #[arg(long)]
        suggest: bool,
    },
    /// Render the built-in CT-like phantom into ./occlux-demo/ (no files, network or GPU needed).
    Demo {
        #[arg(short, long, default_value = "occlux-demo")]
        out: PathBuf,
        #[command(flatten)]
        output: OutputArgs,
    },
    /// Time every rendering method (DOS at n = 2, 5, 13) on CPU and GPU (median after
    /// warm-up) on a volume file or the CT phantom at several sides, as ratios to gradient DVR;
    /// table and JSON with the GPU adapter.
    Bench(bench::BenchArgs),
    /// Open the GPU adapter Occlux uses and describe it (name, driver, backend, device type);
    /// --hardware refuses a software rasterizer (lavapipe, WARP).
    Adapter(adapter::AdapterArgs),
    /// Time VAO volumes at several radii on CPU and GPU (median after warm-up); table and JSON.
    BenchAo(vao_bench::VaoBenchArgs),
    /// Accuracy of the fast VAO estimates against the exact count and Monte Carlo, over
    /// sampled voxels of each scene's volume; Markdown table and JSON.
    AoAccuracy(vao_accuracy::AccuracyArgs),
    /// Directional occlusion shading against the cone-phase and ambient Monte Carlo references
    /// (relative RMSE over the volume's pixels) for scenes x theta x n; table and JSON.
    DosAccuracy(dos_accuracy::AccuracyArgs),
    /// AO-shaded DVR with the occlusion sweep's visibility under ambient light, against the
    /// ambient Monte Carlo reference or a Cycles render (relative RMSE over the volume's
    /// pixels), with the time of each stage; table and JSON.
    SweepAccuracy(sweep_accuracy::SweepAccuracyArgs),
    /// Image plane sweep volume illumination against the single-scattering Monte Carlo
    /// reference or a Cycles render (relative RMSE over the volume's pixels), over its line
    /// width, cache size, piecewise integration and early ray termination, with its time
    /// beside unshaded DVR's (CPU); table and JSON.
    IpsviAccuracy(ipsvi_accuracy::IpsviAccuracyArgs),
    /// Speed against accuracy: every registered method at its chart settings, Occlux's Monte
    /// Carlo and Cycles at increasing samples per pixel, per scene and lighting, against the
    /// path-traced truth; the Pareto front and the speed-up over Cycles at equal error; CSV,
    /// JSON, SVG and PNG in OUT/.
    Chart(chart::ChartArgs),
    /// Pick the cheapest configuration (every registered method at its chart settings, and
    /// Occlux's Monte Carlo) whose relative RMSE against the scene's path-traced truth stays
    /// within --error, from a pilot render at a small size; says what it chose and why, and
    /// the `[render]` to paste (a scene's `method = "auto"` does this when it renders).
    Plan(plan::PlanArgs),
    /// Validate the planner against exhaustive search: per scene and budget, whether its
    /// choice stays within the budget at the full size, and its time over the fastest
    /// configuration that does; Markdown table and JSON.
    PlanCheck(plan_check::PlanCheckArgs),
    /// One volume, every method at each of its chart settings side by side with Monte Carlo
    /// and the path-traced truth, each with its time and error under it: OUT/gallery.png and
    /// OUT/gallery.json.
    Gallery(gallery::GalleryArgs),
    /// Occlusion sweeping's geometric mode at the paper's sizes on the box-and-sphere phantom
    /// (CPU): the signed distance alone, with the combined occlusion, with the eight octants;
    /// medians, the occlusion's cost over the signed distance's; table and JSON.
    BenchSweep(sweep_bench::SweepBenchArgs),
    /// Monte Carlo reference of the scene (CPU): OUT/STEM-ESTIMATOR.exr (float32 layers beauty
    /// = per-pixel mean, stderr = its standard error) and a PNG preview.
    Reference {
        scene: PathBuf,
        /// ambient: AO, isotropic; cone: the DOS cone phase function; single: directional and
        /// point lights with exact shadows; multiple: all lights, random walk.
        #[arg(long)]
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
        #[arg(long, default_value = "sphere")]
        variant: AoVariant,
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
    /// AO volume of the scene's classified volume (VAO: Ruiz, Szirmay-Kalos et al.; or occlusion
    /// sweeping): OUT/STEM-ao.vdb (grid `ao`, openness 1 = unoccluded; `ao_variance` with
    /// --variance; `sdf`, a level set, and `ao_oct0`..`ao_oct7` with --octants, by sweep),
    /// OUT/STEM-ao.png (the middle z slice) and OUT/STEM-ao.json (parameters and timing).
    Ao {
        scene: PathBuf,
        /// VAO: cdf, gauss (Winitzki's erf), gauss-exact, penner, or exact (the voxel count:
        /// slow); sweep (occlusion sweeping: the AO of an iso-surface from its signed
        /// distance); sweep-physical (the visibility, mean transmittance over all directions, by
        /// a lattice walk); ordinates (the visibility along straight paths, by discrete
        /// ordinates, the default).
        #[arg(long, default_value = "ordinates")]
        method: String,
        /// ordinates: the directions of the discrete ordinates.
        #[arg(long, default_value_t = occlux::transport::DEFAULT_DIRECTIONS)]
        directions: u32,
        /// sweep: the raw value's iso-surface (default: where a voxel of the classified
        /// extinction is half opaque).
        #[arg(long, allow_negative_numbers = true)]
        iso: Option<f32>,
        /// sweep: AO^(1/gamma) as a post-process.
        #[arg(long, default_value_t = 2.0)]
        gamma: f32,
        /// sweep: the intensity of the light from each octant, eight values in [0, 1] in the
        /// order of the ao_oct grids (bit 0: -x, bit 1: -y, bit 2: -z); e.g. 1,1,1,1,0,0,0,0
        /// lights from above only (the paper's cloudy day).
        #[arg(long, value_delimiter = ',')]
        octant_intensities: Option<Vec<f32>>,
        /// sweep: the surface's opacity alpha in (0, 1]; below 1 light passes through it.
        #[arg(long, default_value_t = 1.0)]
        alpha: f32,
        /// sweep: the combined scalar AO (the mean of the octants) instead of the octants
        /// weighted by the normal's geometry terms.
        #[arg(long)]
        combined: bool,
        /// sweep: also write the eight octant visibilities (grids ao_oct0..ao_oct7).
        #[arg(long)]
        octants: bool,
        /// Tangent-sphere radius in voxels (VAO).
        #[arg(long, default_value_t = 10)]
        radius: u32,
        /// extinction (the classified sigma_t) or value (the raw values).
        #[arg(long, default_value = "extinction")]
        field: String,
        /// Also write the local variance (grid `ao_variance`).
        #[arg(long)]
        variance: bool,
        /// What the `ao` grid means: unoccluded (1 in empty space and on an open flat surface,
        /// as Blender shades) or raw (VAO only: the paper's openness, 1/2 in empty space and on
        /// a flat interface).
        #[arg(long, default_value = "unoccluded")]
        convention: String,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        /// Where to compute: auto picks a hardware GPU adapter if one opens, else the CPU.
        #[arg(long, default_value = "auto")]
        device: DeviceChoice,
        /// VDB value compression on top of active-mask compression.
        #[arg(long, default_value = "zip")]
        compression: VdbCompression,
        /// Store VDB values as half floats.
        #[arg(long)]
        half: bool,
    },
    /// Bake the scene's light into grids any renderer can shade with, without tracing shadows:
    /// OUT/STEM-bake.vdb holds `density` and `value` (as `export` writes them), `ao` (the
    /// ambient visibility), per sun or lamp i `light{i}` (its irradiance reaching each voxel per
    /// unit strength) and `light{i}_multiple_r/_g/_b` (its multiply scattered light per unit
    /// strength); OUT/STEM-bake.json says which grid is which light (docs/blender.md).
    Bake {
        scene: PathBuf,
        #[arg(short, long, default_value = "occlux-out")]
        out: PathBuf,
        /// Directions of the ambient visibility (discrete ordinates).
        #[arg(long, default_value_t = occlux::transport::DEFAULT_DIRECTIONS)]
        directions: u32,
        /// Leave out the multiply scattered light (the light{i}_multiple grids).
        #[arg(long)]
        no_multiple: bool,
        /// Henyey-Greenstein asymmetry of the multiple scattering, in (-1, 1).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        g: f32,
        /// Where to compute: auto picks a hardware GPU adapter if one opens, else the CPU.
        #[arg(long, default_value = "auto")]
        device: DeviceChoice,
        /// VDB value compression on top of active-mask compression.
        #[arg(long, default_value = "zip")]
        compression: VdbCompression,
        /// Store VDB values as half floats.
        #[arg(long)]
        half: bool,
    },
    /// The rendering methods a scene can name, with their parameters (defaults, ranges), the
    /// lights they take and the layers and grids they write.
    Methods {
        /// Print the registry as JSON (what the Python package and the add-on read).
        #[arg(long)]
        json: bool,
    },
    /// Compare the scene's Monte Carlo reference with Cycles (runs the Python harness
    /// `occlux_lab.cycles` in the venv that .ci/run creates: .venv, or $OCCLUX_PYTHON).
    CheckCycles {
        scene: PathBuf,
        /// ambient, single or multiple (Cycles has no counterpart of the cone phase function).
        #[arg(long, default_value = "single")]
        estimator: EstimatorName,
        /// Samples per pixel, for Occlux and for Cycles.
        #[arg(long, default_value_t = 256)]
        spp: u32,
        /// Cycles renders (spp / seeds samples each); their spread is Cycles' standard error.
        #[arg(long, default_value_t = occlux_lab::cycles::DEFAULT_SEEDS)]
        seeds: u32,
        /// Volume bounces (multiple only).
        #[arg(long, default_value_t = 8)]
        bounces: u32,
        /// Henyey-Greenstein asymmetry (single and multiple).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        g: f32,
        #[arg(short, long, default_value = "occlux-check")]
        out: PathBuf,
    },
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

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so printing into a pipe whose reader has gone (`occlux info F |
    // head -1`) fails, and println! panics on that. Restore the default every Unix filter has:
    // the process ends quietly when its reader does. Outputs are written atomically and a
    // staging folder left by an ended run is removed by the next, so nothing half-written stays.
    #[cfg(unix)]
    // SAFETY: called first, before any thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Interrupted (Ctrl-C, SIGTERM, SIGHUP), the outputs being written are removed: their
    // staging folders go, and what the folder held before stays. 130 is the shell's status for
    // a run ended by Ctrl-C.
    if let Err(e) = ctrlc::set_handler(|| {
        occlux::export::atomic::remove_live_staging();
        eprintln!("interrupted: partial outputs removed");
        std::process::exit(130);
    }) {
        eprintln!("warning: interrupting will leave partial outputs behind ({e})");
    }
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
        Command::Render { scene, out, output } => output.run(
            &Scene::from_file(&scene)?,
            &pipeline::stem(&scene),
            &out,
            &Outputs::Render,
            quiet,
        ),
        Command::Export {
            scene,
            out,
            output,
            compression,
            half,
        } => {
            let vdb = VdbOptions {
                compression: compression.into(),
                half,
            };
            output.run(
                &Scene::from_file(&scene)?,
                &pipeline::stem(&scene),
                &out,
                &Outputs::Export(vdb),
                quiet,
            )
        }
        Command::Series {
            scene,
            frames,
            out,
            name,
            render,
            export,
            ao,
            ao_radius,
            output,
            compression,
            half,
        } => {
            let both = !render && !export;
            let options = SeriesOptions {
                render: render || both,
                export: export || both,
                ao,
                ao_radius,
                zip: matches!(compression, VdbCompression::Zip),
                half,
                float32: output.float32,
                exposure: output.exposure,
            };
            let name = name.unwrap_or_else(|| pipeline::stem(&scene));
            series::run(&scene, frames, &out, &name, &options, output.device, quiet)
        }
        Command::Demo { out, output } => output.run(
            &Scene::parse(DEMO_SCENE, Path::new("."))?,
            "demo",
            &out,
            &Outputs::Render,
            quiet,
        ),
        Command::Info {
            file,
            raw_dims,
            raw_type,
            raw_spacing,
            grid,
            suggest,
        } => {
            let options = load_options(raw_dims, raw_type, raw_spacing, grid)?;
            print!("{}", volume::info::describe(&file, &options, suggest)?);
            Ok(())
        }
        Command::Bench(args) => bench::run(&args, quiet),
        Command::Adapter(args) => adapter::run(&args, quiet),
        Command::BenchAo(args) => vao_bench::run(&args, quiet),
        Command::AoAccuracy(args) => vao_accuracy::run(&args, quiet),
        Command::DosAccuracy(args) => dos_accuracy::run(&args, quiet),
        Command::SweepAccuracy(args) => sweep_accuracy::run(&args, quiet),
        Command::IpsviAccuracy(args) => ipsvi_accuracy::run(&args, quiet),
        Command::Chart(args) => chart::run(&args, quiet),
        Command::Plan(args) => plan::run(&args, quiet),
        Command::PlanCheck(args) => plan_check::run(&args, quiet),
        Command::Gallery(args) => gallery::run(&args, quiet),
        Command::BenchSweep(args) => sweep_bench::run(&args, quiet),
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
            reference::run(&scene, &params, &out, exposure, quiet)
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
            directions,
            iso,
            gamma,
            octant_intensities,
            alpha,
            combined,
            octants,
            radius,
            field,
            variance,
            convention,
            out,
            device,
            compression,
            half,
        } => {
            let intensities = match octant_intensities {
                Some(list) => GeometricParams::intensities_from(&list)?,
                None => [1.0; 8],
            };
            let params = AoVolumeParams {
                method: method.parse()?,
                radius,
                field: field.parse()?,
                variance,
                iso,
                geometric: GeometricParams {
                    gamma,
                    intensities,
                    alpha,
                    normal_weighted: !combined,
                },
                octants,
                convention: convention.parse()?,
                directions,
            };
            let vdb = VdbOptions {
                compression: compression.into(),
                half,
            };
            ao_volume(&scene, &params, device, &out, &vdb, quiet)
        }
        Command::Bake {
            scene,
            out,
            directions,
            no_multiple,
            g,
            device,
            compression,
            half,
        } => {
            let params = occlux::bake::BakeParams {
                directions,
                multiple: !no_multiple,
                g,
            };
            let vdb = VdbOptions {
                compression: compression.into(),
                half,
            };
            crate::bake::bake_scene(&scene, &params, device, &out, &vdb, quiet)
        }
        Command::Methods { json } => {
            methods(json);
            Ok(())
        }
        Command::CheckCycles {
            scene,
            estimator,
            spp,
            seeds,
            bounces,
            g,
            out,
        } => occlux_lab::cycles::run(&occlux_lab::cycles::CheckOptions {
            scene: &scene,
            estimator: estimator.as_str(),
            spp,
            seeds,
            bounces,
            g,
            out: &out,
        }),
    }
}

/// Prints the method registry: JSON, or a summary per method.
fn methods(json: bool) {
    if json {
        println!("{:#}", occlux::registry::describe());
    } else {
        print!("{}", occlux::registry::summary());
    }
}

/// How `occlux info` reads the file: raw files need their layout.
fn load_options(
    raw_dims: Option<Vec<usize>>,
    raw_type: Option<String>,
    raw_spacing: Option<Vec<f32>>,
    grid: Option<String>,
) -> occlux::Result<LoadOptions> {
    let mut options = LoadOptions {
        grid,
        ..LoadOptions::default()
    };
    if let Some(dims) = raw_dims {
        let name =
            raw_type.ok_or_else(|| occlux::Error::param("--raw-type", "needed with --raw-dims"))?;
        let scalar = ScalarType::from_name(&name)
            .ok_or_else(|| occlux::Error::param("--raw-type", format!("unknown type '{name}'")))?;
        let spacing = match raw_spacing {
            Some(spacing) => xyz("--raw-spacing", &spacing)?,
            None => [1.0; 3],
        };
        options.raw = Some(RawSpec {
            dims: xyz("--raw-dims", &dims)?,
            scalar,
            spacing: glam::Vec3::from_array(spacing),
            origin: glam::Vec3::ZERO,
            big_endian: false,
            header_bytes: 0,
        });
    }
    Ok(options)
}

/// The three values of an X,Y,Z option (clap splits them at the commas).
fn xyz<T: Copy>(flag: &str, values: &[T]) -> occlux::Result<[T; 3]> {
    <[T; 3]>::try_from(values).map_err(|_| {
        occlux::Error::param(
            flag,
            format!("takes three values as X,Y,Z, got {}", values.len()),
        )
    })
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
