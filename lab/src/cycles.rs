//! `occlux check-cycles`: runs the Python harness (`python -m occlux_lab.cycles`) that renders the
//! scene with Blender's Cycles and compares it with Occlux's Monte Carlo reference, passing it
//! every option it takes. The harness needs Blender as a Python module, so it runs in the venv
//! that `.ci/run` creates; it computes Occlux's export and reference in-process.

use occlux::error::{Error, Result};
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

/// Cycles renders per comparison: `DEFAULT_SEEDS` in `occlux.blender` (plugin/python/occlux/
/// blender/common.py), the harness's own default.
pub const DEFAULT_SEEDS: u32 = 32;

/// What `occlux check-cycles` passes to the harness: every option `python -m occlux_lab.cycles`
/// takes, with its defaults in the CLI.
#[derive(Clone, Copy, Debug)]
pub struct CheckOptions<'a> {
    pub scene: &'a Path,
    /// ambient, single or multiple.
    pub estimator: &'a str,
    /// Samples per pixel, for Occlux and for Cycles.
    pub spp: u32,
    /// Cycles renders (spp / seeds samples each).
    pub seeds: u32,
    /// Volume bounces (multiple only).
    pub bounces: u32,
    /// Henyey-Greenstein asymmetry (single and multiple).
    pub g: f32,
    /// Where the report, images and error map go.
    pub out: &'a Path,
}

impl CheckOptions<'_> {
    /// The harness's command-line arguments after `-m occlux_lab.cycles`.
    pub fn harness_args(&self) -> Vec<std::ffi::OsString> {
        let mut args: Vec<std::ffi::OsString> = vec![self.scene.into()];
        for (key, value) in [
            ("--estimator", self.estimator.to_owned()),
            ("--spp", self.spp.to_string()),
            ("--seeds", self.seeds.to_string()),
            ("--bounces", self.bounces.to_string()),
            // `--g=-0.3`: a negative value in its own argument would read as an option.
            ("--g", self.g.to_string()),
        ] {
            args.push(format!("{key}={value}").into());
        }
        args.push("--out".into());
        args.push(self.out.into());
        args
    }
}

/// The measurement harness's Python packages (`occlux_lab`): in the repository, not in the wheel
/// users install, so every harness run puts them on the path.
const LAB_PYTHON: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/python");

/// `python` with [`LAB_PYTHON`] ahead of any `PYTHONPATH` the caller set.
fn lab_command(python: &Path) -> Result<Command> {
    let mut paths = vec![PathBuf::from(LAB_PYTHON)];
    if let Some(inherited) = std::env::var_os("PYTHONPATH") {
        paths.extend(std::env::split_paths(&inherited));
    }
    let joined = std::env::join_paths(paths)
        .map_err(|e| Error::param("PYTHONPATH", format!("cannot add {LAB_PYTHON}: {e}")))?;
    let mut command = Command::new(python);
    command.env("PYTHONPATH", joined);
    Ok(command)
}

/// The Python that can run `module`: found (see [`find_python`]) and able to import bpy and
/// `module`; `what` names the command in errors.
fn harness_python(what: &str, module: &str) -> Result<PathBuf> {
    let python = find_python().ok_or_else(|| {
        Error::param(
            what,
            format!("no Python environment with Blender found; {SETUP}"),
        )
    })?;
    let probe = lab_command(&python)?
        .args(["-c", &format!("import bpy, {module}")])
        .output()
        .map_err(|e| Error::io(&python, e))?;
    if !probe.status.success() {
        return Err(Error::param(
            what,
            format!(
                "{} cannot import bpy and {module} ({}); {SETUP}",
                python.display(),
                String::from_utf8_lossy(&probe.stderr)
                    .trim()
                    .lines()
                    .last()
                    .unwrap_or("")
            ),
        ));
    }
    Ok(python)
}

/// Runs `python -m MODULE ARGS` in the harness's Python; an error naming `what` unless it
/// succeeds.
pub(crate) fn run_module(what: &str, module: &str, args: &[std::ffi::OsString]) -> Result<()> {
    let python = harness_python(what, module)?;
    let status = lab_command(&python)?
        .args(["-m", module])
        .args(args)
        .status()
        .map_err(|e| Error::io(&python, e))?;
    if status.success() {
        Ok(())
    } else {
        Err(Error::param(
            what,
            format!("python -m {module} failed ({status})"),
        ))
    }
}

/// Runs the harness for `options.scene`, writing its report, images and error map into
/// `options.out`. The harness computes Occlux's side in-process (the `occlux` package).
pub fn run(options: &CheckOptions<'_>) -> Result<()> {
    run_module("check-cycles", "occlux_lab.cycles", &options.harness_args())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_option_reaches_the_harness() {
        let options = CheckOptions {
            scene: Path::new("scene.toml"),
            estimator: "multiple",
            spp: 64,
            seeds: 8,
            bounces: 3,
            g: -0.3,
            out: Path::new("out dir"),
        };
        let args: Vec<String> = options
            .harness_args()
            .iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            args,
            [
                "scene.toml",
                "--estimator=multiple",
                "--spp=64",
                "--seeds=8",
                "--bounces=3",
                "--g=-0.3",
                "--out",
                "out dir"
            ]
        );
    }
}
