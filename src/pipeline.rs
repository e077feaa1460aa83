//! Runs a scene end to end: load, classify, render on the chosen device, write the outputs.

use crate::ao::vao::AoVolume;
use crate::bake::Baked;
use crate::classify::Classification;
use crate::error::{Error, Result};
use crate::export::atomic::{write_bytes_atomic, OutputSet};
use crate::export::exr::{render_layers, write_exr, ExrLayer, Precision};
use crate::export::png::write_png_preview;
use crate::export::usd::{write_usda, StageDescription};
use crate::export::vdb::{write_vdb, VdbGrid, VdbOptions};
use crate::gpu::Compute;
use crate::plan::measure::Subject;
use crate::plan::{Choice, Planned};
use crate::progress::Progress;
use crate::render::ao_shaded::{AO_GRID, AO_OCTANT_GRIDS, AO_VARIANCE_GRID, SDF_GRID};
use crate::render::reference::{Estimator, ReferenceImage, ReferenceParams};
use crate::render::{Grid, MethodInput, RenderImage, Rendered};
use crate::scene::Scene;
use crate::volume::Volume;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What `occlux render`, `export` and `demo` write beside the render.
pub enum Outputs {
    /// The render alone (EXR + PNG).
    Render,
    /// The render, the grids (VDB) and a USD stage.
    Export(VdbOptions),
}

/// A scene ready to render: an `auto` scene with the planner's choice in place of its method
/// and the plan that chose it ([`settle`]); a scene that names its method as it is
/// ([`Settled::named`]).
#[derive(Clone, Debug)]
pub struct Settled<'a> {
    pub scene: Cow<'a, Scene>,
    /// What the planner chose and its record for the EXR header; None when the scene named its
    /// method.
    pub planned: Option<Planned>,
}

impl<'a> Settled<'a> {
    /// A scene that names its method (an `auto` scene is refused when it renders: it is
    /// [`settle`]d first).
    pub fn named(scene: &'a Scene) -> Self {
        Self {
            scene: Cow::Borrowed(scene),
            planned: None,
        }
    }
}

impl std::ops::Deref for Settled<'_> {
    type Target = Scene;

    fn deref(&self) -> &Scene {
        &self.scene
    }
}

/// An `auto` scene planned (the planner's progress, what it chose and why, to `say`): the
/// scene with the chosen method and its [`Planned`]; any other scene as it is.
pub fn settle<'a>(
    scene: &'a Scene,
    volume: &Volume,
    compute: &Compute,
    say: &dyn Fn(&str),
) -> Result<Settled<'a>> {
    let Some(budget) = scene.auto else {
        return Ok(Settled::named(scene));
    };
    let lut = scene.classification.bake(volume);
    let subject = Subject {
        scene,
        volume,
        lut: &lut,
        compute,
    };
    let plan = crate::plan::plan(&subject, &budget, &|line: &str| {
        say(&format!("planning: {line}"))
    })?;
    say(&plan.explain());
    let choice = plan.choice().clone();
    let mut chosen = scene.clone();
    if let Choice::Method { method, .. } = &choice {
        chosen.method = method.clone();
    }
    Ok(Settled {
        scene: Cow::Owned(chosen),
        planned: Some(Planned {
            record: plan.record(),
            choice,
        }),
    })
}

/// Renders a scene's method for an already loaded volume; an `auto` scene must be settled
/// ([`settle`]) first, so that what is written says what rendered it.
pub fn render(
    settled: &Settled,
    volume: &Volume,
    compute: &Compute,
    progress: &dyn Progress,
) -> Result<Rendered> {
    let scene = &*settled.scene;
    let lut = scene.classification.bake(volume);
    if let Some(planned) = &settled.planned {
        let subject = Subject {
            scene,
            volume,
            lut: &lut,
            compute,
        };
        return planned.choice.render(&subject, progress);
    }
    if scene.auto.is_some() {
        return Err(Error::param(
            "render.method",
            "\"auto\" is planned before it renders (pipeline::settle)",
        ));
    }
    let input = MethodInput {
        volume,
        classification: &scene.classification,
        lut: &lut,
        camera: &scene.camera,
        lighting: &scene.lighting,
        compute,
        progress,
    };
    scene.method.render(&input)
}

/// How renders are written.
#[derive(Clone, Copy, Debug)]
pub struct OutputOptions {
    pub precision: Precision,
    /// Exposure applied before the PNG's tone map.
    pub exposure: f32,
}

impl OutputOptions {
    pub fn validate(&self) -> Result<()> {
        if !(self.exposure > 0.0 && self.exposure.is_finite()) {
            return Err(Error::param(
                "exposure",
                format!("must be positive, got {}", self.exposure),
            ));
        }
        Ok(())
    }
}

impl Default for OutputOptions {
    fn default() -> Self {
        Self {
            precision: Precision::Half,
            exposure: 1.0,
        }
    }
}

/// Writes `OUT/STEM.exr` (layers `beauty` and `depth`, plus the method's shading factor:
/// `occlusion` for DOS, `shadow` for IPSVI and half-angle slicing, as channels V (premultiplied
/// by coverage) and A (coverage); camera and parameters in the header) and
/// the preview `OUT/STEM.png`, creating `out_dir` if needed. Returns the paths written.
pub fn write_render(
    img: &RenderImage,
    settled: &Settled,
    out_dir: &Path,
    stem: &str,
    options: &OutputOptions,
) -> Result<Vec<PathBuf>> {
    let mut set = OutputSet::new(out_dir)?;
    write_image_files(
        img,
        &render_layers(img),
        &header_metadata(settled),
        &mut set,
        stem,
        options,
    )?;
    set.commit()
}

/// Writes a Monte Carlo reference: `OUT/STEM.exr` (float32 layers `beauty`, the per-pixel
/// mean, and `stderr`, its standard error; the scene and estimator in the header) and a PNG
/// preview of the mean. Returns the paths written.
pub fn write_reference(
    image: &ReferenceImage,
    scene: &Scene,
    params: &ReferenceParams,
    out_dir: &Path,
    stem: &str,
    exposure: f32,
) -> Result<Vec<PathBuf>> {
    let mut meta = header_metadata(&Settled::named(scene));
    let (g, bounces, aperture) = match params.estimator {
        Estimator::Multiple { bounces } => (params.g, Some(bounces), None),
        Estimator::Single => (params.g, None, None),
        Estimator::Cone { aperture } => (0.0, None, Some(aperture.to_degrees())),
        Estimator::Ambient => (0.0, None, None),
    };
    let description = serde_json::json!({
        "estimator": params.estimator.name(),
        "spp": params.spp,
        "seed": params.seed,
        "g": g,
        "bounces": bounces,
        "aperture_deg": aperture,
    });
    meta.insert("occlux/reference".into(), description.to_string());
    let options = OutputOptions {
        precision: Precision::Float,
        exposure,
    };
    let mut set = OutputSet::new(out_dir)?;
    write_image_files(
        &image.to_render(),
        &image.layers(),
        &meta,
        &mut set,
        stem,
        &options,
    )?;
    set.commit()
}

/// `STEM.exr` holding `layers` with `meta` in its header, and the PNG preview of `preview`, as
/// part of `set`.
pub fn write_image_files(
    preview: &RenderImage,
    layers: &[ExrLayer],
    meta: &BTreeMap<String, String>,
    set: &mut OutputSet,
    stem: &str,
    options: &OutputOptions,
) -> Result<()> {
    options.validate()?;
    write_exr(
        &set.path(&format!("{stem}.exr"))?,
        preview.width,
        preview.height,
        layers,
        meta,
        options.precision,
    )?;
    write_png_preview(
        &set.path(&format!("{stem}.png"))?,
        preview,
        options.exposure,
    )
}

/// The grids `export` writes for every method: extinction per scene unit, and the volume's
/// own values; a method adds the grids it computed (its registry entry's `grids`).
pub const EXPORT_GRIDS: [&str; 2] = ["density", "value"];

/// Writes a scene's exchange files into `out_dir`: the render (`STEM.exr`, `STEM.png`), the
/// grids (`STEM.vdb`: `density`, the classified extinction sigma_t per scene unit, `value`,
/// the volume's values, and the grids the method computed, such as AO-shaded DVR's `ao`) and a USD
/// stage (`STEM.usda`) whose volume points at those grids, with the scene's camera and lights.
/// Returns the paths written.
pub fn export(
    rendered: &Rendered,
    settled: &Settled,
    volume: &Volume,
    out_dir: &Path,
    stem: &str,
    output: &OutputOptions,
    vdb: &VdbOptions,
) -> Result<Vec<PathBuf>> {
    let scene = &*settled.scene;
    let vdb_name = format!("{stem}.vdb");
    let density = ExportDensity::new(&scene.classification, volume)?;
    let grids = export_grids(&rendered.grids, &density, volume);
    let vdb = &planned_precision(scene, &grids, vdb);
    let names: Vec<&str> = grids.iter().map(|g| g.name).collect();
    let stage = StageDescription::new(
        &vdb_name,
        &names,
        volume.bounds(),
        &scene.camera,
        &scene.lighting.lights,
    )?;
    // All four files or none: the stage points at the grids, and a stage without its images
    // (or grids without their stage) would be a half export. The stage is the set's marker,
    // moved into place last: where it is, the whole export is.
    let mut set = OutputSet::new(out_dir)?;
    write_vdb(&set.path(&vdb_name)?, &grids, vdb)?;
    write_usda(&set.marker(&format!("{stem}.usda"))?, &stage)?;
    let image = &rendered.image;
    let meta = header_metadata(settled);
    write_image_files(image, &render_layers(image), &meta, &mut set, stem, output)?;
    set.commit()
}

/// An `auto` scene's grids are stored as half floats when its error budget is at least
/// [`crate::plan::HALF_FLOAT_BUDGET`] and every value fits one: a half float's relative
/// rounding of 2^-11 is far inside such a budget, and the file is half the size.
fn planned_precision(scene: &Scene, grids: &[VdbGrid], vdb: &VdbOptions) -> VdbOptions {
    let allows = scene
        .auto
        .is_some_and(|budget| budget.error >= crate::plan::HALF_FLOAT_BUDGET);
    VdbOptions {
        half: vdb.half || (allows && grids.iter().all(VdbGrid::fits_half)),
        ..*vdb
    }
}

/// The `density` grid an export writes, the classified extinction of a volume. Under a 1D
/// table it is a function of each voxel's own value, which the VDB writer applies leaf by leaf
/// as it reads them, so an export never holds a dense extinction beside the volume (512^3:
/// 2.07x the dense volume with it); a 2D table reads neighbours for the gradient, so it is
/// classified into a dense grid first.
pub enum ExportDensity {
    Mapped(Box<dyn Fn(f32) -> f32 + Sync>),
    Dense(Volume),
}

impl ExportDensity {
    pub fn new(classification: &Classification, volume: &Volume) -> Result<Self> {
        if classification.uses_gradient() {
            return Ok(Self::Dense(classification.extinction(volume)?));
        }
        // The same table and lookup as Classification::extinction's, so the same values.
        let lut = classification.bake(volume);
        Ok(Self::Mapped(Box::new(move |v| lut.lookup(v, 0.0).sigma_t)))
    }

    /// The `density` grid of `volume` (the volume this was made for).
    pub fn grid<'a>(&'a self, volume: &'a Volume) -> VdbGrid<'a> {
        match self {
            Self::Mapped(sigma_t) => VdbGrid::mapped(EXPORT_GRIDS[0], volume, sigma_t.as_ref()),
            Self::Dense(extinction) => VdbGrid::from_volume(EXPORT_GRIDS[0], extinction),
        }
    }
}

/// The grids an export writes: `density` (the classified extinction), `value` (`volume`) and
/// the grids the method computed (`method_grids`).
pub fn export_grids<'a>(
    method_grids: &'a [Grid],
    density: &'a ExportDensity,
    volume: &'a Volume,
) -> Vec<VdbGrid<'a>> {
    let mut grids = vec![
        density.grid(volume),
        VdbGrid::from_volume(EXPORT_GRIDS[1], volume),
    ];
    grids.extend(
        method_grids
            .iter()
            .map(|grid| vdb_grid(grid.name, &grid.volume)),
    );
    grids
}

/// The VDB grid of a volume Occlux computed, by its name: the signed distance (`sdf`) is a
/// level set, the rest fog volumes.
pub fn vdb_grid<'a>(name: &'a str, volume: &'a Volume) -> VdbGrid<'a> {
    if name == SDF_GRID {
        VdbGrid::level_set(name, volume)
    } else {
        VdbGrid::from_volume(name, volume)
    }
}

/// The VDB grids of an AO volume: `ao` (openness) and, where computed, `ao_variance`, `sdf`
/// (a level set) and `ao_oct0`..`ao_oct7`.
pub fn ao_grids(ao: &AoVolume) -> Vec<VdbGrid<'_>> {
    let mut grids = vec![VdbGrid::from_volume(AO_GRID, &ao.openness)];
    if let Some(variance) = &ao.variance {
        grids.push(VdbGrid::from_volume(AO_VARIANCE_GRID, variance));
    }
    if let Some(sdf) = &ao.sdf {
        grids.push(vdb_grid(SDF_GRID, sdf));
    }
    for (name, octant) in AO_OCTANT_GRIDS.iter().zip(&ao.octants) {
        grids.push(VdbGrid::from_volume(name, octant));
    }
    grids
}

/// Writes an AO volume: `OUT/STEM-ao.vdb` (grids `ao` and, if computed, `ao_variance`),
/// `OUT/STEM-ao.png` (the openness of the middle z slice, +y up) and `OUT/STEM-ao.json`
/// (`record`: parameters and timing). Returns the paths written.
pub fn write_ao(
    ao: &AoVolume,
    record: &serde_json::Value,
    out_dir: &Path,
    stem: &str,
    vdb: &VdbOptions,
) -> Result<Vec<PathBuf>> {
    let mut set = OutputSet::new(out_dir)?;
    write_vdb(&set.path(&format!("{stem}-ao.vdb"))?, &ao_grids(ao), vdb)?;
    let png = set.path(&format!("{stem}-ao.png"))?;
    write_png_preview(&png, &middle_slice(&ao.openness), 1.0)?;
    let text =
        serde_json::to_string_pretty(record).map_err(|e| Error::param("json", e.to_string()))?;
    // The record is the set's marker, moved into place last: where it is, the grids are.
    write_bytes_atomic(&set.marker(&format!("{stem}-ao.json"))?, text.as_bytes())?;
    set.commit()
}

/// Writes a bake: `OUT/STEM-bake.vdb` (grids `density` and `value` as an export writes them,
/// then the baked grids, [`crate::bake`]) and `OUT/STEM-bake.json` (`record`, the set's
/// marker). Returns the paths written.
pub fn write_bake(
    baked: &Baked,
    volume: &Volume,
    record: &serde_json::Value,
    out_dir: &Path,
    stem: &str,
    vdb: &VdbOptions,
) -> Result<Vec<PathBuf>> {
    let named = baked.grids();
    // The bake holds the dense extinction already: the density grid is it.
    let density = VdbGrid::from_volume(EXPORT_GRIDS[0], &baked.extinction);
    let mut grids = vec![density, VdbGrid::from_volume(EXPORT_GRIDS[1], volume)];
    grids.extend(
        named
            .iter()
            .map(|(name, grid)| VdbGrid::from_volume(name, grid)),
    );
    let mut set = OutputSet::new(out_dir)?;
    write_vdb(&set.path(&format!("{stem}-bake.vdb"))?, &grids, vdb)?;
    let text =
        serde_json::to_string_pretty(record).map_err(|e| Error::param("json", e.to_string()))?;
    write_bytes_atomic(&set.marker(&format!("{stem}-bake.json"))?, text.as_bytes())?;
    set.commit()
}

/// The middle z slice of `volume` as a grey image, row 0 at the largest y.
fn middle_slice(volume: &Volume) -> RenderImage {
    let [nx, ny, nz] = volume.dims();
    let mut image = RenderImage::new(nx as u32, ny as u32);
    for (row, pixels) in image.rgba.chunks_mut(nx).enumerate() {
        let j = ny - 1 - row;
        for (i, p) in pixels.iter_mut().enumerate() {
            let v = volume.at(i, j, nz / 2);
            *p = [v, v, v, 1.0];
        }
    }
    image
}

/// Camera, method parameters and lights for the EXR header, each as JSON text (`occlux/camera`:
/// [`crate::camera::Camera::describe`]; `occlux/method`: the method tagged by `method`, as in a
/// scene's `[render]`; `occlux/lighting`: `{lights, background}`).
pub fn header_metadata(settled: &Settled) -> BTreeMap<String, String> {
    let scene = &*settled.scene;
    let mut meta = BTreeMap::new();
    meta.insert("occlux/version".into(), env!("CARGO_PKG_VERSION").into());
    meta.insert("occlux/camera".into(), scene.camera.describe().to_string());
    match &settled.planned {
        Some(planned) => insert_plan(&mut meta, &planned.record),
        None => {
            meta.insert("occlux/method".into(), scene.method.to_json().to_string());
        }
    }
    // The classification as applied: its window on the volume's values resolved.
    meta.insert(
        "occlux/classification".into(),
        crate::json::tree(&scene.classification).to_string(),
    );
    meta.insert(
        "occlux/lighting".into(),
        crate::json::tree(&scene.lighting).to_string(),
    );
    meta
}

/// An `auto` scene's plan record into EXR header `meta`: `occlux/plan`, and the choice as
/// `occlux/method` (what rendered the image, not the scene's placeholder).
pub fn insert_plan(meta: &mut BTreeMap<String, String>, record: &serde_json::Value) {
    meta.insert("occlux/method".into(), record["method"].to_string());
    meta.insert("occlux/plan".into(), record.to_string());
}

/// Output files are named after the scene file.
pub fn stem(scene: &Path) -> String {
    scene
        .file_stem()
        .map_or("render".into(), |s| s.to_string_lossy().into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Budget, Scattering};

    #[test]
    fn auto_scenes_store_half_floats_where_the_budget_allows_and_the_values_fit() {
        let scene = |error: Option<f64>| {
            let mut scene = Scene::parse(
                "[volume]\nphantom = \"sphere\"\nsize = 4\n[camera]\nwidth = 4\nheight = 4\n",
                Path::new("."),
            )
            .unwrap();
            scene.auto = error.map(|e| Budget::new(e, Scattering::Single));
            scene
        };
        let small =
            Volume::new([2, 1, 1], glam::Vec3::ONE, glam::Vec3::ZERO, vec![0.5, 1.0]).unwrap();
        let huge =
            Volume::new([2, 1, 1], glam::Vec3::ONE, glam::Vec3::ZERO, vec![0.5, 1e6]).unwrap();
        let grids = |v| vec![VdbGrid::from_volume("density", v)];
        let float = VdbOptions::default();
        let half = |error, v| planned_precision(&scene(error), &grids(v), &float).half;
        assert!(half(Some(0.05), &small));
        assert!(!half(Some(0.005), &small), "a tight budget keeps float32");
        assert!(!half(Some(0.05), &huge), "1e6 does not fit a half float");
        assert!(!half(None, &small), "a fixed method keeps what was asked");
    }
}
