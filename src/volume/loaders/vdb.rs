//! OpenVDB float grids, read with vdb-rs into a dense volume over the active voxels' bounding
//! box.
//!
//! - Grid choice: `LoadOptions::grid` by name, else `density` if present, else the first float
//!   grid in name order.
//! - Inactive voxels read as 0: vdb-rs does not expose a grid's background, and fog volumes (the
//!   kind Occlux reads and writes) have background 0.
//! - Active tiles (uniform 8^3 or 128^3 blocks) are expanded into their voxels.
//! - The index-to-world map must be a scale and translation (vdb-rs reads no other): voxel
//!   (i, j, k) of the grid's index space sits at `translation + (i, j, k) * scale`; the volume's
//!   origin is the world position of the bounding box's first voxel.
//! - Half-float grids are read as Occlux writes them; vdb-rs 0.6 fails on those that OpenVDB
//!   itself writes (tests/python/test_exchange.py), and they are refused with a message
//!   saying so. Full-float grids from OpenVDB, Blosc-compressed or not, are read.
//! - vdb-rs panics on some malformed or unsupported files rather than returning an error; those
//!   panics are caught here and reported as format errors naming the file. It also allocates
//!   whatever a length field says, and a failed allocation cannot be caught: [`vdb_sizes`]
//!   checks every such field against the file's size first.

use super::{
    check_spacing, finish, vdb_sizes, Frame, LoadOptions, NonFiniteVoxels, Placement, SourceInfo,
};
use crate::error::{Error, Result};
use crate::export::vdb::{BOX_MAX, BOX_MIN};
use crate::volume::Volume;
use glam::{DVec3, IVec3, Vec3};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;
use vdb_rs::{Grid, Map, MetadataValue, VdbLevel, VdbReader};

const MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
const FLOAT_TREE: &str = "Tree_float_5_4_3";

pub(super) fn load(path: &Path, opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    check_magic(path)?;
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        read_float_grid(path, BufReader::new(file), opts.grid.as_deref())
    }));
    let (name, grid) = match parsed {
        Ok(result) => result?,
        Err(panic) => {
            let why = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown reason");
            return Err(Error::format(
                path,
                format!("not a readable OpenVDB file (the VDB reader stopped: {why})"),
            ));
        }
    };
    let half = grid.descriptor.meta_data.is_half_float();
    let (volume, non_finite) = densify(path, &grid, opts)?;
    let info = SourceInfo {
        format: "OpenVDB",
        scalar: if half { "float16" } else { "float32" }.into(),
        grid: Some(name),
        non_finite,
        frame: Frame::ALIGNED,
        hounsfield: None,
    };
    Ok((volume, info))
}

/// Rejects files that are not VDB before the reader sees them (it panics on some).
fn check_magic(path: &Path) -> Result<()> {
    let mut head = [0u8; 12];
    let mut file = File::open(path).map_err(|e| Error::io(path, e))?;
    file.read_exact(&mut head)
        .map_err(|_| Error::format(path, "too short to be an OpenVDB file"))?;
    if head[..8] != MAGIC {
        return Err(Error::format(
            path,
            "not an OpenVDB file (wrong magic number)",
        ));
    }
    let version = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if !(222..=300).contains(&version) {
        return Err(Error::format(
            path,
            format!("OpenVDB file version {version} is not supported (222 and later are)"),
        ));
    }
    Ok(())
}

fn read_float_grid(
    path: &Path,
    reader: BufReader<File>,
    wanted: Option<&str>,
) -> Result<(String, Grid<f32>)> {
    let fail = |e: vdb_rs::ParseError| Error::format(path, format!("reading OpenVDB: {e}"));
    let open = || File::open(path).map_err(|e| Error::io(path, e));
    vdb_sizes::check_header(path, open()?)?;
    let mut vdb = VdbReader::new(reader).map_err(fail)?;
    let mut names = vdb.available_grids();
    names.sort();
    let is_float = |name: &str| {
        vdb.grid_descriptors
            .get(name)
            .is_some_and(|d| d.grid_type.starts_with(FLOAT_TREE))
    };
    let name = match wanted {
        Some(name) if names.iter().any(|n| n == name) => {
            if !is_float(name) {
                return Err(Error::format(
                    path,
                    format!(
                        "grid '{name}' is a {}, not a float grid",
                        vdb.grid_descriptors[name].grid_type
                    ),
                ));
            }
            name.to_string()
        }
        Some(name) => {
            return Err(Error::format(
                path,
                format!("no grid named '{name}'; the file has: {}", names.join(", ")),
            ))
        }
        None if is_float("density") => "density".to_string(),
        None => names.iter().find(|n| is_float(n)).cloned().ok_or_else(|| {
            Error::format(
                path,
                format!("no float grid in the file (grids: {})", names.join(", ")),
            )
        })?,
    };
    let descriptor = &vdb.grid_descriptors[&name];
    let at = vdb_sizes::GridAt {
        grid_pos: descriptor.grid_pos,
        block_pos: descriptor.block_pos,
        compression: descriptor.compression.bits(),
        half: descriptor.meta_data.is_half_float(),
    };
    vdb_sizes::check_grid(path, open()?, &at)?;
    let grid = vdb.read_grid::<f32>(&name).map_err(fail)?;
    Ok((name, grid))
}

/// A grid iterator position (integral, carried as floats by vdb-rs) as an index.
fn index_of(p: [f32; 3]) -> IVec3 {
    IVec3::new(p[0] as i32, p[1] as i32, p[2] as i32)
}

/// Index-space extent of each item the grid iterator yields.
fn extent(level: VdbLevel) -> i32 {
    level.scale() as i32
}

/// The index box a grid Occlux padded declares as its own (`occlux_box_min`/`_max`), if any.
fn declared_box(grid: &Grid<f32>) -> Option<(IVec3, IVec3)> {
    let corner = |key: &str| match grid.descriptor.meta_data.0.get(key) {
        Some(MetadataValue::Vec3i(v)) => Some(IVec3::new(v.x, v.y, v.z)),
        _ => None,
    };
    Some((corner(BOX_MIN)?, corner(BOX_MAX)?))
}

/// Fills a dense volume over the bounding box of the active voxels and tiles, within the box
/// the grid declares as its own when Occlux padded it (the padding only serves renderers that
/// fade to the background beyond the stored voxels).
fn densify(path: &Path, grid: &Grid<f32>, opts: &LoadOptions) -> Result<(Volume, NonFiniteVoxels)> {
    let (mut lo, mut hi) = (IVec3::MAX, IVec3::MIN);
    for (corner, _, level) in grid.iter() {
        let c = index_of(corner.to_array());
        lo = lo.min(c);
        hi = hi.max(c + IVec3::splat(extent(level) - 1));
    }
    if let Some((box_lo, box_hi)) = declared_box(grid) {
        (lo, hi) = (lo.max(box_lo), hi.min(box_hi));
    }
    if lo.cmpgt(hi).any() {
        return Err(Error::format(path, "the grid has no active voxels"));
    }
    let size = (hi - lo + IVec3::ONE).as_i64vec3();
    let dims = [size.x as usize, size.y as usize, size.z as usize];
    let count = opts
        .memory
        .check(dims)
        .map_err(|e| Error::format(path, e.to_string()))?;
    let mut values = vec![0.0f32; count];
    for (corner, value, level) in grid.iter() {
        // The item's voxels within [lo, hi], relative to lo.
        let first = index_of(corner.to_array());
        let start = first.max(lo) - lo;
        let end = (first + IVec3::splat(extent(level))).min(hi + IVec3::ONE) - lo;
        if start.cmpge(end).any() {
            continue;
        }
        for k in start.z..end.z {
            for j in start.y..end.y {
                let row = (j as usize + dims[1] * k as usize) * dims[0];
                values[row + start.x as usize..row + end.x as usize].fill(value);
            }
        }
    }
    // vdb-rs carries its own glam version: cross over through arrays.
    let (scale, translation) = match &grid.transform {
        Map::UniformScaleMap { scale_values, .. } => (scale_values.to_array(), [0.0; 3]),
        Map::ScaleTranslateMap {
            scale_values,
            translation,
            ..
        } => (scale_values.to_array(), translation.to_array()),
    };
    let spacing = check_spacing(path, "grid transform", scale)?;
    let origin = DVec3::from(translation) + lo.as_dvec3() * DVec3::from(scale);
    let placement = Placement::grid(
        spacing,
        Vec3::new(origin.x as f32, origin.y as f32, origin.z as f32),
    );
    finish(path, dims, placement, values, opts)
}
