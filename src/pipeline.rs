//! Runs a scene end to end: load, classify, render on the chosen device, write the outputs.

use crate::error::{Error, Result};
use crate::export::exr::{render_layers, write_exr, Precision};
use crate::export::png::write_png_preview;
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::render::raycast::{self, RaycastInput};
use crate::render::RenderImage;
use crate::scene::{Method, Scene};
use crate::volume::Volume;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Renders a scene's method for an already loaded volume.
pub fn render(
    scene: &Scene,
    volume: &Volume,
    compute: &Compute,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    let lut = scene.classification.bake(volume);
    match &scene.method {
        Method::Raycast(params) => {
            let input = RaycastInput {
                volume,
                lut: &lut,
                camera: &scene.camera,
                lighting: &scene.lighting,
                params,
            };
            raycast::render(compute, &input, progress)
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

/// Writes `OUT/STEM.exr` (layers `beauty` and `depth`, camera and parameters in the header) and
/// the preview `OUT/STEM.png`, creating `out_dir` if needed. Returns the paths written.
pub fn write_render(
    img: &RenderImage,
    scene: &Scene,
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
        img.width,
        img.height,
        &render_layers(img),
        &header_metadata(scene),
        options.precision,
    )?;
    write_png_preview(&png_path, img, options.exposure)?;
    Ok(vec![exr_path, png_path])
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
