//! NRRD files: `.nrrd` with an attached header, or a `.nhdr` header whose `data file` names the
//! data.
//!
//! Supported: magics NRRD0001 to NRRD0005; `dimension` 3, or 4 (see [`spatial_axes`]): a size-1
//! first axis is dropped (a vector of one component), else the last axis counts time steps, of
//! which one frame is read ([`LoadOptions::frame`](super::LoadOptions::frame); with size 1, the
//! only one) and whose `spacings` or `space directions` entry is ignored; a 4-D array whose `kinds`
//! name per-voxel components (a vector or colour axis) is refused; every [`ScalarType`] under
//! NRRD's spellings; `raw` and `gzip` encodings; `endian` (required for multi-byte types);
//! `spacings`, or `space directions` with `space origin`; `data file` (one file, relative to the
//! header's folder); `line skip` (lines of the data file before the data); `byte skip` (bytes
//! before the data, counted in the decompressed stream for gzip; -1 with raw means the data ends
//! the file). Spacing defaults to 1 and the origin to 0. `space directions` go through
//! [`Placement::from_frame`] (see [`super::frame`]: permuted and flipped axes are reordered
//! exactly, oblique frames resampled). `space` names the frame of `space directions` and
//! `space origin`: the anatomical spaces (`right-anterior-superior` or `RAS`,
//! `left-posterior-superior` or `LPS`, the `LAS` kind and their `-time` forms) are turned into RAS,
//! NIfTI's world frame, so that a scan written by 3D Slicer (LPS) and the same scan as NIfTI land
//! in the same place; `scanner-xyz` and `3D-right-handed` are taken as they are; a left-handed
//! space is refused (it would mirror).

use super::{
    check_spacing, finish, read_frame, skip, Layout, LoadOptions, Placement, ScalarType,
    SourceInfo, TimeStep,
};
use crate::error::{Error, Result};
use crate::volume::Volume;
use flate2::bufread::GzDecoder;
use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// A header longer than this is not a NRRD header (or lacks its terminating blank line).
const MAX_HEADER_BYTES: u64 = 1 << 20;

pub(super) fn load(path: &Path, opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    let (reader, fields, header) = open(path, opts)?;
    let step = TimeStep::chosen(path, header.frames, opts)?;
    let values = match &header.data_file {
        None => read_data(path, reader, &header, step)?,
        Some(data) => {
            let file = File::open(data).map_err(|e| Error::io(data, e))?;
            read_data(data, BufReader::new(file), &header, step)?
        }
    };
    let (volume, non_finite) = finish(path, header.layout.dims, header.placement, values, opts)?;
    let info = SourceInfo {
        format: "NRRD",
        scalar: header.layout.scalar.name().to_string(),
        grid: None,
        non_finite,
        frame: header.placement.frame(),
        hounsfield: fields
            .get("sample units")
            .filter(|units| super::names_hounsfield(units))
            .map(|units| format!("NRRD sample units \"{units}\"")),
    };
    Ok((volume, info))
}

/// The time steps the header describes.
pub(super) fn frame_count(path: &Path, opts: &LoadOptions) -> Result<usize> {
    open(path, opts).map(|(_, _, header)| header.frames)
}

/// Opens a NRRD file and reads its header, leaving the reader at the first byte after it.
fn open(path: &Path, opts: &LoadOptions) -> Result<(BufReader<File>, Fields, Header)> {
    let mut reader = BufReader::new(File::open(path).map_err(|e| Error::io(path, e))?);
    let fields = read_fields(path, &mut reader)?;
    let header = Header::parse(path, &fields, opts)?;
    Ok((reader, fields, header))
}

/// Header fields by lower-case name; key/value pairs (`key:=value`) and comments are skipped.
type Fields = HashMap<String, String>;

/// Reads the magic and the field lines up to the blank line that ends an attached header (or
/// the end of a detached one), leaving `reader` at the first data byte.
fn read_fields(path: &Path, reader: &mut impl BufRead) -> Result<Fields> {
    let mut header = Read::take(&mut *reader, MAX_HEADER_BYTES);
    let mut line = Vec::new();
    let read = |header: &mut io::Take<_>, line: &mut Vec<u8>| -> Result<usize> {
        line.clear();
        header
            .read_until(b'\n', line)
            .map_err(|e| Error::io(path, e))
    };
    if read(&mut header, &mut line)? == 0 {
        return Err(Error::format(
            path,
            "file is empty: expected a NRRD header starting with NRRD0001..NRRD0005",
        ));
    }
    let magic = trim_end_of_line(&line);
    if !is_magic(magic) {
        let shown = String::from_utf8_lossy(&magic[..magic.len().min(16)]).into_owned();
        return Err(Error::format(
            path,
            format!("not a NRRD file: the first line must be NRRD0001..NRRD0005, found {shown:?}"),
        ));
    }
    let mut fields = Fields::new();
    for number in 2.. {
        if read(&mut header, &mut line)? == 0 {
            if header.limit() == 0 {
                return Err(Error::format(
                    path,
                    format!("header longer than {MAX_HEADER_BYTES} bytes without the blank line that ends it"),
                ));
            }
            break;
        }
        let text = std::str::from_utf8(trim_end_of_line(&line))
            .map_err(|_| Error::format(path, format!("header line {number} is not text")))?;
        if text.is_empty() {
            break;
        }
        if text.starts_with('#') || text.contains(":=") {
            continue;
        }
        let (name, value) = text.split_once(':').ok_or_else(|| {
            Error::format(
                path,
                format!("header line {number} is not 'field: value': {text:?}"),
            )
        })?;
        let name = name.trim().to_ascii_lowercase();
        if fields
            .insert(name.clone(), value.trim().to_string())
            .is_some()
        {
            return Err(Error::format(
                path,
                format!("field '{name}' given twice (header line {number})"),
            ));
        }
    }
    Ok(fields)
}

fn trim_end_of_line(line: &[u8]) -> &[u8] {
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    line.strip_suffix(b"\r").unwrap_or(line)
}

fn is_magic(line: &[u8]) -> bool {
    matches!(
        line,
        [b'N', b'R', b'R', b'D', b'0', b'0', b'0', b'1'..=b'5']
    )
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Raw,
    Gzip,
}

/// What the header says about the data and where it is.
struct Header {
    /// One frame's payload.
    layout: Layout,
    /// Time steps (see [`spatial_axes`]).
    frames: usize,
    placement: Placement,
    encoding: Encoding,
    data_file: Option<PathBuf>,
    line_skip: u64,
    /// -1: the data ends the file (raw only).
    byte_skip: i64,
}

impl Header {
    fn parse(path: &Path, fields: &Fields, opts: &LoadOptions) -> Result<Self> {
        let fail =
            |field: &str, message: String| Error::format(path, format!("{field}: {message}"));
        let dimension_text = required(path, fields, "dimension")?;
        let dimension: usize = dimension_text.parse().map_err(|_| {
            fail(
                "dimension",
                format!("expected an integer, got '{dimension_text}'"),
            )
        })?;
        let sizes = parse_sizes(path, required(path, fields, "sizes")?, dimension)?;
        let (kept, frames) = spatial_axes(path, &sizes, fields)?;
        let dims = kept.map(|a| sizes[a]);

        let type_name = required(path, fields, "type")?;
        let scalar = ScalarType::from_name(type_name).ok_or_else(|| {
            fail(
                "type",
                format!(
                    "'{type_name}' is not supported (supported: {})",
                    ScalarType::supported()
                ),
            )
        })?;
        let endian = fields.get("endian").map(|e| e.to_ascii_lowercase());
        let big_endian = match (endian.as_deref(), scalar.size()) {
            (_, 1) => false,
            (Some("little"), _) => false,
            (Some("big"), _) => true,
            (Some(other), _) => {
                return Err(fail(
                    "endian",
                    format!("expected little or big, got '{other}'"),
                ))
            }
            (None, _) => {
                return Err(fail(
                    "endian",
                    format!("missing; {} data needs it (little or big)", scalar.name()),
                ))
            }
        };
        let encoding = match required(path, fields, "encoding")?
            .to_ascii_lowercase()
            .as_str()
        {
            "raw" => Encoding::Raw,
            "gzip" | "gz" => Encoding::Gzip,
            other => {
                return Err(fail(
                    "encoding",
                    format!("'{other}' is not supported (supported: raw, gzip)"),
                ))
            }
        };
        // The budget is checked as soon as dims and type are known, before any data is touched.
        let layout = Layout::checked(path, dims, scalar, big_endian, opts)?;
        let placement = placement(path, fields, dimension, kept, dims)?;

        let data_file = fields
            .get("data file")
            .or_else(|| fields.get("datafile"))
            .map(|name| data_file_path(path, name))
            .transpose()?;
        let line_skip = match fields.get("line skip") {
            None => 0,
            Some(text) => text.parse().map_err(|_| {
                fail(
                    "line skip",
                    format!("expected a count of lines, got '{text}'"),
                )
            })?,
        };
        let byte_skip = match fields.get("byte skip") {
            None => 0,
            Some(text) => match text.parse::<i64>() {
                Ok(-1) if encoding == Encoding::Raw => -1,
                Ok(n) if n >= 0 => n,
                _ => {
                    return Err(fail(
                        "byte skip",
                        format!(
                            "expected a count of bytes (or -1 with raw encoding), got '{text}'"
                        ),
                    ))
                }
            },
        };
        Ok(Self {
            layout,
            frames,
            placement,
            encoding,
            data_file,
            line_skip,
            byte_skip,
        })
    }
}

fn required<'a>(path: &Path, fields: &'a Fields, name: &str) -> Result<&'a str> {
    fields
        .get(name)
        .map(String::as_str)
        .ok_or_else(|| Error::format(path, format!("missing required field '{name}'")))
}

fn parse_sizes(path: &Path, text: &str, dimension: usize) -> Result<Vec<usize>> {
    if !(dimension == 3 || dimension == 4) {
        return Err(Error::format(
            path,
            format!(
                "dimension: only 3-D volumes are supported (or 4-D: a time series along the \
                 last axis, or a size-1 first axis), got {dimension}"
            ),
        ));
    }
    let sizes = text
        .split_whitespace()
        .map(|token| match token.parse::<i64>() {
            Ok(size) if size > 0 => usize::try_from(size).map_err(|_| token),
            _ => Err(token),
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|token| {
            Error::format(
                path,
                format!("sizes: each size must be a positive integer, got '{token}'"),
            )
        })?;
    if sizes.len() != dimension {
        return Err(Error::format(
            path,
            format!(
                "sizes: '{text}' has {} values for dimension {dimension}",
                sizes.len()
            ),
        ));
    }
    Ok(sizes)
}

/// The three axes that hold the volume, and the time steps: all of a 3-D array (one step); of a
/// 4-D array, the last three after a size-1 first axis (one step, as a vector of one component
/// was always read), else the first three, the last axis counting the steps. A series is
/// refused when `kinds` say it holds per-voxel components, which would otherwise be read as
/// space or time.
fn spatial_axes(path: &Path, sizes: &[usize], fields: &Fields) -> Result<([usize; 3], usize)> {
    match *sizes {
        [1, _, _, _] => Ok(([1, 2, 3], 1)),
        [_, _, _, frames] => match component_axis(fields) {
            Some((axis, kind)) if frames > 1 => Err(Error::format(
                path,
                format!(
                    "kinds: axis {axis} of the 4-D array {sizes:?} is '{kind}', not space or \
                     time: per-voxel components are not supported (a 4-D array is read as a \
                     time series along its last axis, or with a size-1 first axis)"
                ),
            )),
            _ => Ok(([0, 1, 2], frames)),
        },
        // 3-D: parse_sizes passes no other.
        _ => Ok(([0, 1, 2], 1)),
    }
}

/// The first axis of a 4-D array whose `kinds` entry is not one a time series has there (space,
/// or unknown; time or a list last), with that kind.
fn component_axis(fields: &Fields) -> Option<(usize, &str)> {
    let spatial = |kind: &str| matches!(kind, "domain" | "space" | "???" | "none");
    fields
        .get("kinds")?
        .split_whitespace()
        .enumerate()
        .find(|&(axis, kind)| {
            let kind = kind.to_ascii_lowercase();
            !(spatial(&kind) || axis == 3 && matches!(kind.as_str(), "time" | "list"))
        })
}

/// Spacing and origin from `space directions` (+ `space origin`), else `spacings`, else unit.
fn placement(
    path: &Path,
    fields: &Fields,
    dimension: usize,
    kept: [usize; 3],
    dims: [usize; 3],
) -> Result<Placement> {
    if let Some(space_dimension) = fields.get("space dimension") {
        if space_dimension != "3" {
            return Err(Error::format(
                path,
                format!("space dimension: only 3 is supported, got '{space_dimension}'"),
            ));
        }
    }
    let signs = space_signs(path, fields)?;
    let to_ras = |v: [f64; 3]| [v[0] * signs[0], v[1] * signs[1], v[2] * signs[2]];
    let origin = match fields.get("space origin") {
        Some(text) => to_ras(parse_vector(path, "space origin", text)?),
        None => [0.0; 3],
    };
    if let Some(text) = fields.get("space directions") {
        let directions = parse_directions(path, text, dimension)?;
        let mut steps = [[0.0; 3]; 3];
        for (step, &a) in steps.iter_mut().zip(&kept) {
            *step = directions[a].map(to_ras).ok_or_else(|| {
                Error::format(
                    path,
                    format!("space directions: axis {a} is 'none' but holds a spatial axis"),
                )
            })?;
        }
        return Placement::from_frame(path, "space directions", steps, origin, dims);
    }
    let spacing = match fields.get("spacings") {
        Some(text) => {
            let values = text
                .split_whitespace()
                .map(|token| token.parse::<f64>())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|_| {
                    Error::format(path, format!("spacings: expected numbers, got '{text}'"))
                })?;
            if values.len() != dimension {
                return Err(Error::format(
                    path,
                    format!(
                        "spacings: '{text}' has {} values for dimension {dimension}",
                        values.len()
                    ),
                ));
            }
            kept.map(|a| values[a])
        }
        None => [1.0; 3],
    };
    check_spacing(path, "spacings", spacing)?;
    let steps = [
        [spacing[0], 0.0, 0.0],
        [0.0, spacing[1], 0.0],
        [0.0, 0.0, spacing[2]],
    ];
    Placement::from_frame(path, "space origin", steps, origin, dims)
}

/// The signs per axis that take vectors of the header's `space` into RAS (none without one).
fn space_signs(path: &Path, fields: &Fields) -> Result<[f64; 3]> {
    let Some(space) = fields.get("space") else {
        return Ok([1.0; 3]);
    };
    let name = space.trim().to_ascii_lowercase();
    let name = name.strip_suffix("-time").unwrap_or(&name);
    let signs = match name {
        "right-anterior-superior" | "ras" | "scanner-xyz" | "3d-right-handed" => [1.0, 1.0, 1.0],
        "left-anterior-superior" | "las" => [-1.0, 1.0, 1.0],
        "left-posterior-superior" | "lps" => [-1.0, -1.0, 1.0],
        "3d-left-handed" => {
            return Err(Error::format(
                path,
                format!(
                    "space: '{space}' is left-handed; rendered in Occlux's right-handed world                      it would be mirrored"
                ),
            ))
        }
        _ => {
            return Err(Error::format(
                path,
                format!(
                    "space: '{space}' is not a 3D space Occlux knows (right-anterior-superior, \
                     left-anterior-superior, left-posterior-superior, scanner-xyz, \
                     3D-right-handed, or their -time forms)"
                ),
            ))
        }
    };
    Ok(signs)
}

/// Parses `dimension` entries, each a vector `(x,y,z)` or `none`.
fn parse_directions(path: &Path, text: &str, dimension: usize) -> Result<Vec<Option<[f64; 3]>>> {
    let mut directions = Vec::new();
    let mut rest = text.trim_start();
    while !rest.is_empty() {
        let end = if rest.starts_with('(') {
            rest.find(')').map(|close| close + 1).ok_or_else(|| {
                Error::format(path, format!("space directions: unclosed '(' in '{text}'"))
            })?
        } else {
            rest.find(char::is_whitespace).unwrap_or(rest.len())
        };
        let token = &rest[..end];
        directions.push(if token == "none" {
            None
        } else {
            Some(parse_vector(path, "space directions", token)?)
        });
        rest = rest[end..].trim_start();
    }
    if directions.len() != dimension {
        return Err(Error::format(
            path,
            format!(
                "space directions: '{text}' has {} entries for dimension {dimension}",
                directions.len()
            ),
        ));
    }
    Ok(directions)
}

/// Parses `(x,y,z)`.
fn parse_vector(path: &Path, field: &str, text: &str) -> Result<[f64; 3]> {
    let bad = || {
        Error::format(
            path,
            format!("{field}: expected a vector (x,y,z), got '{text}'"),
        )
    };
    let inner = text
        .trim()
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or_else(bad)?;
    let values = inner
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| bad())?;
    <[f64; 3]>::try_from(values).map_err(|_| bad())
}

/// The data file named by a detached header, relative to the header's folder. Lists and
/// numbered file series are not supported.
fn data_file_path(path: &Path, name: &str) -> Result<PathBuf> {
    let tokens: Vec<&str> = name.split_whitespace().collect();
    let series = tokens.first().is_some_and(|t| t.starts_with("LIST"))
        || (tokens.len() >= 4 && tokens[0].contains('%'));
    if series || name.is_empty() {
        return Err(Error::format(
            path,
            format!("data file: only a single file name is supported, got '{name}'"),
        ));
    }
    Ok(path.parent().unwrap_or(Path::new("")).join(name))
}

/// Skips `line skip` lines and `byte skip` bytes, then reads frame `step` from `data_path` (the
/// header's own file when the data is attached).
fn read_data(
    data_path: &Path,
    mut reader: BufReader<File>,
    header: &Header,
    step: TimeStep,
) -> Result<Vec<f32>> {
    for skipped in 0..header.line_skip {
        if reader
            .skip_until(b'\n')
            .map_err(|e| Error::io(data_path, e))?
            == 0
        {
            return Err(Error::format(
                data_path,
                format!(
                    "line skip: the file ends after {skipped} of {} lines",
                    header.line_skip
                ),
            ));
        }
    }
    match header.encoding {
        Encoding::Raw => {
            if header.byte_skip == -1 {
                seek_to_trailing_data(data_path, &mut reader, header)?;
            } else {
                skip(data_path, &mut reader, header.byte_skip as u64, "byte skip")?;
            }
            read_frame(data_path, &mut reader, "raw data", &header.layout, step)
        }
        Encoding::Gzip => {
            let mut decoder = GzDecoder::new(reader);
            skip(
                data_path,
                &mut decoder,
                header.byte_skip as u64,
                "byte skip",
            )?;
            read_frame(data_path, &mut decoder, "gzip data", &header.layout, step)
        }
    }
}

/// `byte skip: -1`: the data, every frame of it, is the last bytes of the file.
fn seek_to_trailing_data(path: &Path, reader: &mut BufReader<File>, header: &Header) -> Result<()> {
    let length = reader
        .get_ref()
        .metadata()
        .map_err(|e| Error::io(path, e))?
        .len();
    let needed = (header.layout.byte_len as u64).saturating_mul(header.frames as u64);
    if length < needed {
        let frames = match header.frames {
            1 => String::new(),
            n => format!("{n} frames of "),
        };
        return Err(Error::format(
            path,
            format!(
                "raw data truncated: {frames}{} need {needed} bytes, the whole file has {length}",
                header.layout.describe()
            ),
        ));
    }
    reader
        .seek(SeekFrom::Start(length - needed))
        .map(|_| ())
        .map_err(|e| Error::io(path, e))
}
