//! Progress reporting from the library: a callback, so the CLI can drive a progress bar and the
//! Blender add-on its own progress API.

/// Receives `(done, total)` in units the caller chose (rows, slices, steps), and may ask the
/// work to stop: long computations check [`Progress::cancelled`] between units and then return
/// [`crate::Error::Cancelled`] without a result.
pub trait Progress: Sync {
    fn update(&self, done: u64, total: u64);

    /// Whether the caller wants the work abandoned.
    fn cancelled(&self) -> bool {
        false
    }
}

/// Reports nothing.
pub struct NoProgress;

impl Progress for NoProgress {
    fn update(&self, _done: u64, _total: u64) {}
}

impl<F: Fn(u64, u64) + Sync> Progress for F {
    fn update(&self, done: u64, total: u64) {
        self(done, total)
    }
}
