//! Occlux's measurement lab: the GPU adapter's description, the benchmarks, the accuracy
//! commands, the speed-against-accuracy chart and gallery, the planner's check and the launchers
//! of the peers (Cycles, VTK, EEVEE) whose Python harness is `lab/python/occlux_lab`. The command line links it for its measuring
//! subcommands; the library and the Python package never do.
pub mod adapter;
pub mod bench;
pub mod chart;
pub mod cycles;
pub mod dos_accuracy;
pub mod gallery;
pub mod ipsvi_accuracy;
pub mod peers;
pub mod plan_check;
pub mod sweep_accuracy;
pub mod sweep_bench;
pub mod term;
pub mod vao_accuracy;
pub mod vao_bench;

use occlux::error::{Error, Result};
use occlux::export::atomic::write_bytes_atomic;
use std::path::Path;

/// Writes a report as pretty JSON, atomically, and says where unless `quiet`.
pub fn write_report(path: &Path, report: &impl serde::Serialize, quiet: bool) -> Result<()> {
    let json =
        serde_json::to_string_pretty(report).map_err(|e| Error::param("report", e.to_string()))?;
    write_bytes_atomic(path, json.as_bytes())?;
    if !quiet {
        println!("wrote {}", path.display());
    }
    Ok(())
}
