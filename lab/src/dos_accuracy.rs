//! `occlux dos-accuracy`: directional occlusion shading against the Monte Carlo references of
//! the same scene: the cone-phase estimator (the integral DOS approximates: ambient light
//! inside the cone of half-angle theta towards the viewer, exact transmittance) and the
//! ambient-occlusion estimator (isotropic phase, light from the whole sphere), for scenes x
//! theta x n, as a printed table and JSON.
//!
//! Each scene keeps its volume, classification and camera; its lights become its ambient
//! lights only (radiance 1 when it has none), since DOS is lit by ambient light alone.

use glam::Vec3;
use occlux::error::{Error, Result};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::lights::Light;
use occlux::progress::NoProgress;
use occlux::registry::Method;
use occlux::render::dos::{self, ConeDistance, DosInput, DosParams};
use occlux::render::reference::{self, Estimator, ReferenceImage, ReferenceInput, ReferenceParams};
use occlux::render::RenderImage;
use occlux::scene::Scene;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct AccuracyArgs {
    /// Scene files (volume, classification and camera are used).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "examples/engine.toml,examples/stag_beetle.toml,examples/demo.toml"
    )]
    pub scenes: Vec<PathBuf>,
    /// Cone half-angles in degrees.
    #[arg(long, value_delimiter = ',', default_value = "30,50,80,85")]
    pub thetas: Vec<f32>,
    /// Grid sides n (n x n cone-base samples).
    #[arg(long, value_delimiter = ',', default_value = "2,5,13")]
    pub grids: Vec<u32>,
    /// Square image side.
    #[arg(long, default_value_t = 96)]
    pub size: u32,
    /// Reference samples per pixel.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Render with DOS's self-occlusion option (not in the paper).
    #[arg(long)]
    pub self_occlusion: bool,
    /// Where DOS runs: auto picks a GPU adapter if one opens (references run on the CPU).
    #[arg(long, default_value = "auto")]
    pub device: DeviceChoice,
    /// Where to write the JSON results.
    #[arg(short, long, default_value = "occlux-dos-accuracy.json")]
    pub out: PathBuf,
}

/// One scene, theta and n.
#[derive(Serialize, Debug, Clone)]
pub struct AccuracyRow {
    pub scene: String,
    pub theta_deg: f32,
    pub grid: u32,
    /// Every DOS parameter of the row, as in a scene's `[render]`.
    pub params: serde_json::Value,
    /// Relative RMSE of DOS against the cone reference of the same theta.
    pub cone_rel_rmse: f64,
    /// Mean DOS radiance over the cone reference's, minus 1 (negative: DOS is darker).
    pub cone_rel_bias: f64,
    /// Relative RMSE of DOS against the ambient-occlusion reference.
    pub ambient_rel_rmse: f64,
    /// The cone reference's own noise: relative RMS of its standard error.
    pub cone_rel_noise: f64,
    /// Coverage-weighted mean of the `occlusion` layer over the image, sum P / sum A: how much
    /// of the cone's light what is seen receives (the paper's Figure 5: larger theta and a
    /// finer grid let more distant occluders count, so it falls).
    pub mean_occlusion: f64,
    pub dos_ms: f64,
}

/// An image's error against a reference, relative to the reference's mean radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativeError {
    /// sqrt(mean squared RGB difference) / mean reference RGB.
    pub rmse: f64,
    /// mean image RGB / mean reference RGB - 1.
    pub bias: f64,
    /// The reference's RMS standard error / its mean RGB: the floor of `rmse`.
    pub noise: f64,
}

/// The error of `image` against a reference over the volume's pixels (where either shows
/// matter, alpha > 1e-3).
pub fn relative_error(image: &RenderImage, reference: &ReferenceImage) -> Result<RelativeError> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(Error::param("reference", "image sizes differ"));
    }
    let (mut sq, mut noise, mut sum, mut count) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    let mut sum_image = 0.0f64;
    for ((a, b), e) in image
        .rgba
        .iter()
        .zip(&reference.mean)
        .zip(&reference.stderr)
    {
        if a[3] <= 1e-3 && b[3] <= 1e-3 {
            continue;
        }
        for c in 0..3 {
            sq += ((a[c] - b[c]) as f64).powi(2);
            noise += (e[c] as f64).powi(2);
            sum += b[c] as f64;
            sum_image += a[c] as f64;
        }
        count += 3;
    }
    if count == 0 || sum <= 0.0 {
        return Err(Error::param(
            "reference",
            "no lit volume pixels to measure over",
        ));
    }
    let mean = sum / count as f64;
    Ok(RelativeError {
        rmse: (sq / count as f64).sqrt() / mean,
        bias: sum_image / sum - 1.0,
        noise: (noise / count as f64).sqrt() / mean,
    })
}

/// Mean occlusion of what the image shows (NaN without an `occlusion` layer or coverage).
pub fn mean_occlusion(image: &RenderImage) -> f64 {
    image
        .factor("occlusion")
        .map_or(f64::NAN, |layer| layer.mean())
}

/// The scene's lighting reduced to its ambient lights (radiance 1 when it has none).
pub fn ambient_only(scene: &mut Scene) {
    scene
        .lighting
        .lights
        .retain(|l| matches!(l, Light::Ambient { .. }));
    if scene.lighting.ambient() == Vec3::ZERO {
        scene.lighting.lights = vec![Light::Ambient {
            radiance: Vec3::ONE,
        }];
    }
}

/// A Monte Carlo reference of `scene` with `estimator` (seed 1).
pub fn reference_image(
    scene: &Scene,
    volume: &occlux::volume::Volume,
    lut: &occlux::classify::Lut,
    estimator: Estimator,
    spp: u32,
) -> Result<ReferenceImage> {
    seeded_reference_image(scene, volume, lut, estimator, spp, 1, 0.0)
}

/// A Monte Carlo reference of `scene` with `estimator`, `seed` and Henyey-Greenstein `g`.
pub fn seeded_reference_image(
    scene: &Scene,
    volume: &occlux::volume::Volume,
    lut: &occlux::classify::Lut,
    estimator: Estimator,
    spp: u32,
    seed: u64,
    g: f32,
) -> Result<ReferenceImage> {
    let params = ReferenceParams {
        estimator,
        spp,
        seed,
        g,
    };
    reference::render(
        &ReferenceInput {
            volume,
            lut,
            camera: &scene.camera,
            lighting: &scene.lighting,
            params: &params,
        },
        &NoProgress,
    )
}

/// Runs the table, prints it unless `quiet`, and writes the JSON.
/// DOS's parameters for one row: theta and n, the exact cone distance, the rest at the
/// registry's defaults.
fn params(args: &AccuracyArgs, theta_deg: f32, grid: u32) -> DosParams {
    DosParams {
        theta_deg,
        grid,
        distance: ConeDistance::Exact,
        self_occlusion: args.self_occlusion,
        ..DosParams::default()
    }
}

pub fn run(args: &AccuracyArgs, quiet: bool) -> Result<()> {
    if args.scenes.is_empty() || args.thetas.is_empty() || args.grids.is_empty() {
        return Err(Error::param(
            "--scenes/--thetas/--grids",
            "need at least one of each",
        ));
    }
    // Every case is checked against the registry's ranges before any reference is sampled.
    for &theta_deg in &args.thetas {
        for &grid in &args.grids {
            params(args, theta_deg, grid)
                .validate()
                .map_err(|e| Error::param("--thetas/--grids", e.to_string()))?;
        }
    }
    let (compute, notice) = Compute::resolve(args.device)?;
    if let (Some(notice), false) = (notice, quiet) {
        eprintln!("{notice}");
    }
    let mut rows = vec![];
    for path in &args.scenes {
        let mut scene = Scene::from_file(path)?;
        ambient_only(&mut scene);
        scene.camera.width = args.size;
        scene.camera.height = args.size;
        let occlux::scene::Loaded { scene, volume, .. } = scene.load()?;
        let lut = scene.classification.bake(&volume);
        let name = path.file_stem().map_or_else(
            || path.display().to_string(),
            |s| s.to_string_lossy().into(),
        );
        let ambient = reference_image(&scene, &volume, &lut, Estimator::Ambient, args.spp)?;
        for &theta_deg in &args.thetas {
            let cone = reference_image(
                &scene,
                &volume,
                &lut,
                Estimator::Cone {
                    aperture: theta_deg.to_radians(),
                },
                args.spp,
            )?;
            for &grid in &args.grids {
                let params = params(args, theta_deg, grid);
                let input = DosInput {
                    volume: &volume,
                    lut: &lut,
                    camera: &scene.camera,
                    lighting: &scene.lighting,
                    params: &params,
                };
                let t = Instant::now();
                let image = dos::render(&compute, &input, &NoProgress)?;
                let dos_ms = t.elapsed().as_secs_f64() * 1e3;
                let cone = relative_error(&image, &cone)?;
                let row = AccuracyRow {
                    scene: name.clone(),
                    theta_deg,
                    grid,
                    params: Method::Dos(params.clone()).to_json(),
                    cone_rel_rmse: cone.rmse,
                    cone_rel_bias: cone.bias,
                    ambient_rel_rmse: relative_error(&image, &ambient)?.rmse,
                    cone_rel_noise: cone.noise,
                    mean_occlusion: mean_occlusion(&image),
                    dos_ms,
                };
                if !quiet {
                    println!(
                        "{:<12} theta {:>4}  n {:>2}  cone {:.4} (bias {:+.4}, noise {:.4})  \
                         ambient {:.4}  occlusion {:.4}  {:.0} ms",
                        row.scene,
                        row.theta_deg,
                        row.grid,
                        row.cone_rel_rmse,
                        row.cone_rel_bias,
                        row.cone_rel_noise,
                        row.ambient_rel_rmse,
                        row.mean_occlusion,
                        row.dos_ms
                    );
                }
                rows.push(row);
            }
        }
    }
    #[derive(Serialize)]
    struct Report<'a> {
        size: u32,
        spp: u32,
        self_occlusion: bool,
        device: String,
        rows: &'a [AccuracyRow],
    }
    let report = Report {
        size: args.size,
        spp: args.spp,
        self_occlusion: args.self_occlusion,
        device: compute.describe(),
        rows: &rows,
    };
    super::write_report(&args.out, &report, quiet)
}
