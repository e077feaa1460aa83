#![no_main]
//! Occlux's writers against independent readers: random small grids written as OpenVDB
//! (`write_vdb`, every storage option) and random layers as OpenEXR (`write_exr`, half and
//! float), read back with vdb-rs and the exr crate. Either the writer refuses with an error that
//! says why and leaves nothing in the folder, or the file holds what was written: float values
//! bit for bit, half-float values as f16 rounds them (what tests/vdb.rs expects), and in a VDB
//! exactly the voxels that differ from the background active (padding included).

use exr::prelude::traits::{ReadChannels, ReadLayers};
use exr::prelude::{f16, FlatSamples};
use glam::Vec3;
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use occlux::export::exr::{write_exr, ExrLayer, Precision};
use occlux::export::vdb::{write_vdb, Compression, GridClass, ValueMap, VdbGrid, VdbOptions};
use occlux::Error;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

fuzz_target!(init: occlux_fuzz::one_thread(), |data: &[u8]| {
    let u = &mut Unstructured::new(data);
    let dir = tempfile::tempdir_in(occlux_fuzz::scratch()).expect("a scratch folder");
    // Each leaves the folder empty, so that the other's refusals can be seen to leave nothing.
    let _ = vdb(u, dir.path());
    let _ = exr(u, dir.path());
});

/// A sample: mostly 0 (a fog volume's background, so grids are sparse) or a small multiple of
/// `scale`, now and then any f32 at all (NaN, infinities, subnormals, beyond a half float).
fn sample(u: &mut Unstructured, scale: f32) -> Result<f32> {
    Ok(match u.int_in_range(0u8..=255)? {
        0..=99 => 0.0,
        255 => f32::from_bits(u.arbitrary()?),
        b => (b as f32 - 177.0) * scale,
    })
}

/// A scale for [`sample`]: ordinary, tiny, beyond half floats, near f32's largest, or anything.
fn scale(u: &mut Unstructured) -> Result<f32> {
    if u.ratio(1, 8)? {
        return Ok(f32::from_bits(u.arbitrary()?));
    }
    Ok(*u.choose(&[1.0, 0.5, 1e-3, 1e-8, 1e3, 3e38])?)
}

/// One of the names Occlux writes, or now and then any few bytes (empty, unprintable, long).
fn name(u: &mut Unstructured, usual: &[&str]) -> Result<String> {
    if u.ratio(1, 8)? {
        let len = u.int_in_range(0..=6)?;
        return Ok(String::from_utf8_lossy(u.bytes(len)?).into_owned());
    }
    Ok(u.choose(usual)?.to_string())
}

/// A coordinate: one Occlux writes, or now and then any f32.
fn coordinate(u: &mut Unstructured, usual: &[f32]) -> Result<f32> {
    if u.ratio(1, 16)? {
        return Ok(f32::from_bits(u.arbitrary()?));
    }
    Ok(*u.choose(usual)?)
}

/// The words an error gives the user, beyond its variant's frame.
fn message(e: &Error) -> String {
    match e {
        Error::Param { message, .. } | Error::Format { message, .. } => message.clone(),
        Error::Io { source, .. } => source.to_string(),
        other => other.to_string(),
    }
}

/// A refusal must say why and leave the folder as it was: empty.
fn refused(e: &Error, dir: &Path) {
    assert!(
        !message(e).trim().is_empty(),
        "an error without a message: {e:?}"
    );
    let left: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().collect();
    assert!(left.is_empty(), "refused ({e}) but left {left:?}");
}

/// A grid's data, owned, for the [`VdbGrid`] that borrows it.
struct Source {
    name: String,
    dims: [usize; 3],
    spacing: Vec3,
    origin: Vec3,
    values: Vec<f32>,
    background: f32,
    class: GridClass,
    padded: bool,
    mapped: bool,
}

/// The map of a mapped grid (`VdbGrid::mapped`, the density from the values): any function of
/// the value will do, and doubling can overflow to infinity, which the writer must catch.
fn double(v: f32) -> f32 {
    2.0 * v
}

fn source(u: &mut Unstructured) -> Result<Source> {
    let mut dims = [0; 3];
    for d in &mut dims {
        *d = u.int_in_range(1..=16)?;
    }
    let spacings = [1.0, 0.5, 0.25, 2.0, 3.0];
    let mut spacing = Vec3::splat(coordinate(u, &spacings)?);
    // Uniform spacing is written as another map type than a non-uniform one.
    if u.arbitrary()? {
        spacing.y = coordinate(u, &spacings)?;
        spacing.z = coordinate(u, &spacings)?;
    }
    let origins = [0.0, -1.5, 10.0, 1e6];
    let origin = Vec3::new(
        coordinate(u, &origins)?,
        coordinate(u, &origins)?,
        coordinate(u, &origins)?,
    );
    let scale = scale(u)?;
    let values = (0..dims.iter().product())
        .map(|_| sample(u, scale))
        .collect::<Result<_>>()?;
    // As VdbGrid::from_volume and VdbGrid::level_set make them, or now and then otherwise.
    let class = *u.choose(&[GridClass::FogVolume, GridClass::LevelSet])?;
    let level_set = class == GridClass::LevelSet;
    let background = if u.ratio(3, 4)? {
        if level_set {
            3.0 * spacing.max_element()
        } else {
            0.0
        }
    } else {
        sample(u, scale)?
    };
    let padded = level_set == u.ratio(1, 4)?;
    Ok(Source {
        name: name(u, &["density", "value", "ao", "sdf"])?,
        dims,
        spacing,
        origin,
        values,
        background,
        class,
        padded,
        mapped: u.ratio(1, 4)?,
    })
}

fn vdb(u: &mut Unstructured, dir: &Path) -> Result<()> {
    let count = u.int_in_range(1..=3)?;
    let sources = (0..count).map(|_| source(u)).collect::<Result<Vec<_>>>()?;
    let grids: Vec<VdbGrid> = sources
        .iter()
        .map(|s| VdbGrid {
            name: &s.name,
            dims: s.dims,
            spacing: s.spacing,
            origin: s.origin,
            values: &s.values,
            map: s.mapped.then_some(ValueMap(&double)),
            background: s.background,
            class: s.class,
            padded: s.padded,
        })
        .collect();
    let options = VdbOptions {
        compression: *u.choose(&[Compression::None, Compression::Zip])?,
        half: u.arbitrary()?,
    };
    let path = dir.join("grids.vdb");
    if let Err(e) = write_vdb(&path, &grids, &options) {
        refused(&e, dir);
        return Ok(());
    }
    let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
    let mut reader = vdb_rs::VdbReader::new(file)
        .unwrap_or_else(|e| panic!("vdb-rs cannot open what write_vdb wrote: {e}"));
    let mut names = reader.available_grids();
    names.sort();
    let mut want_names: Vec<String> = sources.iter().map(|s| s.name.clone()).collect();
    want_names.sort();
    assert_eq!(names, want_names);
    for grid in &grids {
        let back = reader
            .read_grid::<f32>(grid.name)
            .unwrap_or_else(|e| panic!("vdb-rs cannot read grid '{}': {e}", grid.name));
        match back.transform {
            vdb_rs::Map::ScaleTranslateMap {
                scale_values,
                translation,
                ..
            } => {
                assert_eq!(scale_values.to_array(), grid.spacing.as_dvec3().to_array());
                assert_eq!(translation.to_array(), grid.origin.as_dvec3().to_array());
            }
            other => panic!("expected a scale-translate map, got {other:?}"),
        }
        let voxels: HashMap<[i32; 3], f32> = back
            .iter()
            .map(|(p, v, level)| {
                assert!(level == vdb_rs::VdbLevel::Voxel, "no tiles are written");
                ([p.x as i32, p.y as i32, p.z as i32], v)
            })
            .collect();
        assert_eq!(voxels, active(grid, options.half), "grid '{}'", grid.name);
    }
    std::fs::remove_file(&path).unwrap();
    Ok(())
}

/// The active voxels a reader must find: every written index (the grid, and its padding, which
/// repeats the border) whose value differs from the background, as stored.
fn active(grid: &VdbGrid, half: bool) -> HashMap<[i32; 3], f32> {
    let pad = grid.padded as i32;
    let [nx, ny, nz] = grid.dims.map(|d| d as i32);
    let mut voxels = HashMap::new();
    for k in -pad..nz + pad {
        for j in -pad..ny + pad {
            for i in -pad..nx + pad {
                let at = |c: i32, n: i32| c.clamp(0, n - 1) as usize;
                let index = at(i, nx) + grid.dims[0] * (at(j, ny) + grid.dims[1] * at(k, nz));
                let v = grid.values[index];
                let v = grid.map.map_or(v, |ValueMap(f)| f(v));
                if v != grid.background {
                    let stored = if half { f16::from_f32(v).to_f32() } else { v };
                    voxels.insert([i, j, k], stored);
                }
            }
        }
    }
    voxels
}

/// A channel as compared: its full name, whether it is stored as f16, and its samples' bits.
type Channel = (String, bool, Vec<u32>);

fn exr(u: &mut Unstructured, dir: &Path) -> Result<()> {
    let (width, height) = (u.int_in_range(0..=16)?, u.int_in_range(0..=16)?);
    let pixels = width as usize * height as usize;
    let precision = *u.choose(&[Precision::Half, Precision::Float])?;
    let mut layers = Vec::new();
    let mut want: Vec<Channel> = Vec::new();
    for _ in 0..u.int_in_range(0..=3)? {
        let layer = name(u, &["beauty", "depth", "occlusion", "shadow"])?;
        let channels: Vec<String> = if u.ratio(1, 8)? {
            (0..u.int_in_range(0..=3)?)
                .map(|_| name(u, &["R", "Z"]))
                .collect::<Result<_>>()?
        } else {
            let sets: [&[&str]; 4] = [&["R", "G", "B", "A"], &["Z"], &["V", "A"], &["Y"]];
            u.choose(&sets)?.iter().map(|c| c.to_string()).collect()
        };
        let scale = scale(u)?;
        let mut samples = (0..pixels * channels.len())
            .map(|_| sample(u, scale))
            .collect::<Result<Vec<_>>>()?;
        if u.ratio(1, 16)? {
            samples.pop();
        }
        for (c, channel) in channels.iter().enumerate() {
            // Depth is float32 whatever the precision (Blender's background depth is 1e10).
            let half = precision == Precision::Half && channel != "Z";
            let values = samples.iter().skip(c).step_by(channels.len());
            let bits = values
                .map(|&v| if half { f16::from_f32(v).to_f32() } else { v }.to_bits())
                .collect();
            want.push((format!("{layer}.{channel}"), half, bits));
        }
        layers.push(ExrLayer {
            name: layer,
            channels,
            pixels: samples,
        });
    }
    let mut meta = BTreeMap::new();
    for _ in 0..u.int_in_range(0..=3)? {
        let key = if u.ratio(3, 4)? {
            format!("occlux/{}", name(u, &["camera", "method", "lighting"])?)
        } else {
            name(u, &["occlux/plan"])?
        };
        let len = u.int_in_range(0..=16)?;
        meta.insert(key, String::from_utf8_lossy(u.bytes(len)?).into_owned());
    }
    let path = dir.join("layers.exr");
    if let Err(e) = write_exr(&path, width, height, &layers, &meta, precision) {
        refused(&e, dir);
        return Ok(());
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .non_parallel()
        .pedantic()
        .from_file(&path)
        .unwrap_or_else(|e| panic!("exr cannot read what write_exr wrote: {e}"));
    assert_eq!(image.layer_data.len(), 1, "one part");
    let part = &image.layer_data[0];
    assert_eq!(
        (part.size.0, part.size.1),
        (width as usize, height as usize)
    );
    let mut got: Vec<Channel> = part
        .channel_data
        .list
        .iter()
        .map(|c| {
            let half = matches!(c.sample_data, FlatSamples::F16(_));
            let bits = c.sample_data.values_as_f32().map(f32::to_bits).collect();
            (c.name.to_string(), half, bits)
        })
        .collect();
    // The file holds its channels sorted by name; two of one name come in either order.
    got.sort();
    want.sort();
    assert_eq!(got, want, "the channels read back are those written");
    let texts: BTreeMap<String, String> = part
        .attributes
        .other
        .iter()
        .filter_map(|(key, value)| match value {
            exr::meta::attribute::AttributeValue::Text(t) => Some((key.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    assert_eq!(
        texts, meta,
        "the text attributes read back are those written"
    );
    std::fs::remove_file(&path).unwrap();
    Ok(())
}
