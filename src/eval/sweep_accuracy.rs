//! `occlux sweep-accuracy`: AO-shaded DVR with an occlusion sweep's AO volume (the physical
//! mode's visibility by default, or the geometric mode's AO with `--method sweep`) under the
//! ambient light of each scene (radiance 1, background 1, no direct light, isotropic phase),
//! against the path-traced truth of the same scene: Occlux's ambient Monte Carlo reference, or
//! a Cycles render given with `--cycles` (for the engine scene of
//! ../shared/bench/engine-cycles). Error over the volume's pixels as DESIGN.md defines it, and
//! the time of each stage; table and JSON.

use crate::ao::{self, AoMethod, AoVolumeParams};
use crate::error::{Error, Result};
use crate::export::exr::read_exr;
use crate::gpu::{Compute, DeviceChoice};
use crate::lights::Light;
use crate::progress::NoProgress;
use crate::render::raycast::{self, AoFactors, RaycastInput, RaycastParams, Shading};
use crate::render::reference::Estimator;
use crate::scene::Scene;
use glam::Vec3;
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
    /// Square image side for the scenes measured against the Monte Carlo reference.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Samples per pixel of the Monte Carlo reference.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Where the sweep and the ray caster run: auto picks a hardware GPU adapter if one opens.
    #[arg(long, value_enum, default_value = "auto")]
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

/// Whether a reference pixel shows the volume: its grey differs from the background's by more
/// than 0.5 % of it (DESIGN.md's pixels to measure over).
pub fn shows_volume(reference: &[f32; 3], background: f32) -> bool {
    let grey = (reference[0] + reference[1] + reference[2]) as f64 / 3.0;
    (grey - background as f64).abs() > 0.005 * background as f64
}

/// Relative RMSE, bias and reference noise over the pixels where the reference differs from the
/// background by more than 0.5 % of it (DESIGN.md).
pub fn design_error(
    image: &[[f32; 4]],
    reference: &[[f32; 3]],
    stderr: Option<&[[f32; 3]]>,
    background: f32,
) -> Result<(usize, f64, f64, f64)> {
    if image.len() != reference.len() {
        return Err(Error::param("reference", "image sizes differ"));
    }
    let (mut sq, mut sum, mut sum_image, mut noise, mut n) = (0.0f64, 0.0, 0.0, 0.0, 0usize);
    for (p, (a, b)) in image.iter().zip(reference).enumerate() {
        if !shows_volume(b, background) {
            continue;
        }
        for c in 0..3 {
            sq += (a[c] as f64 - b[c] as f64).powi(2);
            sum += b[c] as f64;
            sum_image += a[c] as f64;
            noise += stderr.map_or(0.0, |e| (e[p][c] as f64).powi(2));
        }
        n += 3;
    }
    if n == 0 || sum <= 0.0 {
        return Err(Error::param(
            "reference",
            "no volume pixels to measure over",
        ));
    }
    let mean = sum / n as f64;
    Ok((
        n / 3,
        (sq / n as f64).sqrt() / mean,
        sum_image / sum - 1.0,
        (noise / n as f64).sqrt() / mean,
    ))
}

pub fn run(args: &SweepAccuracyArgs, quiet: bool) -> Result<()> {
    if args.scenes.is_empty() {
        return Err(Error::param("--scenes", "need at least one scene"));
    }
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        crate::progress::notice(quiet, line);
    }
    let method: AoMethod = args.method.parse()?;
    if matches!(method, AoMethod::Vao(_)) {
        return Err(Error::param(
            "--method",
            "sweep-physical or sweep (VAO's accuracy: occlux ao-accuracy)",
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
        let crate::scene::Loaded { scene, volume, .. } = scene.load()?;
        // The physical sweep reads the extinction, timed apart; the geometric mode classifies
        // inside its own time (extinction_ms 0).
        let (visibility, extinction_ms, sweep_ms) = if method == AoMethod::SweepPhysical {
            let started = Instant::now();
            let extinction = scene.classification.extinction(&volume)?;
            let extinction_ms = started.elapsed().as_secs_f64() * 1e3;
            let started = Instant::now();
            let visibility = ao::sweep::visibility(&compute, &extinction, &NoProgress)?;
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
        crate::progress::say(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_counts_only_pixels_that_differ_from_the_background() {
        // Two volume pixels (0.5 and 0.25 grey) and one background pixel the image gets wrong.
        let reference = [[0.5; 3], [0.25; 3], [1.0; 3]];
        let image = [
            [0.55, 0.55, 0.55, 1.0],
            [0.275, 0.275, 0.275, 1.0],
            [9.0; 4],
        ];
        let (pixels, rmse, bias, noise) = design_error(&image, &reference, None, 1.0).unwrap();
        assert_eq!(pixels, 2);
        // Differences 0.05 and 0.025 over a mean of 0.375.
        let want = ((0.05f64.powi(2) + 0.025f64.powi(2)) / 2.0).sqrt() / 0.375;
        assert!((rmse - want).abs() < 1e-6, "{rmse} vs {want}");
        assert!((bias - 0.1).abs() < 1e-6 && noise == 0.0);
        assert!(design_error(&image[..2], &reference, None, 1.0).is_err());
        assert!(design_error(&image[2..], &reference[2..], None, 1.0).is_err());
    }
}
