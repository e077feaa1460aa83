//! Multilayer OpenEXR, the layout of docs/architecture.md#export-conventions: one file per render,
//! layers `beauty` (RGBA), `depth` (Z) and per-method layers, with the camera and parameters as
//! text attributes.
//!
//! Layers are stored the way Blender, Nuke and OpenImageIO name them in one part: channel
//! `layer.channel` (e.g. `beauty.R`, `depth.Z`). Values are float16 by default; depth is always
//! float32, because the background depth 1e10 (Blender's value) is beyond float16's 65504.

use crate::error::{Error, Result};
use crate::export::atomic::write_atomic;
use crate::render::RenderImage;
use exr::prelude::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// Sample precision of the colour layers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    #[default]
    Half,
    Float,
}

/// One layer: its channels' names and their samples interleaved per pixel, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrLayer {
    pub name: String,
    pub channels: Vec<String>,
    pub pixels: Vec<f32>,
}

impl ExrLayer {
    /// The samples of one channel, or None if the layer has no such channel.
    pub fn channel(&self, name: &str) -> Option<Vec<f32>> {
        let n = self.channels.len();
        let c = self.channels.iter().position(|x| x == name)?;
        Some(self.pixels.iter().skip(c).step_by(n).copied().collect())
    }
}

/// A multilayer EXR read back: size, layers (channels sorted by name) and text attributes.
#[derive(Clone, Debug)]
pub struct ExrImage {
    pub width: u32,
    pub height: u32,
    pub layers: Vec<ExrLayer>,
    pub metadata: BTreeMap<String, String>,
}

impl ExrImage {
    /// The R, G and B of the first layer that has all three, per pixel.
    pub fn rgb(&self) -> Option<Vec<[f32; 3]>> {
        let layer = self.layers.iter().find(|l| {
            ["R", "G", "B"]
                .iter()
                .all(|c| l.channels.iter().any(|n| n == c))
        })?;
        let at = |c: &str| layer.channels.iter().position(|n| n == c).unwrap_or(0);
        let (r, g, b, n) = (at("R"), at("G"), at("B"), layer.channels.len());
        Some(layer.pixels.chunks(n).map(|p| [p[r], p[g], p[b]]).collect())
    }

    pub fn layer(&self, name: &str) -> Option<&ExrLayer> {
        self.layers.iter().find(|l| l.name == name)
    }
}

/// The channels of a shading factor's layer ([`crate::render::Factor`]): the factor
/// premultiplied by coverage, P, and the coverage, A (`occlusion.V` and `occlusion.A`,
/// `shadow.V` and `shadow.A`).
pub const FACTOR_CHANNELS: [&str; 2] = ["V", "A"];

/// The layers of a render: `beauty` (R, G, B, A) and `depth` (Z); a render with a shading
/// factor adds it as one layer named after it (`occlusion` for DOS, `shadow` for IPSVI and
/// half-angle slicing) with the channels of [`FACTOR_CHANNELS`]: `V` is
/// P = sum_i T_i alpha_i f_i, the factor f_i of each sample along the pixel's ray weighted as
/// its colour is composited (T_i the transmittance in front of it, alpha_i its opacity), and
/// `A` its coverage 1 - T (the same as `beauty.A`). So `0 <= V <= A`, `V = A` where nothing
/// occludes or shadows, `V = A = 0` where the ray meets nothing: a premultiplied grey, smooth
/// wherever the image is. Shade another render of the same view by
/// `render * (1 - strength * (A - V))`: a multiplier that is 1 where the layer has no coverage.
pub fn render_layers(img: &RenderImage) -> Vec<ExrLayer> {
    let mut layers = vec![
        ExrLayer {
            name: "beauty".into(),
            channels: ["R", "G", "B", "A"].map(String::from).to_vec(),
            pixels: img.rgba.iter().flatten().copied().collect(),
        },
        ExrLayer {
            name: "depth".into(),
            channels: vec!["Z".into()],
            pixels: img.depth.clone(),
        },
    ];
    if let Some(factor) = &img.factor {
        layers.push(ExrLayer {
            name: factor.name.into(),
            channels: FACTOR_CHANNELS.map(String::from).to_vec(),
            pixels: factor.values.iter().flatten().copied().collect(),
        });
    }
    layers
}

/// Writes the layers atomically. Rejects NaN or infinite samples, naming layer, channel and
/// pixel, and layers whose pixel count does not match the size.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    layers: &[ExrLayer],
    metadata: &BTreeMap<String, String>,
    precision: Precision,
) -> Result<()> {
    let pixels = width as usize * height as usize;
    if pixels == 0 || layers.is_empty() {
        return Err(Error::param(
            "exr",
            "an EXR needs a non-empty size and at least one layer",
        ));
    }
    let mut channels = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for layer in layers {
        validate_layer(layer, pixels, precision)?;
        for (c, channel) in layer.channels.iter().enumerate() {
            let values = layer.pixels.iter().skip(c).step_by(layer.channels.len());
            // Depth keeps float32: Blender's background depth 1e10 overflows float16.
            let samples = if precision == Precision::Float || channel == "Z" {
                FlatSamples::F32(values.copied().collect())
            } else {
                FlatSamples::F16(values.map(|&v| f16::from_f32(v)).collect())
            };
            channels.push(AnyChannel::new(
                name(&format!("{}.{channel}", layer.name))?,
                samples,
            ));
        }
    }
    let mut attributes = LayerAttributes {
        software_name: Some(text(concat!("occlux ", env!("CARGO_PKG_VERSION")))?),
        ..LayerAttributes::default()
    };
    for (key, value) in metadata {
        attributes
            .other
            .insert(name(key)?, AttributeValue::Text(text(value)?));
    }
    let layer = Layer::new(
        (width as usize, height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let image = Image::from_layer(layer);
    write_atomic(path, |w| {
        image
            .write()
            .to_buffered(&mut *w)
            .map_err(|e| Error::format(path, format!("writing EXR: {e}")))?;
        w.flush().map_err(|e| Error::io(path, e))?;
        sort_header_attributes(w.get_mut()).map_err(|e| Error::io(path, e))
    })
}

/// Puts the header's attributes of the single-part EXR in `file` in the order of their names.
/// The exr crate keeps the text attributes in a `HashMap` and writes them in its iteration
/// order, which changes from run to run, so the same render would give files that differ in
/// bytes. The EXR format allows attributes in any order, and a permutation keeps the header's
/// length, so the offset table and pixel data after it stay valid.
fn sort_header_attributes(file: &mut std::fs::File) -> std::io::Result<()> {
    use std::io::{BufRead, Read, Seek, SeekFrom};
    file.seek(SeekFrom::Start(8))?;
    let mut header = std::io::BufReader::new(&mut *file);
    // Each attribute: its name and type, each ending in a zero byte, a 4-byte size and the
    // value; an empty name ends the header.
    let mut records: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
    loop {
        let mut name = Vec::new();
        header.read_until(0, &mut name)?;
        if name.len() <= 1 {
            break;
        }
        let mut record = name.clone();
        header.read_until(0, &mut record)?;
        let mut size = [0u8; 4];
        header.read_exact(&mut size)?;
        record.extend_from_slice(&size);
        let size = u32::from_le_bytes(size) as u64;
        let before = record.len();
        header.by_ref().take(size).read_to_end(&mut record)?;
        if (record.len() - before) as u64 != size {
            return Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "the EXR header ends inside an attribute",
            ));
        }
        records.push((name, record));
    }
    drop(header);
    records.sort();
    file.seek(SeekFrom::Start(8))?;
    for (_, record) in &records {
        file.write_all(record)?;
    }
    Ok(())
}

fn validate_layer(layer: &ExrLayer, pixels: usize, precision: Precision) -> Result<()> {
    let key = format!("exr layer `{}`", layer.name);
    let valid_name = |s: &str| !s.is_empty() && s.is_ascii() && !s.contains('.');
    if !valid_name(&layer.name) || !layer.channels.iter().all(|c| valid_name(c)) {
        return Err(Error::param(
            &key,
            "layer and channel names must be non-empty ASCII without '.'",
        ));
    }
    if layer.pixels.len() != pixels * layer.channels.len() {
        return Err(Error::param(
            &key,
            format!(
                "has {} samples, expected {pixels} pixels x {} channels",
                layer.pixels.len(),
                layer.channels.len()
            ),
        ));
    }
    if let Some(i) = layer.pixels.iter().position(|v| !v.is_finite()) {
        let n = layer.channels.len();
        return Err(Error::param(
            &key,
            format!(
                "channel {} at pixel {} is {}: refusing to write a non-finite value",
                layer.channels[i % n],
                i / n,
                layer.pixels[i]
            ),
        ));
    }
    // Float16 holds at most 65504: a larger colour would be written as infinity.
    let largest = f16::MAX.to_f32();
    if precision == Precision::Half {
        for (c, channel) in layer.channels.iter().enumerate() {
            // Depth is float32 whatever the precision.
            if channel == "Z" {
                continue;
            }
            let values = layer.pixels.iter().skip(c).step_by(layer.channels.len());
            if let Some((p, v)) = values.enumerate().find(|(_, v)| v.abs() > largest) {
                return Err(Error::param(
                    &key,
                    format!(
                        "channel {channel} at pixel {p} is {v}, beyond float16's {largest}: \
                         write float32 (occlux --float32, Python float32=True) or dimmer \
                         lights"
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn text(s: &str) -> Result<Text> {
    Text::new_or_none(s).ok_or_else(|| Error::param("exr", format!("'{s}' cannot be an EXR text")))
}

/// An attribute's or a channel's name: the header ends each at a NUL byte, so an empty name or
/// one holding NUL would end the header's list early and leave the file unreadable.
fn name(s: &str) -> Result<Text> {
    if s.is_empty() || s.contains('\0') {
        return Err(Error::param(
            "exr",
            format!("{s:?} cannot name an EXR attribute or channel: names are non-empty and hold no NUL byte"),
        ));
    }
    text(s)
}

/// Reads an EXR written by [`write_exr`] or another tool (Blender writes one part per pass),
/// grouping channels `layer.channel` into layers; a part's name prefixes its channels, and
/// channels with no prefix at all form the layer "". Text attributes of every part are kept.
pub fn read_exr(path: &Path) -> Result<ExrImage> {
    let image = read_all_flat_layers_from_file(path)
        .map_err(|e| Error::format(path, format!("reading EXR: {e}")))?;
    let size = image
        .layer_data
        .first()
        .map(|part| part.size)
        .unwrap_or_default();
    let pixels = size.0 * size.1;
    let mut grouped: BTreeMap<String, Vec<(String, Vec<f32>)>> = BTreeMap::new();
    let mut metadata = BTreeMap::new();
    for part in &image.layer_data {
        if part.size != size {
            return Err(Error::format(
                path,
                "parts of different sizes are not supported",
            ));
        }
        let prefix = part
            .attributes
            .layer_name
            .as_ref()
            .map(|n| format!("{n}."))
            .unwrap_or_default();
        for channel in &part.channel_data.list {
            let full = format!("{prefix}{}", channel.name);
            let (layer, name) = full.rsplit_once('.').unwrap_or(("", full.as_str()));
            grouped.entry(layer.to_string()).or_default().push((
                name.to_string(),
                channel.sample_data.values_as_f32().collect(),
            ));
        }
        for (key, value) in &part.attributes.other {
            if let AttributeValue::Text(t) = value {
                metadata.insert(key.to_string(), t.to_string());
            }
        }
    }
    let layers = grouped
        .into_iter()
        .map(|(name, channels)| ExrLayer {
            name,
            channels: channels.iter().map(|(n, _)| n.clone()).collect(),
            pixels: (0..pixels)
                .flat_map(|i| channels.iter().map(move |(_, v)| v[i]))
                .collect(),
        })
        .collect();
    Ok(ExrImage {
        width: size.0 as u32,
        height: size.1 as u32,
        layers,
        metadata,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layers() -> Vec<ExrLayer> {
        let img = RenderImage {
            width: 3,
            height: 2,
            rgba: (0..6)
                .map(|i| [i as f32 * 0.1, 0.5, 2.0, 1.0 - i as f32 * 0.2])
                .collect(),
            depth: vec![1.5, 2.25, crate::render::BACKGROUND_DEPTH, 3.0, 4.0, 5.0],
            factor: None,
        };
        render_layers(&img)
    }

    #[test]
    fn a_factor_is_one_layer_of_premultiplied_value_and_coverage_and_no_shaded_copy() {
        let coverage = [0.0, 0.25, 0.5, 0.75, 1.0, 1.0];
        let img = RenderImage {
            width: 3,
            height: 2,
            rgba: coverage.iter().map(|&a| [0.5, 0.5, 0.5, a]).collect(),
            depth: vec![crate::render::BACKGROUND_DEPTH; 6],
            factor: Some(crate::render::Factor::new(
                "occlusion",
                &[0.0, 0.25, 0.25, 0.8, 0.1, 1.0],
                &coverage,
            )),
        };
        let layers = render_layers(&img);
        let names: Vec<&str> = layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["beauty", "depth", "occlusion"]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        write_exr(&path, 3, 2, &layers, &BTreeMap::new(), Precision::Float).unwrap();
        let back = read_exr(&path).unwrap();
        let names: Vec<&str> = back.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(
            names,
            ["beauty", "depth", "occlusion"],
            "no RGBA copy of beauty"
        );
        let layer = back.layer("occlusion").unwrap();
        // Channels are read back sorted by name.
        assert_eq!(layer.channels, ["A", "V"]);
        // P is clamped into [0, A] (0.8 > 0.75).
        assert_eq!(
            layer.channel("V").unwrap(),
            [0.0, 0.25, 0.25, 0.75, 0.1, 1.0]
        );
        assert_eq!(layer.channel("A").unwrap(), coverage);
    }

    #[test]
    fn names_the_header_cannot_end_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        for key in ["", "\0", "occlux/\0plan"] {
            let meta = BTreeMap::from([(key.to_string(), String::new())]);
            let e = write_exr(&path, 3, 2, &layers(), &meta, Precision::Half).unwrap_err();
            assert!(e.to_string().contains("NUL"), "{e}");
            assert!(!path.exists());
        }
    }

    #[test]
    fn round_trip_keeps_layers_values_and_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.exr");
        let meta = BTreeMap::from([("occlux/camera".to_string(), "{\"fov\": 0.5}".to_string())]);
        for precision in [Precision::Half, Precision::Float] {
            write_exr(&path, 3, 2, &layers(), &meta, precision).unwrap();
            let back = read_exr(&path).unwrap();
            assert_eq!((back.width, back.height), (3, 2));
            assert_eq!(
                back.metadata.get("occlux/camera"),
                meta.get("occlux/camera")
            );
            for want in layers() {
                let got = back.layer(&want.name).unwrap();
                for c in &want.channels {
                    let (a, b) = (got.channel(c).unwrap(), want.channel(c).unwrap());
                    for (x, y) in a.iter().zip(&b) {
                        // Depth is float32 always; colour is exact in Float, 11 bits in Half.
                        let tol = if precision == Precision::Half && c != "Z" {
                            1e-3
                        } else {
                            0.0
                        };
                        assert!(
                            (x - y).abs() <= tol * y.abs(),
                            "{}.{c}: {x} vs {y}",
                            want.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn non_finite_values_are_refused_and_nothing_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.exr");
        let mut bad = layers();
        bad[0].pixels[5] = f32::NAN;
        let err = write_exr(&path, 3, 2, &bad, &BTreeMap::new(), Precision::Half).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("beauty") && msg.contains("channel G at pixel 1"),
            "{msg}"
        );
        assert!(!path.exists());
        let short = vec![ExrLayer {
            name: "ao".into(),
            channels: vec!["Y".into()],
            pixels: vec![0.5; 5],
        }];
        assert!(write_exr(&path, 3, 2, &short, &BTreeMap::new(), Precision::Half).is_err());
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }

    #[test]
    fn the_same_image_gives_the_same_bytes() {
        // The exr crate's attribute map iterates in an order seeded per map, so without the
        // sort ten attributes came out in a different order nearly every time.
        let dir = tempfile::tempdir().unwrap();
        let meta: BTreeMap<String, String> = (0..10)
            .map(|i| (format!("occlux/key{i}"), format!("value {i}")))
            .collect();
        let files: Vec<Vec<u8>> = (0..4)
            .map(|i| {
                let path = dir.path().join(format!("{i}.exr"));
                write_exr(&path, 3, 2, &layers(), &meta, Precision::Half).unwrap();
                std::fs::read(&path).unwrap()
            })
            .collect();
        assert!(files.windows(2).all(|pair| pair[0] == pair[1]));
        let back = read_exr(&dir.path().join("0.exr")).unwrap();
        for (key, value) in &meta {
            assert_eq!(back.metadata.get(key), Some(value), "{key}");
        }
        assert_eq!(
            back.layer("beauty").unwrap().channel("B").unwrap(),
            [2.0; 6]
        );
    }

    #[test]
    fn colours_beyond_float16_are_refused_in_half_and_kept_in_float() {
        // 65504 is float16's largest value: 3e5 would have been written as infinity.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bright.exr");
        let mut bright = layers();
        bright[0].pixels[4 * 3 + 1] = 3e5;
        let err = write_exr(&path, 3, 2, &bright, &BTreeMap::new(), Precision::Half)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("channel G at pixel 3")
                && err.contains("65504")
                && err.contains("float32"),
            "{err}"
        );
        assert!(!path.exists());
        write_exr(&path, 3, 2, &bright, &BTreeMap::new(), Precision::Float).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!(back.layer("beauty").unwrap().channel("G").unwrap()[3], 3e5);
        // The largest float16 itself is written as it is.
        bright[0].pixels[4 * 3 + 1] = 65504.0;
        write_exr(&path, 3, 2, &bright, &BTreeMap::new(), Precision::Half).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!(
            back.layer("beauty").unwrap().channel("G").unwrap()[3],
            65504.0
        );
    }

    #[test]
    fn garbage_is_a_format_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("junk.exr");
        std::fs::write(&path, b"not an exr at all").unwrap();
        assert!(read_exr(&path)
            .unwrap_err()
            .to_string()
            .contains("junk.exr"));
    }
}
