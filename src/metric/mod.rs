//! How far an image is from a reference of the same scene: the error figures of
//! docs/architecture.md, over the pixels that show the volume. The planner predicts with them,
//! the lab's accuracy commands and chart report them, the add-on's Check Against Cycles shows
//! them and their map ([`error_map`]).

pub mod error_map;

use crate::error::{Error, Result};

/// Whether a reference pixel shows the volume: its grey differs from the background's by more
/// than 0.5 % of it (the pixels every error figure is measured over).
pub fn shows_volume(reference: &[f32; 3], background: f32) -> bool {
    let grey = (reference[0] + reference[1] + reference[2]) as f64 / 3.0;
    (grey - background as f64).abs() > 0.005 * background as f64
}

/// Pixels measured, relative RMSE, bias and reference noise over the pixels where the reference
/// shows the volume ([`shows_volume`]); `image` is RGBA whose alpha is ignored.
pub fn design_error(
    image: &[[f32; 4]],
    reference: &[[f32; 3]],
    stderr: Option<&[[f32; 3]]>,
    background: f32,
) -> Result<(usize, f64, f64, f64)> {
    if image.len() != reference.len() {
        return Err(Error::param("reference", "image sizes differ"));
    }
    let (mut sq, mut sum, mut sum_image, mut noise, mut n) = (0.0f64, 0.0, 0.0, 0.0, 0usize);
    for (p, (a, b)) in image.iter().zip(reference).enumerate() {
        if !shows_volume(b, background) {
            continue;
        }
        for c in 0..3 {
            sq += (a[c] as f64 - b[c] as f64).powi(2);
            sum += b[c] as f64;
            sum_image += a[c] as f64;
            noise += stderr.map_or(0.0, |e| (e[p][c] as f64).powi(2));
        }
        n += 3;
    }
    if n == 0 || sum <= 0.0 {
        return Err(Error::param(
            "reference",
            "no volume pixels to measure over",
        ));
    }
    let mean = sum / n as f64;
    Ok((
        n / 3,
        (sq / n as f64).sqrt() / mean,
        sum_image / sum - 1.0,
        (noise / n as f64).sqrt() / mean,
    ))
}

/// The error of an image against a reference, over the volume's pixels.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_counts_only_pixels_that_differ_from_the_background() {
        // Two volume pixels (0.5 and 0.25 grey) and one background pixel the image gets wrong.
        let reference = [[0.5; 3], [0.25; 3], [1.0; 3]];
        let image = [
            [0.55, 0.55, 0.55, 1.0],
            [0.275, 0.275, 0.275, 1.0],
            [9.0; 4],
        ];
        let (pixels, rmse, bias, noise) = design_error(&image, &reference, None, 1.0).unwrap();
        assert_eq!(pixels, 2);
        // Differences 0.05 and 0.025 over a mean of 0.375.
        let want = ((0.05f64.powi(2) + 0.025f64.powi(2)) / 2.0).sqrt() / 0.375;
        assert!((rmse - want).abs() < 1e-6, "{rmse} vs {want}");
        assert!((bias - 0.1).abs() < 1e-6 && noise == 0.0);
        assert!(design_error(&image[..2], &reference, None, 1.0).is_err());
        assert!(design_error(&image[2..], &reference[2..], None, 1.0).is_err());
    }

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
}
