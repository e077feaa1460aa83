//! The OpenVDB writer (no Rust crate writes VDB): float grids in the standard
//! `Tree_float_5_4_3` layout of file version 224, several grids per file, fog-volume or
//! level-set class,
//! sparse (voxels equal to the background are inactive; leaves without active voxels and empty
//! internal nodes are not written), the index-to-world transform in the grid, optional zlib.
//! Layout: ../shared/notes/openvdb-format.md and OpenVDB's io/Archive.cc.
//!
//! Voxel (i, j, k) of a grid is stored at index coordinate (i, j, k), and the transform maps it
//! to `origin + (i, j, k) * spacing`, so voxel centres keep their world positions.
//!
//! Fog volumes are padded: one more voxel on every side (index -1 and n) repeats its neighbour
//! on the border, and the metadata `occlux_box_min` / `occlux_box_max` give the grid's own
//! index box. Occlux samples a volume up to its box's faces (half a voxel beyond the outer
//! voxel centres) with the border value held there; a VDB renderer (Cycles, OpenVDB's
//! samplers) fades to the background over the voxel beyond the last stored one, which without
//! the padding thins every face by half a voxel. With it, a material that masks its density to
//! the box (the add-on's does, as the Cycles harness's) renders the volume exactly as Occlux
//! does; one that does not shows it up to one voxel wider. Occlux's reader clips to the box.
//!
//! Value blocks always use OpenVDB's active-mask compression (flag 2): inactive values equal the
//! background, so a block stores its metadata byte 0 and then only its active values. On top of
//! that, zlib (flag 1) is optional, and so is half-float storage (`Tree_float_5_4_3_HalfFloat`:
//! values are rounded to f16 in the file and widened back to f32 by readers).
//!
//! Memory: the writer keeps the tree's topology (leaf origins) and reads each leaf's values
//! from the source grid when it writes them, encoding [`LEAVES_PER_BATCH`] leaves at a time in
//! parallel, so beyond the source it holds a few MiB whatever the grid's size. A grid can be
//! [`VdbGrid::mapped`]: its values are a map of another grid's (the density from the volume's
//! values), applied leaf by leaf, so the mapped grid is never dense (512^3: `occlux export`
//! peaked at 1.05x the dense volume; 2.07x with the density a dense grid of its own, 2.49x when
//! the writer also held the whole tree).

use crate::error::{Error, Result};
use crate::export::atomic::write_atomic;
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

const FILE_VERSION: u32 = 224;
/// Grid metadata of a padded grid: its own index box, inclusive (see the module).
pub const BOX_MIN: &str = "occlux_box_min";
pub const BOX_MAX: &str = "occlux_box_max";
const LIBRARY_VERSION: (u32, u32) = (12, 0);
const COMPRESS_ZIP: u32 = 1;
const COMPRESS_ACTIVE_MASK: u32 = 2;
/// Block metadata "no mask or inactive values": every inactive value is the background, and only
/// the active values follow.
const NO_MASK_OR_INACTIVE_VALS: u8 = 0;
/// Block metadata "no mask, all values": every value of the node follows.
const NO_MASK_AND_ALL_VALS: u8 = 6;
/// The largest finite half float: larger values would turn into infinities.
const HALF_MAX: f32 = 65504.0;

fn fits_half(v: f32) -> bool {
    v.abs() <= HALF_MAX
}

/// How value blocks are stored (on top of the active-mask compression, which is always on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Compression {
    None,
    #[default]
    Zip,
}

impl std::str::FromStr for Compression {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "none" => Ok(Self::None),
            "zip" => Ok(Self::Zip),
            _ => Err(Error::param(
                "compression",
                format!("'{s}' is not one of none, zip"),
            )),
        }
    }
}

/// One dense float grid to write; values x fastest.
#[derive(Clone, Copy, Debug)]
pub struct VdbGrid<'a> {
    pub name: &'a str,
    pub dims: [usize; 3],
    pub spacing: Vec3,
    pub origin: Vec3,
    pub values: &'a [f32],
    /// What each of `values` goes through as it is read: a grid derived voxel by voxel from
    /// another's values ([`VdbGrid::mapped`]), written without a dense copy of its own.
    pub map: Option<ValueMap<'a>>,
    pub background: f32,
    pub class: GridClass,
    /// Write one more voxel on every side repeating the border (fog volumes; see the module).
    pub padded: bool,
}

/// A voxel-by-voxel function of a grid's values ([`VdbGrid::map`]).
#[derive(Clone, Copy)]
pub struct ValueMap<'a>(pub &'a (dyn Fn(f32) -> f32 + Sync));

impl std::fmt::Debug for ValueMap<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ValueMap(..)")
    }
}

/// OpenVDB's grid class: how readers (Blender among them) interpret the values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GridClass {
    /// Densities, 0 outside.
    #[default]
    FogVolume,
    /// A signed distance, negative inside; its background is the narrow band's half width.
    LevelSet,
}

impl GridClass {
    fn name(self) -> &'static [u8] {
        match self {
            GridClass::FogVolume => b"fog volume",
            GridClass::LevelSet => b"level set",
        }
    }
}

/// OpenVDB's default half width of a level set's narrow band, in voxels.
const LEVEL_SET_HALF_WIDTH: f32 = 3.0;

impl<'a> VdbGrid<'a> {
    /// A grid holding a volume's values, background 0.
    pub fn from_volume(name: &'a str, volume: &'a Volume) -> Self {
        Self {
            name,
            dims: volume.dims(),
            spacing: volume.spacing(),
            origin: volume.origin(),
            values: volume.values(),
            map: None,
            background: 0.0,
            class: GridClass::FogVolume,
            padded: true,
        }
    }

    /// A grid of `map` of each of a volume's values (the classified extinction of its raw
    /// values under a 1D table), background 0: the writer maps each leaf as it reads it, so
    /// no dense grid of the mapped values is ever held.
    pub fn mapped(name: &'a str, volume: &'a Volume, map: &'a (dyn Fn(f32) -> f32 + Sync)) -> Self {
        Self {
            map: Some(ValueMap(map)),
            ..Self::from_volume(name, volume)
        }
    }

    /// The value written for stored voxel `index`.
    #[inline]
    fn value(&self, index: usize) -> f32 {
        match self.map {
            Some(ValueMap(f)) => f(self.values[index]),
            None => self.values[index],
        }
    }

    /// The index and value of the first voxel whose written value fails `ok`, in parallel.
    fn find_bad(&self, ok: impl Fn(f32) -> bool + Sync) -> Option<(usize, f32)> {
        (0..self.values.len())
            .into_par_iter()
            .map(|i| (i, self.value(i)))
            .find_first(|&(_, v)| !ok(v))
    }

    /// A signed distance (negative inside, world units) as a level set: every voxel stored,
    /// the background OpenVDB's default narrow-band half width (three voxels).
    pub fn level_set(name: &'a str, sdf: &'a Volume) -> Self {
        Self {
            background: LEVEL_SET_HALF_WIDTH * sdf.spacing().max_element(),
            class: GridClass::LevelSet,
            // A distance beyond the grid is not the border's: the narrow band ends there.
            padded: false,
            ..Self::from_volume(name, sdf)
        }
    }

    fn validate(&self, options: &VdbOptions) -> Result<()> {
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
        if !self.background.is_finite() {
            return Err(Error::param(key, "the background must be finite"));
        }
        if let Some((i, v)) = self.find_bad(f32::is_finite) {
            return Err(Error::param(
                key,
                format!("value {v} at voxel {:?} is not finite", self.voxel_of(i)),
            ));
        }
        if options.half {
            if let Some((i, v)) = self.find_bad(fits_half) {
                return Err(Error::param(
                    key,
                    format!(
                        "value {v} at voxel {:?} does not fit a half float (|v| <= {HALF_MAX}); \
                         write float32",
                        self.voxel_of(i)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Every value fits a half float.
    pub fn fits_half(&self) -> bool {
        self.find_bad(fits_half).is_none()
    }

    fn voxel_of(&self, index: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [index % nx, (index / nx) % ny, index / (nx * ny)]
    }

    /// The index range written along `axis`: the grid's, and the padding around it.
    fn written(&self, axis: usize) -> std::ops::Range<i32> {
        let pad = self.padded as i32;
        -pad..self.dims[axis] as i32 + pad
    }

    /// The stored voxel written at index `i` along `axis`, None beyond what is written.
    fn source(&self, axis: usize, i: i32) -> Option<usize> {
        self.written(axis)
            .contains(&i)
            .then(|| i.clamp(0, self.dims[axis] as i32 - 1) as usize)
    }
}

/// Writing options.
#[derive(Clone, Copy, Debug, Default)]
pub struct VdbOptions {
    pub compression: Compression,
    /// Store values as half floats (half the size; about 3 significant digits).
    pub half: bool,
}

impl VdbOptions {
    fn flags(&self) -> u32 {
        COMPRESS_ACTIVE_MASK
            | match self.compression {
                Compression::None => 0,
                Compression::Zip => COMPRESS_ZIP,
            }
    }
}

/// Writes the grids into one file, atomically.
pub fn write_vdb(path: &Path, grids: &[VdbGrid], options: &VdbOptions) -> Result<()> {
    let each: Vec<(VdbGrid, VdbOptions)> = grids.iter().map(|g| (*g, *options)).collect();
    write_vdb_each(path, &each)
}

/// Writes the grids into one file, atomically, each with its own options: OpenVDB stores the
/// compression and the half-float flag per grid, so a grid whose values need no more than a
/// half float's 11 significant bits (an occlusion in [0, 1]) can be stored as one beside a
/// float32 grid.
pub fn write_vdb_each(path: &Path, grids: &[(VdbGrid, VdbOptions)]) -> Result<()> {
    if grids.is_empty() {
        return Err(Error::param("vdb", "nothing to write: no grids"));
    }
    for (n, (grid, options)) in grids.iter().enumerate() {
        grid.validate(options)?;
        if grids[..n].iter().any(|(g, _)| g.name == grid.name) {
            return Err(Error::param(
                "vdb",
                format!("two grids are named '{}'", grid.name),
            ));
        }
    }
    write_atomic(path, |w| {
        write_file(w, grids).map_err(|e| Error::io(path, e))
    })
}

fn write_file<W: Write + Seek>(w: &mut W, grids: &[(VdbGrid, VdbOptions)]) -> std::io::Result<()> {
    w.write_all(&0x5644_4220i64.to_le_bytes())?;
    w.write_all(&FILE_VERSION.to_le_bytes())?;
    w.write_all(&LIBRARY_VERSION.0.to_le_bytes())?;
    w.write_all(&LIBRARY_VERSION.1.to_le_bytes())?;
    w.write_all(&[1])?; // grid offsets follow each descriptor
    w.write_all(uuid(grids).as_bytes())?;
    w.write_all(&0u32.to_le_bytes())?; // no file metadata
    w.write_all(&(grids.len() as u32).to_le_bytes())?;
    for (grid, options) in grids {
        write_grid(w, grid, options)?;
    }
    Ok(())
}

/// A deterministic 36-character identifier from the grids' names and sizes.
fn uuid(grids: &[(VdbGrid, VdbOptions)]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for (g, _) in grids {
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
/// A 4-level node's leaves (those with active voxels), by origin.
type Node4 = BTreeSet<Origin>;

/// Leaves whose value blocks are encoded at once (in parallel) before being written: bounds
/// what the writer holds beyond the dense grid to this many encoded blocks (at most 2 KiB
/// each), whatever the grid's size.
const LEAVES_PER_BATCH: usize = 4096;

/// A sparse tree's topology: the leaves (8^3) with active voxels, keyed by their origin and
/// grouped under 4-level (128^3) and 5-level (4096^3) nodes, in OpenVDB's child order (x
/// slowest). The values stay in the dense grid; [`gather`] reads a leaf's when it is written.
struct Tree {
    /// node5 origin -> node4 origin -> leaf origins.
    nodes: BTreeMap<Origin, BTreeMap<Origin, Node4>>,
    active_voxels: u64,
    /// Index-space bounding box of the active voxels (inclusive).
    active_box: [[i32; 3]; 2],
}

/// The values of the leaf at `origin` (x slowest): the grid's, its padding's, and the
/// background beyond.
fn gather(grid: &VdbGrid, origin: Origin) -> Leaf {
    let [nx, ny, _] = grid.dims;
    let mut leaf = [grid.background; 512];
    for dk in 0..8 {
        let Some(k) = grid.source(2, origin[2] + dk) else {
            continue;
        };
        for dj in 0..8 {
            let Some(j) = grid.source(1, origin[1] + dj) else {
                continue;
            };
            let row = nx * (j + ny * k);
            for di in 0..8 {
                if let Some(i) = grid.source(0, origin[0] + di) {
                    leaf[((di as usize) << 6) | ((dj as usize) << 3) | dk as usize] =
                        grid.value(row + i);
                }
            }
        }
    }
    leaf
}

/// The origins of the leaves that cover what is written along `axis` (multiples of 8).
fn leaf_origins(grid: &VdbGrid, axis: usize) -> impl Iterator<Item = i32> {
    let range = grid.written(axis);
    (range.start.div_euclid(8)..=(range.end - 1).div_euclid(8)).map(|n| 8 * n)
}

fn build_tree(grid: &VdbGrid) -> Tree {
    let mut nodes: BTreeMap<Origin, BTreeMap<Origin, Node4>> = BTreeMap::new();
    let mut active_voxels = 0;
    let mut active_box = [[i32::MAX; 3], [i32::MIN; 3]];
    for lk in leaf_origins(grid, 2) {
        for lj in leaf_origins(grid, 1) {
            for li in leaf_origins(grid, 0) {
                let o = [li, lj, lk];
                // Beyond the grid a leaf holds the background, so only voxels count.
                let leaf = gather(grid, o);
                let mut any = false;
                for (n, _) in leaf
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| **v != grid.background)
                {
                    any = true;
                    active_voxels += 1;
                    let at = [
                        o[0] + (n >> 6) as i32,
                        o[1] + ((n >> 3) & 7) as i32,
                        o[2] + (n & 7) as i32,
                    ];
                    for a in 0..3 {
                        active_box[0][a] = active_box[0][a].min(at[a]);
                        active_box[1][a] = active_box[1][a].max(at[a]);
                    }
                }
                if any {
                    let n4 = o.map(|c| c & !127);
                    let n5 = o.map(|c| c & !4095);
                    nodes
                        .entry(n5)
                        .or_default()
                        .entry(n4)
                        .or_default()
                        .insert(o);
                }
            }
        }
    }
    Tree {
        nodes,
        active_voxels,
        active_box,
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

/// The value block of an internal node of `count` tiles, none of them active (all are the
/// background). Normally it holds no values at all. For zipped half floats, OpenVDB writes an
/// empty block as the metadata byte alone (its HalfWriter returns before the zip header), which
/// vdb-rs 0.6 misreads (it expects the header); there every tile is written instead (metadata
/// 6), which both read, and which zlib shrinks to a few dozen bytes.
fn tile_block(count: usize, background: f32, options: &VdbOptions) -> std::io::Result<Vec<u8>> {
    if options.half && options.compression == Compression::Zip {
        let mut block = encode_values(std::iter::repeat_n(background, count), options)?;
        block[0] = NO_MASK_AND_ALL_VALS;
        Ok(block)
    } else {
        encode_values(std::iter::empty(), options)
    }
}

/// A value block under active-mask compression: the metadata byte, then the active values
/// (those differing from the background; the node masks say where they go), as f32 or f16,
/// raw or zlib-compressed.
fn encode_values(
    active: impl Iterator<Item = f32>,
    options: &VdbOptions,
) -> std::io::Result<Vec<u8>> {
    let mut block = vec![NO_MASK_OR_INACTIVE_VALS];
    let raw: Vec<u8> = if options.half {
        // OpenVDB's HalfWriter writes nothing at all, not even a zip header, for zero values.
        let mut active = active.peekable();
        if active.peek().is_none() {
            return Ok(block);
        }
        active
            .flat_map(|v| half::f16::from_f32(v).to_le_bytes())
            .collect()
    } else {
        active.flat_map(|v| v.to_le_bytes()).collect()
    };
    match options.compression {
        Compression::None => block.extend_from_slice(&raw),
        Compression::Zip => {
            let zipped = ZIPPER.with(|z| z.borrow_mut().zip(&raw))?;
            if zipped.len() < raw.len() {
                block.extend_from_slice(&(zipped.len() as i64).to_le_bytes());
                block.extend_from_slice(&zipped);
            } else {
                block.extend_from_slice(&(-(raw.len() as i64)).to_le_bytes());
                block.extend_from_slice(&raw);
            }
        }
    }
    Ok(block)
}

thread_local! {
    /// Each thread's zlib stream, reset for every block: a fresh one per block spent more time
    /// setting up and clearing its tables than compressing a leaf's 2 KiB.
    static ZIPPER: std::cell::RefCell<Zipper> = std::cell::RefCell::new(Zipper::new());
}

/// A reusable zlib compressor at the default level.
struct Zipper {
    stream: flate2::Compress,
}

impl Zipper {
    fn new() -> Self {
        Self {
            stream: flate2::Compress::new(flate2::Compression::default(), true),
        }
    }

    /// `raw` as one zlib stream (header, deflate data, Adler-32), as `ZlibEncoder` writes it.
    fn zip(&mut self, raw: &[u8]) -> std::io::Result<Vec<u8>> {
        self.stream.reset();
        let mut out = Vec::with_capacity(raw.len() + raw.len() / 16 + 64);
        loop {
            let consumed = self.stream.total_in() as usize;
            let status = self
                .stream
                .compress_vec(&raw[consumed..], &mut out, flate2::FlushCompress::Finish)
                .map_err(std::io::Error::other)?;
            match status {
                flate2::Status::StreamEnd => return Ok(out),
                _ => out.reserve(out.capacity().max(64)),
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
    string(
        w,
        if options.half {
            "Tree_float_5_4_3_HalfFloat"
        } else {
            "Tree_float_5_4_3"
        },
    )?;
    string(w, "")?; // no instance parent
    let offsets_at = w.stream_position()?;
    w.write_all(&[0u8; 24])?; // grid, block and end positions, patched below
    let grid_pos = w.stream_position()?;
    w.write_all(&options.flags().to_le_bytes())?;

    let tree = build_tree(grid);
    let vec3i = |v: [i32; 3]| -> Vec<u8> { v.iter().flat_map(|c| c.to_le_bytes()).collect() };
    // OpenVDB marks half-float grids twice: the type name's suffix and this metadata (which is
    // what vdb-rs reads).
    w.write_all(&(5 + options.half as u32 + 2 * grid.padded as u32).to_le_bytes())?;
    metadata(w, "class", "string", grid.class.name())?;
    if options.half {
        metadata(w, "is_saved_as_half_float", "bool", &[1])?;
    }
    metadata(w, "file_bbox_min", "vec3i", &vec3i(tree.active_box[0]))?;
    metadata(w, "file_bbox_max", "vec3i", &vec3i(tree.active_box[1]))?;
    metadata(
        w,
        "file_voxel_count",
        "int64",
        &(tree.active_voxels as i64).to_le_bytes(),
    )?;
    metadata(w, "name", "string", grid.name.as_bytes())?;
    if grid.padded {
        let last = grid.dims.map(|d| d as i32 - 1);
        metadata(w, BOX_MIN, "vec3i", &vec3i([0; 3]))?;
        metadata(w, BOX_MAX, "vec3i", &vec3i(last))?;
    }

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
    for (n5, children) in &tree.nodes {
        for c in n5 {
            w.write_all(&c.to_le_bytes())?;
        }
        w.write_all(&mask(
            32768,
            children.keys().map(|o| child_index(*o, *n5, 7, 5)),
        ))?;
        w.write_all(&mask(32768, []))?;
        w.write_all(&tile_block(32768, grid.background, options)?)?;
        for (n4, leaves) in children {
            w.write_all(&mask(
                4096,
                leaves.iter().map(|o| child_index(*o, *n4, 3, 4)),
            ))?;
            w.write_all(&mask(4096, []))?;
            w.write_all(&tile_block(4096, grid.background, options)?)?;
            for &leaf in leaves {
                w.write_all(&leaf_mask(&gather(grid, leaf), grid.background))?;
            }
        }
    }
    let block_pos = w.stream_position()?;
    // Leaves are encoded (and compressed) in parallel a batch at a time, then written in the
    // file's order.
    let leaves: Vec<Origin> = tree
        .nodes
        .values()
        .flat_map(|c| c.values())
        .flatten()
        .copied()
        .collect();
    let background = grid.background;
    for batch in leaves.chunks(LEAVES_PER_BATCH) {
        let blocks = batch
            .par_iter()
            .map(|&origin| {
                let leaf = gather(grid, origin);
                let mut block = leaf_mask(&leaf, background);
                block.extend(encode_values(
                    leaf.iter().copied().filter(|&v| v != background),
                    options,
                )?);
                Ok(block)
            })
            .collect::<std::io::Result<Vec<Vec<u8>>>>()?;
        for block in &blocks {
            w.write_all(block)?;
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
