//! Headerless raw files (`.raw`): the layout comes from [`RawSpec`](super::RawSpec) (x fastest,
//! then y, then z), after `header_bytes` bytes that are skipped. The file's size must be exactly
//! `header_bytes + voxels * type size`: anything else means the spec does not describe the file.

use super::{
    check_spacing, finish, read_values, skip, Frame, Layout, LoadOptions, Placement, SourceInfo,
};
use crate::error::{Error, Result};
use crate::volume::Volume;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// Why a file of `found` bytes is not `header_bytes` followed by `layout`'s voxels (`needed`
/// bytes in all, None past 2^64). Neutral about where the layout came from (the CLI's flags, a
/// scene's keys or the Blender panel's fields all share it), and it says which way the size is
/// wrong: a longer file may hold a header, or other dims or another type.
fn size_mismatch(found: u64, needed: Option<u64>, header_bytes: u64, layout: &Layout) -> String {
    let header = match header_bytes {
        0 => String::new(),
        n => format!("a {n}-byte header and "),
    };
    let what = format!(
        "{header}{} ({} bytes of voxels)",
        layout.describe(),
        layout.byte_len
    );
    match needed {
        Some(n) if found > n => format!(
            "file is {found} bytes, too large: {what} need {n}, {} fewer (does the file hold \
             a header, or other dims or another type?)",
            found - n
        ),
        Some(n) => format!("file is {found} bytes, too small: {what} need {n}"),
        None => format!("file is {found} bytes, too small: {what} need more than 2^64"),
    }
}

pub(super) fn load(path: &Path, opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    let spec = opts.raw.as_ref().ok_or_else(|| {
        Error::format(
            path,
            "a .raw file has no header: give its dims, type and spacing (CLI: --raw-dims X,Y,Z \
             --raw-type uint8|int8|uint16|int16|uint32|int32|float|double --raw-spacing X,Y,Z; \
             scene: [volume.raw] dims, type, spacing)",
        )
    })?;
    let layout = Layout::checked(path, spec.dims, spec.scalar, spec.big_endian, opts)?;
    let spacing = check_spacing(path, "raw spacing", spec.spacing.to_array().map(f64::from))?;
    if !spec.origin.is_finite() {
        return Err(Error::format(
            path,
            format!("raw origin must be finite, got {}", spec.origin),
        ));
    }
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let found = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let needed = spec.header_bytes.checked_add(layout.byte_len as u64);
    if needed != Some(found) {
        return Err(Error::format(
            path,
            size_mismatch(found, needed, spec.header_bytes, &layout),
        ));
    }
    let mut reader = BufReader::new(file);
    skip(path, &mut reader, spec.header_bytes, "header_bytes")?;
    let values = read_values(path, reader, "raw data", &layout)?;
    let (volume, non_finite) = finish(
        path,
        spec.dims,
        Placement::grid(spacing, spec.origin),
        values,
        opts,
    )?;
    let info = SourceInfo {
        format: "raw",
        scalar: spec.scalar.name().to_string(),
        grid: None,
        non_finite,
        frame: Frame::ALIGNED,
        hounsfield: None,
    };
    Ok((volume, info))
}
