//! `occlux info`: what a volume file holds, as a user reads it: format, dims, spacing, bounds,
//! value range and a histogram.

use super::{load_with_info, LoadOptions};
use crate::error::Result;
use std::path::Path;

/// Loads `file` and prints its description on standard output.
pub fn print(file: &Path, options: &LoadOptions) -> Result<()> {
    let (vol, source) = load_with_info(file, options)?;
    let [nx, ny, nz] = vol.dims();
    let (lo, hi) = vol.value_range();
    let (blo, bhi) = vol.bounds();
    println!("file      {}", file.display());
    println!(
        "format    {} ({}{})",
        source.format,
        source.scalar,
        source
            .grid
            .map_or(String::new(), |g| format!(", grid '{g}'"))
    );
    println!(
        "dims      {nx} x {ny} x {nz} ({} voxels, {:.1} MiB as f32)",
        vol.values().len(),
        vol.values().len() as f64 * 4.0 / (1 << 20) as f64
    );
    println!("spacing   {}", vol.spacing());
    println!("origin    {}", vol.origin());
    println!("bounds    {blo} .. {bhi}");
    println!("values    {lo} .. {hi}");
    println!("histogram (16 bins over the value range, % of voxels)");
    let hist = vol.histogram(16);
    let total = vol.values().len() as f64;
    let width = (hi - lo) / 16.0;
    for (b, count) in hist.iter().enumerate() {
        let pct = *count as f64 / total * 100.0;
        println!(
            "  {:>12.4} .. {:<12.4} {:6.2}% {}",
            lo + b as f32 * width,
            lo + (b + 1) as f32 * width,
            pct,
            "#".repeat((pct / 2.0).ceil() as usize)
        );
    }
    Ok(())
}
