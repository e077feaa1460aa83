//! CPU twin of the VAO volume: the statistics of `stats`, streamed slice by slice, and the
//! estimate per voxel written over the field's own slice as each is finished, so that the
//! peak holds the field and a few slices (an owned field is consumed; a borrowed one is
//! copied first).

use super::estimate::{openness, variance};
use super::stats::stream_stats;
use super::{AoVolume, ScalarField, UnitMap, VaoParams};
use crate::error::Result;
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;
use std::borrow::Cow;

/// Voxels per parallel job of the estimate.
const CHUNK: usize = 16 * 1024;

/// Computes the AO volume of `field` mapped by `map` on the CPU (`params` validated by the
/// caller); the variance is that of the mapped field.
pub fn ao_volume(
    field: Cow<'_, ScalarField>,
    map: UnitMap,
    params: &VaoParams,
    progress: &dyn Progress,
) -> Result<AoVolume> {
    let grid = &field.values;
    let (dims, spacing, origin) = (grid.dims(), grid.spacing(), grid.origin());
    let outside = field.outside;
    let mut values = match field {
        Cow::Owned(field) => field.values.into_values(),
        Cow::Borrowed(field) => field.values.values().to_vec(),
    };
    let slice = dims[0] * dims[1];
    let mut variances = params.variance.then(|| vec![0.0f32; values.len()]);
    stream_stats(
        &mut values,
        dims,
        map,
        outside,
        params.radius as usize,
        progress,
        |k, stats, open| {
            open.par_chunks_mut(CHUNK).enumerate().for_each(|(c, out)| {
                for (n, o) in out.iter_mut().enumerate() {
                    let i = c * CHUNK + n;
                    *o = openness(params.estimator, map.apply(*o), &stats.at(i));
                }
            });
            if let Some(v) = &mut variances {
                for ((v, &mean), &second) in v[k * slice..][..slice]
                    .iter_mut()
                    .zip(stats.mean)
                    .zip(stats.second)
                {
                    *v = variance(mean, second);
                }
            }
        },
    )?;
    let grid = |v| Volume::new(dims, spacing, origin, v);
    let variance = variances.map(grid).transpose()?;
    Ok(AoVolume::new(grid(values)?, variance))
}
