//! The system TrueType font that labels Occlux's PNG figures (the error map's key here, the
//! lab's chart and gallery), read at run time from the usual places: headless machines have no
//! fontconfig, and shipping a font would put its licence in every build.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

/// Where the PNG's font is looked for, first found wins: Debian/Ubuntu, Fedora (old and new
/// layouts), Arch, then Liberation and FreeFont on Debian/Fedora, then macOS and Windows.
pub const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// The bytes of the first of [`FONT_PATHS`] that parses as a font, read once per process (the
/// answer is kept, found or not). 'static because plotters keeps registered fonts for the life
/// of the process.
pub fn system_font() -> Option<&'static [u8]> {
    static FONT: OnceLock<Option<&'static [u8]>> = OnceLock::new();
    *FONT.get_or_init(|| {
        FONT_PATHS.iter().find_map(|path| {
            let bytes = std::fs::read(path).ok()?;
            FontRef::try_from_slice(&bytes).ok()?;
            // Read once per process: leaking it is what makes it 'static.
            Some(&*Box::leak(bytes.into_boxed_slice()))
        })
    })
}

/// Draws `text` into `rgb` (8-bit RGB rows of `width` pixels) in `colour`, `px` pixels high,
/// centred on `centre_x` with the top of its line box at `top`; glyphs past the edges are
/// clipped. Draws nothing without a system font.
pub fn draw_text_centred(
    rgb: &mut [u8],
    width: usize,
    text: &str,
    px: f32,
    (centre_x, top): (f32, f32),
    colour: [u8; 3],
) {
    let Some(font) = system_font().and_then(|bytes| FontRef::try_from_slice(bytes).ok()) else {
        return;
    };
    let scaled = font.as_scaled(PxScale::from(px));
    let ids: Vec<_> = text.chars().map(|c| font.glyph_id(c)).collect();
    let advance = |i: usize| {
        let kern = ids
            .get(i + 1)
            .map_or(0.0, |&next| scaled.kern(ids[i], next));
        scaled.h_advance(ids[i]) + kern
    };
    let line_width: f32 = (0..ids.len()).map(advance).sum();
    let height = rgb.len() / 3 / width.max(1);
    let mut pen = centre_x - line_width / 2.0;
    for (i, &id) in ids.iter().enumerate() {
        let glyph = id.with_scale_and_position(px, ab_glyph::point(pen, top + scaled.ascent()));
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let x = bounds.min.x as i64 + gx as i64;
                let y = bounds.min.y as i64 + gy as i64;
                if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
                    return;
                }
                let at = (y as usize * width + x as usize) * 3;
                let coverage = coverage.clamp(0.0, 1.0);
                for (channel, &ink) in rgb[at..at + 3].iter_mut().zip(&colour) {
                    let blended = *channel as f32 * (1.0 - coverage) + ink as f32 * coverage;
                    *channel = blended.round() as u8;
                }
            });
        }
        pen += advance(i);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_inks_pixels_around_its_centre_only() {
        let (width, height) = (120, 30);
        let mut rgb = vec![255u8; width * height * 3];
        draw_text_centred(&mut rgb, width, "+20%", 12.0, (60.0, 5.0), [0, 0, 0]);
        let inked: Vec<(usize, usize)> = (0..width * height)
            .filter(|&i| rgb[3 * i] < 128)
            .map(|i| (i % width, i / width))
            .collect();
        if system_font().is_none() {
            // No font on this machine (.ci/run installs fonts-dejavu-core): nothing drawn.
            assert!(inked.is_empty());
            return;
        }
        assert!(!inked.is_empty(), "the text drew nothing");
        let (min_x, max_x) = inked
            .iter()
            .fold((width, 0), |(lo, hi), &(x, _)| (lo.min(x), hi.max(x)));
        // Four glyphs of a 12 px font: narrower than 48 px, centred on 60 within a pixel or two.
        assert!(max_x - min_x < 48, "{min_x}..{max_x}");
        assert!(
            ((min_x + max_x) as f32 / 2.0 - 60.0).abs() <= 2.0,
            "{min_x}..{max_x}"
        );
        assert!(inked.iter().all(|&(_, y)| (5..5 + 14).contains(&y)), "rows");
    }
}
