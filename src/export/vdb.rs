//! The OpenVDB writer (no Rust crate writes VDB): float grids in the standard
//! `Tree_float_5_4_3` layout of file version 224, several grids per file, fog-volume class,
//! sparse (voxels equal to the background are inactive; leaves without active voxels and empty
//! internal nodes are not written), the index-to-world transform in the grid, optional zlib.
//! Layout: ../shared/notes/openvdb-format.md and OpenVDB's io/Archive.cc.
//!
//! Voxel (i, j, k) of a grid is stored at index coordinate (i, j, k), and the transform maps it
//! to `origin + (i, j, k) * spacing`, so voxel centres keep their world positions.
//!
//! Values are written with the "no mask, all values" block encoding (metadata byte 6) and
//! without half floats; the active-mask block compression and half-float storage are left to
//! the exchange-formats work.

use crate::error::{Error, Result};
use crate::export::atomic::write_atomic;
use crate::volume::Volume;
use glam::Vec3;
use std::collections::BTreeMap;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

const FILE_VERSION: u32 = 224;
const LIBRARY_VERSION: (u32, u32) = (12, 0);
const COMPRESS_NONE: u32 = 0;
const COMPRESS_ZIP: u32 = 1;
const NO_MASK_AND_ALL_VALS: u8 = 6;

/// How value blocks are stored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Compression {
    None,
    #[default]
    Zip,
}

/// One dense float grid to write; values x fastest.
#[derive(Clone, Copy, Debug)]
pub struct VdbGrid<'a> {
    pub name: &'a str,
    pub dims: [usize; 3],
    pub spacing: Vec3,
    pub origin: Vec3,
    pub values: &'a [f32],
    pub background: f32,
}

impl<'a> VdbGrid<'a> {
    /// A grid holding a volume's values, background 0.
    pub fn from_volume(name: &'a str, volume: &'a Volume) -> Self {
        Self {
            name,
            dims: volume.dims(),
            spacing: volume.spacing(),
            origin: volume.origin(),
            values: volume.values(),
            background: 0.0,
        }
    }

    fn validate(&self) -> Result<()> {
        let key = format!("vdb grid '{}'", self.name);
        let printable = self.name.chars().all(|c| c.is_ascii_graphic() || c == ' ');
        if self.name.is_empty() || !printable {
            return Err(Error::param(key, "names must be non-empty printable ASCII"));
        }
        let count = crate::volume::voxel_count(self.dims)?;
        if self.dims.iter().any(|&d| d > 1 << 20) || count != self.values.len() {
            return Err(Error::param(
                key,
                format!(
                    "dims {:?} do not match {} values",
                    self.dims,
                    self.values.len()
                ),
            ));
        }
        if !self.spacing.is_finite()
            || self.spacing.min_element() <= 0.0
            || !self.origin.is_finite()
        {
            return Err(Error::param(
                key,
                "spacing must be positive and origin finite",
            ));
        }
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            return Err(Error::param(
                key,
                format!("value {} at index {i} is not finite", self.values[i]),
            ));
        }
        Ok(())
    }
}

/// Writing options.
#[derive(Clone, Copy, Debug, Default)]
pub struct VdbOptions {
    pub compression: Compression,
}

/// Writes the grids into one file, atomically.
pub fn write_vdb(path: &Path, grids: &[VdbGrid], options: &VdbOptions) -> Result<()> {
    if grids.is_empty() {
        return Err(Error::param("vdb", "nothing to write: no grids"));
    }
    for (n, grid) in grids.iter().enumerate() {
        grid.validate()?;
        if grids[..n].iter().any(|g| g.name == grid.name) {
            return Err(Error::param(
                "vdb",
                format!("two grids are named '{}'", grid.name),
            ));
        }
    }
    write_atomic(path, |w| {
        write_file(w, grids, options).map_err(|e| Error::io(path, e))
    })
}

fn write_file<W: Write + Seek>(
    w: &mut W,
    grids: &[VdbGrid],
    options: &VdbOptions,
) -> std::io::Result<()> {
    w.write_all(&0x5644_4220i64.to_le_bytes())?;
    w.write_all(&FILE_VERSION.to_le_bytes())?;
    w.write_all(&LIBRARY_VERSION.0.to_le_bytes())?;
    w.write_all(&LIBRARY_VERSION.1.to_le_bytes())?;
    w.write_all(&[1])?; // grid offsets follow each descriptor
    w.write_all(uuid(grids).as_bytes())?;
    w.write_all(&0u32.to_le_bytes())?; // no file metadata
    w.write_all(&(grids.len() as u32).to_le_bytes())?;
    for grid in grids {
        write_grid(w, grid, options)?;
    }
    Ok(())
}

/// A deterministic 36-character identifier from the grids' names and sizes.
fn uuid(grids: &[VdbGrid]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for g in grids {
        for b in g.name.bytes().chain(g.values.len().to_le_bytes()) {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    let hex = format!("{h:016x}{:016x}", h.rotate_left(29) ^ 0x9e37_79b9_7f4a_7c15);
    format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

fn string(w: &mut impl Write, s: &str) -> std::io::Result<()> {
    w.write_all(&(s.len() as u32).to_le_bytes())?;
    w.write_all(s.as_bytes())
}

fn metadata(w: &mut impl Write, name: &str, type_name: &str, bytes: &[u8]) -> std::io::Result<()> {
    string(w, name)?;
    string(w, type_name)?;
    w.write_all(&(bytes.len() as u32).to_le_bytes())?;
    w.write_all(bytes)
}

/// Index-space origin of a node.
type Origin = [i32; 3];
/// A leaf's 512 values, x slowest.
type Leaf = [f32; 512];
/// A 4-level node's leaves, by origin.
type Node4 = BTreeMap<Origin, Leaf>;

/// A sparse tree: leaves (8^3) keyed by their origin, grouped under 4-level (128^3) and
/// 5-level (4096^3) nodes, in OpenVDB's child order (x slowest).
struct Tree {
    /// node5 origin -> node4 origin -> leaf origin -> 512 values (x slowest).
    nodes: BTreeMap<Origin, BTreeMap<Origin, Node4>>,
    active_voxels: u64,
}

fn build_tree(grid: &VdbGrid) -> Tree {
    let [nx, ny, nz] = grid.dims;
    let mut nodes: BTreeMap<Origin, BTreeMap<Origin, Node4>> = BTreeMap::new();
    let mut active_voxels = 0;
    for lk in (0..nz).step_by(8) {
        for lj in (0..ny).step_by(8) {
            for li in (0..nx).step_by(8) {
                let mut leaf = [grid.background; 512];
                let mut any = false;
                for k in lk..(lk + 8).min(nz) {
                    for j in lj..(lj + 8).min(ny) {
                        let row = &grid.values[nx * (j + ny * k)..][..nx];
                        for i in li..(li + 8).min(nx) {
                            let v = row[i];
                            if v != grid.background {
                                leaf[((i - li) << 6) | ((j - lj) << 3) | (k - lk)] = v;
                                any = true;
                                active_voxels += 1;
                            }
                        }
                    }
                }
                if any {
                    let o = [li as i32, lj as i32, lk as i32];
                    let n4 = o.map(|c| c & !127);
                    let n5 = o.map(|c| c & !4095);
                    nodes
                        .entry(n5)
                        .or_default()
                        .entry(n4)
                        .or_default()
                        .insert(o, leaf);
                }
            }
        }
    }
    Tree {
        nodes,
        active_voxels,
    }
}

/// A node mask of `bits` bits with the given indices set, as little-endian u64 words.
fn mask(bits: usize, on: impl IntoIterator<Item = usize>) -> Vec<u8> {
    let mut words = vec![0u64; bits / 64];
    for i in on {
        words[i >> 6] |= 1 << (i & 63);
    }
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

fn child_index(origin: [i32; 3], parent: [i32; 3], shift: u32, log2: u32) -> usize {
    let l = |a: usize| ((origin[a] - parent[a]) >> shift) as usize;
    (l(0) << (2 * log2)) | (l(1) << log2) | l(2)
}

/// A value block: the metadata byte, then the values, raw or zlib-compressed.
fn values(w: &mut impl Write, values: &[f32], compression: Compression) -> std::io::Result<()> {
    w.write_all(&[NO_MASK_AND_ALL_VALS])?;
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    match compression {
        Compression::None => w.write_all(&raw),
        Compression::Zip => {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(&raw)?;
            let zipped = z.finish()?;
            if zipped.len() < raw.len() {
                w.write_all(&(zipped.len() as i64).to_le_bytes())?;
                w.write_all(&zipped)
            } else {
                w.write_all(&(-(raw.len() as i64)).to_le_bytes())?;
                w.write_all(&raw)
            }
        }
    }
}

fn write_grid<W: Write + Seek>(
    w: &mut W,
    grid: &VdbGrid,
    options: &VdbOptions,
) -> std::io::Result<()> {
    string(w, grid.name)?;
    string(w, "Tree_float_5_4_3")?;
    string(w, "")?; // no instance parent
    let offsets_at = w.stream_position()?;
    w.write_all(&[0u8; 24])?; // grid, block and end positions, patched below
    let grid_pos = w.stream_position()?;
    let flags = match options.compression {
        Compression::None => COMPRESS_NONE,
        Compression::Zip => COMPRESS_ZIP,
    };
    w.write_all(&flags.to_le_bytes())?;

    let tree = build_tree(grid);
    let dims = grid.dims.map(|d| d as i32);
    let bbox_max: Vec<u8> = dims.iter().flat_map(|d| (d - 1).to_le_bytes()).collect();
    w.write_all(&5u32.to_le_bytes())?;
    metadata(w, "class", "string", b"fog volume")?;
    metadata(w, "file_bbox_min", "vec3i", &[0u8; 12])?;
    metadata(w, "file_bbox_max", "vec3i", &bbox_max)?;
    metadata(
        w,
        "file_voxel_count",
        "int64",
        &(tree.active_voxels as i64).to_le_bytes(),
    )?;
    metadata(w, "name", "string", grid.name.as_bytes())?;

    let (s, t) = (grid.spacing.as_dvec3(), grid.origin.as_dvec3());
    let uniform = s.x == s.y && s.y == s.z;
    string(
        w,
        if uniform {
            "UniformScaleTranslateMap"
        } else {
            "ScaleTranslateMap"
        },
    )?;
    for v in [t, s, s, 1.0 / s, 1.0 / (s * s), 0.5 / s] {
        for c in v.to_array() {
            w.write_all(&c.to_le_bytes())?;
        }
    }

    // Topology: buffer count, background, no root tiles, the 5-level children.
    w.write_all(&1i32.to_le_bytes())?;
    w.write_all(&grid.background.to_le_bytes())?;
    w.write_all(&0u32.to_le_bytes())?;
    w.write_all(&(tree.nodes.len() as u32).to_le_bytes())?;
    let tiles5 = vec![grid.background; 32768];
    let tiles4 = vec![grid.background; 4096];
    for (n5, children) in &tree.nodes {
        for c in n5 {
            w.write_all(&c.to_le_bytes())?;
        }
        w.write_all(&mask(
            32768,
            children.keys().map(|o| child_index(*o, *n5, 7, 5)),
        ))?;
        w.write_all(&mask(32768, []))?;
        values(w, &tiles5, options.compression)?;
        for (n4, leaves) in children {
            w.write_all(&mask(
                4096,
                leaves.keys().map(|o| child_index(*o, *n4, 3, 4)),
            ))?;
            w.write_all(&mask(4096, []))?;
            values(w, &tiles4, options.compression)?;
            for leaf in leaves.values() {
                w.write_all(&leaf_mask(leaf, grid.background))?;
            }
        }
    }
    let block_pos = w.stream_position()?;
    for leaves in tree.nodes.values().flat_map(|c| c.values()) {
        for leaf in leaves.values() {
            w.write_all(&leaf_mask(leaf, grid.background))?;
            values(w, leaf, options.compression)?;
        }
    }
    let end_pos = w.stream_position()?;
    w.seek(SeekFrom::Start(offsets_at))?;
    for pos in [grid_pos, block_pos, end_pos] {
        w.write_all(&(pos as i64).to_le_bytes())?;
    }
    w.seek(SeekFrom::Start(end_pos))?;
    Ok(())
}

fn leaf_mask(leaf: &Leaf, background: f32) -> Vec<u8> {
    mask(512, (0..512).filter(|&i| leaf[i] != background))
}
