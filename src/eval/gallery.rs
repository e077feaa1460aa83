//! `occlux gallery SCENE`: one volume, every registered method at each of its chart settings
//! side by side, beside Occlux's Monte Carlo at a few samples and the path-traced truth, each
//! with its time and its error against the truth under it. The scene's lights light every
//! tile; a method renders those it takes (so a method without shadows, or without ambient
//! light, shows what that costs). Writes OUT/gallery.png and OUT/gallery.json.

use crate::error::{Error, Result};
use crate::eval::bench::timed_keeping;
use crate::eval::chart::plot::{png_font_registered, write_png, FAMILY, FONT_PATHS};
use crate::export::png::tone_map;
use crate::gpu::{Compute, DeviceChoice};
use crate::plan::command::scene_to_plan;
use crate::plan::measure::{monte_carlo, render_method, resized, Subject, Truth};
use crate::plan::{truth_estimator, Choice, Scattering};
use crate::progress::Progress;
use crate::registry::METHODS;
use crate::render::RenderImage;
use plotters::prelude::*;
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct GalleryArgs {
    pub scene: PathBuf,
    /// Each tile's longer side, pixels (the scene's view at this size).
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Samples per pixel of the truth.
    #[arg(long, default_value_t = 1024)]
    pub spp: u32,
    /// Samples per pixel of the Monte Carlo tile.
    #[arg(long, default_value_t = 16)]
    pub mc_spp: u32,
    /// Timed renders per tile (median, after a warm-up).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Exposure of the tiles' tone map (Blender's Standard view).
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f32,
    #[arg(long, value_enum, default_value = "cpu")]
    pub device: DeviceChoice,
    #[arg(short, long, default_value = "occlux-gallery")]
    pub out: PathBuf,
}

/// One tile: what rendered it, its time and its error.
#[derive(Serialize)]
struct Tile {
    label: String,
    seconds: f64,
    rel_rmse: Option<f64>,
    rel_bias: Option<f64>,
    #[serde(skip)]
    image: RenderImage,
}

#[derive(Serialize)]
struct Report<'a> {
    scene: String,
    device: String,
    truth: String,
    truth_spp: u32,
    truth_noise: f64,
    tiles: &'a [Tile],
}

/// Tiles per row.
const COLUMNS: usize = 4;
/// Caption height under each tile, and its two lines' text size.
const CAPTION: u32 = 40;
const TEXT_SIZE: f64 = 12.0;

pub fn run(args: &GalleryArgs, quiet: bool) -> Result<()> {
    if args.repeats == 0 || args.spp < 2 || args.mc_spp < 2 || !(128..=1024).contains(&args.size) {
        return Err(Error::param(
            "--size/--spp/--mc-spp/--repeats",
            "need a tile side in [128, 1024] (room for its caption), at least 2 samples per pixel and one repeat",
        ));
    }
    if !(args.exposure > 0.0 && args.exposure.is_finite()) {
        return Err(Error::param("--exposure", "must be positive"));
    }
    crate::export::atomic::check_writable(&args.out)?;
    let png = args.out.join("gallery.png");
    if !png_font_registered() {
        return Err(Error::io(
            &png,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!(
                    "no TrueType font for the captions; tried {}; install one, e.g. \
                     `apt-get install fonts-dejavu-core`",
                    FONT_PATHS.join(", ")
                ),
            ),
        ));
    }
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        crate::progress::notice(quiet, line);
    }
    let mut loaded = scene_to_plan(&args.scene)?.load()?;
    loaded.scene.camera = resized(&loaded.scene.camera, args.size);
    let lut = loaded.scene.classification.bake(&loaded.volume);
    let subject = Subject {
        scene: &loaded.scene,
        volume: &loaded.volume,
        lut: &lut,
        compute: &compute,
    };
    let camera = loaded.scene.camera;
    let estimator = truth_estimator(&loaded.scene.lighting, Scattering::Single);
    let settings: Vec<_> = METHODS
        .iter()
        .filter(|spec| !spec.lights_of(&loaded.scene.lighting).lights.is_empty())
        .flat_map(|spec| spec.chart.iter().map(move |setting| (spec, setting)))
        .collect();
    let total = settings.len() as u64 + 2;
    let bar = crate::progress::Bar::new(quiet, total, "gallery");
    bar.message("the truth");
    let (truth_image, truth_seconds) = monte_carlo(&subject, &camera, estimator, args.spp, 11)?;
    let truth = Truth::new(&subject, camera, &truth_image)?;
    let mut tiles = vec![];
    for (spec, setting) in settings {
        let method = spec.at_setting(setting)?;
        let label = Choice::Method {
            method: method.clone(),
            setting: setting.replace('\n', ", "),
        }
        .label();
        bar.message(&label);
        let (timing, (image, _)) =
            timed_keeping(args.repeats, || render_method(&subject, &method, &camera))?;
        let (rmse, bias) = truth.error(&image.rgba, 0.0)?;
        tiles.push(Tile {
            label,
            seconds: timing.median_ms / 1e3,
            rel_rmse: Some(rmse),
            rel_bias: Some(bias),
            image,
        });
        bar.update(tiles.len() as u64, total);
    }
    bar.message("Monte Carlo");
    let (mc, mc_seconds) = monte_carlo(&subject, &camera, estimator, args.mc_spp, 2)?;
    let (rmse, bias) = truth.error(&mc.mean, 0.0)?;
    tiles.push(Tile {
        label: Choice::MonteCarlo {
            estimator,
            spp: args.mc_spp,
        }
        .label(),
        seconds: mc_seconds,
        rel_rmse: Some(rmse),
        rel_bias: Some(bias),
        image: mc.to_render(),
    });
    tiles.push(Tile {
        label: format!("truth: monte-carlo {} {} spp", estimator.name(), args.spp),
        seconds: truth_seconds,
        rel_rmse: None,
        rel_bias: None,
        image: truth_image.to_render(),
    });
    bar.finish();
    let (rgb, size) = compose(&tiles, args.exposure, &png)?;
    // The picture and its numbers as one set.
    let mut set = crate::export::atomic::OutputSet::new(&args.out)?;
    write_png(&set.path("gallery.png")?, &rgb, size)?;
    let report = Report {
        scene: args.scene.display().to_string(),
        device: compute.describe(),
        truth: estimator.name().to_owned(),
        truth_spp: args.spp,
        truth_noise: truth.noise,
        tiles: &tiles,
    };
    super::write_report(&set.path("gallery.json")?, &report, true)?;
    crate::progress::report_written(&set.commit()?, quiet);
    Ok(())
}

/// The tiles in rows of [`COLUMNS`], each tone-mapped with its caption under it, as RGB.
fn compose(tiles: &[Tile], exposure: f32, path: &std::path::Path) -> Result<(Vec<u8>, (u32, u32))> {
    let (w, h) = (tiles[0].image.width, tiles[0].image.height);
    let columns = tiles.len().min(COLUMNS) as u32;
    let rows = tiles.len().div_ceil(COLUMNS) as u32;
    let size = (w * columns, (h + CAPTION) * rows);
    let mut rgb = vec![24u8; size.0 as usize * size.1 as usize * 3];
    for (n, tile) in tiles.iter().enumerate() {
        let (x0, y0) = (
            (n as u32 % columns) * w,
            (n as u32 / columns) * (h + CAPTION),
        );
        for (j, row) in tile.image.rgba.chunks(w as usize).enumerate() {
            let at = ((y0 as usize + j) * size.0 as usize + x0 as usize) * 3;
            for (i, p) in row.iter().enumerate() {
                for c in 0..3 {
                    rgb[at + 3 * i + c] = tone_map(p[c], exposure);
                }
            }
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        let style = (FAMILY, TEXT_SIZE)
            .into_font()
            .color(&RGBColor(230, 230, 230));
        for (n, tile) in tiles.iter().enumerate() {
            let (x0, y0) = (
                (n as u32 % columns) * w,
                (n as u32 / columns) * (h + CAPTION) + h,
            );
            let second = match (tile.rel_rmse, tile.rel_bias) {
                (Some(rmse), Some(bias)) => format!(
                    "{:.3} s   error {rmse:.3} ({:+.0} %)",
                    tile.seconds,
                    100.0 * bias
                ),
                _ => format!("{:.2} s", tile.seconds),
            };
            // `ao ao_method=gauss, ao_radius=4`: the setting as short as it reads.
            let first = tile.label.replace('"', "").replace(" = ", "=");
            for (line, text) in [&first, &second].into_iter().enumerate() {
                root.draw(&Text::new(
                    text.clone(),
                    (x0 as i32 + 6, y0 as i32 + 4 + 18 * line as i32),
                    style.clone(),
                ))
                .map_err(|e| Error::format(path, format!("drawing the gallery: {e}")))?;
            }
        }
        root.present()
            .map_err(|e| Error::format(path, format!("drawing the gallery: {e}")))?;
    }
    Ok((rgb, size))
}
