//! The chart's measurements for one scene under one lighting: every registered method at each
//! of its chart settings, Occlux's Monte Carlo and Cycles at increasing samples per pixel, and
//! the other peers (VTK, EEVEE) along their quality axes, all against the path-traced truth of
//! the same lighting (Occlux's Monte Carlo reference at high spp, which `occlux check-cycles`
//! shows agrees with Cycles).

use super::pareto::{self, Curve, Reached};
use crate::bench::timed_keeping;
use crate::dos_accuracy::seeded_reference_image;
use crate::peers::{self, Peer};
use occlux::classify::Lut;
use occlux::error::{Error, Result};
use occlux::export::exr::read_exr;
use occlux::gpu::Compute;
use occlux::lights::Lighting;
use occlux::method::Model;
use occlux::metric::design_error;
use occlux::progress::NoProgress;
use occlux::registry::{Method, METHODS};
use occlux::render::reference::{self, Estimator, ReferenceInput, ReferenceParams};
use occlux::render::MethodInput;
use occlux::scene::Scene;
use occlux::volume::Volume;
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Volume bounces of the multiple-scattering lighting (those of the engine's Cycles reference).
pub const BOUNCES: u32 = occlux::render::reference::DEFAULT_BOUNCES;

/// What light a panel's scene is under, and so which path-traced truth it is measured against.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LightingMode {
    /// The scene's ambient lights (uniform radiance 1 if it has none), single scattering: the
    /// `ambient` estimator (volumetric ambient occlusion).
    Ambient,
    /// The scene's suns and lamps, single scattering with shadows: the `single` estimator.
    Sun,
    /// The scene's suns and lamps, multiple scattering (8 bounces): the `multiple` estimator.
    Multi,
}

impl LightingMode {
    pub fn name(self) -> &'static str {
        match self {
            LightingMode::Ambient => "ambient",
            LightingMode::Sun => "sun",
            LightingMode::Multi => "multi",
        }
    }

    /// The Monte Carlo estimator of its truth.
    pub fn estimator(self) -> Estimator {
        match self {
            LightingMode::Ambient => Estimator::Ambient,
            LightingMode::Sun => Estimator::Single,
            LightingMode::Multi => Estimator::Multiple { bounces: BOUNCES },
        }
    }

    /// The scene file's tree lit this way at `size` pixels square: its lights of the kinds
    /// this lighting uses (a uniform ambient light of radiance 1 if an ambient scene has
    /// none), the volume's path made absolute against `base` (the tree is written elsewhere
    /// for Cycles), and no `[render]` (the chart picks the methods).
    pub fn scene_tree(self, mut tree: Value, base: &Path, size: u32) -> Result<Value> {
        let table = tree
            .as_object_mut()
            .ok_or_else(|| Error::param("scene", "not a table"))?;
        table.remove("render");
        let camera = table
            .get_mut("camera")
            .and_then(Value::as_object_mut)
            .ok_or_else(|| Error::param("camera", "missing"))?;
        camera.insert("width".into(), size.into());
        camera.insert("height".into(), size.into());
        if let Some(Value::String(path)) = table.get("volume").and_then(|v| v.get("path")) {
            let joined = base.join(path);
            let absolute = std::path::absolute(&joined).map_err(|e| Error::io(&joined, e))?;
            table["volume"]["path"] = absolute.to_string_lossy().into_owned().into();
        }
        let wanted = |kind: &str| match self {
            LightingMode::Ambient => kind == "ambient",
            LightingMode::Sun | LightingMode::Multi => kind == "directional" || kind == "point",
        };
        let mut lights: Vec<Value> = table
            .get("lights")
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default()
            .into_iter()
            .filter(|l| l.get("type").and_then(Value::as_str).is_some_and(wanted))
            .collect();
        if lights.is_empty() {
            match self {
                LightingMode::Ambient => {
                    lights.push(serde_json::json!({ "type": "ambient", "radiance": 1.0 }))
                }
                LightingMode::Sun | LightingMode::Multi => {
                    return Err(Error::param(
                        "lights",
                        format!("no sun or lamp for the {} lighting", self.name()),
                    ))
                }
            }
        }
        table.insert("lights".into(), Value::Array(lights));
        Ok(tree)
    }
}

/// One method at one setting, measured.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub scene: String,
    pub lighting: &'static str,
    pub method: &'static str,
    /// Its `[render]` keys beyond the defaults ("" for the defaults).
    pub setting: String,
    /// The device it ran on.
    pub device: String,
    /// Median wall time of the render, volume loaded (see the module docs of `chart`).
    pub seconds: f64,
    pub rel_rmse: f64,
    pub rel_bias: f64,
    /// The same against the path-traced reference of the method's own model
    /// ([`occlux::method::RenderMethod::model`]: the DOS cone, single scattering for IPSVI
    /// under the multiple-scattering lighting), at the truth's samples and seed, under the
    /// lights the method renders: its error as an approximation, apart from its model's. None
    /// where the method has no such model (gradient shading, the unoccluded ambient term).
    pub model_rel_rmse: Option<f64>,
    pub model_rel_bias: Option<f64>,
    /// On the panel's Pareto front of time against error.
    pub pareto: bool,
    /// Cycles' time to the same error over this point's time, and how Cycles' time was read
    /// off its curve; None without a Cycles curve.
    pub speedup_vs_cycles: Option<f64>,
    pub cycles_reached: Option<Reached>,
    /// The same against Occlux's own Monte Carlo.
    pub speedup_vs_monte_carlo: Option<f64>,
}

/// A path tracer at one sample count.
#[derive(Clone, Debug, Serialize)]
pub struct CurvePoint {
    pub spp: u32,
    pub seconds: f64,
    pub rel_rmse: f64,
    pub rel_bias: f64,
}

/// A peer renderer (VTK, EEVEE) at one of its settings.
#[derive(Clone, Debug, Serialize)]
pub struct PeerPoint {
    /// Its setting in words, as the peer states it.
    pub setting: String,
    pub seconds: f64,
    pub rel_rmse: f64,
    pub rel_bias: f64,
    /// Cycles' time to the same error over this point's time (None without a Cycles curve).
    pub speedup_vs_cycles: Option<f64>,
    /// The same against Occlux's own Monte Carlo.
    pub speedup_vs_monte_carlo: Option<f64>,
}

/// A peer renderer along its quality axis.
#[derive(Clone, Debug, Serialize)]
pub struct PeerSeries {
    /// Its name in the legend ("VTK", "EEVEE", "VTK, no shadows").
    pub peer: String,
    /// What its seconds include, as the peer states it.
    pub timing: String,
    pub points: Vec<PeerPoint>,
}

/// One scene under one lighting.
#[derive(Clone, Debug, Serialize)]
pub struct Panel {
    pub scene: String,
    pub lighting: &'static str,
    pub reference_spp: u32,
    /// The truth's own relative noise (design_error's).
    pub reference_noise: f64,
    pub points: Vec<Point>,
    pub monte_carlo: Vec<CurvePoint>,
    pub cycles: Vec<CurvePoint>,
    pub peers: Vec<PeerSeries>,
}

/// What a panel is measured with.
pub struct Setup<'a> {
    pub compute: &'a Compute,
    pub reference_spp: u32,
    pub mc_spp: &'a [u32],
    /// The peers to run (Cycles at `cycles_spp`).
    pub peers: &'a [Peer],
    pub cycles_spp: &'a [u32],
    pub repeats: usize,
    /// Where the lit scene file and the peers' renders go.
    pub work: &'a Path,
    pub progress: &'a dyn Fn(&str),
}

/// The loaded scene of a panel and its truth.
struct Truth<'a> {
    scene: &'a Scene,
    volume: &'a Volume,
    lut: &'a Lut,
    mean: Vec<[f32; 3]>,
    background: f32,
}

impl Truth<'_> {
    /// Relative RMSE and bias of an image against the truth (docs/architecture.md#error-measure).
    fn error(&self, image: &[[f32; 4]]) -> Result<(f64, f64)> {
        let (_, rmse, bias, _) = design_error(image, &self.mean, None, self.background)?;
        Ok((rmse, bias))
    }

    /// The same for an EXR a peer wrote (its first layer with R, G and B).
    fn exr_error(&self, path: &Path) -> Result<(f64, f64)> {
        let exr = read_exr(path)?;
        let rgb = exr
            .rgb()
            .ok_or_else(|| Error::format(path, "no layer with R, G and B"))?;
        if rgb.len() != self.mean.len() {
            return Err(Error::format(
                path,
                format!("{} pixels, the scene has {}", rgb.len(), self.mean.len()),
            ));
        }
        let rgba: Vec<[f32; 4]> = rgb.iter().map(|c| [c[0], c[1], c[2], 1.0]).collect();
        self.error(&rgba)
    }
}

/// Occlux's Monte Carlo reference of `scene` at `spp` with `seed`, and its time.
fn monte_carlo(
    scene: &Scene,
    volume: &Volume,
    lut: &Lut,
    estimator: Estimator,
    spp: u32,
    seed: u64,
) -> Result<(f64, reference::ReferenceImage)> {
    let started = std::time::Instant::now();
    let image = seeded_reference_image(scene, volume, lut, estimator, spp, seed, 0.0)?;
    Ok((started.elapsed().as_secs_f64(), image))
}

/// Measures one scene file under one lighting.
pub fn panel(path: &Path, light: LightingMode, size: u32, setup: &Setup) -> Result<Panel> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let tree: Value = toml::from_str(&text).map_err(|e| Error::format(path, e.message()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let tree = light
        .scene_tree(tree, base, size)
        .map_err(|e| Error::format(path, e.to_string()))?;
    let scene = Scene::from_value(tree.clone(), base)?;
    let name = path
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    (setup.progress)(&format!("{name} {}: reference", light.name()));
    let occlux::scene::Loaded { scene, volume, .. } = scene.load()?;
    let lut = scene.classification.bake(&volume);
    let estimator = light.estimator();
    let (_, truth_image) = monte_carlo(&scene, &volume, &lut, estimator, setup.reference_spp, 1)?;
    let background = scene.lighting.background.element_sum() / 3.0;
    let mean: Vec<[f32; 3]> = truth_image
        .mean
        .iter()
        .map(|m| [m[0], m[1], m[2]])
        .collect();
    let (_, _, _, reference_noise) = design_error(
        &truth_image.mean,
        &mean,
        Some(&truth_image.stderr),
        background,
    )?;
    let truth = Truth {
        scene: &scene,
        volume: &volume,
        lut: &lut,
        mean,
        background,
    };
    let mut points = methods(&truth, &name, light, setup)?;
    let monte_carlo = mc_curve(&truth, estimator, setup)?;
    let (mut cycles, mut peers) = (vec![], vec![]);
    if !setup.peers.is_empty() {
        let scene_file = lit_scene_file(&tree, &name, light, setup)?;
        for &peer in setup.peers {
            (setup.progress)(&format!("{name} {}: {}", light.name(), peer.label()));
            let (timing, renders) = peer_series(&truth, peer, &scene_file, light, setup)?;
            if peer == Peer::Cycles {
                cycles = renders.into_iter().map(|(_, point)| point).collect();
            } else {
                peers.extend(series_of(peer, &timing, renders));
            }
        }
    }
    mark(&mut points, &mut peers, &monte_carlo, &cycles);
    Ok(Panel {
        scene: name,
        lighting: light.name(),
        reference_spp: setup.reference_spp,
        reference_noise,
        points,
        monte_carlo,
        cycles,
        peers,
    })
}

/// The path-traced references of the methods' own models, each rendered once per panel.
struct ModelReferences<'a> {
    truth: &'a Truth<'a>,
    spp: u32,
    /// The truth's own model: its estimator with g = 0 under the panel's lights.
    truth_model: (Model, &'a Lighting),
    rendered: Vec<(Model, Lighting, Vec<[f32; 3]>)>,
}

impl ModelReferences<'_> {
    /// Relative RMSE and bias of `image` against `model` under `lit`, rendering its reference
    /// the first time it is asked for.
    fn error(&mut self, image: &[[f32; 4]], model: Model, lit: &Lighting) -> Result<(f64, f64)> {
        if (model, lit) == self.truth_model {
            return self.truth.error(image);
        }
        let found = self
            .rendered
            .iter()
            .position(|(m, l, _)| *m == model && l == lit);
        let index = match found {
            Some(index) => index,
            None => {
                let params = ReferenceParams {
                    estimator: model.estimator,
                    spp: self.spp,
                    seed: 1,
                    g: model.g,
                };
                let input = ReferenceInput {
                    volume: self.truth.volume,
                    lut: self.truth.lut,
                    camera: &self.truth.scene.camera,
                    lighting: lit,
                    params: &params,
                };
                let image = reference::render(&input, &NoProgress)?;
                let mean = image.mean.iter().map(|m| [m[0], m[1], m[2]]).collect();
                self.rendered.push((model, lit.clone(), mean));
                self.rendered.len() - 1
            }
        };
        let mean = &self.rendered[index].2;
        let (_, rmse, bias, _) = design_error(image, mean, None, self.truth.background)?;
        Ok((rmse, bias))
    }
}

/// Every registered method worth weighing for the lighting (`MethodSpec::weighs`) at each of
/// its chart settings, against the truth and against its own model's reference.
fn methods(truth: &Truth, name: &str, light: LightingMode, setup: &Setup) -> Result<Vec<Point>> {
    let truth_model = Model {
        estimator: light.estimator(),
        g: 0.0,
    };
    let mut models = ModelReferences {
        truth,
        spp: setup.reference_spp,
        truth_model: (truth_model, &truth.scene.lighting),
        rendered: vec![],
    };
    let mut points = vec![];
    for spec in METHODS {
        if !spec.weighs(&truth.scene.lighting) {
            continue;
        }
        let lit = spec.lights_of(&truth.scene.lighting);
        for setting in spec.chart {
            (setup.progress)(&format!("{name} {}: {} {setting}", light.name(), spec.name));
            let method: Method = spec.at_setting(setting)?;
            let input = MethodInput {
                volume: truth.volume,
                classification: &truth.scene.classification,
                lut: truth.lut,
                camera: &truth.scene.camera,
                lighting: &lit,
                compute: setup.compute,
                progress: &NoProgress,
            };
            let (timing, rendered) = timed_keeping(setup.repeats, || method.render(&input))?;
            let (rel_rmse, rel_bias) = truth.error(&rendered.image.rgba)?;
            let (model_rel_rmse, model_rel_bias) = match method.model() {
                Some(model) => {
                    (setup.progress)(&format!(
                        "{name} {}: the reference of {} {setting}",
                        light.name(),
                        spec.name
                    ));
                    let (rmse, bias) = models.error(&rendered.image.rgba, model, &lit)?;
                    (Some(rmse), Some(bias))
                }
                None => (None, None),
            };
            points.push(Point {
                scene: name.to_owned(),
                lighting: light.name(),
                method: spec.name,
                setting: setting.replace('\n', ", "),
                device: setup.compute.describe(),
                seconds: timing.median_ms / 1e3,
                rel_rmse,
                rel_bias,
                model_rel_rmse,
                model_rel_bias,
                pareto: false,
                speedup_vs_cycles: None,
                cycles_reached: None,
                speedup_vs_monte_carlo: None,
            });
        }
    }
    Ok(points)
}

/// Occlux's Monte Carlo at each of `setup.mc_spp`, with another seed than the truth's.
fn mc_curve(truth: &Truth, estimator: Estimator, setup: &Setup) -> Result<Vec<CurvePoint>> {
    setup
        .mc_spp
        .iter()
        .map(|&spp| {
            let (seconds, image) =
                monte_carlo(truth.scene, truth.volume, truth.lut, estimator, spp, 2)?;
            let (rel_rmse, rel_bias) = truth.error(&image.mean)?;
            Ok(CurvePoint {
                spp,
                seconds,
                rel_rmse,
                rel_bias,
            })
        })
        .collect()
}

/// The lit scene written as a scene file for the peers, in its own folder of `setup.work`.
fn lit_scene_file(tree: &Value, name: &str, light: LightingMode, setup: &Setup) -> Result<PathBuf> {
    let folder: PathBuf = setup.work.join(format!("{name}-{}", light.name()));
    std::fs::create_dir_all(&folder).map_err(|e| Error::io(&folder, e))?;
    let scene_file = folder.join(format!("{name}.toml"));
    let text = toml::to_string(tree).map_err(|e| Error::param("chart", e.to_string()))?;
    occlux::export::atomic::write_bytes_atomic(&scene_file, text.as_bytes())?;
    Ok(scene_file)
}

/// A peer's renders as series: its quality axis, then each series of points off it that the
/// peer names (VTK without shadows), in the order they first appear.
fn series_of(
    peer: Peer,
    timing: &str,
    renders: Vec<(peers::Render, CurvePoint)>,
) -> Vec<PeerSeries> {
    let mut all: Vec<PeerSeries> = vec![];
    for (render, p) in renders {
        let name = match &render.series {
            None => peer.label().to_owned(),
            Some(series) => format!("{}, {series}", peer.label()),
        };
        let point = PeerPoint {
            setting: render.setting,
            seconds: p.seconds,
            rel_rmse: p.rel_rmse,
            rel_bias: p.rel_bias,
            speedup_vs_cycles: None,
            speedup_vs_monte_carlo: None,
        };
        match all.iter_mut().find(|s| s.peer == name) {
            Some(series) => series.points.push(point),
            None => all.push(PeerSeries {
                peer: name,
                timing: timing.to_owned(),
                points: vec![point],
            }),
        }
    }
    all
}

/// `peer` on the lit scene file (Cycles at each of `setup.cycles_spp`), each render measured
/// against the truth: what its times include, and its renders with their measurements (spp
/// 0 where the peer has no sample count).
fn peer_series(
    truth: &Truth,
    peer: Peer,
    scene_file: &Path,
    light: LightingMode,
    setup: &Setup,
) -> Result<(String, Vec<(peers::Render, CurvePoint)>)> {
    let folder = scene_file.parent().unwrap_or(setup.work);
    let request = peers::Request {
        scene: scene_file,
        estimator: light.estimator().name(),
        bounces: BOUNCES,
        g: 0.0,
        cycles_spp: setup.cycles_spp,
        out: folder,
    };
    let report = peers::curve(peer, &request).map_err(|e| {
        Error::param(
            "--peers",
            format!("{}: {e} (--peers or --no-peers leaves it out)", peer.name()),
        )
    })?;
    let points = report
        .points
        .into_iter()
        .map(|render| {
            let (rel_rmse, rel_bias) = truth.exr_error(&render.exr)?;
            let point = CurvePoint {
                spp: render.spp.unwrap_or(0),
                seconds: render.seconds,
                rel_rmse,
                rel_bias,
            };
            Ok((render, point))
        })
        .collect::<Result<_>>()?;
    Ok((report.timing, points))
}

/// The Pareto front among the panel's methods, and each one's (and each peer point's) speed-up
/// at equal error.
fn mark(
    points: &mut [Point],
    peers: &mut [PeerSeries],
    monte_carlo: &[CurvePoint],
    cycles: &[CurvePoint],
) {
    let pairs: Vec<(f64, f64)> = points.iter().map(|p| (p.seconds, p.rel_rmse)).collect();
    let curve = |c: &[CurvePoint]| Curve {
        points: c.iter().map(|p| (p.spp, p.seconds, p.rel_rmse)).collect(),
    };
    let (mc, cy) = (curve(monte_carlo), curve(cycles));
    for (point, on_front) in points.iter_mut().zip(pareto::front(&pairs)) {
        point.pareto = on_front;
        if let Some((t, how)) = cy.time_for(point.rel_rmse) {
            point.speedup_vs_cycles = Some(t / point.seconds);
            point.cycles_reached = Some(how);
        }
        point.speedup_vs_monte_carlo = mc.time_for(point.rel_rmse).map(|(t, _)| t / point.seconds);
    }
    for point in peers.iter_mut().flat_map(|s| s.points.iter_mut()) {
        point.speedup_vs_cycles = cy.time_for(point.rel_rmse).map(|(t, _)| t / point.seconds);
        point.speedup_vs_monte_carlo = mc.time_for(point.rel_rmse).map(|(t, _)| t / point.seconds);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree() -> Value {
        toml::from_str(
            "[volume]\npath = \"data/ct.nrrd\"\n[camera]\nposition = [0, -4, 0]\n\
             [[lights]]\ntype = \"ambient\"\nradiance = 0.3\n\
             [[lights]]\ntype = \"directional\"\ndirection = [0, 0, 1]\nirradiance = 3\n\
             [render]\nmethod = \"dos\"\n",
        )
        .unwrap()
    }

    #[test]
    fn a_peer_point_off_its_axis_is_a_series_of_its_own() {
        let render = |setting: &str, series: Option<&str>| {
            let render = peers::Render {
                setting: setting.into(),
                seconds: 1.0,
                exr: "x.exr".into(),
                spp: None,
                series: series.map(str::to_owned),
            };
            let point = CurvePoint {
                spp: 0,
                seconds: 1.0,
                rel_rmse: 0.1,
                rel_bias: 0.0,
            };
            (render, point)
        };
        let renders = vec![
            render("step 1", None),
            render("no shadows", Some("no shadows")),
            render("step 0.5", None),
        ];
        let series = series_of(Peer::Vtk, "one render", renders);
        let names: Vec<&str> = series.iter().map(|s| s.peer.as_str()).collect();
        assert_eq!(names, ["VTK", "VTK, no shadows"]);
        let settings: Vec<&str> = series[0]
            .points
            .iter()
            .map(|p| p.setting.as_str())
            .collect();
        assert_eq!(settings, ["step 1", "step 0.5"]);
        assert!(series.iter().all(|s| s.timing == "one render"));
    }

    #[test]
    fn each_lighting_keeps_its_lights_and_the_volume_is_found_from_anywhere() {
        let base = Path::new("examples");
        let kinds = |t: &Value| -> Vec<String> {
            t["lights"]
                .as_array()
                .unwrap()
                .iter()
                .map(|l| l["type"].as_str().unwrap().to_owned())
                .collect()
        };
        let ambient = LightingMode::Ambient.scene_tree(tree(), base, 24).unwrap();
        assert_eq!(kinds(&ambient), ["ambient"]);
        let sun = LightingMode::Multi.scene_tree(tree(), base, 24).unwrap();
        assert_eq!(kinds(&sun), ["directional"]);
        assert!(sun.get("render").is_none());
        assert_eq!(sun["camera"]["width"], 24);
        let path = PathBuf::from(sun["volume"]["path"].as_str().unwrap());
        assert!(
            path.is_absolute() && path.ends_with("examples/data/ct.nrrd"),
            "{path:?}"
        );
        // No sun: an ambient scene gets radiance 1; a sun lighting cannot be made.
        let mut dark = tree();
        dark["lights"] = Value::Array(vec![]);
        let lit = LightingMode::Ambient
            .scene_tree(dark.clone(), base, 8)
            .unwrap();
        assert_eq!(lit["lights"][0]["radiance"], 1.0);
        let err = LightingMode::Sun.scene_tree(dark, base, 8).unwrap_err();
        assert!(err.to_string().contains("no sun or lamp"), "{err}");
    }
}
