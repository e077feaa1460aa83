//! `occlux sweep-accuracy`: AO-shaded DVR with an occlusion sweep's AO volume (the physical mode's
//! visibility by default, or the geometric mode's AO with `--method sweep`) under the ambient light
//! of each scene (radiance 1, background 1, no direct light, isotropic phase), against the
//! path-traced truth of the same scene: Occlux's ambient Monte Carlo reference, or a Cycles render
//! given with `--cycles` (for the engine scene of ../shared/bench/engine-cycles). Error over the
//! volume's pixels as docs/architecture.md#error-measure defines it, and the time of each stage;
//! table and JSON.

use glam::Vec3;
use occlux::ao::{self, AoMethod, AoVolumeParams};
use occlux::error::{Error, Result};
use occlux::export::exr::read_exr;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::lights::Light;
use occlux::metric::design_error;
use occlux::progress::NoProgress;
use occlux::render::raycast::{self, AoFactors, RaycastInput, RaycastParams, Shading};
use occlux::render::reference::Estimator;
use occlux::scene::Scene;
use serde::Serialize;
use std::borrow::Cow;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct SweepAccuracyArgs {
    /// Scene files (volume, classification and camera are used; the lights are replaced).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "examples/engine.toml,examples/bonsai.toml,examples/tooth.toml"
    )]
    pub scenes: Vec<PathBuf>,
    /// A Cycles render of the first scene under the same light (e.g.
    /// ../shared/bench/engine-cycles/ambient_ref8192.exr); it replaces the Monte Carlo
    /// reference for that scene and sets its image size.
    #[arg(long)]
    pub cycles: Option<PathBuf>,
    /// sweep-physical (the visibility, the mean transmittance over all directions) or sweep
    /// (the paper's geometric mode, at its defaults: the extinction's half-maximum surface,
    /// gamma 2, all octants).
    #[arg(long, default_value = "sweep-physical")]
    pub method: String,
    /// The discrete ordinates' directions (`--method ordinates`).
    #[arg(long, default_value_t = occlux::transport::DEFAULT_DIRECTIONS)]
    pub directions: u32,
    /// Square image side for the scenes measured against the Monte Carlo reference.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Samples per pixel of the Monte Carlo reference.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Where the sweep and the ray caster run: auto picks a hardware GPU adapter if one opens.
    #[arg(long, default_value = "auto")]
    pub device: DeviceChoice,
    #[arg(short, long, default_value = "occlux-sweep-accuracy.json")]
    pub out: PathBuf,
}

/// One scene's error and timings.
#[derive(Serialize, Debug, Clone)]
pub struct SweepRow {
    pub scene: String,
    /// "cycles" or "occlux-ambient-SPP".
    pub reference: String,
    pub pixels: usize,
    pub rel_rmse: f64,
    pub rel_bias: f64,
    /// The Monte Carlo reference's own relative noise (0 for a Cycles file: see its README).
    pub reference_noise: f64,
    pub extinction_ms: f64,
    pub sweep_ms: f64,
    pub render_ms: f64,
}

pub fn run(args: &SweepAccuracyArgs, quiet: bool) -> Result<()> {
    if args.scenes.is_empty() {
        return Err(Error::param("--scenes", "need at least one scene"));
    }
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        crate::term::notice(quiet, line);
    }
    let method: AoMethod = args.method.parse()?;
    if matches!(method, AoMethod::Vao(_)) {
        return Err(Error::param(
            "--method",
            "sweep-physical, ordinates or sweep (VAO's accuracy: occlux ao-accuracy)",
        ));
    }
    let cycles = args.cycles.as_deref().map(read_exr).transpose()?;
    let mut rows = vec![];
    for (index, path) in args.scenes.iter().enumerate() {
        let mut scene = Scene::from_file(path)?;
        scene.lighting.lights = vec![Light::Ambient {
            radiance: Vec3::ONE,
        }];
        scene.lighting.background = Vec3::ONE;
        let against_cycles = cycles.as_ref().filter(|_| index == 0);
        let (width, height) =
            against_cycles.map_or((args.size, args.size), |c| (c.width, c.height));
        scene.camera.width = width;
        scene.camera.height = height;
        let occlux::scene::Loaded { scene, volume, .. } = scene.load()?;
        // The physical sweep reads the extinction, timed apart; the geometric mode classifies
        // inside its own time (extinction_ms 0).
        let (visibility, extinction_ms, sweep_ms) = if method != AoMethod::Sweep {
            let started = Instant::now();
            let extinction = scene.classification.extinction(&volume)?;
            let extinction_ms = started.elapsed().as_secs_f64() * 1e3;
            let started = Instant::now();
            let visibility = if method == AoMethod::Ordinates {
                occlux::transport::visibility(&compute, &extinction, args.directions, &NoProgress)?
            } else {
                ao::sweep::physical::visibility(&compute, &extinction, &NoProgress)?
            };
            (
                visibility,
                extinction_ms,
                started.elapsed().as_secs_f64() * 1e3,
            )
        } else {
            let params = AoVolumeParams {
                method,
                ..Default::default()
            };
            let started = Instant::now();
            let ao = ao::ao_volume(
                &compute,
                Cow::Borrowed(&volume),
                &scene.classification,
                &params,
                &NoProgress,
            )?;
            (ao.openness, 0.0, started.elapsed().as_secs_f64() * 1e3)
        };
        let lut = scene.classification.bake(&volume);
        let render_params = RaycastParams {
            shading: Shading::AmbientOcclusion { direct: None },
            ..RaycastParams::default()
        };
        let input = RaycastInput {
            volume: &volume,
            lut: &lut,
            camera: &scene.camera,
            lighting: &scene.lighting,
            params: &render_params,
            ao: Some(AoFactors {
                openness: &visibility,
                opacity: None,
            }),
        };
        let started = Instant::now();
        let image = raycast::render(&compute, &input, &NoProgress)?;
        let render_ms = started.elapsed().as_secs_f64() * 1e3;
        let (reference, (pixels, rel_rmse, rel_bias, reference_noise)) = match against_cycles {
            Some(exr) => {
                let pixels = exr
                    .rgb()
                    .ok_or_else(|| Error::param("--cycles", "no layer with R, G and B"))?;
                (
                    "cycles".to_owned(),
                    design_error(&image.rgba, &pixels, None, 1.0)?,
                )
            }
            None => {
                let mc = super::dos_accuracy::reference_image(
                    &scene,
                    &volume,
                    &lut,
                    Estimator::Ambient,
                    args.spp,
                )?;
                let mean: Vec<[f32; 3]> = mc.mean.iter().map(|m| [m[0], m[1], m[2]]).collect();
                (
                    format!("occlux-ambient-{}", args.spp),
                    design_error(&image.rgba, &mean, Some(&mc.stderr), 1.0)?,
                )
            }
        };
        let row = SweepRow {
            scene: path.display().to_string(),
            reference,
            pixels,
            rel_rmse,
            rel_bias,
            reference_noise,
            extinction_ms,
            sweep_ms,
            render_ms,
        };
        crate::term::say(
            quiet,
            format_args!(
                "{:<28} vs {:<20} rel RMSE {:.4} bias {:+.4} (noise {:.4}); extinction {:.0} ms, \
                 sweep {:.0} ms, render {:.0} ms",
                row.scene,
                row.reference,
                row.rel_rmse,
                row.rel_bias,
                row.reference_noise,
                row.extinction_ms,
                row.sweep_ms,
                row.render_ms
            ),
        );
        rows.push(row);
    }
    #[derive(Serialize)]
    struct Report<'a> {
        method: &'a str,
        device: String,
        cpu_threads: usize,
        rows: &'a [SweepRow],
    }
    let report = Report {
        method: method.name(),
        device: compute.describe(),
        cpu_threads: rayon::current_num_threads(),
        rows: &rows,
    };
    super::write_report(&args.out, &report, quiet)
}
