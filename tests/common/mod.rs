//! Helpers shared by integration tests. Each test binary compiles its own copy and uses a
//! subset, hence the allowance.
#![allow(dead_code)]

pub mod layers;
pub mod quadrature;
pub mod render;
pub mod twins;
pub mod vdb;

use std::path::{Path, PathBuf};

/// The shared real volumes (`../shared/data/scivis/` beside the checkout), or a panic saying
/// they are missing.
pub fn scivis_dir() -> PathBuf {
    let dir = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/scivis/"
    ));
    assert!(
        dir.is_dir(),
        "{} is missing: these tests need ../shared (the shared data folder beside the checkout; CI has it)",
        dir.display()
    );
    dir.to_path_buf()
}

/// The value a VDB grid Occlux wrote holds at index `c`: fog volumes are padded by one voxel
/// repeating the border (src/export/vdb.rs), so an index just outside reads the nearest voxel.
pub fn padded_at(volume: &occlux::volume::Volume, c: [i32; 3]) -> f32 {
    let d = volume.dims();
    let at = |a: usize| c[a].clamp(0, d[a] as i32 - 1) as usize;
    volume.at(at(0), at(1), at(2))
}

/// The active voxels of `volume` written as a padded fog volume: its non-zero voxels and those
/// of the padding.
pub fn padded_nonzero(volume: &occlux::volume::Volume) -> usize {
    let [nx, ny, nz] = volume.dims().map(|d| d as i32);
    let mut count = 0;
    for k in -1..=nz {
        for j in -1..=ny {
            for i in -1..=nx {
                count += (padded_at(volume, [i, j, k]) != 0.0) as usize;
            }
        }
    }
    count
}
