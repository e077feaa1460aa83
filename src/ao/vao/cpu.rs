//! CPU twin of the VAO volume: the statistics of `stats`, then the estimate per voxel.

use super::estimate::openness;
use super::stats::local_stats;
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
    let stats = local_stats(field, map, params.radius as usize, progress)?;
    let values = field.values.values();
    let mut open = vec![0.0f32; values.len()];
    open.par_chunks_mut(CHUNK).enumerate().for_each(|(c, out)| {
        let start = c * CHUNK;
        for (n, o) in out.iter_mut().enumerate() {
            let i = start + n;
            *o = openness(params.estimator, map.apply(values[i]), &stats.at(i));
        }
    });
    let grid = |v| {
        let f = &field.values;
        Volume::new(f.dims(), f.spacing(), f.origin(), v)
    };
    let variance = if params.variance {
        let v = (0..values.len())
            .into_par_iter()
            .map(|i| stats.at(i).variance())
            .collect();
        Some(grid(v)?)
    } else {
        None
    };
    Ok(AoVolume::new(grid(open)?, variance))
}
