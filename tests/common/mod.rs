//! Helpers shared by integration tests. Each test binary compiles its own copy and uses a
//! subset, hence the allowance.
#![allow(dead_code)]

pub mod layers;
pub mod quadrature;
pub mod twins;

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
