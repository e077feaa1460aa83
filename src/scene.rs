//! The scene file (TOML): volume source, classification, camera, lights, background and the
//! method with its parameters, as one struct tree. Unknown keys and out-of-range values are
//! errors that name the key (and the file).
//!
//! ```toml
//! [volume]
//! path = "../shared/data/scivis/engine.nrrd"   # relative to the scene file; or phantom = "ct"
//! fit = 2.0                                    # scale so the largest extent is 2 world units
//! centre = [0, 0, 0]                           # move the bounding box's centre here
//!
//! [classification]
//! units = "raw"                                # control points in the volume's own values
//! points = [{ value = 60, sigma_t = 0 }, { value = 120, sigma_t = 20, albedo = [0.8, 0.8, 0.8] }]
//!
//! [camera]
//! position = [3.2, -3.2, 2.6]
//! target = [0, 0, 0]
//! lens_mm = 65                                 # or fov_deg (vertical); or projection = "orthographic"
//! width = 256
//! height = 256
//!
//! [[lights]]
//! type = "ambient"
//! radiance = 0.3
//!
//! [[lights]]
//! type = "directional"
//! direction = [-0.3, -1, 1.2]                  # towards the light (where Blender's sun sits)
//! irradiance = 3
//!
//! [render]
//! method = "dos"                               # a registered method (default "gradient")
//! theta_deg = 50                               # that method's parameters
//! ```
//!
//! `[render]` is read through the method registry ([`crate::registry`]): `method` picks the
//! method, whose parameters struct takes the other keys (unknown ones are errors naming the
//! methods that do take them), checked against the registry's ranges. `occlux methods` lists
//! every method with its parameters, defaults and ranges. `method = "auto"` with `error = E`
//! (and optionally `scattering = "multiple"`, `pilot = 64`) leaves the choice to the planner
//! ([`crate::plan`]) when the scene is rendered.

use crate::budget::{Budget, Scattering};
use crate::camera::{Camera, Projection};
use crate::classify::{
    presets, Classification, ControlPoint, TransferFunction, TransferFunction1D,
    TransferFunction2D, ValueRange, ValueUnits, Widget, DEFAULT_LUT_SIZE,
};
use crate::error::{Error, Result};
use crate::lights::{Light, Lighting};
use crate::memory::MemoryLimit;
pub use crate::registry::Method;
use crate::series::FrameSpec;
use crate::volume::{self, phantom, LoadOptions, NonFinite, RawSpec, ScalarType, Volume};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

/// What a render holds per pixel at its peak besides the volume: the image's layers in f32 and
/// their encoding into files (`bench/memory.sh`: about 75 MiB at 1024^2 over the volume).
pub const IMAGE_BYTES_PER_PIXEL: u64 = 80;

/// A scene ready to run: every field validated. What depends on the data (a framed camera, a
/// content centre, a robust window, Hounsfield presets) is settled by [`Scene::load`].
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub volume: VolumeSource,
    pub classification: Classification,
    /// The camera; with `framing`, its direction, projection and image size, placed by
    /// [`Scene::load`].
    pub camera: Camera,
    /// Place the camera so that the visible content fills the frame (`camera.frame`).
    pub framing: Option<Framing>,
    /// A preset given without units: read in Hounsfield units when the file says its values
    /// are HU ([`crate::volume::SourceInfo::hounsfield`]), normalised otherwise.
    pub units_from_data: Option<String>,
    pub lighting: Lighting,
    /// The method; with `auto`, a placeholder that the planner's choice replaces when the
    /// scene is rendered ([`crate::pipeline::settle`]).
    pub method: Method,
    /// `method = "auto"`: what the planner must meet.
    pub auto: Option<Budget>,
}

/// How [`Scene::load`] frames the visible content.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    /// Share of each half of the frame left free around the content.
    pub margin: f32,
}

/// Default `camera.margin`.
pub const DEFAULT_MARGIN: f32 = 0.05;
/// The direction a camera without `position` or `direction` looks from (towards the camera):
/// front right, above, as the examples' cameras.
pub const DEFAULT_DIRECTION: [f32; 3] = [1.0, -1.0, 0.8];

/// Where the volume comes from and how it is placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeSource {
    pub kind: SourceKind,
    pub options: LoadOptions,
    /// Scale so that the largest bounding-box extent is this many world units (`fit = "auto"`:
    /// [`AUTO_FIT`]).
    pub fit: Option<f32>,
    /// Where the bounding box's centre (or the visible content's) goes.
    pub centre: Option<Centre>,
    /// A series' frames (`volume.frames`), resolved against the scene's folder: what `occlux
    /// series` renders when no `--frames` are given. The volume itself is then the first frame
    /// (unless `path` names another), so `occlux render` previews the series.
    pub frames: Option<Vec<PathBuf>>,
}

/// `volume.fit = "auto"`: the longest side, in world units, that the presets' extinctions are
/// made for.
pub const AUTO_FIT: f32 = 2.0;

/// What `volume.centre` moves, and where.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Centre {
    /// The bounding box's centre to this point.
    Point([f32; 3]),
    /// The visible content's centre to the origin (`centre = "content"`).
    Content,
}

/// A scene with its volume loaded and everything that depends on the data settled.
pub struct Loaded {
    /// The scene with its camera framed, its classification's window resolved (in the EXR
    /// header as `occlux/classification`) and Hounsfield presets chosen.
    pub scene: Scene,
    pub volume: Volume,
    /// What was decided from the data, one line each, for the user.
    pub notices: Vec<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SourceKind {
    File(PathBuf),
    Phantom { name: String, size: usize },
}

impl Scene {
    /// Reads and validates a scene file; relative volume paths are resolved against its folder.
    pub fn from_file(path: &Path) -> Result<Self> {
        let (tree, base) = Self::file_tree(path)?;
        Self::from_value(tree, &base).map_err(|e| match e {
            Error::Param { .. } => Error::format(path, e.to_string()),
            other => other,
        })
    }

    /// A scene file's tree, unvalidated, and the folder its relative paths are read from (what
    /// `occlux series` keeps to build each frame's scene).
    pub fn file_tree(path: &Path) -> Result<(Value, PathBuf)> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let tree: toml::Value =
            toml::from_str(&text).map_err(|e| Error::format(path, e.message()))?;
        let tree = json_tree(tree, &mut String::new())
            .map_err(|(key, message)| Error::format(path, format!("`{key}`: {message}")))?;
        Ok((tree, path.parent().unwrap_or(Path::new(".")).to_path_buf()))
    }

    /// Parses and validates scene text; `base` resolves relative paths.
    pub fn parse(text: &str, base: &Path) -> Result<Self> {
        let tree: toml::Value =
            toml::from_str(text).map_err(|e| Error::param("scene", e.message()))?;
        let tree = json_tree(tree, &mut String::new()).map_err(|(key, m)| Error::param(key, m))?;
        Self::from_value(tree, base)
    }

    /// Builds and validates a scene from the scene file's tree in any serde form (a parsed TOML
    /// file, JSON, a Python dict); `base` resolves relative paths. Errors name the key.
    pub fn from_value(tree: Value, base: &Path) -> Result<Self> {
        let file: SceneFile = serde_path_to_error::deserialize(tree)
            .map_err(|e| Error::param(e.path().to_string(), e.inner().to_string()))?;
        file.resolve(base)
    }

    /// The scene as resolved, as JSON: the volume's source and placement, the classification,
    /// the camera (frame, projection, image size), the lights with the background, and the
    /// method with every parameter.
    pub fn describe(&self) -> Value {
        json!({
            "volume": self.volume.describe(),
            "classification": crate::json::tree(&self.classification),
            "camera": self.camera.describe(),
            "lighting": crate::json::tree(&self.lighting),
            "method": match &self.auto {
                Some(budget) => json!({ "method": "auto", "budget": crate::json::tree(budget) }),
                None => self.method.to_json(),
            },
        })
    }

    /// Loads (or generates) the volume and places it in the world, as [`Scene::load`] does,
    /// for a command that renders no image (an import, an export, a bake): its memory check
    /// counts the method's volumes but not the image's layers.
    pub fn load_volume(&self) -> Result<Volume> {
        Ok(self
            .load_holding(self.peak_volumes(), 0, &self.holder())?
            .volume)
    }

    /// [`Scene::load_volume`] for a command other than the scene's render, which holds
    /// `volumes` dense f32 volumes at its peak (`holder` names it in a refusal).
    pub fn load_volume_holding(&self, volumes: f64, holder: &str) -> Result<Volume> {
        Ok(self.load_holding(volumes, 0, holder)?.volume)
    }

    /// Loads (or generates) the volume, places it in the world, and settles what depends on
    /// the data: Hounsfield presets, the classification's window, the content centre and the
    /// framed camera, with a notice for each and for an optical depth too small or large to
    /// show (see [`crate::framing`]). A volume whose render would not fit in memory is
    /// refused before its voxels are read ([`Scene::peak_volumes`]).
    pub fn load(&self) -> Result<Loaded> {
        let holder = self.holder();
        let pixels = u64::from(self.camera.width) * u64::from(self.camera.height);
        self.load_holding(self.peak_volumes(), pixels * IMAGE_BYTES_PER_PIXEL, &holder)
    }

    /// What holds the peak of the scene's own loads, as a refusal names it.
    fn holder(&self) -> String {
        format!("method = \"{}\"", self.method.spec().name)
    }

    /// [`Scene::load`] for a command that holds `volumes` dense f32 volumes and `fixed_bytes`
    /// besides at its peak.
    pub fn load_holding(&self, volumes: f64, fixed_bytes: u64, holder: &str) -> Result<Loaded> {
        let (volume, hounsfield) = self.load_placed(volumes, fixed_bytes, holder)?;
        crate::framing::settle(self, volume, hounsfield.as_deref())
    }

    /// The scene's render's peak memory as a multiple of the dense f32 volume: its method's,
    /// or with `method = "auto"` the largest any registered method takes at its defaults
    /// (the planner may choose any).
    pub fn peak_volumes(&self) -> f64 {
        match self.auto {
            None => self.method.peak_volumes(),
            Some(_) => crate::registry::METHODS
                .iter()
                .filter_map(|spec| spec.at_setting("").ok())
                .map(|method| method.peak_volumes())
                .fold(self.method.peak_volumes(), f64::max),
        }
    }

    /// The volume scaled by `fit` and moved to a `centre` point, and why its values are HU
    /// when its file says so; the memory checked for a command holding `volumes` of it.
    fn load_placed(
        &self,
        volumes: f64,
        fixed_bytes: u64,
        holder: &str,
    ) -> Result<(Volume, Option<String>)> {
        let src = &self.volume;
        let memory = src
            .options
            .memory
            .clone()
            .holding(volumes, fixed_bytes, holder);
        let (mut volume, hounsfield) = match &src.kind {
            SourceKind::File(path) => {
                let options = LoadOptions {
                    memory,
                    ..src.options.clone()
                };
                let (volume, info) = volume::load_with_info(path, &options)?;
                (volume, info.hounsfield)
            }
            SourceKind::Phantom { name, size } => {
                memory.check([*size; 3])?;
                (phantom::by_name(name, *size)?, None)
            }
        };
        if let Some(fit) = src.fit {
            let (lo, hi) = volume.bounds();
            let scale = fit / (hi - lo).max_element();
            volume = Volume::new(
                volume.dims(),
                volume.spacing() * scale,
                volume.origin() * scale,
                volume.into_values(),
            )?;
        }
        if let Some(Centre::Point(centre)) = src.centre {
            volume = volume.with_centre(Vec3::from(centre));
        }
        Ok((volume, hounsfield))
    }
}

// ---- The file's form: serde structs that mirror the TOML. ----

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    volume: VolumeSection,
    #[serde(default)]
    classification: ClassificationSection,
    camera: CameraSection,
    #[serde(default)]
    lights: Vec<LightSection>,
    #[serde(default)]
    background: Option<Colour>,
    /// `method` and that method's parameters (see [`Method::from_table`]).
    #[serde(default)]
    render: Map<String, Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VolumeSection {
    path: Option<PathBuf>,
    phantom: Option<String>,
    size: Option<usize>,
    grid: Option<String>,
    raw: Option<RawSection>,
    fit: Option<NumberOr<f32>>,
    centre: Option<NumberOr<[f32; 3]>>,
    /// Substitute for NaN/infinite values; absent: such values are an error.
    replace_non_finite: Option<f32>,
    memory_budget_gib: Option<f64>,
    /// A series: a shell pattern or folder, or a list of files.
    frames: Option<FrameSpec>,
    /// The time step of a 4-D file to read (0-based).
    time: Option<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSection {
    dims: [usize; 3],
    #[serde(rename = "type")]
    scalar: String,
    #[serde(default = "unit_spacing")]
    spacing: [f32; 3],
    #[serde(default)]
    origin: [f32; 3],
    #[serde(default)]
    big_endian: bool,
    #[serde(default)]
    header_bytes: u64,
}

/// A value or a word (`fit = "auto"`, `centre = "content"`, `frame = "content"`).
#[derive(Deserialize)]
#[serde(untagged)]
enum NumberOr<T> {
    Value(T),
    Word(String),
}

impl<T> NumberOr<T> {
    /// The value, or None for `word`; any other word is an error naming `key`.
    fn value_or(self, key: &str, word: &str) -> Result<Option<T>> {
        match self {
            NumberOr::Value(v) => Ok(Some(v)),
            NumberOr::Word(w) if w == word => Ok(None),
            NumberOr::Word(w) => Err(Error::param(
                key,
                format!("expected a value or \"{word}\", got \"{w}\""),
            )),
        }
    }
}

fn unit_spacing() -> [f32; 3] {
    [1.0; 3]
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ClassificationSection {
    preset: Option<String>,
    units: Option<ValueUnits>,
    range: Option<ValueRange>,
    points: Option<Vec<ControlPoint>>,
    widgets: Option<Vec<Widget>>,
    #[serde(default = "one")]
    density_scale: f32,
    #[serde(default = "default_lut_size")]
    lut_size: usize,
}

impl Default for ClassificationSection {
    fn default() -> Self {
        Self {
            preset: None,
            units: None,
            range: None,
            points: None,
            widgets: None,
            density_scale: 1.0,
            lut_size: DEFAULT_LUT_SIZE,
        }
    }
}

fn one() -> f32 {
    1.0
}
fn default_lut_size() -> usize {
    DEFAULT_LUT_SIZE
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSection {
    #[serde(default)]
    projection: ProjectionKind,
    position: Option<[f32; 3]>,
    /// From the target towards the camera, for a framed camera.
    direction: Option<[f32; 3]>,
    frame: Option<String>,
    margin: Option<f32>,
    #[serde(default)]
    target: [f32; 3],
    #[serde(default = "z_up")]
    up: [f32; 3],
    fov_deg: Option<f32>,
    lens_mm: Option<f32>,
    sensor_mm: Option<f32>,
    ortho_scale: Option<f32>,
    #[serde(default = "default_side")]
    width: u32,
    #[serde(default = "default_side")]
    height: u32,
}

fn z_up() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}
fn default_side() -> u32 {
    512
}

#[derive(Deserialize, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum ProjectionKind {
    #[default]
    Perspective,
    Orthographic,
}

/// A TOML tree as the JSON tree the scene is read from. TOML has `nan` and `inf`, JSON has
/// neither: serde's conversion turns them into null, which an optional key reads as absent, so
/// `background = nan` became the default unnoticed. They are refused here with the key (`key`
/// is the path so far, as serde_path_to_error writes it).
fn json_tree(value: toml::Value, key: &mut String) -> std::result::Result<Value, (String, String)> {
    let at = |key: &str| {
        if key.is_empty() {
            "scene".to_owned()
        } else {
            key.to_owned()
        }
    };
    Ok(match value {
        toml::Value::Float(v) if !v.is_finite() => {
            return Err((
                at(key),
                format!("{v} is not a value a scene takes: numbers must be finite"),
            ))
        }
        toml::Value::Float(v) => json!(v),
        toml::Value::Integer(v) => json!(v),
        toml::Value::String(v) => Value::String(v),
        toml::Value::Boolean(v) => Value::Bool(v),
        toml::Value::Datetime(v) => Value::String(v.to_string()),
        toml::Value::Array(items) => {
            let mut out = Vec::with_capacity(items.len());
            for (i, item) in items.into_iter().enumerate() {
                let length = key.len();
                key.push_str(&format!("[{i}]"));
                out.push(json_tree(item, key)?);
                key.truncate(length);
            }
            Value::Array(out)
        }
        toml::Value::Table(table) => {
            let mut out = Map::new();
            for (name, item) in table {
                let length = key.len();
                if !key.is_empty() {
                    key.push('.');
                }
                key.push_str(&name);
                out.insert(name, json_tree(item, key)?);
                key.truncate(length);
            }
            Value::Object(out)
        }
    })
}

/// A grey level or an RGB triple, every value finite and >= 0 as an f32. Read by hand rather
/// than as an untagged enum, whose error ("data did not match any variant") names neither the
/// value nor what was wanted.
#[derive(Clone, Copy)]
struct Colour(Vec3);

impl Colour {
    fn rgb(self) -> Vec3 {
        self.0
    }
}

impl<'de> Deserialize<'de> for Colour {
    fn deserialize<D: serde::Deserializer<'de>>(
        deserializer: D,
    ) -> std::result::Result<Self, D::Error> {
        use serde::de::{Error as _, SeqAccess, Visitor};
        struct Expect;
        fn checked<E: serde::de::Error>(value: f64) -> std::result::Result<f32, E> {
            let narrowed = value as f32;
            if narrowed.is_finite() && narrowed >= 0.0 {
                Ok(narrowed)
            } else {
                Err(E::custom(format!(
                    "{value} is not a colour value: each must be finite, >= 0 and at most {:e}",
                    f32::MAX
                )))
            }
        }
        impl<'de> Visitor<'de> for Expect {
            type Value = Colour;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a grey level or [r, g, b], finite and >= 0")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> std::result::Result<Colour, E> {
                checked(v).map(|g| Colour(Vec3::splat(g)))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> std::result::Result<Colour, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> std::result::Result<Colour, E> {
                self.visit_f64(v as f64)
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Colour, A::Error> {
                let mut rgb = Vec::with_capacity(3);
                while let Some(v) = seq.next_element::<f64>()? {
                    rgb.push(checked::<A::Error>(v)?);
                }
                match rgb[..] {
                    [r, g, b] => Ok(Colour(Vec3::new(r, g, b))),
                    _ => Err(A::Error::custom(format!(
                        "a colour takes 3 values [r, g, b], got {}",
                        rgb.len()
                    ))),
                }
            }
        }
        deserializer.deserialize_any(Expect)
    }
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightSection {
    Ambient {
        radiance: Colour,
    },
    Directional {
        direction: [f32; 3],
        irradiance: Colour,
    },
    Point {
        position: [f32; 3],
        intensity: Colour,
    },
}

impl SceneFile {
    fn resolve(mut self, base: &Path) -> Result<Scene> {
        let (classification, units_from_data) = self.classification.resolve()?;
        let (camera, framing) = self.camera.resolve()?;
        let auto = auto_budget(&mut self.render)?;
        let method = Method::from_table(self.render)?;
        let scene = Scene {
            volume: self.volume.resolve(base)?,
            classification,
            camera,
            framing,
            units_from_data,
            lighting: Lighting {
                lights: self
                    .lights
                    .into_iter()
                    .enumerate()
                    .map(|(i, l)| l.resolve(i))
                    .collect::<Result<_>>()?,
                background: self.background.map_or(Vec3::ZERO, Colour::rgb),
            },
            auto,
            method,
        };
        scene.lighting.validate()?;
        // A method lit by fewer kinds of light than the scene has is refused here, not after
        // the volume has loaded; the planner picks among those that render some of them.
        if scene.auto.is_none() {
            scene.method.spec().check_lights(&scene.lighting)?;
        }
        Ok(scene)
    }
}

/// `method = "auto"`: takes its keys (`error`, `scattering`, `pilot`) out of `[render]`,
/// leaving it empty for the placeholder method; None for any other method.
fn auto_budget(render: &mut Map<String, Value>) -> Result<Option<Budget>> {
    if render.get("method").and_then(Value::as_str) != Some("auto") {
        return Ok(None);
    }
    render.remove("method");
    let error = match render.remove("error") {
        Some(Value::Number(n)) => n.as_f64().unwrap_or(f64::NAN),
        Some(other) => {
            return Err(Error::param(
                "render.error",
                format!("must be a number, got {other}"),
            ))
        }
        None => {
            return Err(Error::param(
                "render.error",
                "method = \"auto\" needs an error budget: the largest relative RMSE against \
                 the path-traced truth, e.g. error = 0.05",
            ))
        }
    };
    let scattering = match render.remove("scattering") {
        None => Scattering::Single,
        Some(Value::String(name)) => Scattering::from_name(&name).ok_or_else(|| {
            Error::param(
                "render.scattering",
                format!("must be \"single\" or \"multiple\", got \"{name}\""),
            )
        })?,
        Some(other) => {
            return Err(Error::param(
                "render.scattering",
                format!("must be \"single\" or \"multiple\", got {other}"),
            ))
        }
    };
    let mut budget = Budget::new(error, scattering);
    if let Some(pilot) = render.remove("pilot") {
        budget.pilot = pilot
            .as_u64()
            .and_then(|p| u32::try_from(p).ok())
            .ok_or_else(|| {
                Error::param(
                    "render.pilot",
                    format!("must be a whole number of pixels, got {pilot}"),
                )
            })?;
    }
    if let Some(key) = render.keys().next() {
        return Err(Error::param(
            format!("render.{key}"),
            "method = \"auto\" takes error, scattering and pilot; the planner sets the rest",
        ));
    }
    budget.validate().map_err(|e| match e {
        Error::Param { key, message } => Error::param(format!("render.{key}"), message),
        other => other,
    })?;
    Ok(Some(budget))
}

impl VolumeSource {
    /// Where the volume comes from and how it is placed, as JSON.
    pub fn describe(&self) -> Value {
        let source = match &self.kind {
            SourceKind::File(path) => json!({ "path": path, "grid": self.options.grid }),
            SourceKind::Phantom { name, size } => json!({ "phantom": name, "size": size }),
        };
        json!({
            "source": source,
            "fit": crate::json::tree(&self.fit),
            "centre": crate::json::tree(&self.centre),
        })
    }
}

impl VolumeSection {
    fn resolve(self, base: &Path) -> Result<VolumeSource> {
        let frames = match &self.frames {
            Some(spec) => Some(spec.resolve(base).map_err(|e| match e {
                Error::Param { message, .. } => Error::param("volume.frames", message),
                other => other,
            })?),
            None => None,
        };
        let first_frame = frames.as_ref().map(|f| f[0].clone());
        let kind = match (self.path.or(first_frame), self.phantom) {
            (Some(path), None) => SourceKind::File(base.join(path)),
            (None, Some(name)) => {
                let size = self.size.unwrap_or(64);
                phantom::check_name(&name)?;
                if !(2..=phantom::MAX_SIDE).contains(&size) {
                    return Err(Error::param(
                        "volume.size",
                        format!("must be in 2..={}, got {size}", phantom::MAX_SIDE),
                    ));
                }
                SourceKind::Phantom { name, size }
            }
            _ => {
                return Err(Error::param(
                    "volume",
                    "give exactly one of `path` (a volume file) or `phantom` (a built-in)",
                ))
            }
        };
        let fit = match self.fit {
            Some(fit) => Some(fit.value_or("volume.fit", "auto")?.unwrap_or(AUTO_FIT)),
            None => None,
        };
        if let Some(fit) = fit {
            if !(fit > 0.0 && fit.is_finite()) {
                return Err(Error::param(
                    "volume.fit",
                    format!("must be positive, got {fit}"),
                ));
            }
        }
        let centre = match self.centre {
            Some(c) => Some(
                c.value_or("volume.centre", "content")?
                    .map_or(Centre::Content, Centre::Point),
            ),
            None => None,
        };
        if matches!(centre, Some(Centre::Point(c)) if !Vec3::from(c).is_finite()) {
            return Err(Error::param("volume.centre", "must be finite"));
        }
        let mut options = LoadOptions {
            grid: self.grid,
            frame: self.time,
            ..LoadOptions::default()
        };
        if let Some(x) = self.replace_non_finite {
            if !x.is_finite() {
                return Err(Error::param("volume.replace_non_finite", "must be finite"));
            }
            options.non_finite = NonFinite::Replace(x);
        }
        if let Some(gib) = self.memory_budget_gib {
            if !(gib > 0.0 && gib.is_finite()) {
                return Err(Error::param(
                    "volume.memory_budget_gib",
                    format!("must be positive, got {gib}"),
                ));
            }
            let bytes = (gib * (1u64 << 30) as f64) as u64;
            options.memory.limit = MemoryLimit::Bytes(bytes, "volume.memory_budget_gib");
        }
        if let Some(raw) = self.raw {
            options.raw = Some(RawSpec {
                dims: raw.dims,
                scalar: ScalarType::from_name(&raw.scalar).ok_or_else(|| {
                    Error::param("volume.raw.type", format!("unknown type '{}'", raw.scalar))
                })?,
                spacing: Vec3::from(raw.spacing),
                origin: Vec3::from(raw.origin),
                big_endian: raw.big_endian,
                header_bytes: raw.header_bytes,
            });
        }
        Ok(VolumeSource {
            kind,
            options,
            fit,
            centre,
            frames,
        })
    }
}

impl ClassificationSection {
    /// The classification, and the preset to read in Hounsfield units if the data says so
    /// (a preset without `units`).
    fn resolve(self) -> Result<(Classification, Option<String>)> {
        let units = self.units.unwrap_or_default();
        let user = |tf| Classification {
            tf,
            units,
            density_scale: 1.0,
            lut_size: DEFAULT_LUT_SIZE,
            range: ValueRange::default(),
        };
        let (mut c, from_data) = match (self.preset, self.points, self.widgets) {
            (Some(name), None, None) => {
                let c = presets::preset_in(&name, units)?;
                let from_data =
                    (self.units.is_none() && presets::HU_PRESETS.contains(&&*name)).then_some(name);
                (c, from_data)
            }
            (None, Some(points), None) => (
                user(TransferFunction::OneD(TransferFunction1D::new(points)?)),
                None,
            ),
            (None, None, Some(widgets)) => (
                user(TransferFunction::TwoD(TransferFunction2D::new(widgets)?)),
                None,
            ),
            (None, None, None) => (presets::preset("ct-bone")?, None),
            _ => {
                return Err(Error::param(
                    "classification",
                    "give one of `preset`, `points` (1D) or `widgets` (2D)",
                ))
            }
        };
        if let Some(range) = self.range {
            if c.units != ValueUnits::Normalized {
                return Err(Error::param(
                    "classification.range",
                    "only for normalised units: raw and HU values need no window",
                ));
            }
            c.range = range;
        }
        c.density_scale = self.density_scale;
        c.lut_size = self.lut_size;
        c.validate()?;
        Ok((c, from_data))
    }
}

impl CameraSection {
    /// The camera, and how to frame it once the volume is known: without `position` the
    /// content is framed from `direction`; `frame = "content"` frames it from `position`'s
    /// direction.
    fn resolve(self) -> Result<(Camera, Option<Framing>)> {
        let target = Vec3::from(self.target);
        let frame = match self.frame.as_deref() {
            None => self.position.is_none(),
            Some("content") => true,
            Some("none") => false,
            Some(other) => {
                return Err(Error::param(
                    "camera.frame",
                    format!("expected \"content\" or \"none\", got \"{other}\""),
                ))
            }
        };
        let position = match (self.position, self.direction) {
            (Some(_), Some(_)) => {
                return Err(Error::param(
                    "camera.direction",
                    "give position or direction, not both",
                ))
            }
            (Some(p), None) => Vec3::from(p),
            (None, direction) if frame => {
                let d = Vec3::from(direction.unwrap_or(DEFAULT_DIRECTION));
                if !d.is_finite() || d.length() == 0.0 {
                    return Err(Error::param(
                        "camera.direction",
                        "must be a finite non-zero vector",
                    ));
                }
                // Provisional: `Scene::load` moves it to frame the content.
                target + d.normalize() * 4.0
            }
            (None, _) => {
                return Err(Error::param(
                    "camera.position",
                    "needed unless the camera frames the content (frame = \"content\")",
                ))
            }
        };
        let margin = self.margin.unwrap_or(DEFAULT_MARGIN);
        if !(0.0..0.5).contains(&margin) {
            return Err(Error::param(
                "camera.margin",
                format!("must be in [0, 0.5), got {margin}"),
            ));
        }
        if self.margin.is_some() && !frame {
            return Err(Error::param(
                "camera.margin",
                "only for a framed camera (frame = \"content\", or no position)",
            ));
        }
        let framing = frame.then_some(Framing { margin });
        let projection = match self.projection {
            ProjectionKind::Perspective => {
                if self.ortho_scale.is_some() {
                    return Err(Error::param(
                        "camera.ortho_scale",
                        "only for projection = \"orthographic\"",
                    ));
                }
                let fov_y = match (self.fov_deg, self.lens_mm) {
                    (Some(deg), None) => {
                        if self.sensor_mm.is_some() {
                            return Err(Error::param("camera.sensor_mm", "only with lens_mm"));
                        }
                        deg.to_radians()
                    }
                    (None, Some(lens)) => Camera::fov_y_from_lens(
                        lens,
                        self.sensor_mm.unwrap_or(36.0),
                        self.width,
                        self.height,
                    )?,
                    (None, None) => 40f32.to_radians(),
                    (Some(_), Some(_)) => {
                        return Err(Error::param(
                            "camera.fov_deg",
                            "give fov_deg or lens_mm, not both",
                        ))
                    }
                };
                Projection::Perspective { fov_y }
            }
            ProjectionKind::Orthographic => {
                if self.fov_deg.is_some() || self.lens_mm.is_some() {
                    return Err(Error::param(
                        "camera.fov_deg",
                        "fov_deg and lens_mm are only for perspective cameras",
                    ));
                }
                Projection::Orthographic {
                    scale: self.ortho_scale.unwrap_or(2.0),
                }
            }
        };
        let camera = Camera::look_at(
            position,
            target,
            Vec3::from(self.up),
            projection,
            self.width,
            self.height,
        )?;
        Ok((camera, framing))
    }
}

impl LightSection {
    fn resolve(self, index: usize) -> Result<Light> {
        Ok(match self {
            LightSection::Ambient { radiance } => Light::Ambient {
                radiance: radiance.rgb(),
            },
            LightSection::Directional {
                direction,
                irradiance,
            } => {
                let d = Vec3::from(direction);
                if !d.is_finite() || d.length() == 0.0 {
                    return Err(Error::param(
                        format!("lights[{index}].direction"),
                        "must be a finite non-zero vector",
                    ));
                }
                Light::Directional {
                    to_light: d.normalize(),
                    irradiance: irradiance.rgb(),
                }
            }
            LightSection::Point {
                position,
                intensity,
            } => Light::Point {
                position: Vec3::from(position),
                intensity: intensity.rgb(),
            },
        })
    }
}
