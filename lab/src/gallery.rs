//! `occlux gallery SCENE`: one volume, every registered method at each of its chart settings
//! side by side, beside Occlux's Monte Carlo at a few samples and the path-traced truth, each
//! with its time and its error against the truth under it; a group of rows per lighting (as
//! `occlux chart` lights a scene: its ambient lights, its suns and lamps), a method in each
//! lighting whose lights it renders. Writes OUT/gallery.png and OUT/gallery.json.

use crate::bench::timed_keeping;
use crate::chart::measure::LightingMode;
use crate::chart::plot::{png_font_registered, FAMILY};
use occlux::error::{Error, Result};
use occlux::export::png::tone_map;
use occlux::export::png::write_rgb_png;
use occlux::font::FONT_PATHS;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::plan::measure::{monte_carlo, render_method, Subject, Truth};
use occlux::plan::{method_candidates, Choice};
use occlux::progress::Progress;
use occlux::render::RenderImage;
use occlux::scene::Scene;
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
    /// Lightings, a group of rows each: ambient (the scene's ambient lights, or radiance 1),
    /// sun (its suns and lamps), multi (the same with 8 bounces); as `occlux chart`.
    #[arg(long, value_delimiter = ',', default_value = "ambient,sun")]
    pub lightings: Vec<LightingMode>,
    #[arg(long, default_value = "cpu")]
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

/// The tiles of one lighting: its methods, Monte Carlo and the truth.
#[derive(Serialize)]
struct Group {
    lighting: &'static str,
    /// The truth's estimator and its own relative noise.
    truth: &'static str,
    truth_noise: f64,
    tiles: Vec<Tile>,
}

#[derive(Serialize)]
struct Report<'a> {
    scene: String,
    device: String,
    truth_spp: u32,
    groups: &'a [Group],
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
    occlux::export::atomic::check_writable(&args.out)?;
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
        crate::term::notice(quiet, line);
    }
    let (tree, base) = Scene::file_tree(&args.scene)?;
    let bar = crate::term::Bar::new(quiet, args.lightings.len() as u64, "gallery");
    let mut groups = vec![];
    for (n, &light) in args.lightings.iter().enumerate() {
        let lit = light
            .scene_tree(tree.clone(), &base, args.size)
            .map_err(|e| Error::format(&args.scene, e.to_string()))?;
        let scene = Scene::from_value(lit, &base)?;
        groups.push(group(&scene, light, args, &compute, &|line: &str| {
            bar.message(&format!("{}: {line}", light.name()))
        })?);
        bar.update(n as u64 + 1, args.lightings.len() as u64);
    }
    bar.finish();
    let (rgb, size) = compose(&groups, args.exposure, &png)?;
    // The picture and its numbers as one set.
    let mut set = occlux::export::atomic::OutputSet::new(&args.out)?;
    write_rgb_png(&set.path("gallery.png")?, &rgb, size)?;
    let report = Report {
        scene: args.scene.display().to_string(),
        device: compute.describe(),
        truth_spp: args.spp,
        groups: &groups,
    };
    super::write_report(&set.marker("gallery.json")?, &report, true)?;
    crate::term::report_written(&set.commit()?, quiet);
    Ok(())
}

/// One lighting's tiles: every registered method at each of its chart settings that renders
/// some of its lights, Monte Carlo at a few samples, and the truth.
fn group(
    scene: &Scene,
    light: LightingMode,
    args: &GalleryArgs,
    compute: &Compute,
    say: &dyn Fn(&str),
) -> Result<Group> {
    let loaded = scene.load()?;
    let lut = loaded.scene.classification.bake(&loaded.volume);
    let subject = Subject {
        scene: &loaded.scene,
        volume: &loaded.volume,
        lut: &lut,
        compute,
    };
    let camera = loaded.scene.camera;
    let estimator = light.estimator();
    say("the truth");
    let (truth_image, truth_seconds) = monte_carlo(&subject, &camera, estimator, args.spp, 11)?;
    let truth = Truth::new(&subject, camera, &truth_image)?;
    let mut tiles = vec![];
    for choice in method_candidates(&loaded.scene.lighting)? {
        let Choice::Method { method, .. } = &choice else {
            continue;
        };
        let label = choice.label();
        say(&label);
        let (timing, (image, _)) =
            timed_keeping(args.repeats, || render_method(&subject, method, &camera))?;
        let (rmse, bias) = truth.error(&image.rgba, 0.0)?;
        tiles.push(Tile {
            label,
            seconds: timing.median_ms / 1e3,
            rel_rmse: Some(rmse),
            rel_bias: Some(bias),
            image,
        });
    }
    say("Monte Carlo");
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
        label: format!("{} truth ({} spp)", light.name(), args.spp),
        seconds: truth_seconds,
        rel_rmse: None,
        rel_bias: None,
        image: truth_image.to_render(),
    });
    Ok(Group {
        lighting: light.name(),
        truth: estimator.name(),
        truth_noise: truth.noise,
        tiles,
    })
}

/// Each group's tiles in rows of [`COLUMNS`] (a group starts a row), each tone-mapped with
/// its caption under it, as RGB.
fn compose(
    groups: &[Group],
    exposure: f32,
    path: &std::path::Path,
) -> Result<(Vec<u8>, (u32, u32))> {
    let first = &groups[0].tiles[0].image;
    let (w, h) = (first.width, first.height);
    let columns = COLUMNS as u32;
    // Each tile's place: (column, row).
    let mut places = vec![];
    let mut row = 0u32;
    for g in groups {
        for n in 0..g.tiles.len() as u32 {
            places.push((n % columns, row + n / columns));
        }
        row += (g.tiles.len() as u32).div_ceil(columns);
    }
    let tiles: Vec<&Tile> = groups.iter().flat_map(|g| &g.tiles).collect();
    let size = (w * columns, (h + CAPTION) * row);
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
