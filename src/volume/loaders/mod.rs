//! Volume loaders: NRRD (`.nrrd`, `.nhdr`), NIfTI-1 (`.nii`, `.nii.gz`), OpenVDB (`.vdb`),
//! headerless raw (`.raw`) and NumPy (`.npy`) files into a [`Volume`].
//!
//! Every loader takes the same steps, so bad input fails the same way in every format:
//! parse the header; build a [`Layout`], which checks the memory budget before any data is read
//! or decompressed; read exactly the payload's bytes ([`read_payload`]); convert them with the one
//! shared [`decode`]; hand the values to [`finish`], which applies the [`NonFinite`] policy and
//! builds the volume. Every error names the file.
//!
//! Time series: a 4-D NRRD (`sizes: X Y Z T`) or NIfTI-1 (`dim[0] = 4`, `dim[4] = T`) file
//! holds T volumes one after another, time the last (slowest) axis. A loader reads one of them,
//! [`LoadOptions::frame`], and only its bytes: earlier frames are passed over (sought past in a
//! plain file, decompressed and discarded in a gzip stream), later ones are not read, so bytes
//! missing from or left over after a series show when its last frame is read. Every frame has
//! the 3-D placement (spacing, axes, origin) and, in NIfTI, the value scaling; the time axis'
//! own spacing or direction is ignored. [`frame_count`] reads only the header. `occlux series`
//! reads each frame.

mod frame;
mod nifti;
mod npy;
mod nrrd;
mod raw;
mod vdb;
mod vdb_sizes;

use super::Volume;
use crate::error::{Error, Result};
use crate::memory::MemoryBudget;
use flate2::bufread::GzDecoder;
pub use frame::Frame;
use frame::Placement;
use glam::Vec3;
use rayon::prelude::*;
use std::fs::File;
use std::io::{self, BufRead, BufReader, ErrorKind, Read, Seek, SeekFrom};
use std::path::Path;

/// How a file stores each voxel value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl ScalarType {
    pub const ALL: [ScalarType; 8] = [
        ScalarType::U8,
        ScalarType::I8,
        ScalarType::U16,
        ScalarType::I16,
        ScalarType::U32,
        ScalarType::I32,
        ScalarType::F32,
        ScalarType::F64,
    ];

    /// Canonical name: "uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64".
    pub fn name(self) -> &'static str {
        match self {
            ScalarType::U8 => "uint8",
            ScalarType::I8 => "int8",
            ScalarType::U16 => "uint16",
            ScalarType::I16 => "int16",
            ScalarType::U32 => "uint32",
            ScalarType::I32 => "int32",
            ScalarType::F32 => "float32",
            ScalarType::F64 => "float64",
        }
    }

    /// Whether the type holds integers.
    pub fn is_integer(self) -> bool {
        !matches!(self, ScalarType::F32 | ScalarType::F64)
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        match self {
            ScalarType::U8 | ScalarType::I8 => 1,
            ScalarType::U16 | ScalarType::I16 => 2,
            ScalarType::U32 | ScalarType::I32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// Parses a type name, case-insensitively: the canonical names, NRRD's spellings
    /// (`uchar`, `unsigned char`, `short`, `ushort`, `unsigned short int`, `int`, `uint`, `float`,
    /// `double`, ...), the `<stdint.h>` names (`uint8_t`, ...) and Rust's (`u8`, `f32`, ...).
    /// 64-bit integers are not supported (they do not fit f32 without silent loss).
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name.split_whitespace().collect::<Vec<_>>().join(" ");
        Some(match name.to_ascii_lowercase().as_str() {
            "uint8" | "uint8_t" | "u8" | "uchar" | "unsigned char" => ScalarType::U8,
            "int8" | "int8_t" | "i8" | "signed char" => ScalarType::I8,
            "uint16" | "uint16_t" | "u16" | "ushort" | "unsigned short" | "unsigned short int" => {
                ScalarType::U16
            }
            "int16" | "int16_t" | "i16" | "short" | "short int" | "signed short"
            | "signed short int" => ScalarType::I16,
            "uint32" | "uint32_t" | "u32" | "uint" | "unsigned int" => ScalarType::U32,
            "int32" | "int32_t" | "i32" | "int" | "signed int" => ScalarType::I32,
            "float32" | "f32" | "float" => ScalarType::F32,
            "float64" | "f64" | "double" => ScalarType::F64,
            _ => return None,
        })
    }

    /// The canonical names, for error messages.
    fn supported() -> String {
        Self::ALL.map(Self::name).join(", ")
    }
}

/// What to do with NaN and infinite voxel values.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum NonFinite {
    /// Fail, naming the first offending voxel.
    #[default]
    Reject,
    /// Substitute this value.
    Replace(f32),
    /// Substitute 0 and say where they were ([`SourceInfo::non_finite`]): what `occlux info`
    /// reads bad files with.
    Census,
}

/// The NaN and infinite values a file held, with [`NonFinite::Census`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NonFiniteVoxels {
    pub nan: usize,
    pub positive_infinite: usize,
    pub negative_infinite: usize,
    /// Every such voxel's index as stored in the file (x fastest), in file order.
    pub indices: Vec<usize>,
    /// The grid's voxels as stored in the file (before it was brought into the world frame),
    /// which `indices` count in.
    pub stored_dims: [usize; 3],
}

/// How to read a headerless `.raw` file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawSpec {
    /// Voxels along x, y, z; x varies fastest in the file.
    pub dims: [usize; 3],
    pub scalar: ScalarType,
    pub spacing: Vec3,
    /// World position of the centre of voxel (0, 0, 0).
    pub origin: Vec3,
    pub big_endian: bool,
    /// Bytes to skip at the start of the file.
    pub header_bytes: u64,
}

/// Options common to all loaders.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// The memory the volume may take, and what the command holds besides it. Default: the
    /// system's available memory, for the volume alone ([`MemoryBudget::default`]).
    pub memory: MemoryBudget,
    /// Policy for NaN and infinite values. Default [`NonFinite::Reject`].
    pub non_finite: NonFinite,
    /// Layout of a `.raw` file (required for `.raw`, ignored otherwise).
    pub raw: Option<RawSpec>,
    /// Name of the grid to read from a `.vdb` file (default: the only or first float grid).
    pub grid: Option<String>,
    /// The time step to read from a 4-D NRRD or NIfTI-1 file whose last axis counts them
    /// (0-based; see [`frame_count`]). None reads a file with one frame, and refuses a series.
    pub frame: Option<usize>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            memory: MemoryBudget::default(),
            non_finite: NonFinite::Reject,
            raw: None,
            grid: None,
            frame: None,
        }
    }
}

/// What a file held, for reporting (`occlux info`).
#[derive(Clone, Debug, PartialEq)]
pub struct SourceInfo {
    /// Format name, e.g. "NRRD".
    pub format: &'static str,
    /// Stored value type, e.g. "uint8" (see [`ScalarType::name`]).
    pub scalar: String,
    /// The grid read, for formats with several (VDB).
    pub grid: Option<String>,
    /// The NaN and infinite values found (with [`NonFinite::Census`]; empty otherwise).
    pub non_finite: NonFiniteVoxels,
    /// How the stored grid was brought into the world frame.
    pub frame: Frame,
    /// Why the file's values are Hounsfield units, when the file says so (NIfTI's DICOM
    /// rescale or description, NRRD's `sample units`); None when it does not.
    pub hounsfield: Option<String>,
}

/// Whether a unit's or a description's text names Hounsfield units ("HU" as a word, or
/// "Hounsfield").
pub(crate) fn names_hounsfield(text: &str) -> bool {
    text.to_ascii_lowercase().contains("hounsfield")
        || text
            .split(|c: char| !c.is_ascii_alphanumeric())
            .any(|word| word == "HU")
}

const SUPPORTED: &str = ".nrrd, .nhdr, .nii, .nii.gz, .vdb, .raw, .npy";

/// Loads a volume, choosing the format by the file's extension.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Volume> {
    load_with_info(path, opts).map(|(volume, _)| volume)
}

/// Loads a volume and says what the file held.
pub fn load_with_info(path: &Path, opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    let format = Format::of(path)?;
    if !format.has_time() {
        TimeStep::chosen(path, 1, opts)?;
    }
    match format {
        Format::Nrrd => nrrd::load(path, opts),
        Format::Nifti => nifti::load(path, opts),
        Format::Vdb => vdb::load(path, opts),
        Format::Raw => raw::load(path, opts),
        Format::Npy => npy::load(path, opts),
    }
}

/// The time steps a file holds, from its header alone: T for a 4-D NRRD or NIfTI-1 series, 1
/// for every other file (formats without a time axis are only opened). Errors as [`load`]'s.
pub fn frame_count(path: &Path, opts: &LoadOptions) -> Result<usize> {
    match Format::of(path)? {
        Format::Nrrd => nrrd::frame_count(path, opts),
        Format::Nifti => nifti::frame_count(path, opts),
        Format::Vdb | Format::Raw | Format::Npy => {
            File::open(path).map(|_| 1).map_err(|e| Error::io(path, e))
        }
    }
}

/// The formats, told apart by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Nrrd,
    Nifti,
    Vdb,
    Raw,
    Npy,
}

impl Format {
    fn of(path: &Path) -> Result<Self> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if name.ends_with(".nii.gz") {
            return Ok(Format::Nifti);
        }
        match name.rsplit_once('.').map_or("", |(_, ext)| ext) {
            "nrrd" | "nhdr" => Ok(Format::Nrrd),
            "nii" => Ok(Format::Nifti),
            "vdb" => Ok(Format::Vdb),
            "raw" => Ok(Format::Raw),
            "npy" => Ok(Format::Npy),
            _ => Err(Error::format(
                path,
                format!("unsupported file extension (supported: {SUPPORTED})"),
            )),
        }
    }

    /// Whether the format can store a time series.
    fn has_time(self) -> bool {
        matches!(self, Format::Nrrd | Format::Nifti)
    }
}

/// The time step a loader reads: frame `index` of the `count` stored one after another (a 3-D
/// file holds one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct TimeStep {
    index: usize,
    count: usize,
}

impl TimeStep {
    /// The frame [`LoadOptions::frame`] names among a file's `count`; without one, the only
    /// frame (a series is refused rather than read as its first frame unasked).
    fn chosen(path: &Path, count: usize, opts: &LoadOptions) -> Result<Self> {
        let index = match opts.frame {
            None if count > 1 => {
                return Err(Error::format(
                    path,
                    format!(
                        "the file holds {count} time steps (a 4-D series): a frame must be \
                         chosen, 0 to {} (`occlux series` reads each)",
                        count - 1
                    ),
                ))
            }
            None => 0,
            Some(index) if index >= count => {
                let held = match count {
                    1 => "1 time step (frame 0 only)".to_string(),
                    _ => format!("{count} time steps (frames 0 to {})", count - 1),
                };
                return Err(Error::format(
                    path,
                    format!("frame {index} does not exist: the file holds {held}"),
                ));
            }
            Some(index) => index,
        };
        Ok(Self { index, count })
    }

    /// `what` (the data's name in messages) with the frame, for a series.
    fn name(self, what: &str) -> String {
        match self.count {
            1 => what.to_string(),
            count => format!("{what} of frame {} of {count}", self.index),
        }
    }
}

/// The payload a header describes: dims (x fastest) and how each value is stored. Building one
/// checks the memory budget, so no loader can read data before that check.
#[derive(Clone, Copy, Debug)]
struct Layout {
    dims: [usize; 3],
    scalar: ScalarType,
    big_endian: bool,
    byte_len: usize,
}

impl Layout {
    /// Checks `dims` against the memory budget (before anything is allocated or decompressed).
    fn checked(
        path: &Path,
        dims: [usize; 3],
        scalar: ScalarType,
        big_endian: bool,
        opts: &LoadOptions,
    ) -> Result<Self> {
        let count = opts.memory.check(dims).map_err(|e| in_file(path, e))?;
        let byte_len = count.checked_mul(scalar.size()).ok_or_else(|| {
            Error::format(
                path,
                format!("{} overflow the address space", describe(dims, scalar)),
            )
        })?;
        Ok(Self {
            dims,
            scalar,
            big_endian,
            byte_len,
        })
    }

    fn describe(&self) -> String {
        describe(self.dims, self.scalar)
    }
}

fn describe(dims: [usize; 3], scalar: ScalarType) -> String {
    format!("{}x{}x{} {}", dims[0], dims[1], dims[2], scalar.name())
}

/// Turns a volume-level error into one that names the file.
fn in_file(path: &Path, error: Error) -> Error {
    match error {
        Error::Volume(message) => Error::format(path, message),
        other => other,
    }
}

/// Values allocated before the volume first grows (64 Ki).
const FIRST_VALUES: usize = 1 << 16;

/// Bytes read and decoded at a time (4 MiB, a multiple of every type's size): the only copy of
/// the file's bytes a loader holds, so that a volume costs its f32 values and no more.
const CHUNK_BYTES: usize = 4 << 20;

/// Reads exactly the payload's bytes from `reader`, decoding them to f32 as they arrive
/// ([`decode_into`]); `what` names the data in messages ("gzip data"). Fewer bytes, a decoding
/// error, or bytes left over are errors stating expected vs found: left-over data means the
/// header's sizes or type do not describe the file.
fn read_values(
    path: &Path,
    mut reader: impl Read,
    what: &str,
    layout: &Layout,
) -> Result<Vec<f32>> {
    let expected = layout.byte_len;
    let value_size = layout.scalar.size();
    let count = expected / value_size;
    let mut values: Vec<f32> = Vec::new();
    let mut chunk = vec![0u8; CHUNK_BYTES.min(expected)];
    let mut filled = 0;
    while filled < expected {
        let want = (expected - filled).min(chunk.len());
        let mut got = 0;
        while got < want {
            match reader.read(&mut chunk[got..want]) {
                Ok(0) => {
                    return Err(Error::format(
                        path,
                        format!(
                            "{what} truncated: {} need {expected} bytes, found {}",
                            layout.describe(),
                            filled + got
                        ),
                    ))
                }
                Ok(n) => got += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(Error::format(
                        path,
                        format!(
                            "{what} corrupt or truncated after {} of the {expected} bytes that {} need: {e}",
                            filled + got,
                            layout.describe()
                        ),
                    ))
                }
            }
        }
        let arrived = want / value_size;
        if values.capacity() - values.len() < arrived {
            // Grow with the data that arrives, at most doubling, rather than by what the header
            // claims: a truncated file or a corrupt size then costs what the file holds.
            let more = (count - values.len()).min(values.len().max(FIRST_VALUES).max(arrived));
            values.try_reserve_exact(more).map_err(|_| {
                Error::format(
                    path,
                    format!(
                        "cannot allocate {} bytes of f32 values for {}",
                        count * 4,
                        layout.describe()
                    ),
                )
            })?;
        }
        decode_into(&chunk[..want], layout, &mut values);
        filled += want;
    }
    let mut probe = [0u8; 1];
    match reader.read(&mut probe) {
        Ok(0) => Ok(values),
        Ok(_) => Err(Error::format(
            path,
            format!(
                "{what} longer than expected: {} need {expected} bytes and more follow (check sizes and type)",
                layout.describe()
            ),
        )),
        Err(e) => Err(Error::format(
            path,
            format!("{what} corrupt or truncated after its {expected} bytes: {e}"),
        )),
    }
}

/// Passes over the frames before `step` in `reader`, then reads the frame's values (see
/// [`read_values`]; `what` names the data). A frame followed by others is read from a reader
/// that ends with it, so that the later frames stay unread.
fn read_frame(
    path: &Path,
    reader: &mut dyn Source,
    what: &str,
    layout: &Layout,
    step: TimeStep,
) -> Result<Vec<f32>> {
    let frame_bytes = layout.byte_len as u64;
    // A product past u64 cannot be in a file: passing over it fails on the file's end.
    let before = frame_bytes.saturating_mul(step.index as u64);
    reader.pass_over(
        path,
        before,
        &format!("frame {} of {}", step.index, step.count),
    )?;
    let limit = if step.index + 1 < step.count {
        frame_bytes
    } else {
        u64::MAX
    };
    read_values(path, reader.take(limit), &step.name(what), layout)
}

/// A payload's stream that can pass over bytes without handing them out.
trait Source: Read {
    /// Moves `count` bytes on; `what` names the bytes in messages.
    fn pass_over(&mut self, path: &Path, count: u64, what: &str) -> Result<()>;
}

/// A plain file seeks past the bytes unread.
impl Source for BufReader<File> {
    fn pass_over(&mut self, path: &Path, count: u64, what: &str) -> Result<()> {
        let length = self
            .get_ref()
            .metadata()
            .map_err(|e| Error::io(path, e))?
            .len();
        let position = self.stream_position().map_err(|e| Error::io(path, e))?;
        let left = length.saturating_sub(position);
        if left < count {
            return Err(Error::format(
                path,
                format!("{what}: the file ends after {left} of the {count} bytes to skip"),
            ));
        }
        self.seek(SeekFrom::Start(position + count))
            .map(|_| ())
            .map_err(|e| Error::io(path, e))
    }
}

/// A gzip stream has no way past its bytes but decompressing them.
impl<R: BufRead> Source for GzDecoder<R> {
    fn pass_over(&mut self, path: &Path, count: u64, what: &str) -> Result<()> {
        skip(path, self, count, what)
    }
}

/// Reads and discards `count` bytes before the payload; `what` names the skip in messages.
fn skip(path: &Path, reader: &mut impl Read, count: u64, what: &str) -> Result<()> {
    let skipped = io::copy(&mut reader.take(count), &mut io::sink())
        .map_err(|e| Error::format(path, format!("{what}: cannot read the file: {e}")))?;
    if skipped < count {
        return Err(Error::format(
            path,
            format!("{what}: the file ends after {skipped} of the {count} bytes to skip"),
        ));
    }
    Ok(())
}

/// The one conversion of stored values to f32, used by every loader: appends the values that
/// `bytes` holds, packed in the layout's type and byte order, to `values`. Integers convert
/// exactly up to 2^24 and round beyond; doubles round to the nearest f32.
fn decode_into(bytes: &[u8], layout: &Layout, values: &mut Vec<f32>) {
    let big = layout.big_endian;
    match layout.scalar {
        ScalarType::U8 => values.par_extend(bytes.par_iter().map(|&b| f32::from(b))),
        ScalarType::I8 => values.par_extend(bytes.par_iter().map(|&b| f32::from(b as i8))),
        ScalarType::U16 => convert(bytes, big, values, |b| f32::from(u16::from_le_bytes(b))),
        ScalarType::I16 => convert(bytes, big, values, |b| f32::from(i16::from_le_bytes(b))),
        ScalarType::U32 => convert(bytes, big, values, |b| u32::from_le_bytes(b) as f32),
        ScalarType::I32 => convert(bytes, big, values, |b| i32::from_le_bytes(b) as f32),
        ScalarType::F32 => convert(bytes, big, values, f32::from_le_bytes),
        ScalarType::F64 => convert(bytes, big, values, |b| f64::from_le_bytes(b) as f32),
    }
}

/// Appends `from_le` of each `N`-byte value to `values`, reversing big-endian values first so
/// that byte order is handled in this one place.
fn convert<const N: usize>(
    bytes: &[u8],
    big_endian: bool,
    values: &mut Vec<f32>,
    from_le: impl Fn([u8; N]) -> f32 + Sync,
) {
    values.par_extend(bytes.par_chunks_exact(N).map(|chunk| {
        let mut value = [0u8; N];
        value.copy_from_slice(chunk);
        if big_endian {
            value.reverse();
        }
        from_le(value)
    }));
}

/// Checks that per-axis spacings from `field` are positive and finite.
fn check_spacing(path: &Path, field: &str, spacing: [f64; 3]) -> Result<Vec3> {
    for (a, &s) in spacing.iter().enumerate() {
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::format(
                path,
                format!("{field}: axis {a} spacing must be positive and finite, got {s}"),
            ));
        }
    }
    Ok(Vec3::new(
        spacing[0] as f32,
        spacing[1] as f32,
        spacing[2] as f32,
    ))
}

/// The common last step: applies the non-finite policy (voxel indices as stored in the file),
/// flips the axes the placement asks for, and builds the volume; also returns what the census
/// found (empty unless the policy is [`NonFinite::Census`]).
fn finish(
    path: &Path,
    dims: [usize; 3],
    placement: Placement,
    mut values: Vec<f32>,
    opts: &LoadOptions,
) -> Result<(Volume, NonFiniteVoxels)> {
    let census = apply_non_finite(path, dims, &mut values, opts.non_finite)?;
    let world_dims = placement.world_dims(dims);
    if world_dims != dims {
        opts.memory.check(world_dims).map_err(|e| {
            Error::format(
                path,
                format!("{}: the world-aligned grid: {e}", placement.frame()),
            )
        })?;
    }
    let values = placement.apply(dims, values);
    let volume = Volume::new(world_dims, placement.spacing, placement.origin, values)
        .map_err(|e| in_file(path, e))?;
    Ok((volume, census))
}

fn apply_non_finite(
    path: &Path,
    dims: [usize; 3],
    values: &mut [f32],
    policy: NonFinite,
) -> Result<NonFiniteVoxels> {
    match policy {
        NonFinite::Reject => match values.par_iter().position_first(|v| !v.is_finite()) {
            None => Ok(NonFiniteVoxels::default()),
            Some(index) => {
                let [nx, ny] = [dims[0].max(1), dims[1].max(1)];
                let (i, j, k) = (index % nx, (index / nx) % ny, index / (nx * ny));
                Err(Error::format(
                    path,
                    format!(
                        "voxel [{i}, {j}, {k}] holds {}: non-finite values are rejected unless a \
                         replacement value is given (scene key volume.replace_non_finite)",
                        values[index]
                    ),
                ))
            }
        },
        NonFinite::Replace(x) => {
            values
                .par_iter_mut()
                .filter(|v| !v.is_finite())
                .for_each(|v| *v = x);
            Ok(NonFiniteVoxels::default())
        }
        NonFinite::Census => {
            let indices: Vec<usize> = values
                .par_iter()
                .enumerate()
                .filter(|(_, v)| !v.is_finite())
                .map(|(i, _)| i)
                .collect();
            let mut census = NonFiniteVoxels::default();
            for &i in &indices {
                let v = values[i];
                if v.is_nan() {
                    census.nan += 1;
                } else if v > 0.0 {
                    census.positive_infinite += 1;
                } else {
                    census.negative_infinite += 1;
                }
                values[i] = 0.0;
            }
            census.indices = indices;
            census.stored_dims = dims;
            Ok(census)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(scalar: ScalarType, big_endian: bool, count: usize) -> Layout {
        Layout::checked(
            Path::new("t"),
            [count, 1, 1],
            scalar,
            big_endian,
            &LoadOptions::default(),
        )
        .unwrap()
    }

    #[test]
    fn decode_handles_every_type_and_byte_order() {
        let cases: [(ScalarType, f64); 8] = [
            (ScalarType::U8, 200.0),
            (ScalarType::I8, -100.0),
            (ScalarType::U16, 60000.0),
            (ScalarType::I16, -30000.0),
            (ScalarType::U32, 4_000_000.0),
            (ScalarType::I32, -2_000_000.0),
            (ScalarType::F32, -1.5e-3),
            (ScalarType::F64, 12345.25),
        ];
        for (scalar, value) in cases {
            let le: Vec<u8> = match scalar {
                ScalarType::U8 => vec![value as u8],
                ScalarType::I8 => (value as i8).to_le_bytes().to_vec(),
                ScalarType::U16 => (value as u16).to_le_bytes().to_vec(),
                ScalarType::I16 => (value as i16).to_le_bytes().to_vec(),
                ScalarType::U32 => (value as u32).to_le_bytes().to_vec(),
                ScalarType::I32 => (value as i32).to_le_bytes().to_vec(),
                ScalarType::F32 => (value as f32).to_le_bytes().to_vec(),
                ScalarType::F64 => value.to_le_bytes().to_vec(),
            };
            let be: Vec<u8> = le.iter().rev().copied().collect();
            for (bytes, big_endian) in [(le.clone(), false), (be, true)] {
                let mut values = vec![7.0];
                decode_into(&bytes, &layout(scalar, big_endian, 1), &mut values);
                assert_eq!(values, vec![7.0, value as f32], "{scalar:?}");
            }
        }
    }

    #[test]
    fn names_round_trip_and_aliases_parse() {
        for scalar in ScalarType::ALL {
            assert_eq!(ScalarType::from_name(scalar.name()), Some(scalar));
        }
        assert_eq!(
            ScalarType::from_name("Unsigned  Char"),
            Some(ScalarType::U8)
        );
        assert_eq!(ScalarType::from_name("double"), Some(ScalarType::F64));
        assert_eq!(ScalarType::from_name("int64"), None);
    }
}
