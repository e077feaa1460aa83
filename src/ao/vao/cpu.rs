//! CPU twin of the VAO volume: the statistics of `stats`, then the estimate per voxel.

use super::estimate::{openness, variance, BoxStats};
use super::stats::{local_stats, LocalStats};
use super::{AoVolume, ScalarField, UnitMap, VaoParams};
use crate::error::Result;
use crate::progress::Progress;
use crate::volume::Volume;
use rayon::prelude::*;

/// Voxels per parallel job of the estimate.
const CHUNK: usize = 16 * 1024;

/// Computes the AO volume of `field` mapped by `map` on the CPU (`params` validated by the
/// caller); the variance is that of the mapped field.
pub fn ao_volume(
    field: &ScalarField,
    map: UnitMap,
    params: &VaoParams,
    progress: &dyn Progress,
) -> Result<AoVolume> {
    let LocalStats {
        min: mut open,
        max,
        mean,
        second,
    } = local_stats(field, map, params.radius as usize, progress)?;
    let values = field.values.values();
    // The openness takes the minimum's place, voxel by voxel once it is read: one dense grid
    // fewer at the peak (the variance below still reads mean and second moment).
    open.par_chunks_mut(CHUNK).enumerate().for_each(|(c, out)| {
        let start = c * CHUNK;
        for (n, o) in out.iter_mut().enumerate() {
            let i = start + n;
            let box_stats = BoxStats {
                min: *o,
                max: max[i],
                mean: mean[i],
                second: second[i],
            };
            *o = openness(params.estimator, map.apply(values[i]), &box_stats);
        }
    });
    drop(max);
    let grid = |v| {
        let f = &field.values;
        Volume::new(f.dims(), f.spacing(), f.origin(), v)
    };
    let variance = if params.variance {
        let v = mean
            .par_iter()
            .zip(&second)
            .map(|(&mean, &second)| variance(mean, second))
            .collect();
        Some(grid(v)?)
    } else {
        None
    };
    Ok(AoVolume::new(grid(open)?, variance))
}
