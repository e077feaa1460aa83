//! A method's image against a reference image (Cycles, or a Monte Carlo reference) of the same
//! scene: DESIGN.md's error figures over the volume's pixels, and a picture of where the
//! difference lies with its colour key (the add-on's Check Against Cycles shows both).

use crate::error::{Error, Result};
use crate::eval::chart::plot::{png_font_registered, write_png, FAMILY};
use crate::eval::sweep_accuracy::{design_error, shows_volume};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// DESIGN.md's error of an image against a reference, over the volume's pixels.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ImageError {
    /// Pixels where the reference differs from the background by more than 0.5 % of it.
    pub pixels: usize,
    /// RMSE of the linear RGB difference over those pixels / the reference's mean there.
    pub rel_rmse: f64,
    /// Mean difference / the reference's mean there.
    pub bias: f64,
    /// The reference's own standard error, RMS over those pixels / its mean (0 without one).
    pub noise: f64,
}

/// The error of `image` (linear RGB, or RGBA whose alpha is ignored) against `reference`, with
/// the reference's per-pixel standard error if it has one; `background` is the grey the
/// background shows.
pub fn image_error(
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    stderr: Option<&[[f32; 3]]>,
    background: f32,
) -> Result<ImageError> {
    if stderr.is_some_and(|e| e.len() != reference.len()) {
        return Err(Error::param(
            "stderr",
            "its size differs from the reference's",
        ));
    }
    let rgba: Vec<[f32; 4]> = image.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
    let (pixels, rel_rmse, bias, noise) = design_error(&rgba, reference, stderr, background)?;
    Ok(ImageError {
        pixels,
        rel_rmse,
        bias,
        noise,
    })
}

/// The map's colour scale runs over ± the first of these that holds 95 % of the volume's
/// pixels' relative differences (the last holds whatever remains, saturated).
const RANGES: [f64; 8] = [0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0];
/// The map is drawn at least this many pixels along its longer side (nearest neighbour).
const MIN_SIDE: usize = 256;
/// Height of the colour key below the map.
const KEY_HEIGHT: u32 = 44;
/// Grey of pixels outside the volume (no difference measured there).
const OUTSIDE: RGBColor = RGBColor(96, 96, 96);

/// Writes a PNG of where `image` differs from `reference` (both `width` x `height`, row 0 at
/// the top): each volume pixel (as [`image_error`] counts them) coloured by the difference of
/// its grey over the reference's mean, blue where the image is darker, white where they agree,
/// red where it is brighter, saturating at ± the returned range; other pixels mid grey. Below
/// the map, a colour key labelled with the range (the labels need a system font; without one
/// the key is drawn unlabelled and the range is only returned).
pub fn write_error_map(
    path: &Path,
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    (width, height): (usize, usize),
    background: f32,
) -> Result<f64> {
    if width == 0 || height == 0 || image.len() != width * height {
        return Err(Error::param(
            "image",
            format!("{} pixels for {width} x {height}", image.len()),
        ));
    }
    if reference.len() != image.len() {
        return Err(Error::param(
            "reference",
            "its size differs from the image's",
        ));
    }
    let grey = |p: &[f32; 3]| (p[0] + p[1] + p[2]) as f64 / 3.0;
    let volume: Vec<usize> = (0..reference.len())
        .filter(|&i| shows_volume(&reference[i], background))
        .collect();
    let sum: f64 = volume.iter().map(|&i| grey(&reference[i])).sum();
    if volume.is_empty() || sum <= 0.0 {
        return Err(Error::param(
            "reference",
            "no volume pixels to measure over",
        ));
    }
    let mean = sum / volume.len() as f64;
    let difference = |i: usize| (grey(&image[i]) - grey(&reference[i])) / mean;
    let mut sizes: Vec<f64> = volume.iter().map(|&i| difference(i).abs()).collect();
    sizes.sort_by(f64::total_cmp);
    let typical = sizes[(sizes.len() * 95 / 100).min(sizes.len() - 1)];
    let range = RANGES
        .into_iter()
        .find(|&r| typical <= r)
        .unwrap_or(RANGES[RANGES.len() - 1]);

    let scale = MIN_SIDE.div_ceil(width.max(height)).max(1);
    let size = ((width * scale) as u32, (height * scale) as u32 + KEY_HEIGHT);
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        let fail = |e: DrawingAreaErrorKind<_>| Error::format(path, format!("drawing: {e}"));
        root.fill(&WHITE).map_err(fail)?;
        let mut in_volume = vec![false; image.len()];
        volume.iter().for_each(|&i| in_volume[i] = true);
        for (i, &measured) in in_volume.iter().enumerate() {
            let colour = if measured {
                diverging(difference(i) / range)
            } else {
                OUTSIDE
            };
            let (x, y) = ((i % width * scale) as i32, (i / width * scale) as i32);
            let s = scale as i32;
            root.draw(&Rectangle::new([(x, y), (x + s, y + s)], colour.filled()))
                .map_err(fail)?;
        }
        draw_key(&root, size, range).map_err(fail)?;
        root.present().map_err(fail)?;
    }
    write_png(path, &rgb, size)?;
    Ok(range)
}

/// Blue (-1) through white (0) to red (+1), clamped.
fn diverging(t: f64) -> RGBColor {
    let t = t.clamp(-1.0, 1.0);
    let fade = |full: f64| (255.0 * (1.0 - t.abs()) + full * t.abs()).round() as u8;
    if t < 0.0 {
        RGBColor(fade(33.0), fade(102.0), fade(172.0))
    } else {
        RGBColor(fade(178.0), fade(24.0), fade(43.0))
    }
}

/// The colour key under the map: the scale from -range to +range, and its labels when a font
/// is found.
fn draw_key<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    (width, height): (u32, u32),
    range: f64,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let top = (height - KEY_HEIGHT) as i32 + 6;
    let (left, right) = (width as i32 / 10, width as i32 * 9 / 10);
    for x in left..right {
        let t = 2.0 * (x - left) as f64 / (right - left - 1).max(1) as f64 - 1.0;
        root.draw(&Rectangle::new(
            [(x, top), (x + 1, top + 12)],
            diverging(t).filled(),
        ))?;
    }
    if !png_font_registered() {
        return Ok(());
    }
    let percent = |v: f64| format!("{:+}%", (100.0 * v).round());
    let style = TextStyle::from((FAMILY, 12).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
    let y = top + 15;
    root.draw_text(&percent(-range), &style, (left, y))?;
    root.draw_text("image - reference", &style, ((left + right) / 2, y))?;
    root.draw_text(&percent(range), &style, (right, y))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_figures_have_closed_forms() {
        // A reference of grey 0.5 on a background of 0.1, an image 10 % brighter on half the
        // pixels and equal on the rest: bias +5 %, relative RMSE sqrt(0.5 x 0.01) = 0.0707.
        let reference = vec![[0.5f32; 3]; 4];
        let image = vec![[0.55f32; 3], [0.55; 3], [0.5; 3], [0.5; 3]];
        let e = image_error(&image, &reference, None, 0.1).unwrap();
        assert_eq!(e.pixels, 4);
        assert!((e.bias - 0.05).abs() < 1e-6, "{e:?}");
        assert!((e.rel_rmse - 0.5f64.sqrt() * 0.1).abs() < 1e-6, "{e:?}");
        let flat = vec![[0.1f32; 3]; 4];
        assert!(
            image_error(&flat, &flat, None, 0.1).is_err(),
            "no volume pixels"
        );
    }

    #[test]
    fn the_map_colours_the_sign_and_keeps_its_range() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("map.png");
        let reference = vec![[0.5f32; 3], [0.5; 3], [0.1; 3], [0.5; 3]];
        // Differences of -/+ 0.125 (exact in f32): the scale's 0.2 holds them.
        let image = vec![[0.4375f32; 3], [0.5625; 3], [0.1; 3], [0.5; 3]];
        let range = write_error_map(&path, &image, &reference, (2, 2), 0.1).unwrap();
        assert_eq!(range, 0.2);
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (256, 256 + KEY_HEIGHT));
        let at = |x: usize, y: usize| {
            let i = (y * info.width as usize + x) * 3;
            [buf[i], buf[i + 1], buf[i + 2]]
        };
        let (darker, brighter, outside, equal) =
            (at(10, 10), at(200, 10), at(10, 200), at(200, 200));
        assert!(
            darker[2] > darker[0],
            "blue where the image is darker: {darker:?}"
        );
        assert!(
            brighter[0] > brighter[2],
            "red where it is brighter: {brighter:?}"
        );
        assert_eq!(outside, [96, 96, 96]);
        assert_eq!(equal, [255, 255, 255]);
    }
}
