//! The renderers a user would pick instead of Occlux, as series of `occlux chart`: Cycles (the
//! path tracer users check against), VTK's GPU volume ray caster (what a scientist renders
//! volumes with) and Blender's EEVEE (what Blender users preview with). Each is a Python module
//! (lab/python/occlux_lab/peers/) run in the harness's venv: it renders a scene file at a few
//! settings of its own quality axis, times each render and writes the images and
//! `OUT/PEER-ESTIMATOR-curve.json`, which this module reads back.

use occlux::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// A peer renderer of the chart.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Peer {
    /// Blender's Cycles at increasing samples per pixel: the path tracer, whose curve gives
    /// every point its speed-up at equal error.
    Cycles,
    /// VTK's GPU volume ray caster with volumetric shadows, at decreasing sample distances.
    Vtk,
    /// Blender's EEVEE at finer froxels and more volume samples.
    Eevee,
}

impl Peer {
    /// Its name in files and in the JSON (as `--peers` takes it).
    pub fn name(self) -> &'static str {
        match self {
            Peer::Cycles => "cycles",
            Peer::Vtk => "vtk",
            Peer::Eevee => "eevee",
        }
    }

    /// Its name in the figure's legend.
    pub fn label(self) -> &'static str {
        match self {
            Peer::Cycles => "Cycles",
            Peer::Vtk => "VTK",
            Peer::Eevee => "EEVEE",
        }
    }

    /// The Python module that renders its curve.
    fn module(self) -> &'static str {
        match self {
            Peer::Cycles => "occlux_lab.cycles.curve",
            Peer::Vtk => "occlux_lab.peers.vtk",
            Peer::Eevee => "occlux_lab.peers.eevee",
        }
    }
}

/// One render of a peer: its setting in words, its wall time, the EXR it wrote, for a path
/// tracer its samples per pixel, and for a point off the peer's quality axis the series it
/// belongs to (drawn apart: VTK without shadows).
#[derive(Clone, Debug, Deserialize)]
pub struct Render {
    pub setting: String,
    pub seconds: f64,
    pub exr: PathBuf,
    #[serde(default)]
    pub spp: Option<u32>,
    #[serde(default)]
    pub series: Option<String>,
}

/// A peer's curve as its module wrote it.
#[derive(Clone, Debug, Deserialize)]
pub struct Report {
    /// What its seconds include, in words.
    pub timing: String,
    pub points: Vec<Render>,
}

/// What a peer renders: the scene file, the estimator of the lighting's truth (ambient, single
/// or multiple), its bounces and phase asymmetry, and Cycles' sample counts.
pub struct Request<'a> {
    pub scene: &'a Path,
    pub estimator: &'a str,
    pub bounces: u32,
    pub g: f32,
    pub cycles_spp: &'a [u32],
    /// Where its images and JSON go.
    pub out: &'a Path,
}

/// The arguments of `python -m MODULE` for `peer` (the contract of occlux_lab.peers).
fn module_args(peer: Peer, request: &Request) -> Vec<OsString> {
    let mut args: Vec<OsString> = vec![request.scene.into()];
    let mut options = vec![
        ("--estimator", request.estimator.to_owned()),
        ("--bounces", request.bounces.to_string()),
        // `--g=-0.3`: a negative value in its own argument would read as an option.
        ("--g", request.g.to_string()),
    ];
    if peer == Peer::Cycles {
        let spp: Vec<String> = request.cycles_spp.iter().map(u32::to_string).collect();
        options.push(("--spp", spp.join(",")));
    }
    args.extend(options.iter().map(|(k, v)| format!("{k}={v}").into()));
    args.push("--out".into());
    args.push(request.out.into());
    args
}

/// Renders `peer`'s curve and reads back what it wrote.
pub fn curve(peer: Peer, request: &Request) -> Result<Report> {
    super::cycles::run_module("chart", peer.module(), &module_args(peer, request))?;
    let path = request
        .out
        .join(format!("{}-{}-curve.json", peer.name(), request.estimator));
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    serde_json::from_str(&text).map_err(|e| Error::format(&path, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_peer_gets_the_lighting_and_only_cycles_its_sample_counts() {
        let request = Request {
            scene: Path::new("lit scene.toml"),
            estimator: "multiple",
            bounces: 8,
            g: -0.3,
            cycles_spp: &[1, 4],
            out: Path::new("out"),
        };
        let strings = |peer| -> Vec<String> {
            module_args(peer, &request)
                .iter()
                .map(|a| a.to_string_lossy().into_owned())
                .collect()
        };
        let common = [
            "lit scene.toml",
            "--estimator=multiple",
            "--bounces=8",
            "--g=-0.3",
        ];
        let vtk = strings(Peer::Vtk);
        assert_eq!(vtk[..4], common);
        assert_eq!(vtk[4..], ["--out", "out"]);
        let cycles = strings(Peer::Cycles);
        assert_eq!(cycles[..4], common);
        assert_eq!(cycles[4..], ["--spp=1,4", "--out", "out"]);
    }
}
