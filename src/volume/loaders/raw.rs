//! Headerless raw files (`.raw`): the layout comes from [`RawSpec`](super::RawSpec) (x fastest,
//! then y, then z), after `header_bytes` bytes that are skipped. The file's size must be exactly
//! `header_bytes + voxels * type size`: anything else means the spec does not describe the file.

use super::{
    check_spacing, decode, finish, read_payload, skip, Frame, Layout, LoadOptions, Placement,
    SourceInfo,
};
use crate::error::{Error, Result};
use crate::volume::Volume;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

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
            format!(
                "file is {found} bytes, but header_bytes {} + {} ({} bytes) need {}",
                spec.header_bytes,
                layout.describe(),
                layout.byte_len,
                needed.map_or("more than 2^64".to_string(), |n| n.to_string())
            ),
        ));
    }
    let mut reader = BufReader::new(file);
    skip(path, &mut reader, spec.header_bytes, "header_bytes")?;
    let bytes = read_payload(path, reader, "raw data", &layout)?;
    let values = decode(&bytes, &layout);
    drop(bytes);
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
