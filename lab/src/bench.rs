//! `occlux bench`: times every registered rendering method at its defaults (the ray caster's
//! unshaded and gradient DVR, AO-shaded DVR, IPSVI, half-angle slicing), directional occlusion
//! shading at n = 2, 5, 13 (theta 50 degrees, a slice per voxel), each lit by the scene's lights
//! of the kinds it renders (DOS: the ambient light; IPSVI and half-angle: the sun), on the CPU
//! and the GPU at several image sizes, on one volume file or on the built-in CT phantom at
//! several sides: the median of repeats after a warm-up render (shader compilation, first-touch
//! allocation), printed as a table with each method's time over gradient DVR's on the same
//! device, volume and size, and written as JSON with the GPU adapter and the machine's cores.

use crate::adapter::AdapterReport;
use occlux::camera::MAX_IMAGE_SIDE;
use occlux::error::{Error, Result};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::method::RenderMethod;
use occlux::progress::NoProgress;
use occlux::registry::{Method, METHODS};
use occlux::render::dos::{self, DosInput, DosParams};
use occlux::render::raycast::{cpu, gpu, RaycastInput, RaycastParams};
use occlux::render::MethodInput;
use occlux::scene::{Scene, SourceKind};
use occlux::volume::phantom;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The benchmark scene: engine.nrrd placed, classified and lit as in shared/bench/engine-cycles.
const BENCH_SCENE: &str = include_str!("../../examples/engine.toml");

/// The scene of `--volume-sizes`: the CT phantom under the soft-tissue preset, an ambient light
/// and a sun (the accuracy tools' "demo"); the phantom fills the same box at every side, so the
/// sides differ in voxels only.
const PHANTOM_SCENE: &str = include_str!("../../examples/demo.toml");

/// More timed repeats than this per case is a typo, not a benchmark.
pub const MAX_REPEATS: usize = 1000;

/// The longest `--case-seconds`: a day.
pub const MAX_CASE_SECONDS: f64 = 86_400.0;

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Volume to render (classified with the engine scene's transfer function).
    #[arg(
        long,
        default_value = "../shared/data/scivis/engine.nrrd",
        conflicts_with = "volume_sizes"
    )]
    pub volume: PathBuf,
    /// Instead of --volume, the built-in CT phantom at each of these sides (voxels a side,
    /// classified and lit as examples/demo.toml).
    #[arg(long, value_delimiter = ',')]
    pub volume_sizes: Option<Vec<usize>>,
    /// Square image sides to time.
    #[arg(long, value_delimiter = ',', default_value = "256,512")]
    pub sizes: Vec<u32>,
    /// Only these cases (unshaded, gradient, ao, dos-n2, dos-n5, dos-n13, ipsvi, half-angle);
    /// gradient DVR is timed whatever the list, as the ratios' baseline. Unset: every case.
    #[arg(long, value_delimiter = ',')]
    pub methods: Option<Vec<String>>,
    /// Timed repeats per case (after one warm-up render); the median is reported.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// End a case's timed repeats once they add up to this many seconds (after at least one),
    /// which bounds the whole run on slow devices; each row says how many it made. Unset: always
    /// --repeats.
    #[arg(long)]
    pub case_seconds: Option<f64>,
    /// Devices to time: cpu, gpu, both (an error without a GPU adapter), or auto (both when a
    /// GPU adapter opens, else the CPU).
    #[arg(long, default_value = "auto")]
    pub device: BenchDevices,
    /// Where to write the JSON results.
    #[arg(
        short,
        long,
        visible_alias = "json",
        default_value = "occlux-bench.json"
    )]
    pub out: PathBuf,
}

/// The devices a benchmark times (`--device`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchDevices {
    /// The CPU, and the GPU when an adapter opens.
    Auto,
    Cpu,
    Gpu,
    /// The CPU and the GPU, or an error when no adapter opens.
    Both,
}

impl std::str::FromStr for BenchDevices {
    type Err = Error;

    fn from_str(name: &str) -> Result<Self> {
        let choices = [
            ("auto", BenchDevices::Auto),
            ("cpu", BenchDevices::Cpu),
            ("gpu", BenchDevices::Gpu),
            ("both", BenchDevices::Both),
        ];
        occlux::names::parse_name("--device", name, &choices)
    }
}

/// One timed case.
#[derive(Serialize, Debug, Clone)]
pub struct BenchRow {
    /// The case: the registry's method name, with DOS's grid (`dos-n5`).
    pub method: String,
    /// Every parameter of the method, as in a scene's `[render]`.
    pub params: serde_json::Value,
    pub device: String,
    /// The image's side in pixels.
    pub size: u32,
    /// The volume's voxels along x, y and z.
    pub volume_dims: [usize; 3],
    #[serde(flatten)]
    pub timing: Timing,
    /// The timed runs the median is of (below `--repeats` where `--case-seconds` ended them).
    pub repeats: usize,
    /// Median time over gradient DVR's on the same device, volume and size.
    pub ratio_to_gradient: f64,
}

/// DOS grids timed.
const DOS_GRIDS: [u32; 3] = [2, 5, 13];

/// The cases `--methods` names (with gradient DVR, the baseline), or all of them; an unknown
/// name is an error that lists the cases.
fn chosen_cases(methods: Option<&[String]>) -> Result<Vec<(String, Method)>> {
    let all = cases()?;
    let Some(names) = methods else {
        return Ok(all);
    };
    if let Some(unknown) = names
        .iter()
        .find(|name| !all.iter().any(|(label, _)| label == *name))
    {
        let known: Vec<&str> = all.iter().map(|(label, _)| label.as_str()).collect();
        return Err(Error::param(
            "--methods",
            format!("unknown case '{unknown}'; known: {}", known.join(", ")),
        ));
    }
    Ok(all
        .into_iter()
        .filter(|(label, _)| label == "gradient" || names.contains(label))
        .collect())
}

/// The timed cases, in the registry's order: every registered method at its defaults, DOS at
/// each of [`DOS_GRIDS`] (named `dos-nN`).
fn cases() -> Result<Vec<(String, Method)>> {
    let mut cases = vec![];
    for spec in METHODS {
        if spec.name == DosParams::SPEC.name {
            for grid in DOS_GRIDS {
                let params = DosParams {
                    grid,
                    ..DosParams::default()
                };
                cases.push((format!("{}-n{grid}", spec.name), Method::Dos(params)));
            }
        } else {
            cases.push((spec.name.to_owned(), spec.at_setting("")?));
        }
    }
    Ok(cases)
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
    /// The volume file, or "phantom ct" for `--volume-sizes` (each row names its dims).
    volume: String,
    /// Timed repeats per case (fewer where `case_seconds` ended them: see each row), after this
    /// many untimed warm-up renders.
    repeats: usize,
    case_seconds: Option<f64>,
    warmup_runs: usize,
    /// The CPU twins' threads (rayon's pool) and the cores the machine offers.
    cpu_threads: usize,
    cpu_count: usize,
    /// The GPU adapter timed; null when only the CPU was.
    adapter: Option<AdapterReport>,
    rows: &'a [BenchRow],
}

/// Refuses what would make no benchmark, before any volume is read: no or zero repeats and
/// sizes, a case budget that is not a positive number of seconds, images the camera cannot
/// take, phantoms beyond what one can be.
fn check(args: &BenchArgs) -> Result<()> {
    if !(1..=MAX_REPEATS).contains(&args.repeats) {
        return Err(Error::param(
            "--repeats",
            format!("must be in 1..={MAX_REPEATS}, got {}", args.repeats),
        ));
    }
    if let Some(seconds) = args.case_seconds {
        if !(seconds > 0.0 && seconds <= MAX_CASE_SECONDS) {
            return Err(Error::param(
                "--case-seconds",
                format!("must be in (0, {MAX_CASE_SECONDS}], got {seconds}"),
            ));
        }
    }
    check_sides("--sizes", &args.sizes, 1..=MAX_IMAGE_SIDE)?;
    match &args.volume_sizes {
        Some(sides) => check_sides(
            "--volume-sizes",
            sides,
            phantom::MIN_SIDE..=phantom::MAX_SIDE,
        ),
        None => Ok(()),
    }
}

/// At least one side, each in `range`; the error names `option`.
fn check_sides<T>(option: &str, sides: &[T], range: std::ops::RangeInclusive<T>) -> Result<()>
where
    T: PartialOrd + std::fmt::Display,
{
    if sides.is_empty() {
        return Err(Error::param(option, "needs at least one side"));
    }
    match sides.iter().find(|side| !range.contains(side)) {
        Some(side) => Err(Error::param(
            option,
            format!(
                "each side must be in {}..={}, got {side}",
                range.start(),
                range.end()
            ),
        )),
        None => Ok(()),
    }
}

/// The scenes timed, one per volume: the file under the engine scene, or the CT phantom at each
/// of `--volume-sizes` under [`PHANTOM_SCENE`].
fn scenes(args: &BenchArgs) -> Result<Vec<Scene>> {
    let at = |text: &str, kind: SourceKind| -> Result<Scene> {
        let mut scene = Scene::parse(text, Path::new("."))?;
        scene.volume.kind = kind;
        Ok(scene)
    };
    match &args.volume_sizes {
        Some(sides) => sides
            .iter()
            .map(|&size| {
                let ct = SourceKind::Phantom {
                    name: "ct".to_owned(),
                    size,
                };
                at(PHANTOM_SCENE, ct)
            })
            .collect(),
        None => Ok(vec![at(
            BENCH_SCENE,
            SourceKind::File(args.volume.clone()),
        )?]),
    }
}

/// Runs the benchmark, prints the table unless `quiet`, and writes the JSON.
pub fn run(args: &BenchArgs, quiet: bool) -> Result<()> {
    check(args)?;
    let cases = chosen_cases(args.methods.as_deref())?;
    let scenes = scenes(args)?;
    let devices = devices(args.device, quiet)?;
    let mut rows = vec![];
    for scene in scenes {
        // One volume in memory at a time: the largest phantoms are gigabytes.
        let loaded = scene.load()?;
        let lut = loaded.scene.classification.bake(&loaded.volume);
        for compute in &devices {
            rows.extend(time_device(args, &cases, &loaded, &lut, compute, quiet)?);
        }
    }
    let adapter = devices.iter().find_map(|compute| match compute {
        Compute::Gpu(ctx) => Some(AdapterReport::of(ctx)),
        Compute::Cpu => None,
    });
    let report = BenchReport {
        volume: match &args.volume_sizes {
            Some(_) => "phantom ct".to_owned(),
            None => args.volume.display().to_string(),
        },
        repeats: args.repeats,
        case_seconds: args.case_seconds,
        warmup_runs: WARMUP_RUNS,
        cpu_threads: rayon::current_num_threads(),
        cpu_count: std::thread::available_parallelism().map_or(1, |n| n.get()),
        adapter,
        rows: &rows,
    };
    super::write_report(&args.out, &report, quiet)
}

/// Times every case at every image size on one device and volume.
fn time_device(
    args: &BenchArgs,
    cases: &[(String, Method)],
    loaded: &occlux::scene::Loaded,
    lut: &occlux::classify::Lut,
    compute: &Compute,
    quiet: bool,
) -> Result<Vec<BenchRow>> {
    let occlux::scene::Loaded { scene, volume, .. } = loaded;
    // The GPU keeps the volume resident across renders, as an interactive session would:
    // upload once (timed separately), then time the renders.
    let uploaded = match compute {
        Compute::Gpu(ctx) => {
            let t = Instant::now();
            let uploaded = gpu::GpuVolume::upload(ctx, volume, lut)?;
            if !quiet {
                println!(
                    "upload    {:>8.1} ms  {:?}  {}",
                    t.elapsed().as_secs_f64() * 1e3,
                    volume.dims(),
                    compute.describe()
                );
            }
            Some(uploaded)
        }
        Compute::Cpu => None,
    };
    let mut rows = vec![];
    for &size in &args.sizes {
        let mut camera = scene.camera;
        camera.width = size;
        camera.height = size;
        let mut times: Vec<(&str, &Method, Timing, usize)> = vec![];
        for (label, method) in cases {
            let lighting = method.spec().lights_of(&scene.lighting);
            let view = View {
                volume,
                classification: &scene.classification,
                lut,
                camera: &camera,
                lighting: &lighting,
                compute,
            };
            let budget_ms = args.case_seconds.map_or(f64::INFINITY, |s| s * 1e3);
            let (timing, runs, ()) = timed_within(args.repeats, budget_ms, || {
                render_resident(method, &view, uploaded.as_ref())
            })?;
            times.push((label, method, timing, runs));
        }
        let gradient = times
            .iter()
            .find(|(label, ..)| *label == "gradient")
            .map_or(f64::NAN, |(_, _, t, _)| t.median_ms);
        for (label, method, timing, runs) in times {
            let row = BenchRow {
                method: label.to_owned(),
                params: method.to_json(),
                device: compute.describe(),
                size,
                volume_dims: volume.dims(),
                timing,
                repeats: runs,
                ratio_to_gradient: timing.median_ms / gradient,
            };
            if !quiet {
                println!(
                    "{:<10} {:>5}^2  {:>4}^3  {}  {:>6.2}x gradient  {}",
                    row.method,
                    row.size,
                    row.volume_dims[0],
                    row.timing,
                    row.ratio_to_gradient,
                    row.device
                );
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The devices a benchmark times for `choice`: auto takes the CPU and, when an adapter
/// opens, the GPU; both needs the adapter to open.
pub(crate) fn devices(choice: BenchDevices, quiet: bool) -> Result<Vec<Compute>> {
    let mut devices = vec![];
    if choice != BenchDevices::Gpu {
        devices.push(Compute::Cpu);
    }
    if choice != BenchDevices::Cpu {
        match Compute::resolve(DeviceChoice::Gpu) {
            Ok((gpu, _)) => devices.push(gpu),
            Err(e) if choice == BenchDevices::Auto => {
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

/// Untimed runs of each case before its timed ones, as the reports state it: one, whose result
/// [`timed_keeping`] hands back.
const WARMUP_RUNS: usize = 1;

/// Times `repeats` runs of `run` (at least one) after one untimed warm-up run (shader
/// compilation and first-touch allocation).
pub(crate) fn timed<T>(repeats: usize, run: impl Fn() -> Result<T>) -> Result<Timing> {
    timed_keeping(repeats, run).map(|(timing, _)| timing)
}

/// As [`timed`], also returning the warm-up run's result (for callers that measure it too).
pub(crate) fn timed_keeping<T>(repeats: usize, run: impl Fn() -> Result<T>) -> Result<(Timing, T)> {
    timed_within(repeats, f64::INFINITY, run).map(|(timing, _, kept)| (timing, kept))
}

/// As [`timed_keeping`], ending the timed runs once they add up to `budget_ms` (after at least
/// one), so that a slow case on a slow device costs a run or two instead of `repeats`; also
/// returns how many timed runs were made.
fn timed_within<T>(
    repeats: usize,
    budget_ms: f64,
    run: impl Fn() -> Result<T>,
) -> Result<(Timing, usize, T)> {
    let kept = run()?;
    let mut times = vec![];
    while times.len() < repeats.max(1) && times.iter().sum::<f64>() < budget_ms {
        let t = Instant::now();
        run()?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let runs = times.len();
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
    Ok((timing, runs, kept))
}
