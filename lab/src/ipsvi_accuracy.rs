//! `occlux ipsvi-accuracy`: IPSVI against the path-traced single-scattering truth of the same scene
//! (Occlux's `single` Monte Carlo reference, or a Cycles render given with `--cycles`), over its
//! parameters (line width, cache size, piecewise integration, early ray termination), under each
//! scene's own directional and point lights (its ambient ones left out) or a lamp; relative RMSE
//! and bias over the volume's pixels (docs/architecture.md#error-measure), and the median time
//! beside unshaded DVR's, measured in the same run on the same device (the CPU by default).

use super::bench::{timed, timed_keeping};
use glam::Vec3;
use occlux::classify::Lut;
use occlux::error::{Error, Result};
use occlux::export::exr::read_exr;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::lights::Light;
use occlux::method::RenderMethod;
use occlux::metric::design_error;
use occlux::progress::NoProgress;
use occlux::render::half_angle::{self, HalfAngleInput, HalfAngleParams};
use occlux::render::ipsvi::cache::{CacheMap, Resolution};
use occlux::render::ipsvi::{self, IpsviInput, IpsviParams, Scattering};
use occlux::render::raycast::{self, RaycastInput, RaycastParams};
use occlux::render::reference::Estimator;
use occlux::render::RenderImage;
use occlux::scene::Scene;
use occlux::volume::Volume;
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct IpsviAccuracyArgs {
    /// Scene files; their directional and point lights are used (ambient ones are left out).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "examples/engine-sun.toml"
    )]
    pub scenes: Vec<PathBuf>,
    /// A Cycles render of the first scene under its own lights (e.g.
    /// ../shared/bench/engine-cycles/sun_ref8192.exr, or multi_ref8192.exr with --scattering
    /// multiple); it replaces the Monte Carlo reference for that scene and sets its image size.
    #[arg(long)]
    pub cycles: Option<PathBuf>,
    /// Also measure every scene under a point light X,Y,Z of intensity I (its lights replaced):
    /// "X,Y,Z,I".
    #[arg(long)]
    pub lamp: Option<String>,
    /// Line widths to measure.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub line_widths: Vec<u32>,
    /// Cache sizes to measure; 0: the default, matched to the image.
    #[arg(long, value_delimiter = ',', default_value = "0")]
    pub cache_sizes: Vec<u32>,
    /// Piecewise integration: on, off or both ("on,off").
    #[arg(long, value_delimiter = ',', default_value = "on")]
    pub piecewise: Vec<Switch>,
    /// Early ray termination (threshold 1e-3) on, off (0) or both.
    #[arg(long, value_delimiter = ',', default_value = "on")]
    pub ert: Vec<Switch>,
    /// Scattering to render and measure: single (against the `single` reference), multiple
    /// (against `multiple` with --bounces, beside single scattering against it), or both
    /// ("single,multiple").
    #[arg(long, value_delimiter = ',', default_value = "single")]
    pub scattering: Vec<Scattering>,
    /// Scatterings after the first in the `multiple` reference (Cycles' volume bounces; the
    /// engine's Cycles reference uses 8).
    #[arg(long, default_value_t = 8)]
    pub bounces: u32,
    /// Henyey-Greenstein asymmetry of the medium, for IPSVI and the reference alike.
    #[arg(long, default_value_t = 0.0)]
    pub g: f32,
    /// Square image side for the scenes measured against the Monte Carlo reference.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Samples per pixel of the Monte Carlo reference.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Also measure half-angle slicing (Kniss et al. 2003, the paper's baseline) at its defaults,
    /// under suns and lamps (a lamp too close to the volume for its slices is left out, saying
    /// why).
    #[arg(long)]
    pub half_angle: bool,
    /// Where IPSVI and the DVR it is timed against run (half-angle slicing: the CPU); auto
    /// picks a hardware GPU adapter if one opens.
    #[arg(long, default_value = "cpu")]
    pub device: DeviceChoice,
    /// Timed renders per case (median, after one warm-up).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    #[arg(short, long, default_value = "occlux-ipsvi-accuracy.json")]
    pub out: PathBuf,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Switch {
    On,
    Off,
}

/// One case: the method and its parameters, error and time.
#[derive(Serialize, Debug, Clone)]
pub struct IpsviRow {
    pub scene: String,
    pub light: &'static str,
    pub reference: String,
    /// "ipsvi" with its line width, cache size (0: the default), piecewise integration and
    /// early ray termination, or "half-angle".
    pub method: String,
    /// The first light's cache (IPSVI) or light buffer (half-angle), in texels, and its extra
    /// memory: two 8-byte entries per texel (IPSVI's cache and merge; half-angle's buffer is
    /// one f32 per texel).
    pub cache: [u32; 2],
    pub cache_bytes: u64,
    pub pixels: usize,
    pub rel_rmse: f64,
    pub rel_bias: f64,
    pub reference_noise: f64,
    /// Median render time, and unshaded DVR's on the same scene in the same run.
    pub ms: f64,
    pub dvr_ms: f64,
}

/// A method to measure.
enum Case {
    Ipsvi(IpsviParams),
    HalfAngle(HalfAngleParams),
}

impl Case {
    /// Renders IPSVI on `compute`, half-angle slicing on the CPU (it has no GPU twin).
    fn render(
        &self,
        compute: &Compute,
        volume: &Volume,
        lut: &Lut,
        scene: &Scene,
    ) -> Result<RenderImage> {
        Ok(match self {
            Case::Ipsvi(params) => {
                let input = IpsviInput {
                    volume,
                    lut,
                    camera: &scene.camera,
                    lighting: &scene.lighting,
                    params,
                };
                ipsvi::render(compute, &input, &NoProgress)?
            }
            Case::HalfAngle(params) => {
                let input = HalfAngleInput {
                    volume,
                    lut,
                    camera: &scene.camera,
                    lighting: &scene.lighting,
                    params,
                };
                half_angle::cpu::render(&input, &NoProgress)?
            }
        })
    }

    /// The first light's cache map and the bytes it takes.
    fn cache(&self, volume: &Volume, scene: &Scene) -> ([u32; 2], u64) {
        let (lo, hi) = volume.bounds();
        let (texels, bytes_per_texel) = match self {
            Case::Ipsvi(params) => (params.cache_size, 16),
            Case::HalfAngle(params) => (params.light_buffer, 4),
        };
        let resolution = Resolution::for_view(texels, volume, &scene.camera);
        scene
            .lighting
            .lights
            .first()
            .and_then(|light| CacheMap::new(light, lo, hi, resolution))
            .map_or(([0, 0], 0), |map| {
                (
                    [map.size.x, map.size.y],
                    map.texels() as u64 * bytes_per_texel,
                )
            })
    }

    fn describe(&self) -> String {
        let on = |b: bool| if b { "on" } else { "off" };
        match self {
            Case::Ipsvi(p) => format!(
                "ipsvi{} w {} cache {} piecewise {} ert {}",
                match p.scattering {
                    Scattering::Single => "",
                    Scattering::Multiple => " multiple",
                    Scattering::Transport => " transport",
                },
                p.line_width,
                p.cache_size.unwrap_or(0),
                on(p.piecewise),
                on(p.ert_threshold > 0.0)
            ),
            Case::HalfAngle(_) => "half-angle".to_owned(),
        }
    }
}

/// A point light from "X,Y,Z,I".
fn parse_lamp(text: &str) -> Result<Light> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::param("--lamp", format!("'{text}': {e}")))?;
    match values[..] {
        [x, y, z, i] if values.iter().all(|v| v.is_finite()) && i >= 0.0 => Ok(Light::Point {
            position: Vec3::new(x, y, z),
            intensity: Vec3::splat(i),
        }),
        _ => Err(Error::param(
            "--lamp",
            format!("needs four finite numbers X,Y,Z,I with I >= 0, got '{text}'"),
        )),
    }
}

pub fn run(args: &IpsviAccuracyArgs, quiet: bool) -> Result<()> {
    if args.scenes.is_empty() {
        return Err(Error::param("--scenes", "need at least one scene"));
    }
    let lamp = args.lamp.as_deref().map(parse_lamp).transpose()?;
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        crate::term::notice(quiet, line);
    }
    let cycles = args.cycles.as_deref().map(read_exr).transpose()?;
    let mut rows = vec![];
    for (index, path) in args.scenes.iter().enumerate() {
        let mut scene = Scene::from_file(path)?;
        // IPSVI renders suns and lamps; the scene's ambient lights are left out of both sides.
        scene
            .lighting
            .lights
            .retain(|l| !matches!(l, Light::Ambient { .. }));
        let mut lightings = vec![];
        if !scene.lighting.lights.is_empty() {
            lightings.push(("scene", scene.lighting.clone()));
        }
        if let Some(lamp) = lamp {
            let mut lit = scene.lighting.clone();
            lit.lights = vec![lamp];
            lightings.push(("lamp", lit));
        }
        if lightings.is_empty() {
            return Err(Error::param(
                "--scenes",
                format!(
                    "{} has no directional or point light (give --lamp)",
                    path.display()
                ),
            ));
        }
        let occlux::scene::Loaded { scene, volume, .. } = scene.load()?;
        let lut = scene.classification.bake(&volume);
        for (light_name, lighting) in lightings {
            let mut scene = scene.clone();
            scene.lighting = lighting;
            let against_cycles = cycles
                .as_ref()
                .filter(|_| index == 0 && light_name == "scene");
            let (width, height) =
                against_cycles.map_or((args.size, args.size), |c| (c.width, c.height));
            scene.camera.width = width;
            scene.camera.height = height;
            let background = scene.lighting.background.element_sum() / 3.0;
            let dvr_params = RaycastParams::default();
            let dvr = RaycastInput {
                volume: &volume,
                lut: &lut,
                camera: &scene.camera,
                lighting: &scene.lighting,
                params: &dvr_params,
                ao: None,
            };
            let dvr_ms = timed(args.repeats, || {
                raycast::render(&compute, &dvr, &NoProgress)
            })?
            .median_ms;
            for &scattering in &args.scattering {
                let estimator = match scattering {
                    Scattering::Single => Estimator::Single,
                    Scattering::Multiple | Scattering::Transport => Estimator::Multiple {
                        bounces: args.bounces,
                    },
                };
                let (reference, truth, stderr) = match against_cycles {
                    Some(exr) => (
                        "cycles".to_owned(),
                        exr.rgb()
                            .ok_or_else(|| Error::param("--cycles", "no layer with R, G and B"))?,
                        None,
                    ),
                    None => {
                        let mc = super::dos_accuracy::seeded_reference_image(
                            &scene, &volume, &lut, estimator, args.spp, 1, args.g,
                        )?;
                        let mean = mc.mean.iter().map(|m| [m[0], m[1], m[2]]).collect();
                        (
                            format!("occlux-{}-{}", estimator.name(), args.spp),
                            mean,
                            Some(mc.stderr),
                        )
                    }
                };
                let mut cases: Vec<Case> = vec![];
                for &line_width in &args.line_widths {
                    for &cache_size in &args.cache_sizes {
                        for &piecewise in &args.piecewise {
                            for &ert in &args.ert {
                                cases.push(Case::Ipsvi(IpsviParams {
                                    line_width,
                                    cache_size: (cache_size > 0).then_some(cache_size),
                                    piecewise: piecewise == Switch::On,
                                    ert_threshold: if ert == Switch::On { 1e-3 } else { 0.0 },
                                    scattering,
                                    g: args.g,
                                    ..IpsviParams::default()
                                }));
                            }
                        }
                    }
                }
                // What the multiple-scattering term buys: single scattering against the same
                // reference, and the transport solve beside the diffusion term.
                if scattering == Scattering::Multiple {
                    for scattering in [Scattering::Single, Scattering::Transport] {
                        cases.push(Case::Ipsvi(IpsviParams {
                            scattering,
                            g: args.g,
                            ..IpsviParams::default()
                        }));
                    }
                }
                if args.half_angle
                    && scattering == Scattering::Single
                    && HalfAngleParams::SPEC.check_lights(&scene.lighting).is_ok()
                {
                    cases.push(Case::HalfAngle(HalfAngleParams::default()));
                }
                for case in &cases {
                    let render = || case.render(&compute, &volume, &lut, &scene);
                    let (timing, image) = match timed_keeping(args.repeats, render) {
                        Ok(measured) => measured,
                        // A lamp too close to the volume for half-angle's slices (refused by
                        // name): its rows go without half-angle slicing.
                        Err(e) if matches!(case, Case::HalfAngle(_)) => {
                            crate::term::notice(
                                quiet,
                                format!(
                                    "{}, {light_name}: no half-angle slicing: {e}",
                                    path.display()
                                ),
                            );
                            continue;
                        }
                        Err(e) => return Err(e),
                    };
                    let ms = timing.median_ms;
                    let (pixels, rel_rmse, rel_bias, reference_noise) =
                        design_error(&image.rgba, &truth, stderr.as_deref(), background)?;
                    let (cache, cache_bytes) = case.cache(&volume, &scene);
                    let row = IpsviRow {
                        scene: path.display().to_string(),
                        light: light_name,
                        reference: reference.clone(),
                        method: case.describe(),
                        cache,
                        cache_bytes,
                        pixels,
                        rel_rmse,
                        rel_bias,
                        reference_noise,
                        ms,
                        dvr_ms,
                    };
                    crate::term::say(
                        quiet,
                        format_args!(
                            "{:<26} {:<5} vs {:<18} {:<44} cache {}x{} ({:.1} MiB) rel RMSE {:.4} \
                         bias {:+.4} (noise {:.4}) {:.0} ms, DVR {:.0} ms ({:.2}x DVR's speed)",
                            row.scene,
                            row.light,
                            row.reference,
                            row.method,
                            row.cache[0],
                            row.cache[1],
                            row.cache_bytes as f64 / (1 << 20) as f64,
                            row.rel_rmse,
                            row.rel_bias,
                            row.reference_noise,
                            row.ms,
                            row.dvr_ms,
                            row.dvr_ms / row.ms
                        ),
                    );
                    rows.push(row);
                }
            }
        }
    }
    #[derive(Serialize)]
    struct Report<'a> {
        device: String,
        cpu_threads: usize,
        rows: &'a [IpsviRow],
    }
    let report = Report {
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
    fn lamps_parse_or_say_why_not() {
        assert_eq!(
            parse_lamp("1, -2.5, 3, 40").unwrap(),
            Light::Point {
                position: Vec3::new(1.0, -2.5, 3.0),
                intensity: Vec3::splat(40.0),
            }
        );
        for bad in ["1,2,3", "1,2,3,-1", "1,2,nan,4", "a,b,c,d"] {
            let message = parse_lamp(bad).unwrap_err().to_string();
            assert!(message.contains("--lamp"), "{bad}: {message}");
        }
    }
}
