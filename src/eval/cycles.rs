//! `occlux check-cycles`: runs the Python harness (`python -m occlux.cycles`) that renders the
//! scene with Blender's Cycles and compares it with Occlux's Monte Carlo reference. The harness
//! needs Blender as a Python module, so it runs in the venv that `.ci/run` creates.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// How to make the Python environment the harness needs, for error messages.
const SETUP: &str = "create it with: python3 -m venv .venv && \
     .venv/bin/pip install -r tests/python/requirements.txt && \
     .venv/bin/maturin develop --release -m plugin/Cargo.toml \
     (or point $OCCLUX_PYTHON at a Python that has bpy 5 and occlux)";

/// The Python to run: $OCCLUX_PYTHON, else `.venv/bin/python` in the current folder or one
/// above it, or above this executable (target/release/occlux in a checkout).
fn find_python() -> Option<PathBuf> {
    if let Some(python) = std::env::var_os("OCCLUX_PYTHON") {
        return Some(PathBuf::from(python));
    }
    let cwd = std::env::current_dir().ok();
    let exe = std::env::current_exe().ok();
    [cwd, exe]
        .into_iter()
        .flatten()
        .flat_map(|start| {
            start
                .ancestors()
                .map(|dir| dir.join(".venv/bin/python"))
                .collect::<Vec<_>>()
        })
        .find(|python| python.is_file())
}

/// Runs the harness for `scene`, writing its report, images and error map into `out`.
pub fn run(scene: &Path, estimator: &str, spp: u32, out: &Path) -> Result<()> {
    let python = find_python().ok_or_else(|| {
        Error::param(
            "check-cycles",
            format!("no Python environment with Blender found; {SETUP}"),
        )
    })?;
    let probe = Command::new(&python)
        .args(["-c", "import bpy, occlux.cycles"])
        .output()
        .map_err(|e| Error::io(&python, e))?;
    if !probe.status.success() {
        return Err(Error::param(
            "check-cycles",
            format!(
                "{} cannot import bpy and occlux.cycles ({}); {SETUP}",
                python.display(),
                String::from_utf8_lossy(&probe.stderr)
                    .trim()
                    .lines()
                    .last()
                    .unwrap_or("")
            ),
        ));
    }
    let mut command = Command::new(&python);
    command
        .args(["-m", "occlux.cycles"])
        .arg(scene)
        .args(["--estimator", estimator, "--spp", &spp.to_string(), "--out"])
        .arg(out);
    // The harness runs this same binary for the export and the reference.
    if let Ok(exe) = std::env::current_exe() {
        command.env("OCCLUX_BIN", exe);
    }
    let status = command.status().map_err(|e| Error::io(&python, e))?;
    if status.success() {
        Ok(())
    } else {
        Err(Error::param(
            "check-cycles",
            format!("the Cycles harness failed ({status})"),
        ))
    }
}
