//! PNG previews: 8-bit sRGB with Blender's "Standard" view transform (linear radiance times the
//! exposure, clamped to [0, 1], then the sRGB transfer function), so a preview looks like
//! Blender's display of the same EXR.

use crate::error::{Error, Result};
use crate::export::atomic::write_atomic;
use crate::render::RenderImage;
use std::path::Path;

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// An 8-bit code for a linear value after exposure: clamped, sRGB-encoded, rounded.
pub fn tone_map(linear: f32, exposure: f32) -> u8 {
    let v = (linear * exposure).clamp(0.0, 1.0);
    // NaN never reaches here (renders are finite), but map it to black rather than panic.
    (srgb_encode(if v.is_nan() { 0.0 } else { v }) * 255.0).round() as u8
}

/// Writes the beauty (RGB; the background is already composited in) as an 8-bit sRGB PNG.
pub fn write_png_preview(path: &Path, img: &RenderImage, exposure: f32) -> Result<()> {
    if !(exposure > 0.0 && exposure.is_finite()) {
        return Err(Error::param(
            "exposure",
            format!("must be positive, got {exposure}"),
        ));
    }
    let data: Vec<u8> = img
        .rgba
        .iter()
        .flat_map(|p| [p[0], p[1], p[2]].map(|c| tone_map(c, exposure)))
        .collect();
    write_rgb_png(path, &data, (img.width, img.height))
}

/// Encodes 8-bit sRGB pixels (RGB, row 0 at the top) as a PNG at `path`, atomically.
pub fn write_rgb_png(path: &Path, rgb: &[u8], (width, height): (u32, u32)) -> Result<()> {
    if rgb.len() != width as usize * height as usize * 3 {
        return Err(Error::param(
            "rgb",
            format!("{} bytes for {width} x {height} RGB pixels", rgb.len()),
        ));
    }
    write_atomic(path, |w| {
        let mut encoder = png::Encoder::new(w, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let fail = |e: png::EncodingError| Error::format(path, format!("writing PNG: {e}"));
        let mut writer = encoder.write_header().map_err(fail)?;
        writer.write_image_data(rgb).map_err(fail)?;
        writer.finish().map_err(fail)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_map_follows_srgb() {
        assert_eq!(tone_map(0.0, 1.0), 0);
        assert_eq!(tone_map(1.0, 1.0), 255);
        assert_eq!(tone_map(7.0, 1.0), 255);
        assert_eq!(tone_map(0.5, 1.0), 188);
        assert_eq!(tone_map(0.25, 2.0), 188);
        // The linear segment: 0.002 * 12.92 * 255 = 6.59.
        assert_eq!(tone_map(0.002, 1.0), 7);
        assert!((srgb_encode(0.003_130_8) - 0.040_45).abs() < 1e-4);
    }

    #[test]
    fn preview_reads_back_with_row_zero_on_top() {
        let mut img = RenderImage::new(2, 3);
        img.rgba[0] = [1.0, 0.5, 0.0, 1.0]; // top-left
        img.rgba[5] = [0.0, 0.0, 0.25, 1.0]; // bottom-right
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.png");
        write_png_preview(&path, &img, 1.0).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (2, 3));
        assert_eq!(&buf[0..3], &[255, 188, 0]);
        assert_eq!(&buf[15..18], &[0, 0, tone_map(0.25, 1.0)]);
        assert!(write_png_preview(&path, &img, 0.0).is_err());
    }
}
