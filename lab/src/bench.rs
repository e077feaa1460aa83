//! `occlux bench`: times the baseline ray caster (unshaded and gradient DVR), directional
//! occlusion shading (n = 2, 5, 13; theta 50 degrees, a slice per voxel), IPSVI and half-angle
//! slicing at their defaults, each lit by the scene's lights of the kinds it renders (DOS: the
//! ambient light; IPSVI and half-angle: the sun), on the CPU and the GPU at several image sizes
//! on one volume: the median of repeats after a warm-up render, printed as a table with each
//! method's time over gradient DVR's on the same device and size, and written as JSON.

use occlux::error::{Error, Result};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::method::RenderMethod;
use occlux::progress::NoProgress;
use occlux::registry::Method;
use occlux::render::dos::{self, DosInput, DosParams};
use occlux::render::half_angle::HalfAngleParams;
use occlux::render::ipsvi::IpsviParams;
use occlux::render::raycast::{
    cpu, gpu, GradientParams, RaycastInput, RaycastParams, UnshadedParams,
};
use occlux::render::MethodInput;
use occlux::scene::{Scene, SourceKind};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The benchmark scene: engine.nrrd placed, classified and lit as in shared/bench/engine-cycles.
const BENCH_SCENE: &str = include_str!("../../examples/engine.toml");

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Volume to render (classified with the engine scene's transfer function).
    #[arg(long, default_value = "../shared/data/scivis/engine.nrrd")]
    pub volume: PathBuf,
    /// Square image sides to time.
    #[arg(long, value_delimiter = ',', default_value = "256,512")]
    pub sizes: Vec<u32>,
    /// Timed repeats per case (after one warm-up render).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Devices to time: cpu, gpu, or auto (both when a GPU adapter opens).
    #[arg(long, default_value = "auto")]
    pub device: DeviceChoice,
    /// Where to write the JSON results.
    #[arg(short, long, default_value = "occlux-bench.json")]
    pub out: PathBuf,
}

/// One timed case.
#[derive(Serialize, Debug, Clone)]
pub struct BenchRow {
    /// The case: the registry's method name, with DOS's grid (`dos-n5`).
    pub method: String,
    /// Every parameter of the method, as in a scene's `[render]`.
    pub params: serde_json::Value,
    pub device: String,
    pub size: u32,
    #[serde(flatten)]
    pub timing: Timing,
    pub repeats: usize,
    /// Median time over gradient DVR's on the same device and size.
    pub ratio_to_gradient: f64,
}

/// DOS grids timed.
const DOS_GRIDS: [u32; 3] = [2, 5, 13];

/// The timed cases: the ray caster's registered methods, DOS at each of [`DOS_GRIDS`], IPSVI and
/// half-angle slicing, at their registry defaults otherwise.
fn cases() -> Vec<(String, Method)> {
    let mut cases = vec![
        (
            UnshadedParams::SPEC.name.to_owned(),
            Method::Unshaded(UnshadedParams::default()),
        ),
        (
            GradientParams::SPEC.name.to_owned(),
            Method::Gradient(GradientParams::default()),
        ),
    ];
    for grid in DOS_GRIDS {
        let params = DosParams {
            grid,
            ..DosParams::default()
        };
        cases.push((
            format!("{}-n{grid}", DosParams::SPEC.name),
            Method::Dos(params),
        ));
    }
    cases.push((
        IpsviParams::SPEC.name.to_owned(),
        Method::Ipsvi(IpsviParams::default()),
    ));
    cases.push((
        HalfAngleParams::SPEC.name.to_owned(),
        Method::HalfAngle(HalfAngleParams::default()),
    ));
    cases
}

/// What every case renders: the volume, its table, the camera at the size timed, the lights.
struct View<'a> {
    volume: &'a occlux::volume::Volume,
    classification: &'a occlux::classify::Classification,
    lut: &'a occlux::classify::Lut,
    camera: &'a occlux::camera::Camera,
    lighting: &'a occlux::lights::Lighting,
    compute: &'a Compute,
}

/// Renders `method` once on the view's device; on the GPU the ray caster and DOS read the
/// volume `uploaded` once for all renders.
fn render_resident(method: &Method, view: &View, uploaded: Option<&gpu::GpuVolume>) -> Result<()> {
    let resident = match (view.compute, uploaded) {
        (Compute::Gpu(ctx), Some(volume)) => Some((ctx, volume)),
        _ => None,
    };
    let raycast = |params: &RaycastParams| {
        let input = RaycastInput {
            volume: view.volume,
            lut: view.lut,
            camera: view.camera,
            lighting: view.lighting,
            params,
            ao: None,
        };
        match resident {
            Some((ctx, volume)) => gpu::render_uploaded(ctx, volume, &input, &NoProgress),
            None => cpu::render(&input, &NoProgress),
        }
    };
    match method {
        Method::Unshaded(p) => raycast(&p.raycast()).map(drop),
        Method::Gradient(p) => raycast(&p.raycast()).map(drop),
        Method::Dos(params) => {
            let input = DosInput {
                volume: view.volume,
                lut: view.lut,
                camera: view.camera,
                lighting: view.lighting,
                params,
            };
            match resident {
                Some((ctx, volume)) => {
                    dos::gpu::render_uploaded(ctx, volume, &input, &NoProgress).map(drop)
                }
                None => dos::cpu::render(&input, &NoProgress).map(drop),
            }
        }
        // Methods without a resident GPU path render as a scene would, uploading each time.
        other => other
            .render(&MethodInput {
                volume: view.volume,
                classification: view.classification,
                lut: view.lut,
                camera: view.camera,
                lighting: view.lighting,
                compute: view.compute,
                progress: &NoProgress,
            })
            .map(drop),
    }
}

#[derive(Serialize)]
struct BenchReport<'a> {
    volume: String,
    dims: [usize; 3],
    cpu_threads: usize,
    rows: &'a [BenchRow],
}

/// Runs the benchmark, prints the table unless `quiet`, and writes the JSON.
pub fn run(args: &BenchArgs, quiet: bool) -> Result<()> {
    if args.repeats == 0 || args.sizes.is_empty() {
        return Err(Error::param(
            "--repeats/--sizes",
            "need at least one repeat and one size",
        ));
    }
    let mut scene = Scene::parse(BENCH_SCENE, Path::new("."))?;
    scene.volume.kind = SourceKind::File(args.volume.clone());
    let occlux::scene::Loaded { scene, volume, .. } = scene.load()?;
    let lut = scene.classification.bake(&volume);
    let devices = devices(args.device, quiet)?;
    let mut rows = vec![];
    for compute in &devices {
        // The GPU keeps the volume resident across renders, as an interactive session would:
        // upload once (timed separately), then time the renders.
        let uploaded = match compute {
            Compute::Gpu(ctx) => {
                let t = Instant::now();
                let uploaded = gpu::GpuVolume::upload(ctx, &volume, &lut)?;
                if !quiet {
                    println!(
                        "upload    {:>8.1} ms  {}",
                        t.elapsed().as_secs_f64() * 1e3,
                        compute.describe()
                    );
                }
                Some(uploaded)
            }
            Compute::Cpu => None,
        };
        for &size in &args.sizes {
            let mut camera = scene.camera;
            camera.width = size;
            camera.height = size;
            let mut times: Vec<(String, Method, Timing)> = vec![];
            for (label, method) in cases() {
                let lighting = method.spec().lights_of(&scene.lighting);
                let view = View {
                    volume: &volume,
                    classification: &scene.classification,
                    lut: &lut,
                    camera: &camera,
                    lighting: &lighting,
                    compute,
                };
                let timing = timed(args.repeats, || {
                    render_resident(&method, &view, uploaded.as_ref())
                })?;
                times.push((label, method, timing));
            }
            let gradient = times
                .iter()
                .find(|(label, ..)| label == "gradient")
                .map_or(f64::NAN, |(.., t)| t.median_ms);
            for (label, method, timing) in times {
                let row = BenchRow {
                    method: label,
                    params: method.to_json(),
                    device: compute.describe(),
                    size,
                    timing,
                    repeats: args.repeats,
                    ratio_to_gradient: timing.median_ms / gradient,
                };
                if !quiet {
                    println!(
                        "{:<10} {:>5}^2  {}  {:>6.2}x gradient  {}",
                        row.method, row.size, row.timing, row.ratio_to_gradient, row.device
                    );
                }
                rows.push(row);
            }
        }
    }
    let report = BenchReport {
        volume: args.volume.display().to_string(),
        dims: volume.dims(),
        cpu_threads: rayon::current_num_threads(),
        rows: &rows,
    };
    super::write_report(&args.out, &report, quiet)
}

/// The devices a benchmark times for `choice`: auto takes the CPU and, when an adapter
/// opens, the GPU.
pub(crate) fn devices(choice: DeviceChoice, quiet: bool) -> Result<Vec<Compute>> {
    let mut devices = vec![];
    if choice != DeviceChoice::Gpu {
        devices.push(Compute::Cpu);
    }
    if choice != DeviceChoice::Cpu {
        match Compute::resolve(DeviceChoice::Gpu) {
            Ok((gpu, _)) => devices.push(gpu),
            Err(e) if choice == DeviceChoice::Auto => {
                if !quiet {
                    eprintln!("no GPU timings: {e}");
                }
            }
            Err(e) => return Err(e),
        }
    }
    Ok(devices)
}

/// Times of repeated runs, in milliseconds.
#[derive(Serialize, Debug, Clone, Copy)]
pub struct Timing {
    pub median_ms: f64,
    pub min_ms: f64,
    pub max_ms: f64,
}

impl std::fmt::Display for Timing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:>10.1} ms (min {:.1}, max {:.1})",
            self.median_ms, self.min_ms, self.max_ms
        )
    }
}

/// Times `repeats` runs of `run` (at least one) after one untimed warm-up run (shader
/// compilation and first-touch allocation).
pub(crate) fn timed<T>(repeats: usize, run: impl Fn() -> Result<T>) -> Result<Timing> {
    timed_keeping(repeats, run).map(|(timing, _)| timing)
}

/// As [`timed`], also returning the warm-up run's result (for callers that measure it too).
pub(crate) fn timed_keeping<T>(repeats: usize, run: impl Fn() -> Result<T>) -> Result<(Timing, T)> {
    let kept = run()?;
    let mut times: Vec<f64> = (0..repeats.max(1))
        .map(|_| {
            let t = Instant::now();
            run().map(|_| t.elapsed().as_secs_f64() * 1e3)
        })
        .collect::<Result<_>>()?;
    times.sort_by(f64::total_cmp);
    let n = times.len();
    let median = if n % 2 == 1 {
        times[n / 2]
    } else {
        0.5 * (times[n / 2 - 1] + times[n / 2])
    };
    let timing = Timing {
        median_ms: median,
        min_ms: times[0],
        max_ms: times[n - 1],
    };
    Ok((timing, kept))
}
