//! OpenVDB grids (placeholder until the VDB loader lands).

use super::{LoadOptions, SourceInfo};
use crate::error::{Error, Result};
use crate::volume::Volume;
use std::path::Path;

pub(super) fn load(path: &Path, _opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    Err(Error::format(path, "VDB loading not built yet"))
}
