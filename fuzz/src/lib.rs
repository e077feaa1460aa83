//! What every fuzz target shares: the input written to a file the loaders can open, loaded
//! with a memory budget small enough for libFuzzer's RSS limit, and the invariants a volume
//! that loads must hold.

use occlux::memory::{MemoryBudget, MemoryLimit};
use occlux::volume::{load, LoadOptions, Volume};
use std::path::PathBuf;

/// Largest volume a fuzz input may allocate (a header may claim any size; the budget is the
/// user's guard against that, so it is part of what is fuzzed).
pub const BUDGET: u64 = 64 << 20;

/// A file of this process named `input.<extension>` holding `data`, in memory where the
/// system has a RAM disk (a disk write per input would bound the executions per second).
pub fn file_with(extension: &str, data: &[u8]) -> PathBuf {
    let path = scratch().join(format!(
        "occlux-fuzz-{}-input.{extension}",
        std::process::id()
    ));
    std::fs::write(&path, data).expect("the fuzz input file can be written");
    path
}

/// Where inputs and outputs are written: in memory where the system has a RAM disk.
pub fn scratch() -> PathBuf {
    let shm = std::path::Path::new("/dev/shm");
    if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    }
}

/// Loads `data` as a file with `extension`; a volume that loads must be consistent.
pub fn load_as(extension: &str, data: &[u8], options: LoadOptions) {
    let path = file_with(extension, data);
    let options = LoadOptions {
        memory: MemoryBudget {
            limit: MemoryLimit::Bytes(BUDGET, "the fuzzers' budget"),
            ..MemoryBudget::default()
        },
        ..options
    };
    if let Ok(volume) = load(&path, &options) {
        check(&volume);
    }
}

/// What every loaded volume holds: one finite value per voxel and a finite, positive frame.
pub fn check(volume: &Volume) {
    let [nx, ny, nz] = volume.dims();
    assert_eq!(volume.values().len(), nx * ny * nz);
    assert!(volume.values().iter().all(|v| v.is_finite()));
    assert!(volume.spacing().is_finite() && volume.spacing().min_element() > 0.0);
    assert!(volume.origin().is_finite());
    let (lo, hi) = volume.bounds();
    assert!(lo.is_finite() && hi.is_finite() && hi.cmpgt(lo).all());
}

/// Panics inside the VDB reader are caught by the loader and reported as errors; libFuzzer's
/// hook would abort on them before they are caught. Uncaught panics still abort: the target's
/// wrapper treats them as crashes.
pub fn quiet_caught_panics() {
    std::panic::set_hook(Box::new(|_| {}));
}

/// Rayon on one thread: the settle and render targets' volumes are a few thousand voxels, too
/// small for threads to pay for themselves, and libFuzzer runs one process per core anyway.
pub fn one_thread() {
    std::env::set_var("RAYON_NUM_THREADS", "1");
}
