//! Evaluation: benchmarks and error metrics.
pub mod bench;
pub mod cycles;
