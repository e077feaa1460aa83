//! Time series and batches (`occlux series`): one scene over many volumes, every frame lit and
//! classified the same way, written as one numbered sequence that Blender plays as an animated
//! Volume: `OUT/NAME_0001.vdb`, `OUT/NAME_0001.exr` (and `.png`), ..., and one USD stage
//! `OUT/NAME.usda` whose grids are time samples.
//!
//! Work comes in three steps, so that frames can run anywhere: [`plan`] reads every frame once
//! (refusing frames of other dims or spacing before any work), fixes what must not flicker from
//! frame to frame (the classification's window, as the union of each frame's window; the
//! camera framing the content of every frame; the content's centre) and writes the manifest
//! ([`Manifest`]); [`run_frame`] renders one frame from the manifest alone, writing its files as
//! one atomic set, and skips a frame whose files are all there (so a rerun resumes); [`finish`]
//! writes the stage once every frame is complete. `occlux series` runs the frames in order on
//! this machine; the Python package runs them as Dask tasks (`occlux.series`).

pub mod frames;
mod manifest;

pub use frames::FrameSpec;
pub use manifest::{FrameEntry, Manifest, RawPoint, Resume, Settings};

use crate::ao::{self, AoVolumeParams};
use crate::classify::{ValueRange, ValueUnits, Window};
use crate::error::{Error, Result};
use crate::export::atomic::{check_writable, OutputSet};
use crate::export::exr::{render_layers, Precision};
use crate::export::usd::{write_usda, StageDescription};
use crate::export::vdb::{write_vdb, Compression, VdbOptions};
use crate::framing::{self, Content};
use crate::gpu::Compute;
use crate::pipeline::{self, header_metadata, OutputOptions, Settled, EXPORT_GRIDS};
use crate::progress::{NoProgress, Progress, Report};
use crate::render::ao_shaded::AO_GRID;
use crate::scene::{Centre, Scene, SourceKind};
use crate::volume::{self, LoadOptions, Volume};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// What a series writes for each frame; as data (the manifest, the Python package's keyword
/// arguments) any key left out takes its default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SeriesOptions {
    /// The render: `NAME_0001.exr` (layers as `occlux render`) and its PNG preview.
    pub render: bool,
    /// The grids: `NAME_0001.vdb` (`density`, `value`, the method's grids, `ao`), and the
    /// stage `NAME.usda`.
    pub export: bool,
    /// An AO volume per frame into the VDB's `ao` grid, by this `occlux ao --method`.
    pub ao: Option<String>,
    /// VAO's tangent-sphere radius in voxels (`--ao` with a VAO method).
    pub ao_radius: u32,
    /// zlib on the VDB values.
    pub zip: bool,
    /// VDB values as half floats.
    pub half: bool,
    /// EXR channels as float32.
    pub float32: bool,
    /// Exposure of the PNG preview.
    pub exposure: f32,
}

impl Default for SeriesOptions {
    fn default() -> Self {
        Self {
            render: true,
            export: true,
            ao: None,
            ao_radius: AoVolumeParams::default().radius,
            zip: true,
            half: false,
            float32: false,
            exposure: 1.0,
        }
    }
}

impl SeriesOptions {
    /// Checks the options before any frame is read.
    pub fn validate(&self) -> Result<()> {
        if !self.render && !self.export {
            return Err(Error::param(
                "series",
                "nothing to write: ask for the render, the export or both",
            ));
        }
        if self.ao.is_some() && !self.export {
            return Err(Error::param(
                "ao",
                "the AO volume goes into each frame's VDB: it needs the export",
            ));
        }
        self.output().validate()?;
        self.ao_params().map(|_| ())
    }

    /// The AO volume's parameters, with `--ao`.
    pub fn ao_params(&self) -> Result<Option<AoVolumeParams>> {
        let Some(method) = &self.ao else {
            return Ok(None);
        };
        let params = AoVolumeParams {
            method: method.parse()?,
            radius: self.ao_radius,
            ..AoVolumeParams::default()
        };
        params.validate()?;
        Ok(Some(params))
    }

    fn output(&self) -> OutputOptions {
        OutputOptions {
            precision: if self.float32 {
                Precision::Float
            } else {
                Precision::Half
            },
            exposure: self.exposure,
        }
    }

    fn vdb(&self) -> VdbOptions {
        VdbOptions {
            compression: if self.zip {
                Compression::Zip
            } else {
                Compression::None
            },
            half: self.half,
        }
    }
}

/// The file of frame `number` of series `name` with extension `ext`: `NAME_0001.vdb`, the
/// numbering Blender reads as a sequence.
pub fn frame_file(name: &str, number: u32, ext: &str) -> String {
    format!("{name}_{number:04}.{ext}")
}

/// Reads every frame once and writes the manifest into `out_dir` (or resumes the one there):
/// `tree` is the scene file's tree and `base` its folder; `frames` overrides the scene's
/// `volume.frames`. Frames of other dims or spacing than the first are refused here, naming
/// them. Says what it fixed across the frames to `report`.
pub fn plan(
    tree: Value,
    base: &Path,
    frames: Option<Vec<PathBuf>>,
    name: &str,
    out_dir: &Path,
    options: &SeriesOptions,
    report: &dyn Report,
) -> Result<(Manifest, Resume)> {
    options.validate()?;
    crate::export::usd::check_prim_name(name).map_err(|_| {
        Error::param(
            "name",
            format!("'{name}' cannot name a series: use letters, digits and '_'"),
        )
    })?;
    check_writable(out_dir)?;
    let base = std::path::absolute(base).map_err(|e| Error::io(base, e))?;
    let scene = Scene::from_value(with_frames_of(&tree, &frames), &base)?;
    if scene.auto.is_some() {
        // One method for every frame, so that frames differ only by their data.
        return Err(Error::param(
            "render.method",
            "\"auto\" plans one volume, and a series renders every frame with one method: \
             run `occlux plan` on a frame and put its choice in the scene",
        ));
    }
    // Each frame sets its own path; the frames are the manifest's.
    let mut tree = tree;
    if let Some(volume) = tree.get_mut("volume").and_then(Value::as_object_mut) {
        volume.remove("frames");
    }
    let files = match (
        frames.or_else(|| scene.volume.frames.clone()),
        &scene.volume.kind,
    ) {
        (Some(list), _) => list,
        // No frames named: the scene's own file, a 4-D file's time steps.
        (None, SourceKind::File(path)) => vec![path.clone()],
        (None, SourceKind::Phantom { .. }) => {
            return Err(Error::param(
                "frames",
                "no frames: give --frames (a pattern, a folder or files) or volume.frames",
            ))
        }
    };
    let sources = time_steps(&files, &scene)?;
    let fixed = fix_across(&tree, &base, &scene, &sources, report)?;
    let grids = if options.export {
        grid_names(&scene, options)?
    } else {
        Vec::new()
    };
    let entries = sources
        .iter()
        .zip(1u32..)
        .map(|((source, time), number)| FrameEntry {
            frame: number,
            source: source.clone(),
            time: *time,
            vdb: options.export.then(|| frame_file(name, number, "vdb")),
            exr: options.render.then(|| frame_file(name, number, "exr")),
            png: options.render.then(|| frame_file(name, number, "png")),
        })
        .collect::<Vec<_>>();
    let manifest = Manifest {
        occlux_series: manifest::FORMAT,
        name: name.to_owned(),
        first_frame: 1,
        count: entries.len(),
        frames: entries,
        grids,
        raw_points: fixed.raw_points,
        stage: options.export.then(|| format!("{name}.usda")),
        settings: Settings {
            scene: tree,
            base,
            options: options.clone(),
            window: fixed.window,
            camera: fixed.scene.camera,
            centre: fixed.centre,
            dims: fixed.dims,
            spacing: fixed.spacing,
            bounds: fixed.bounds,
        },
    };
    let resume = manifest.write_or_resume(out_dir)?;
    Ok((manifest, resume))
}

/// A frame's file and, in a 4-D file, its time step.
type Source = (PathBuf, Option<usize>);

/// Every frame of `files` (absolute): a 3-D file is one, a 4-D NRRD or NIfTI file one per time
/// step, in order.
fn time_steps(files: &[PathBuf], scene: &Scene) -> Result<Vec<Source>> {
    let mut sources = Vec::with_capacity(files.len());
    for file in files {
        let path = std::path::absolute(file).map_err(|e| Error::io(file, e))?;
        let options = LoadOptions {
            frame: None,
            ..scene.volume.options.clone()
        };
        match volume::frame_count(&path, &options)? {
            1 => sources.push((path, None)),
            steps => sources.extend((0..steps).map(|t| (path.clone(), Some(t)))),
        }
    }
    Ok(sources)
}

/// The scene tree with a volume path, so that a scene whose only source is `--frames` parses:
/// the first frame stands in until each frame sets its own.
fn with_frames_of(tree: &Value, frames: &Option<Vec<PathBuf>>) -> Value {
    let mut tree = tree.clone();
    if let (Some(first), Some(volume)) = (
        frames.as_ref().and_then(|f| f.first()),
        tree.get_mut("volume").and_then(Value::as_object_mut),
    ) {
        if !volume.contains_key("phantom") {
            volume.insert("path".into(), Value::from(first.to_string_lossy().as_ref()));
        }
        // The frames given override the scene's own, which are then not looked for.
        volume.remove("frames");
    }
    tree
}

/// What the plan fixes across the frames.
struct Fixed {
    scene: Scene,
    window: Option<Window>,
    centre: Option<[f32; 3]>,
    raw_points: Option<Vec<RawPoint>>,
    dims: [usize; 3],
    spacing: [f32; 3],
    bounds: [[f32; 3]; 2],
}

/// Reads every frame: checks their grids agree with the first's, fixes the window as the
/// union of each frame's own, and frames the camera (and centres the content) on the union of
/// every frame's visible content, so nothing moves or flickers but the data.
fn fix_across(
    tree: &Value,
    base: &Path,
    scene: &Scene,
    sources: &[Source],
    report: &dyn Report,
) -> Result<Fixed> {
    let needs_window = scene.classification.units == ValueUnits::Normalized
        && !matches!(scene.classification.range, ValueRange::Window(_));
    let needs_content = scene.framing.is_some() || scene.volume.centre == Some(Centre::Content);
    let bar = report.stage("reading frames", sources.len() as u64);
    let mut grid: Option<(PathBuf, Volume)> = None;
    let mut window: Option<Window> = None;
    let mut template: Option<Scene> = None;
    for (n, (source, time)) in sources.iter().enumerate() {
        let frame = frame_scene_from(tree, base, source, *time)?;
        let loaded = without_data_choices(&frame).load()?;
        check_same_grid(&grid, source, &loaded.volume)?;
        if let ValueRange::Window(w) = loaded.scene.classification.range {
            window = Some(window.map_or(w, |u| union(u, w)));
        }
        if grid.is_none() {
            grid = Some((source.clone(), loaded.volume));
            template = Some(loaded.scene);
        }
        bar.update(n as u64 + 1, sources.len() as u64);
    }
    drop(bar);
    let (_, first) = grid.ok_or_else(|| Error::param("frames", "the series has no frames"))?;
    let mut fixed_scene = template.expect("set with the first frame");
    // Units as settled on the data (a preset read in HU stays HU), framing and centre as asked.
    fixed_scene.framing = scene.framing;
    fixed_scene.volume.centre = scene.volume.centre;
    let window = (fixed_scene.classification.units == ValueUnits::Normalized)
        .then_some(window)
        .flatten();
    if let Some(w) = window {
        fixed_scene.classification.range = ValueRange::Window(w);
        if needs_window {
            report.say(&format!(
                "classification: normalised 0..1 on values {} .. {}, fixed across {} frames \
                     (the union of each frame's window)",
                w.lo,
                w.hi,
                sources.len()
            ));
        }
    }
    let (box_lo, box_hi) = first.bounds();
    let mut centre = match scene.volume.centre {
        Some(Centre::Point(p)) => Some(p),
        _ => None,
    };
    if needs_content {
        let content = content_across(tree, base, &fixed_scene, sources, report)?;
        let (mut lo, mut hi) = content.map_or((box_lo, box_hi), |c| (c.lo, c.hi));
        if scene.volume.centre == Some(Centre::Content) {
            let shift = -0.5 * (lo + hi);
            centre = Some((0.5 * (box_lo + box_hi) + shift).to_array());
            (lo, hi) = (lo + shift, hi + shift);
        }
        if let Some(framing) = scene.framing {
            fixed_scene.camera = fixed_scene.camera.framing(lo, hi, framing.margin)?;
            report.say(&format!(
                "camera: frames the visible content of every frame, [{:.3}, {:.3}, {:.3}] .. \
                     [{:.3}, {:.3}, {:.3}]",
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
            ));
        }
    }
    let shift = centre.map_or(Vec3::ZERO, |c| Vec3::from(c) - 0.5 * (box_lo + box_hi));
    let raw_points = fixed_scene.classification.raw_points(&first).map(|points| {
        points
            .into_iter()
            .map(|p| (p.value, p.sigma_t, p.albedo, p.emission))
            .collect()
    });
    Ok(Fixed {
        scene: fixed_scene,
        window,
        centre,
        raw_points,
        dims: first.dims(),
        spacing: first.spacing().to_array(),
        bounds: [(box_lo + shift).to_array(), (box_hi + shift).to_array()],
    })
}

/// The union of the visible content of every frame under the fixed classification; None when
/// no frame has any.
fn content_across(
    tree: &Value,
    base: &Path,
    fixed: &Scene,
    sources: &[Source],
    report: &dyn Report,
) -> Result<Option<Content>> {
    let bar = report.stage("framing frames", sources.len() as u64);
    let mut union: Option<Content> = None;
    for (n, (source, time)) in sources.iter().enumerate() {
        let mut frame = without_data_choices(&frame_scene_from(tree, base, source, *time)?);
        frame.classification = fixed.classification.clone();
        let volume = frame.load()?.volume;
        if let Some(c) = framing::content(&volume, &frame.classification) {
            union = Some(union.map_or(c, |u| Content {
                lo: u.lo.min(c.lo),
                hi: u.hi.max(c.hi),
                typical_sigma_t: u.typical_sigma_t,
            }));
        }
        bar.update(n as u64 + 1, sources.len() as u64);
    }
    drop(bar);
    Ok(union)
}

/// A frame's scene with no framing and no content centre: what is settled per frame then is
/// only its window and units (framing and centre are fixed across frames).
fn without_data_choices(scene: &Scene) -> Scene {
    let mut scene = scene.clone();
    scene.framing = None;
    if scene.volume.centre == Some(Centre::Content) {
        scene.volume.centre = None;
    }
    scene
}

/// The window covering both.
fn union(a: Window, b: Window) -> Window {
    Window {
        lo: a.lo.min(b.lo),
        hi: a.hi.max(b.hi),
        // Wrapped values are cut from the lowest cut found on any frame.
        cut: match (a.cut, b.cut) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        },
    }
}

/// Frames must share the first frame's grid: a sequence of different grids would not play as
/// one Volume, nor share one classification and camera.
fn check_same_grid(
    first: &Option<(PathBuf, Volume)>,
    source: &Path,
    volume: &Volume,
) -> Result<()> {
    let Some((path, reference)) = first else {
        return Ok(());
    };
    let what = if reference.dims() != volume.dims() {
        Some(format!(
            "dims {:?} against {:?}",
            volume.dims(),
            reference.dims()
        ))
    } else if (reference.spacing() - volume.spacing()).abs().max_element()
        > 1e-5 * reference.spacing().max_element()
    {
        Some(format!(
            "spacing {:?} against {:?}",
            volume.spacing().to_array(),
            reference.spacing().to_array()
        ))
    } else {
        None
    };
    match what {
        Some(what) => Err(Error::format(
            source,
            format!(
                "this frame has {what} of the first frame {}: a series needs one grid",
                path.display()
            ),
        )),
        None => Ok(()),
    }
}

/// The grids each frame's VDB holds.
fn grid_names(scene: &Scene, options: &SeriesOptions) -> Result<Vec<String>> {
    let mut names: Vec<String> = EXPORT_GRIDS.iter().map(|g| g.to_string()).collect();
    names.extend(scene.method.grids().iter().map(|g| g.to_string()));
    if options.ao.is_some() {
        if names.iter().any(|g| g == AO_GRID) {
            return Err(Error::param(
                "ao",
                "the scene's method already computes the ao grid; leave out --ao",
            ));
        }
        names.push(AO_GRID.to_owned());
    }
    Ok(names)
}

/// The scene of one frame: the tree with `volume.path` set to the frame's file (and
/// `volume.time` to its time step in a 4-D file).
fn frame_scene_from(
    tree: &Value,
    base: &Path,
    source: &Path,
    time: Option<usize>,
) -> Result<Scene> {
    let mut tree = tree.clone();
    let volume = tree
        .get_mut("volume")
        .and_then(Value::as_object_mut)
        .ok_or_else(|| Error::param("volume", "the scene has no [volume] table"))?;
    volume.remove("phantom");
    volume.insert(
        "path".into(),
        Value::from(source.to_string_lossy().as_ref()),
    );
    match time {
        Some(t) => volume.insert("time".into(), Value::from(t)),
        None => volume.remove("time"),
    };
    Scene::from_value(tree, base)
}

impl Manifest {
    /// Frame `number`'s scene with everything fixed across the series applied.
    pub fn frame_scene(&self, entry: &FrameEntry) -> Result<Scene> {
        let s = &self.settings;
        let mut scene = frame_scene_from(&s.scene, &s.base, &entry.source, entry.time)?;
        if let Some(w) = s.window {
            scene.classification.range = ValueRange::Window(w);
        }
        scene.camera = s.camera;
        scene.framing = None;
        scene.volume.centre = s.centre.map(Centre::Point);
        Ok(scene)
    }

    /// The entry of frame `number`.
    pub fn entry(&self, number: u32) -> Result<&FrameEntry> {
        self.frames
            .iter()
            .find(|f| f.frame == number)
            .ok_or_else(|| {
                Error::param(
                    "frame",
                    format!(
                        "series '{}' has frames {}..{}, not {number}",
                        self.name,
                        self.first_frame,
                        self.first_frame as usize + self.count - 1
                    ),
                )
            })
    }
}

/// What [`run_frame`] did.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameOutcome {
    /// The frame's files, written.
    Written(Vec<PathBuf>),
    /// Every file of the frame was already there (an earlier run wrote them as one set).
    Complete,
}

/// Renders frame `number` of the series in `out_dir` from its manifest and writes its files
/// as one atomic set; a frame whose files are all there already is left as it is.
pub fn run_frame(
    manifest: &Manifest,
    out_dir: &Path,
    number: u32,
    compute: &Compute,
    progress: &dyn Progress,
) -> Result<FrameOutcome> {
    let entry = manifest.entry(number)?;
    if entry.files().all(|f| out_dir.join(f).is_file()) {
        return Ok(FrameOutcome::Complete);
    }
    let s = &manifest.settings;
    let loaded = manifest.frame_scene(entry)?.load()?;
    let (scene, volume) = (&loaded.scene, &loaded.volume);
    if volume.dims() != s.dims {
        return Err(Error::format(
            &entry.source,
            format!(
                "this frame has dims {:?}, the series {:?} (changed since it was planned)",
                volume.dims(),
                s.dims
            ),
        ));
    }
    let options = &s.options;
    let mut set = OutputSet::new(out_dir)?;
    // The render is needed for the images, or for the grids the method computes on the way.
    let rendered = if entry.exr.is_some() || !scene.method.grids().is_empty() {
        Some(pipeline::render(
            &Settled::named(scene),
            volume,
            compute,
            progress,
        )?)
    } else {
        None
    };
    if let (Some(exr), Some(rendered)) = (&entry.exr, &rendered) {
        let stem = exr.trim_end_matches(".exr");
        let image = &rendered.image;
        pipeline::write_image_files(
            image,
            &render_layers(image),
            &header_metadata(&Settled::named(scene)),
            &mut set,
            stem,
            &options.output(),
        )?;
    }
    if let Some(vdb) = &entry.vdb {
        let ao = match options.ao_params()? {
            Some(params) => Some(ao::ao_volume(
                compute,
                Cow::Borrowed(volume),
                &scene.classification,
                &params,
                &NoProgress,
            )?),
            None => None,
        };
        let density = pipeline::ExportDensity::new(&scene.classification, volume)?;
        let method_grids = rendered.as_ref().map_or(&[][..], |r| &r.grids[..]);
        let mut grids = pipeline::export_grids(method_grids, &density, volume);
        if let Some(ao) = &ao {
            grids.push(crate::export::vdb::VdbGrid::from_volume(
                AO_GRID,
                &ao.openness,
            ));
        }
        // The stage's fields are the manifest's grids: every frame must hold exactly those.
        let names: Vec<&str> = grids.iter().map(|g| g.name).collect();
        if names != manifest.grids {
            return Err(Error::param(
                "series",
                format!(
                    "frame {number} computed grids {names:?}, the manifest lists {:?}",
                    manifest.grids
                ),
            ));
        }
        write_vdb(&set.path(vdb)?, &grids, &options.vdb())?;
    }
    Ok(FrameOutcome::Written(set.commit()?))
}

/// Writes the series' USD stage (`NAME.usda`): the volume's fields read frame `f`'s VDB at time
/// code `f`. Only once every frame's VDB is there, so the stage never points at a missing file.
/// Returns the stage's path, or None without export.
pub fn finish(manifest: &Manifest, out_dir: &Path) -> Result<Option<PathBuf>> {
    let Some(stage_name) = &manifest.stage else {
        return Ok(None);
    };
    let files: Vec<String> = manifest
        .frames
        .iter()
        .filter_map(|f| f.vdb.clone())
        .collect();
    let missing: Vec<&String> = files
        .iter()
        .filter(|f| !out_dir.join(f).is_file())
        .collect();
    if let Some(first) = missing.first() {
        return Err(Error::param(
            "series",
            format!(
                "{} of {} frames are not written yet (first: {first}); the stage is written once \
                 all are",
                missing.len(),
                files.len()
            ),
        ));
    }
    let s = &manifest.settings;
    let scene = manifest.frame_scene(&manifest.frames[0])?;
    let names: Vec<&str> = manifest.grids.iter().map(String::as_str).collect();
    let [lo, hi] = s.bounds;
    let stage = StageDescription::new(
        &files[0],
        &names,
        (Vec3::from(lo), Vec3::from(hi)),
        &s.camera,
        &scene.lighting.lights,
    )?
    .with_time_samples(manifest.first_frame, &files)?;
    let path = out_dir.join(stage_name);
    write_usda(&path, &stage)?;
    Ok(Some(path))
}

/// Runs every frame of a planned series in order on `compute`, with a bar over the frames,
/// then writes the stage. A failed frame does not stop the others: every failure is named at
/// the end, and a rerun redoes only what is missing.
pub fn run(
    manifest: &Manifest,
    out_dir: &Path,
    compute: &Compute,
    report: &dyn Report,
) -> Result<Summary> {
    let bar = report.stage("frames", manifest.count as u64);
    let mut summary = Summary::default();
    for (n, entry) in manifest.frames.iter().enumerate() {
        bar.message(&format!("frame {}", entry.frame));
        match run_frame(manifest, out_dir, entry.frame, compute, &NoProgress) {
            Ok(FrameOutcome::Written(files)) => summary.written.push((entry.frame, files)),
            Ok(FrameOutcome::Complete) => summary.complete.push(entry.frame),
            Err(e) => summary.failed.push((entry.frame, e.to_string())),
        }
        bar.update(n as u64 + 1, manifest.count as u64);
    }
    drop(bar);
    if summary.failed.is_empty() {
        summary.stage = finish(manifest, out_dir)?;
    }
    Ok(summary)
}

/// What a run did, frame by frame.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    pub written: Vec<(u32, Vec<PathBuf>)>,
    /// Frames already complete (skipped).
    pub complete: Vec<u32>,
    /// Frames that failed, with why.
    pub failed: Vec<(u32, String)>,
    pub stage: Option<PathBuf>,
}

impl Summary {
    /// An error naming every failed frame; Ok when none failed.
    pub fn into_result(self) -> Result<Self> {
        if self.failed.is_empty() {
            return Ok(self);
        }
        let lines: Vec<String> = self
            .failed
            .iter()
            .map(|(f, why)| format!("frame {f}: {why}"))
            .collect();
        Err(Error::param(
            "series",
            format!(
                "{} of {} frames failed (a rerun redoes only these):\n{}",
                self.failed.len(),
                self.failed.len() + self.written.len() + self.complete.len(),
                lines.join("\n")
            ),
        ))
    }
}
