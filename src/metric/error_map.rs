//! A picture of where a method's image differs from a reference image of the same scene, with
//! its colour key (the add-on's Check Against Cycles shows it beside the error figures).

use super::shows_volume;
use crate::error::{Error, Result};
use crate::export::png::write_rgb_png;
use crate::font::draw_text_centred;
use std::path::Path;

/// The map's colour scale runs over ± the first of these that holds 95 % of the volume's
/// pixels' relative differences (the last holds whatever remains, saturated).
const RANGES: [f64; 8] = [0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0];
/// The map is drawn at least this many pixels along its longer side (nearest neighbour).
const MIN_SIDE: usize = 256;
/// Height of the colour key below the map.
const KEY_HEIGHT: u32 = 44;
/// Grey of pixels outside the volume (no difference measured there).
const OUTSIDE: [u8; 3] = [96, 96, 96];
/// Height of the key's labels in pixels.
const LABEL_PX: f32 = 12.0;

/// Writes a PNG of where `image` differs from `reference` (both `width` x `height`, row 0 at
/// the top): each volume pixel (as [`super::image_error`] counts them) coloured by the
/// difference of its grey over the reference's mean, blue where the image is darker, white
/// where they agree, red where it is brighter, saturating at ± the returned range; other pixels
/// mid grey. Below the map, a colour key labelled with the range (the labels need a system
/// font, [`crate::font`]; without one the key is drawn unlabelled and the range is only
/// returned).
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
    let in_volume: Vec<bool> = reference
        .iter()
        .map(|p| shows_volume(p, background))
        .collect();
    let (sum, count) = reference
        .iter()
        .zip(&in_volume)
        .filter(|(_, &shown)| shown)
        .fold((0.0, 0usize), |(sum, n), (p, _)| (sum + grey(p), n + 1));
    if count == 0 || sum <= 0.0 {
        return Err(Error::param(
            "reference",
            "no volume pixels to measure over",
        ));
    }
    let mean = sum / count as f64;
    let difference = |i: usize| (grey(&image[i]) - grey(&reference[i])) / mean;
    let mut sizes: Vec<f64> = (0..image.len())
        .filter(|&i| in_volume[i])
        .map(|i| difference(i).abs())
        .collect();
    sizes.sort_by(f64::total_cmp);
    let typical = sizes[(sizes.len() * 95 / 100).min(sizes.len() - 1)];
    let range = RANGES
        .into_iter()
        .find(|&r| typical <= r)
        .unwrap_or(RANGES[RANGES.len() - 1]);

    let scale = MIN_SIDE.div_ceil(width.max(height)).max(1);
    let size = ((width * scale) as u32, (height * scale) as u32 + KEY_HEIGHT);
    let row = size.0 as usize;
    let mut rgb = vec![255u8; row * size.1 as usize * 3];
    let mut fill = |x0: usize, y0: usize, (w, h): (usize, usize), colour: [u8; 3]| {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                rgb[(y * row + x) * 3..][..3].copy_from_slice(&colour);
            }
        }
    };
    for (i, &measured) in in_volume.iter().enumerate() {
        let colour = if measured {
            diverging(difference(i) / range)
        } else {
            OUTSIDE
        };
        fill(i % width * scale, i / width * scale, (scale, scale), colour);
    }
    // The key: the scale from -range to +range across the middle eight tenths, labelled below.
    let top = (size.1 - KEY_HEIGHT) as usize + 6;
    let (left, right) = (row / 10, row * 9 / 10);
    for x in left..right {
        let t = 2.0 * (x - left) as f64 / (right - left - 1).max(1) as f64 - 1.0;
        fill(x, top, (1, 12), diverging(t));
    }
    let percent = |v: f64| format!("{:+}%", (100.0 * v).round());
    let label_top = (top + 15) as f32;
    for (text, x) in [
        (percent(-range), left),
        ("image - reference".to_owned(), (left + right) / 2),
        (percent(range), right),
    ] {
        draw_text_centred(
            &mut rgb,
            row,
            &text,
            LABEL_PX,
            (x as f32, label_top),
            [0, 0, 0],
        );
    }
    write_rgb_png(path, &rgb, size)?;
    Ok(range)
}

/// Blue (-1) through white (0) to red (+1), clamped.
fn diverging(t: f64) -> [u8; 3] {
    let t = t.clamp(-1.0, 1.0);
    let fade = |full: f64| (255.0 * (1.0 - t.abs()) + full * t.abs()).round() as u8;
    if t < 0.0 {
        [fade(33.0), fade(102.0), fade(172.0)]
    } else {
        [fade(178.0), fade(24.0), fade(43.0)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let labels = (256 + 21..256 + KEY_HEIGHT as usize)
            .flat_map(|y| (0..256).map(move |x| (x, y)))
            .filter(|&(x, y)| at(x, y)[0] < 128)
            .count();
        assert_eq!(
            labels > 0,
            crate::font::system_font().is_some(),
            "the key is labelled where a font is found"
        );
    }
}
