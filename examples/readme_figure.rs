//! The README's picture: the built-in demo's phantom (examples/demo-lit.toml) three ways, side by
//! side: unshaded (emission-absorption with unshadowed in-scattering), AO-shaded under an even
//! sky (the physical occlusion sweep's visibility), and lit by the demo's low sun with IPSVI
//! (shadows and multiple scattering).
//!
//! Run: `cargo run --release --example readme_figure -- docs/images/readme-figure.png`
//! (about ten seconds on two CPU cores; the GPU is used when one opens).

use occlux::error::{Error, Result};
use occlux::export::png::{tone_map, write_rgb_png};
use occlux::font::{draw_text_centred, system_font, FONT_PATHS};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{render, Settled};
use occlux::progress::NoProgress;
use occlux::render::RenderImage;
use occlux::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The demo scene; its lights and `[render]` come last, so the text before `[[lights]]` is the
/// volume, classification and camera every panel shares.
const DEMO: &str = include_str!("demo-lit.toml");

/// Each panel's caption and the lights and method that replace the demo's.
const PANELS: [(&str, &str); 3] = [
    (
        "unshaded",
        "[[lights]]\ntype = \"ambient\"\nradiance = 1\n[render]\nmethod = \"unshaded\"\n",
    ),
    (
        "ambient occlusion (sweep-physical)",
        "[[lights]]\ntype = \"ambient\"\nradiance = 1\n\
         [render]\nmethod = \"ao\"\nao_method = \"sweep-physical\"\n",
    ),
    ("sun (IPSVI, multiple scattering)", ""),
];

/// Height of the caption strip under each panel, and of its text.
const CAPTION: u32 = 28;
const CAPTION_PX: f32 = 16.0;

fn main() -> ExitCode {
    let out = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("readme-figure.png"), PathBuf::from);
    match figure(&out) {
        Ok(()) => {
            println!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn figure(out: &Path) -> Result<()> {
    if system_font().is_none() {
        return Err(Error::param(
            "font",
            format!(
                "the captions need a TrueType font; tried {}",
                FONT_PATHS.join(", ")
            ),
        ));
    }
    let (compute, notice) = Compute::resolve(DeviceChoice::Auto)?;
    if let Some(line) = notice {
        eprintln!("{line}");
    }
    let shared = &DEMO[..DEMO.find("[[lights]]").expect("the demo scene has lights")];
    let mut images = Vec::new();
    for (caption, lighting) in PANELS {
        let text = if lighting.is_empty() {
            DEMO.to_owned()
        } else {
            format!("{shared}{lighting}")
        };
        let scene = Scene::parse(&text, Path::new("."))?;
        let loaded = scene.load()?;
        let rendered = render(
            &Settled::named(&loaded.scene),
            &loaded.volume,
            &compute,
            &NoProgress,
        )?;
        images.push((caption, rendered.image));
    }
    let (rgb, size) = compose(&images);
    write_rgb_png(out, &rgb, size)
}

/// The panels left to right, each tone-mapped as the PNG preview is, with its caption centred
/// below it on the scene's background (the panel's corner pixel).
fn compose(images: &[(&str, RenderImage)]) -> (Vec<u8>, (u32, u32)) {
    let (w, h) = (images[0].1.width as usize, images[0].1.height as usize);
    let width = w * images.len();
    let height = h + CAPTION as usize;
    let mut rgb = vec![0u8; width * height * 3];
    for (n, (caption, image)) in images.iter().enumerate() {
        let background = image.rgba[0].map(|c| tone_map(c, 1.0));
        for y in 0..height {
            for x in 0..w {
                let at = (y * width + n * w + x) * 3;
                let pixel = image
                    .rgba
                    .get(y * w + x)
                    .map(|p| p.map(|c| tone_map(c, 1.0)));
                rgb[at..at + 3].copy_from_slice(&pixel.unwrap_or(background)[..3]);
            }
        }
        let centre = (n * w + w / 2) as f32;
        let top = h as f32 + (CAPTION as f32 - CAPTION_PX) / 2.0 - 2.0;
        draw_text_centred(
            &mut rgb,
            width,
            caption,
            CAPTION_PX,
            (centre, top),
            [225, 225, 225],
        );
    }
    (rgb, (width as u32, height as u32))
}
