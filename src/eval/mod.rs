//! Evaluation: benchmarks and error metrics.
pub mod bench;
pub mod cycles;
pub mod dos_accuracy;
pub mod vao_accuracy;
pub mod vao_bench;
