//! A series' manifest, `OUT/NAME.series.json`: the frames and the files each one gets, the
//! grids, the classification on raw values (the add-on's material) and every setting that the
//! frames share (the scene, the window fixed across the series, the camera). It is written
//! before any frame, read by every frame's task (a process on this machine or a Dask worker),
//! and compared on a rerun: the same settings resume, other settings are refused rather than
//! mixed into one sequence.

use crate::camera::Camera;
use crate::classify::Window;
use crate::error::{Error, Result};
use crate::export::atomic::write_bytes_atomic;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The manifest's format version (`occlux_series`).
pub const FORMAT: u32 = 1;

/// A control point on raw values: `(value, sigma_t, albedo, emission)`, as the Python
/// package's `Classification.raw_points` gives it.
pub type RawPoint = (f32, f32, [f32; 3], [f32; 3]);

/// `OUT/NAME.series.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub occlux_series: u32,
    /// The files' stem: `NAME_0001.vdb`, `NAME.usda`.
    pub name: String,
    /// The first frame's number (Blender's frame and the USD time code).
    pub first_frame: u32,
    pub count: usize,
    pub frames: Vec<FrameEntry>,
    /// The grids in every VDB (empty without export).
    pub grids: Vec<String>,
    /// The 1D transfer function on raw values, `(value, sigma_t, albedo, emission)` with
    /// `density_scale` applied: the same for every frame, as the window is. None for 2D.
    pub raw_points: Option<Vec<RawPoint>>,
    /// The USD stage (`NAME.usda`), with export.
    pub stage: Option<String>,
    pub settings: Settings,
}

/// One frame: its source and the files it writes (names relative to the manifest's folder).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameEntry {
    pub frame: u32,
    pub source: PathBuf,
    /// The time step of a 4-D file; None for a 3-D one.
    pub time: Option<usize>,
    pub vdb: Option<String>,
    pub exr: Option<String>,
    pub png: Option<String>,
}

impl FrameEntry {
    /// The files this frame writes.
    pub fn files(&self) -> impl Iterator<Item = &str> {
        [&self.vdb, &self.exr, &self.png]
            .into_iter()
            .filter_map(|f| f.as_deref())
    }
}

/// What every frame shares.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// The scene file's tree, without `volume.frames`; each frame sets `volume.path`.
    pub scene: Value,
    /// The folder the scene's relative paths are read from.
    pub base: PathBuf,
    pub options: super::SeriesOptions,
    /// The classification's window, fixed across the series (normalised units only).
    pub window: Option<Window>,
    /// The camera, framed once on the content of every frame.
    pub camera: Camera,
    /// Where the box's centre goes (the content's centre over every frame, for `centre =
    /// "content"`).
    pub centre: Option<[f32; 3]>,
    /// The grid every frame must have, as placed in the world.
    pub dims: [usize; 3],
    pub spacing: [f32; 3],
    pub bounds: [[f32; 3]; 2],
}

impl Manifest {
    /// The manifest's path in `out_dir`.
    pub fn path(out_dir: &Path, name: &str) -> PathBuf {
        out_dir.join(format!("{name}.series.json"))
    }

    /// Reads a manifest; errors name the file and what is wrong with it.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let manifest: Manifest = serde_json::from_str(&text)
            .map_err(|e| Error::format(path, format!("not an Occlux series manifest: {e}")))?;
        if manifest.occlux_series != FORMAT {
            return Err(Error::format(
                path,
                format!(
                    "series manifest version {} (this Occlux reads {FORMAT})",
                    manifest.occlux_series
                ),
            ));
        }
        Ok(manifest)
    }

    /// Writes the manifest into `out_dir`, or checks that the one there was made with the
    /// same settings and frames (a rerun resumes it); a different one is refused, naming what
    /// differs, as its finished frames would otherwise join a sequence made differently.
    pub fn write_or_resume(&self, out_dir: &Path) -> Result<Resume> {
        let path = Self::path(out_dir, &self.name);
        if path.exists() {
            let old = Self::read(&path)?;
            return match self.difference(&old) {
                None => Ok(Resume::Resumed),
                Some(what) => Err(Error::format(
                    &path,
                    format!(
                        "this folder holds series '{}' made with other {what}; remove its files or \
                         write into another folder",
                        self.name
                    ),
                )),
            };
        }
        std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::param("manifest", e.to_string()))?;
        write_bytes_atomic(&path, text.as_bytes())?;
        Ok(Resume::New)
    }

    /// What differs from `old`, in words; None when they describe the same series.
    fn difference(&self, old: &Manifest) -> Option<String> {
        let (a, b) = (&self.settings, &old.settings);
        let sources = |m: &Manifest| {
            m.frames
                .iter()
                .map(|f| (f.source.clone(), f.time))
                .collect::<Vec<_>>()
        };
        [
            (a.scene != b.scene || a.base != b.base, "scene settings"),
            (
                a.options != b.options,
                "outputs (--render, --export, --ao, ...)",
            ),
            (sources(self) != sources(old), "frames"),
            (
                a.window != b.window || a.camera != b.camera || a.centre != b.centre,
                "data (the window or framing settled from the frames changed)",
            ),
            (self != old, "contents"),
        ]
        .into_iter()
        .find(|(differs, _)| *differs)
        .map(|(_, what)| what.to_owned())
    }
}

/// Whether a series starts afresh or resumes an earlier run's manifest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resume {
    New,
    Resumed,
}
