//! Runs a scene end to end: load, classify, render on the chosen device, write the outputs.

use crate::ao::vao::AoVolume;
use crate::error::{Error, Result};
use crate::export::atomic::write_bytes_atomic;
use crate::export::exr::{render_layers, write_exr, ExrLayer, Precision};
use crate::export::png::write_png_preview;
use crate::export::usd::{write_usda, StageDescription};
use crate::export::vdb::{write_vdb, VdbGrid, VdbOptions};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::render::ao_shaded::{self, View};
use crate::render::dos::{self, DosInput};
use crate::render::raycast::{self, RaycastInput};
use crate::render::reference::{Estimator, ReferenceImage, ReferenceParams};
use crate::render::RenderImage;
use crate::scene::{Method, Scene};
use crate::volume::Volume;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A scene's render and the grids its method computed on the way.
pub struct Rendered {
    pub image: RenderImage,
    /// The AO volume of AO-shaded rendering.
    pub ao: Option<AoVolume>,
}

/// Renders a scene's method for an already loaded volume.
pub fn render(
    scene: &Scene,
    volume: &Volume,
    compute: &Compute,
    progress: &dyn Progress,
) -> Result<Rendered> {
    let lut = scene.classification.bake(volume);
    match &scene.method {
        Method::Raycast(params) => {
            let input = RaycastInput {
                volume,
                lut: &lut,
                camera: &scene.camera,
                lighting: &scene.lighting,
                params,
                ao: None,
            };
            Ok(Rendered {
                image: raycast::render(compute, &input, progress)?,
                ao: None,
            })
        }
        Method::AoShaded(params) => {
            let view = View {
                camera: &scene.camera,
                lighting: &scene.lighting,
            };
            let (image, ao) = ao_shaded::render(
                compute,
                volume,
                &scene.classification,
                &lut,
                &view,
                params,
                progress,
            )?;
            Ok(Rendered {
                image,
                ao: Some(ao),
            })
        }
        Method::Dos(params) => {
            let input = DosInput {
                volume,
                lut: &lut,
                camera: &scene.camera,
                lighting: &scene.lighting,
                params,
            };
            Ok(Rendered {
                image: dos::render(compute, &input, progress)?,
                ao: None,
            })
        }
    }
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

/// Writes `OUT/STEM.exr` (layers `beauty` and `depth`, plus `dos` and `occlusion` for a DOS
/// render; camera and parameters in the header) and
/// the preview `OUT/STEM.png`, creating `out_dir` if needed. Returns the paths written.
pub fn write_render(
    img: &RenderImage,
    scene: &Scene,
    out_dir: &Path,
    stem: &str,
    options: &OutputOptions,
) -> Result<Vec<PathBuf>> {
    let layers = render_layers(img);
    write_image_files(
        img,
        &layers,
        &header_metadata(scene),
        out_dir,
        stem,
        options,
    )
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
    let mut meta = header_metadata(scene);
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
    write_image_files(
        &image.to_render(),
        &image.layers(),
        &meta,
        out_dir,
        stem,
        &options,
    )
}

/// `OUT/STEM.exr` holding `layers` with `meta` in its header, and the PNG preview of `preview`.
fn write_image_files(
    preview: &RenderImage,
    layers: &[ExrLayer],
    meta: &BTreeMap<String, String>,
    out_dir: &Path,
    stem: &str,
    options: &OutputOptions,
) -> Result<Vec<PathBuf>> {
    options.validate()?;
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let exr_path = out_dir.join(format!("{stem}.exr"));
    let png_path = out_dir.join(format!("{stem}.png"));
    write_exr(
        &exr_path,
        preview.width,
        preview.height,
        layers,
        meta,
        options.precision,
    )?;
    write_png_preview(&png_path, preview, options.exposure)?;
    Ok(vec![exr_path, png_path])
}

/// The grids `export` writes for every method: extinction per scene unit, and the volume's
/// own values; AO-shaded rendering adds [`AO_GRID`] and, on request, [`AO_VARIANCE_GRID`].
pub const EXPORT_GRIDS: [&str; 2] = ["density", "value"];
pub const AO_GRID: &str = "ao";
pub const AO_VARIANCE_GRID: &str = "ao_variance";

/// Writes a scene's exchange files into `out_dir`: the render (`STEM.exr`, `STEM.png`), the
/// grids (`STEM.vdb`: `density`, the classified extinction sigma_t per scene unit, `value`,
/// the volume's values, and the AO volume's grids when the method computed one) and a USD
/// stage (`STEM.usda`) whose volume points at those grids, with the scene's camera and lights.
/// Returns the paths written.
pub fn export(
    rendered: &Rendered,
    scene: &Scene,
    volume: &Volume,
    out_dir: &Path,
    stem: &str,
    output: &OutputOptions,
    vdb: &VdbOptions,
) -> Result<Vec<PathBuf>> {
    let vdb_name = format!("{stem}.vdb");
    let extinction = scene.classification.extinction(volume)?;
    let mut grids = vec![
        VdbGrid::from_volume(EXPORT_GRIDS[0], &extinction),
        VdbGrid::from_volume(EXPORT_GRIDS[1], volume),
    ];
    if let Some(ao) = &rendered.ao {
        grids.extend(ao_grids(ao));
    }
    let names: Vec<&str> = grids.iter().map(|g| g.name).collect();
    let stage = StageDescription::new(
        &vdb_name,
        &names,
        volume.bounds(),
        &scene.camera,
        &scene.lighting.lights,
    )?;
    // The grids go first: an empty or invalid grid is the likeliest failure, and it stops the
    // export before anything is written.
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let vdb_path = out_dir.join(&vdb_name);
    write_vdb(&vdb_path, &grids, vdb)?;
    let usd_path = out_dir.join(format!("{stem}.usda"));
    write_usda(&usd_path, &stage)?;
    let mut written = write_render(&rendered.image, scene, out_dir, stem, output)?;
    written.extend([vdb_path, usd_path]);
    Ok(written)
}

/// The VDB grids of an AO volume: `ao` (openness) and `ao_variance` if it was computed.
pub fn ao_grids(ao: &AoVolume) -> Vec<VdbGrid<'_>> {
    let mut grids = vec![VdbGrid::from_volume(AO_GRID, &ao.openness)];
    if let Some(variance) = &ao.variance {
        grids.push(VdbGrid::from_volume(AO_VARIANCE_GRID, variance));
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
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let vdb_path = out_dir.join(format!("{stem}-ao.vdb"));
    write_vdb(&vdb_path, &ao_grids(ao), vdb)?;
    let png_path = out_dir.join(format!("{stem}-ao.png"));
    write_png_preview(&png_path, &middle_slice(&ao.openness), 1.0)?;
    let json_path = out_dir.join(format!("{stem}-ao.json"));
    let text =
        serde_json::to_string_pretty(record).map_err(|e| Error::param("json", e.to_string()))?;
    write_bytes_atomic(&json_path, text.as_bytes())?;
    Ok(vec![vdb_path, png_path, json_path])
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

/// Camera and method parameters for the EXR header, as JSON text.
pub fn header_metadata(scene: &Scene) -> BTreeMap<String, String> {
    let cam = &scene.camera;
    let (hx, hy) = cam.half_extent();
    let camera = serde_json::json!({
        "position": cam.position.to_array(),
        "forward": cam.forward.to_array(),
        "up": cam.up.to_array(),
        "projection": format!("{:?}", cam.projection),
        "half_extent": [hx, hy],
        "width": cam.width,
        "height": cam.height,
    });
    let mut meta = BTreeMap::new();
    meta.insert("occlux/version".into(), env!("CARGO_PKG_VERSION").into());
    meta.insert("occlux/camera".into(), camera.to_string());
    meta.insert("occlux/method".into(), format!("{:?}", scene.method));
    meta.insert("occlux/lighting".into(), format!("{:?}", scene.lighting));
    meta
}
