//! NIfTI-1 single files (`.nii`, and `.nii.gz` decompressed on the fly). The `nifti` crate parses
//! the 348-byte header (and detects its byte order); the data goes through the shared reader and
//! converter like every other format.
//!
//! - dims: `dim[1..=3]`; with `dim[0]` >= 4, `dim[4]` counts time steps, one frame of which is
//!   read ([`LoadOptions::frame`](super::LoadOptions::frame); one time point: the only one), and
//!   every axis beyond the fourth (per-voxel components) must have size 1. `pixdim[4]` (the
//!   time step) is ignored.
//! - values (of every frame): `value * scl_slope + scl_inter` when `scl_slope` is finite and
//!   non-zero; 0 or NaN mean "no scaling" (FSL writes 0, nibabel NaN), and a NaN `scl_inter`
//!   counts as 0.
//! - geometry: the sform when `sform_code > 0`, else the qform when `qform_code > 0`, else
//!   `pixdim` spacing with the origin at 0. The affine's columns and translation go through
//!   [`Placement::from_frame`] (see [`super::frame`]): spacing is each column's length; axes
//!   that are permuted or reversed (an LAS, ARS or LPI scan, qfac = -1) are reordered exactly
//!   so that every voxel keeps its world position; an oblique affine is resampled onto a
//!   world-aligned grid.
//!
//! Not supported (clear errors): `.hdr`/`.img` pairs, NIfTI-2, and complex, RGB and 64-bit
//! integer data.

use super::{
    check_spacing, finish, read_frame, skip, Layout, LoadOptions, Placement, ScalarType, Source,
    SourceInfo, TimeStep,
};
use crate::error::{Error, Result};
use crate::volume::Volume;
use ::nifti::{Endianness, NiftiError, NiftiHeader};
use flate2::bufread::GzDecoder;
use glam::Vec3;
use rayon::prelude::*;
use std::fs::File;
use std::io::{BufReader, ErrorKind};
use std::path::Path;

/// Bytes of a NIfTI-1 header; the data starts at `vox_offset`, after any extensions.
const HEADER_BYTES: u64 = 348;

pub(super) fn load(path: &Path, opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    let mut file = open(path)?;
    let mut reader = file.as_mut();
    let Parsed {
        header,
        layout,
        placement,
        frames,
        data_start,
    } = Parsed::read(path, reader, opts)?;
    let step = TimeStep::chosen(path, frames, opts)?;
    skip(path, &mut reader, data_start - HEADER_BYTES, "vox_offset")?;
    let mut values = read_frame(path, reader, "NIfTI data", &layout, step)?;
    rescale(&mut values, header.scl_slope, header.scl_inter);
    let (volume, non_finite) = finish(path, layout.dims, placement, values, opts)?;
    let info = SourceInfo {
        format: "NIfTI-1",
        scalar: layout.scalar.name().to_string(),
        grid: None,
        non_finite,
        frame: placement.frame(),
        hounsfield: hounsfield(&header, layout.scalar),
    };
    Ok((volume, info))
}

/// The time steps the header describes.
pub(super) fn frame_count(path: &Path, opts: &LoadOptions) -> Result<usize> {
    Parsed::read(path, open(path)?.as_mut(), opts).map(|parsed| parsed.frames)
}

/// The file's bytes, decompressed on the fly when it is gzipped.
fn open(path: &Path) -> Result<Box<dyn Source>> {
    let mut reader = BufReader::new(File::open(path).map_err(|e| Error::io(path, e))?);
    let gzipped = path.to_string_lossy().to_ascii_lowercase().ends_with(".gz");
    if gzipped {
        use std::io::BufRead;
        let start = reader.fill_buf().map_err(|e| Error::io(path, e))?;
        // An empty file is reported as one with no header, below.
        if !start.is_empty() && !start.starts_with(&[0x1f, 0x8b]) {
            return Err(Error::format(
                path,
                "a .gz file must be gzip-compressed, and this one does not start as gzip does \
                 (bytes 1f 8b): if it is an uncompressed NIfTI, name it .nii",
            ));
        }
    }
    Ok(if gzipped {
        Box::new(GzDecoder::new(reader))
    } else {
        Box::new(reader)
    })
}

/// The header, checked as far as anything can be before the data: one frame's payload and
/// its placement, the time steps, and where the first frame starts.
struct Parsed {
    header: NiftiHeader,
    layout: Layout,
    placement: Placement,
    frames: usize,
    data_start: u64,
}

impl Parsed {
    /// Reads the 348-byte header from the start of `reader`.
    fn read(path: &Path, reader: &mut dyn Source, opts: &LoadOptions) -> Result<Self> {
        let header = NiftiHeader::from_reader(reader).map_err(|e| header_error(path, e))?;
        check_kind(path, &header)?;
        let (dims, frames) = dims(path, &header)?;
        let scalar = scalar_type(path, header.datatype)?;
        let big_endian = header.endianness == Endianness::Big;
        let layout = Layout::checked(path, dims, scalar, big_endian, opts)?;
        let placement = placement(path, &header, dims)?;
        let data_start = data_offset(path, header.vox_offset)?;
        Ok(Self {
            header,
            layout,
            placement,
            frames,
            data_start,
        })
    }
}

/// Rescale intercepts that DICOM CT series carry into NIfTI (dcm2niix writes the series'
/// RescaleSlope and RescaleIntercept as scl_slope and scl_inter).
const CT_INTERCEPTS: [f32; 4] = [-1024.0, -1000.0, -2048.0, -3024.0];

/// Why the values are Hounsfield units: the description or intent names them, or integer data
/// carries a CT scanner's DICOM rescale (slope 1, intercept -1024 and the like).
fn hounsfield(header: &NiftiHeader, scalar: ScalarType) -> Option<String> {
    for (field, bytes) in [
        ("descrip", header.descrip.as_slice()),
        ("intent_name", &header.intent_name[..]),
    ] {
        let text = String::from_utf8_lossy(bytes);
        let text = text.trim_end_matches('\0').trim();
        if super::names_hounsfield(text) {
            return Some(format!("NIfTI {field} \"{text}\""));
        }
    }
    (header.scl_slope == 1.0 && CT_INTERCEPTS.contains(&header.scl_inter) && scalar.is_integer())
        .then(|| {
            format!(
                "NIfTI scl_slope 1 and scl_inter {} on integer data (a CT's DICOM rescale)",
                header.scl_inter
            )
        })
}

fn header_error(path: &Path, error: NiftiError) -> Error {
    let message = match error {
        NiftiError::Io(e) if e.kind() == ErrorKind::UnexpectedEof => {
            "file ends inside the 348-byte NIfTI-1 header (empty or truncated)".to_string()
        }
        NiftiError::InvalidFormat => {
            "not a NIfTI-1 file: the magic at byte 344 is neither \"n+1\" nor \"ni1\"".to_string()
        }
        NiftiError::Io(e) => format!("cannot read the NIfTI-1 header: {e}"),
        other => format!("cannot read the NIfTI-1 header: {other}"),
    };
    Error::format(path, message)
}

/// Only single-file NIfTI-1 is read.
fn check_kind(path: &Path, header: &NiftiHeader) -> Result<()> {
    // The nifti crate takes the byte order in which dim[0] lies in 1..=7; when it lies there in
    // neither, it reads the header swapped, and sizeof_hdr comes out as 348 with its bytes
    // reversed. Name dim[0] as the file holds it then, not the swapped size.
    if header.sizeof_hdr.swap_bytes() == HEADER_BYTES as i32 {
        let stated = (header.dim[0] as i16).swap_bytes();
        return Err(Error::format(
            path,
            format!(
                "dim[0] = {stated}: a NIfTI-1 header's dim[0] counts the axes, 1 to 7 \
                 (3 for a volume, 4 for a time series)"
            ),
        ));
    }
    if header.sizeof_hdr != HEADER_BYTES as i32 {
        return Err(Error::format(
            path,
            format!(
                "sizeof_hdr is {}, not 348: not a NIfTI-1 file (NIfTI-2 is not supported)",
                header.sizeof_hdr
            ),
        ));
    }
    if &header.magic != b"n+1\0" {
        return Err(Error::format(
            path,
            "magic \"ni1\" marks a .hdr/.img pair, which is not supported: convert it to a single .nii",
        ));
    }
    Ok(())
}

/// The dims of one frame and the time steps.
fn dims(path: &Path, header: &NiftiHeader) -> Result<([usize; 3], usize)> {
    // The standard declares dim as signed 16-bit; the crate reads it unsigned.
    let dim = header.dim.map(|d| d as i16);
    let rank = dim[0];
    if !(3..=7).contains(&rank) {
        return Err(Error::format(
            path,
            format!("dim[0] = {rank}: only 3-D volumes and 4-D time series are supported"),
        ));
    }
    let rank = rank as usize;
    if let Some(a) = (1..=rank).find(|&a| dim[a] < 1) {
        return Err(Error::format(
            path,
            format!("dim[{a}] = {}: sizes must be positive", dim[a]),
        ));
    }
    if let Some(a) = (5..=rank).find(|&a| dim[a] != 1) {
        return Err(Error::format(
            path,
            format!(
                "dim[{a}] = {}: per-voxel components are not supported (axes beyond the fourth, \
                 time, must have size 1)",
                dim[a]
            ),
        ));
    }
    // dim[4] means nothing below rank 4 (writers leave anything there).
    let frames = if rank >= 4 { dim[4] as usize } else { 1 };
    Ok(([dim[1], dim[2], dim[3]].map(|d| d as usize), frames))
}

/// NIfTI-1 datatype codes (nifti1.h) of the supported types.
const DATATYPES: [(i16, ScalarType); 8] = [
    (2, ScalarType::U8),
    (4, ScalarType::I16),
    (8, ScalarType::I32),
    (16, ScalarType::F32),
    (64, ScalarType::F64),
    (256, ScalarType::I8),
    (512, ScalarType::U16),
    (768, ScalarType::U32),
];

fn scalar_type(path: &Path, code: i16) -> Result<ScalarType> {
    DATATYPES
        .iter()
        .find(|(c, _)| *c == code)
        .map(|(_, scalar)| *scalar)
        .ok_or_else(|| {
            let supported: Vec<String> = DATATYPES
                .iter()
                .map(|(c, s)| format!("{c} ({})", s.name()))
                .collect();
            Error::format(
                path,
                format!(
                    "datatype {code} is not supported (supported: {})",
                    supported.join(", ")
                ),
            )
        })
}

/// Geometry from the sform, else the qform, else pixdim (see the module docs).
fn placement(path: &Path, header: &NiftiHeader, dims: [usize; 3]) -> Result<Placement> {
    if header.sform_code > 0 {
        let rows = [header.srow_x, header.srow_y, header.srow_z];
        let steps = [0, 1, 2].map(|a| rows.map(|row| f64::from(row[a])));
        let origin = rows.map(|row| f64::from(row[3]));
        return Placement::from_frame(path, "sform (srow_x/y/z)", steps, origin, dims);
    }
    let pixdim = [1, 2, 3].map(|a| f64::from(header.pixdim[a]));
    let spacing = check_spacing(path, "pixdim[1..=3]", pixdim)?;
    if header.qform_code > 0 {
        let rotation = quaternion_rotation(header.quatern_b, header.quatern_c, header.quatern_d);
        // qfac, stored in pixdim[0], mirrors the third axis.
        let qfac = if header.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
        let scale = [pixdim[0], pixdim[1], pixdim[2] * qfac];
        let steps = [0, 1, 2].map(|a| rotation.map(|row| row[a] * scale[a]));
        let origin = [header.quatern_x, header.quatern_y, header.quatern_z].map(f64::from);
        return Placement::from_frame(path, "qform", steps, origin, dims);
    }
    Ok(Placement::grid(spacing, Vec3::ZERO))
}

/// Rotation matrix (rows) of the unit quaternion (a, b, c, d), a >= 0 implied, as in nifti1_io.c.
fn quaternion_rotation(b: f32, c: f32, d: f32) -> [[f64; 3]; 3] {
    let (mut b, mut c, mut d) = (f64::from(b), f64::from(c), f64::from(d));
    let rest = 1.0 - (b * b + c * c + d * d);
    let a = if rest < 1e-7 {
        // |(b, c, d)| >= 1: a 180-degree rotation; renormalise.
        let norm = (b * b + c * c + d * d).sqrt();
        (b, c, d) = (b / norm, c / norm, d / norm);
        0.0
    } else {
        rest.sqrt()
    };
    [
        [
            a * a + b * b - c * c - d * d,
            2.0 * (b * c - a * d),
            2.0 * (b * d + a * c),
        ],
        [
            2.0 * (b * c + a * d),
            a * a + c * c - b * b - d * d,
            2.0 * (c * d - a * b),
        ],
        [
            2.0 * (b * d - a * c),
            2.0 * (c * d + a * b),
            a * a + d * d - c * c - b * b,
        ],
    ]
}

/// Where the data starts (after the header and any extensions).
fn data_offset(path: &Path, vox_offset: f32) -> Result<u64> {
    if vox_offset.is_finite() && vox_offset.fract() == 0.0 && vox_offset >= HEADER_BYTES as f32 {
        Ok(vox_offset as u64)
    } else {
        Err(Error::format(
            path,
            format!("vox_offset = {vox_offset}: must be a whole number of bytes, at least 348"),
        ))
    }
}

fn rescale(values: &mut [f32], slope: f32, inter: f32) {
    if !slope.is_finite() || slope == 0.0 {
        return;
    }
    let inter = if inter.is_finite() {
        f64::from(inter)
    } else {
        0.0
    };
    let slope = f64::from(slope);
    values
        .par_iter_mut()
        .for_each(|v| *v = (f64::from(*v) * slope + inter) as f32);
}
