//! `occlux chart`: speed against accuracy. Every registered method at each of its chart settings
//! ([`occlux::method::MethodSpec::chart`]: a method joins by registering), Occlux's Monte Carlo
//! and Cycles at increasing samples per pixel, and the peers a user would pick instead (VTK, EEVEE:
//! [`crate::peers`]) along their quality axes, on each scene under each lighting, all measured
//! against the path-traced truth of that lighting ([`measure`]). Time: the median wall time after a
//! warm-up render, from the loaded volume to the image, everything the method computes on the way
//! included (an AO volume, the GPU upload); Cycles' from scratch, its volume build included, as a
//! user pays it; each peer states its own. Error: relative RMSE and bias over the volume's pixels
//! (docs/architecture.md#error-measure). Writes OUT/chart.json, OUT/chart.csv, OUT/chart.md (the
//! equal-error table: [`table`]), OUT/chart.svg and OUT/chart.png (log time against log error, a
//! panel per scene and lighting, the Pareto front filled, the path tracers and peers as lines).

pub mod measure;
pub mod pareto;
pub mod plot;
pub mod table;

use crate::peers::Peer;
use measure::{LightingMode, Panel, Setup};
use occlux::error::{Error, Result};
use occlux::export::atomic::write_bytes_atomic;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::progress::Progress;
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct ChartArgs {
    /// Scene files (each one's volume, classification and camera; its lights by --lightings).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "examples/engine-sun.toml"
    )]
    pub scenes: Vec<PathBuf>,
    /// Lightings: ambient (the scene's ambient lights, or radiance 1), sun (its suns and
    /// lamps, single scattering), multi (the same, multiple scattering with 8 bounces).
    #[arg(long, value_delimiter = ',', default_value = "ambient,sun,multi")]
    pub lightings: Vec<LightingMode>,
    /// Square image side.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Samples per pixel of the truth (Occlux's Monte Carlo reference).
    #[arg(long, default_value_t = 1024)]
    pub spp: u32,
    /// Occlux's Monte Carlo curve: its sample counts (at least 2: it states its noise).
    #[arg(long, value_delimiter = ',', default_value = "2,8,32,128")]
    pub mc_spp: Vec<u32>,
    /// The peers beside the methods, each through its Python module in the venv of .ci/run:
    /// cycles (at --cycles-spp), vtk (its GPU ray caster with volumetric shadows), eevee.
    #[arg(long, value_delimiter = ',', default_value = "cycles,vtk,eevee")]
    pub peers: Vec<Peer>,
    /// Cycles' curve: its sample counts. Up to 256, so that the fast methods' errors mostly lie
    /// on the curve rather than beyond its end (where the speed-up is extrapolated along its
    /// last segment).
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
    pub cycles_spp: Vec<u32>,
    /// Leave every peer out (no Python with Blender needed).
    #[arg(long)]
    pub no_peers: bool,
    /// Timed renders per method setting (median, after one warm-up).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Where the methods run; auto picks a hardware GPU adapter if one opens.
    #[arg(long, default_value = "cpu")]
    pub device: DeviceChoice,
    #[arg(short, long, default_value = "occlux-chart")]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct Report<'a> {
    device: String,
    cpu_threads: usize,
    size: u32,
    panels: &'a [Panel],
}

pub fn run(args: &ChartArgs, quiet: bool) -> Result<()> {
    if args.scenes.is_empty() || args.lightings.is_empty() || args.repeats == 0 {
        return Err(Error::param(
            "--scenes/--lightings/--repeats",
            "need at least one scene, one lighting and one repeat",
        ));
    }
    if args.size == 0 || args.size > occlux::camera::MAX_IMAGE_SIDE {
        return Err(Error::param(
            "--size",
            format!(
                "must be in 1..={}, got {}",
                occlux::camera::MAX_IMAGE_SIDE,
                args.size
            ),
        ));
    }
    // Occlux's Monte Carlo states its own noise, so it takes two samples at least.
    if args.spp < 2 || args.mc_spp.iter().any(|&s| s < 2) {
        return Err(Error::param(
            "--spp/--mc-spp",
            "Occlux's Monte Carlo takes at least 2 samples per pixel",
        ));
    }
    if args.cycles_spp.contains(&0) {
        return Err(Error::param(
            "--cycles-spp",
            "Cycles takes at least 1 sample per pixel",
        ));
    }
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        crate::term::notice(quiet, line);
    }
    let work = args.out.join("work");
    std::fs::create_dir_all(&work).map_err(|e| Error::io(&work, e))?;
    let panels_total = (args.scenes.len() * args.lightings.len()) as u64;
    let bar = crate::term::Bar::new(quiet, panels_total, "chart");
    let say = |line: &str| bar.message(line);
    let peers: &[Peer] = if args.no_peers { &[] } else { &args.peers };
    let setup = Setup {
        compute: &compute,
        reference_spp: args.spp,
        mc_spp: &args.mc_spp,
        peers,
        cycles_spp: &args.cycles_spp,
        repeats: args.repeats,
        work: &work,
        progress: &say,
    };
    let mut panels = vec![];
    for path in &args.scenes {
        for &light in &args.lightings {
            panels.push(measure::panel(path, light, args.size, &setup)?);
            bar.update(panels.len() as u64, panels_total);
        }
    }
    bar.finish();
    for panel in &panels {
        for p in &panel.points {
            crate::term::say(
                quiet,
                format_args!(
                    "{:<12} {:<7} {:<11} {:<40} {:>8.3} s  rel RMSE {:.3} bias {:+.3}{}{}{}",
                    panel.scene,
                    panel.lighting,
                    p.method,
                    p.setting,
                    p.seconds,
                    p.rel_rmse,
                    p.rel_bias,
                    p.model_rel_rmse
                        .map_or(String::new(), |e| format!(" (own model {e:.3})")),
                    if p.pareto { "  (front)" } else { "" },
                    p.speedup_vs_cycles.map_or(String::new(), |s| {
                        let first = p.cycles_reached == Some(pareto::Reached::FirstSample);
                        format!("  {s:.1}x Cycles{}", if first { " at 1 spp" } else { "" })
                    }),
                ),
            );
        }
        for series in &panel.peers {
            for p in &series.points {
                crate::term::say(
                    quiet,
                    format_args!(
                        "{:<12} {:<7} {:<11} {:<40} {:>8.3} s  rel RMSE {:.3} bias {:+.3}{}",
                        panel.scene,
                        panel.lighting,
                        series.peer,
                        p.setting,
                        p.seconds,
                        p.rel_rmse,
                        p.rel_bias,
                        p.speedup_vs_cycles
                            .map_or(String::new(), |s| format!("  {s:.1}x Cycles")),
                    ),
                );
            }
        }
    }
    let report = Report {
        device: compute.describe(),
        cpu_threads: rayon::current_num_threads(),
        size: args.size,
        panels: &panels,
    };
    super::write_report(&args.out.join("chart.json"), &report, quiet)?;
    let csv = args.out.join("chart.csv");
    write_bytes_atomic(&csv, csv_text(&panels).as_bytes())?;
    let markdown = args.out.join("chart.md");
    write_bytes_atomic(&markdown, table::markdown(&panels).as_bytes())?;
    let (svg, png) = (args.out.join("chart.svg"), args.out.join("chart.png"));
    plot::write_charts(&figure(&panels), &svg, &png)?;
    crate::term::report_written(&[csv, markdown, svg, png], quiet);
    Ok(())
}

/// One row per method setting, per path-tracer sample count and per peer setting.
fn csv_text(panels: &[Panel]) -> String {
    let mut text = String::from(
        "scene,lighting,method,setting,spp,seconds,rel_rmse,rel_bias,pareto,speedup_vs_cycles,speedup_vs_monte_carlo,model_rel_rmse,model_rel_bias\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
    for panel in panels {
        for p in &panel.points {
            text += &format!(
                "{},{},{},\"{}\",,{:.6},{:.6},{:.6},{},{},{},{},{}\n",
                panel.scene,
                panel.lighting,
                p.method,
                p.setting.replace('"', "\"\""),
                p.seconds,
                p.rel_rmse,
                p.rel_bias,
                p.pareto,
                opt(p.speedup_vs_cycles),
                opt(p.speedup_vs_monte_carlo),
                opt(p.model_rel_rmse),
                opt(p.model_rel_bias)
            );
        }
        for (name, curve) in [
            ("monte-carlo", &panel.monte_carlo),
            ("cycles", &panel.cycles),
        ] {
            for c in curve.iter() {
                text += &format!(
                    "{},{},{name},,{},{:.6},{:.6},{:.6},,,,,\n",
                    panel.scene, panel.lighting, c.spp, c.seconds, c.rel_rmse, c.rel_bias
                );
            }
        }
        for series in &panel.peers {
            for p in &series.points {
                text += &format!(
                    "{},{},\"{}\",\"{}\",,{:.6},{:.6},{:.6},,{},{},,\n",
                    panel.scene,
                    panel.lighting,
                    series.peer.to_lowercase(),
                    p.setting.replace('"', "\"\""),
                    p.seconds,
                    p.rel_rmse,
                    p.rel_bias,
                    opt(p.speedup_vs_cycles),
                    opt(p.speedup_vs_monte_carlo)
                );
            }
        }
    }
    text
}

/// The figure's panels.
fn figure(panels: &[Panel]) -> Vec<plot::Panel> {
    panels
        .iter()
        .map(|panel| plot::Panel {
            title: format!("{}, {}", panel.scene, panel.lighting),
            points: panel
                .points
                .iter()
                .map(|p| plot::PlotPoint {
                    series: p.method.to_owned(),
                    label: p.setting.clone(),
                    seconds: p.seconds,
                    error: p.rel_rmse,
                    pareto: p.pareto,
                })
                .collect(),
            curves: [
                ("Occlux Monte Carlo", &panel.monte_carlo),
                ("Cycles", &panel.cycles),
            ]
            .into_iter()
            .filter(|(_, c)| !c.is_empty())
            .map(|(name, c)| plot::Curve {
                name: name.to_owned(),
                points: c.iter().map(|p| (p.seconds, p.rel_rmse)).collect(),
            })
            .chain(panel.peers.iter().map(|series| {
                plot::Curve {
                    name: series.peer.to_owned(),
                    points: series
                        .points
                        .iter()
                        .map(|p| (p.seconds, p.rel_rmse))
                        .collect(),
                }
            }))
            .collect(),
        })
        .collect()
}
