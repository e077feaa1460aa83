//! The sizes an OpenVDB file declares, checked against the bytes it holds before vdb-rs reads
//! it.
//!
//! vdb-rs 0.6 allocates what a file's length fields say (string lengths, metadata blobs, the
//! byte counts of compressed value blocks) before reading that many bytes. A corrupt count then
//! asks for up to 2^63 bytes, and a failed allocation aborts the process (Rust cannot catch
//! it, so neither can the loader's panic guard; in Blender it would close Blender). Fuzzing
//! found such files within a hundred inputs (fuzz/README.md).
//!
//! This walk reads the file in vdb-rs's order (file versions 222 and later, the only ones
//! Occlux accepts) and refuses any length that exceeds the bytes left. It only refuses: where
//! it meets something it does not follow (a transform vdb-rs does not read, a multi-buffer
//! tree), it stops and leaves the verdict to vdb-rs, whose panics the loader catches.

use crate::error::{Error, Result};
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::Path;

const ZIP: u32 = 0x1;
const ACTIVE_MASK: u32 = 0x2;
const BLOSC: u32 = 0x4;

/// The grid fields of a descriptor that the walk of its tree needs.
pub(super) struct GridAt {
    pub grid_pos: u64,
    pub block_pos: u64,
    pub compression: u32,
    pub half: bool,
}

/// A reader that knows how many bytes are left and refuses lengths beyond them.
struct Walk<'a, R> {
    path: &'a Path,
    reader: R,
    len: u64,
}

/// Checks the archive header, its metadata and every grid descriptor's names and metadata.
pub(super) fn check_header(path: &Path, file: std::fs::File) -> Result<()> {
    let mut walk = Walk::new(path, file)?;
    walk.skip(8 + 4 + 4 + 4 + 1 + 36)?; // magic, version, library version, offsets flag, uuid
    walk.metadata()?;
    let grids = walk.u32()?;
    for _ in 0..grids {
        for _ in 0..3 {
            walk.name()?; // name, type, instance parent
        }
        let grid_pos = walk.u64()?;
        walk.u64()?; // block_pos
        let end_pos = walk.u64()?;
        // A grid's data follows its descriptor, and the next descriptor follows the data: each
        // grid moves on through the file, so a corrupt count cannot loop over the same bytes
        // (found by fuzzing: offsets pointing back made 4e9 grids re-read one region).
        let here = walk.position()?;
        if grid_pos < here || end_pos <= grid_pos {
            return Err(walk.corrupt(format!(
                "a grid's data at {grid_pos}..{end_pos} does not follow its descriptor (at {here})"
            )));
        }
        walk.seek(grid_pos)?;
        walk.u32()?; // compression
        walk.metadata()?;
        walk.seek(end_pos)?;
    }
    Ok(())
}

/// Checks one grid's metadata, topology and value blocks.
pub(super) fn check_grid(path: &Path, file: std::fs::File, grid: &GridAt) -> Result<()> {
    let mut walk = Walk::new(path, file)?;
    walk.seek(grid.grid_pos)?;
    walk.u32()?; // compression
    walk.metadata()?;
    let transform = walk.name()?;
    let vectors = match transform.as_slice() {
        b"UniformScaleMap" => 5,
        b"UniformScaleTranslateMap" | b"ScaleTranslateMap" => 6,
        _ => return Ok(()), // vdb-rs refuses it (a panic the loader reports)
    };
    walk.skip(vectors * 24)?;
    if walk.u32()? != 1 {
        return Ok(()); // a multi-buffer tree: vdb-rs refuses it
    }
    walk.skip(4)?; // background
    let tiles = walk.u32()? as u64;
    let roots = walk.u32()?;
    walk.skip(tiles * 17)?;
    // Per root, per internal node: its leaves' value masks, as the data pass reads them in.
    let mut leaves_per_node = Vec::new();
    for _ in 0..roots {
        walk.skip(12)?; // origin
        let children = walk.node(5, grid)?;
        for _ in 0..children {
            let leaves = walk.node(4, grid)?;
            walk.skip(leaves * 64)?;
            leaves_per_node.push(leaves);
        }
    }
    walk.seek(grid.block_pos)?;
    for leaves in leaves_per_node {
        for _ in 0..leaves {
            let mask = walk.mask(512)?;
            let active = mask.iter().map(|w| w.count_ones() as u64).sum();
            walk.values(512, active, grid)?;
        }
    }
    Ok(())
}

impl<'a> Walk<'a, BufReader<std::fs::File>> {
    fn new(path: &'a Path, file: std::fs::File) -> Result<Self> {
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        Ok(Self {
            path,
            reader: BufReader::new(file),
            len,
        })
    }
}

impl<R: BufRead + Seek> Walk<'_, R> {
    fn corrupt(&self, what: String) -> Error {
        Error::format(
            self.path,
            format!(
                "corrupt OpenVDB file, or a layout vdb-rs does not read (such as half-float \
                 grids that OpenVDB itself wrote): {what}"
            ),
        )
    }

    fn position(&mut self) -> Result<u64> {
        self.reader
            .stream_position()
            .map_err(|e| Error::io(self.path, e))
    }

    fn left(&mut self) -> Result<u64> {
        Ok(self.len.saturating_sub(self.position()?))
    }

    /// Refuses `bytes` more than the file holds from here.
    fn fits(&mut self, bytes: u64, what: &str) -> Result<()> {
        let left = self.left()?;
        if bytes > left {
            return Err(self.corrupt(format!("{what} claims {bytes} bytes where {left} are left")));
        }
        Ok(())
    }

    fn skip(&mut self, bytes: u64) -> Result<()> {
        self.fits(bytes, "a field")?;
        let bytes = i64::try_from(bytes).map_err(|_| self.corrupt("an offset".into()))?;
        self.reader
            .seek_relative(bytes)
            .map_err(|e| Error::io(self.path, e))
    }

    fn seek(&mut self, pos: u64) -> Result<()> {
        if pos > self.len {
            return Err(self.corrupt(format!(
                "an offset {pos} beyond the file's {} bytes",
                self.len
            )));
        }
        self.reader
            .seek(SeekFrom::Start(pos))
            .map(|_| ())
            .map_err(|e| Error::io(self.path, e))
    }

    fn bytes<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        self.reader
            .read_exact(&mut b)
            .map_err(|_| self.corrupt("truncated".into()))?;
        Ok(b)
    }

    fn u32(&mut self) -> Result<u32> {
        self.bytes().map(u32::from_le_bytes)
    }

    fn u64(&mut self) -> Result<u64> {
        self.bytes().map(u64::from_le_bytes)
    }

    fn i64(&mut self) -> Result<i64> {
        self.bytes().map(i64::from_le_bytes)
    }

    /// A length-prefixed name.
    fn name(&mut self) -> Result<Vec<u8>> {
        let len = self.u32()? as u64;
        self.fits(len, "a name")?;
        let mut name = vec![0u8; len as usize];
        self.reader
            .read_exact(&mut name)
            .map_err(|_| self.corrupt("truncated".into()))?;
        Ok(name)
    }

    /// A metadata block: entries of name, type and a value of the stated length (vdb-rs reads
    /// booleans, numbers and vec3i by their type, whatever the length says).
    fn metadata(&mut self) -> Result<()> {
        let count = self.u32()?;
        for _ in 0..count {
            self.name()?;
            let kind = self.name()?;
            let len = self.u32()? as u64;
            let bytes = match kind.as_slice() {
                b"bool" => 1,
                b"int32" | b"float" => 4,
                b"int64" => 8,
                b"vec3i" => 12,
                _ => len,
            };
            self.fits(bytes, "a metadata value")?;
            self.skip(bytes)?;
        }
        Ok(())
    }

    fn mask(&mut self, bits: usize) -> Result<Vec<u64>> {
        let mut words = vec![0u64; bits / 64];
        for w in &mut words {
            *w = self.u64()?;
        }
        Ok(words)
    }

    /// An internal node of 2^(3 log2) children: child and value masks, then its values.
    /// Returns how many children it has.
    fn node(&mut self, log2: u32, grid: &GridAt) -> Result<u64> {
        let bits = 1usize << (3 * log2);
        let children = self.mask(bits)?;
        let values = self.mask(bits)?;
        let active = values.iter().map(|w| w.count_ones() as u64).sum();
        self.values(bits as u64, active, grid)?;
        Ok(children.iter().map(|w| w.count_ones() as u64).sum())
    }

    /// A block of `count` values (`active` of them under the value mask), as vdb-rs's
    /// read_compressed: a metadata byte, inactive values, a selection mask, the values.
    fn values(&mut self, count: u64, active: u64, grid: &GridAt) -> Result<()> {
        let meta = self.bytes::<1>()?[0];
        if meta > 6 {
            return Ok(()); // vdb-rs refuses it
        }
        let inactive = match meta {
            2 | 4 => 1,
            5 => 2,
            _ => 0,
        };
        self.skip(inactive * 4)?; // read as the grid's f32
        if matches!(meta, 3..=5) {
            self.skip(count / 8)?;
        }
        let stored = if grid.compression & ACTIVE_MASK != 0 && meta != 6 {
            active
        } else {
            count
        };
        let size = if grid.half { 2 } else { 4 };
        if grid.compression & (BLOSC | ZIP) == 0 {
            return self.skip(stored * size);
        }
        let n = self.i64()?;
        if n <= 0 {
            // Stored uncompressed: -n bytes, in whole values.
            let values = (n / size as i64).unsigned_abs();
            return self.skip(values * size);
        }
        let n = n as u64;
        self.fits(n, "a compressed block")?;
        if grid.compression & BLOSC != 0 && stored > 0 {
            // vdb-rs allocates the decompressed size that the Blosc header states (and reads
            // the 16-byte header whatever the block's length).
            if n < 16 {
                return Err(self.corrupt(format!("a Blosc block of {n} bytes has no header")));
            }
            let head = self.bytes::<8>()?;
            let decompressed = u32::from_le_bytes([head[4], head[5], head[6], head[7]]) as u64;
            if decompressed > stored * size {
                return Err(self.corrupt(format!(
                    "a Blosc block claims {decompressed} bytes for {stored} values"
                )));
            }
            return self.skip(n.saturating_sub(8));
        }
        self.skip(n)
    }
}
