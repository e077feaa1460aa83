//! `occlux plan-check`: validates the planner against exhaustive search. For each scene, every
//! configuration the planner weighs is measured at the full size against the scene's truth
//! (Occlux's Monte Carlo at high spp): each registered method at each of its chart settings,
//! timed (median after a warm-up), and the truth's Monte Carlo estimator at the samples each
//! budget needs (its noise per sample and cost law measured at the full size). For each
//! budget, the planner then plans from its pilot, and its choice is measured: whether its
//! actual error stays within the budget, and its time over the fastest configuration that
//! meets the budget. The goals: within budget in >= 90 % of cases, within 1.5x of the
//! fastest.

use crate::bench::timed_keeping;
use occlux::error::{Error, Result};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::plan::measure::{monte_carlo, pixels, render_method, resized, CostLaw, Subject, Truth};
use occlux::plan::scene_to_plan;
use occlux::plan::{self, Budget, Choice, Scattering};
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct PlanCheckArgs {
    /// Scene files (their lights and camera; their `[render]` is not read).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "examples/demo.toml,examples/engine-sun.toml,examples/engine.toml,examples/bonsai-sun.toml,examples/tooth.toml"
    )]
    pub scenes: Vec<PathBuf>,
    /// Error budgets (relative RMSE).
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.1,0.2,0.4")]
    pub errors: Vec<f64>,
    /// The full image's longer side.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// The planner's pilot (longer side).
    #[arg(long, default_value_t = 48)]
    pub pilot: u32,
    /// Samples per pixel of the truth.
    #[arg(long, default_value_t = 2048)]
    pub spp: u32,
    #[arg(long, default_value = "single")]
    pub scattering: Scattering,
    /// Timed renders per configuration in the exhaustive search (median, after a warm-up).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    #[arg(long, default_value = "cpu")]
    pub device: DeviceChoice,
    /// Where the JSON report goes.
    #[arg(long, default_value = "plan-check.json")]
    pub json: PathBuf,
}

/// A configuration measured at the full size.
#[derive(Clone, Debug, Serialize)]
pub struct Measured {
    pub label: String,
    pub seconds: f64,
    pub error: f64,
}

/// One scene at one budget.
#[derive(Clone, Debug, Serialize)]
pub struct Case {
    pub scene: String,
    pub budget: f64,
    pub chosen: String,
    pub predicted_error: f64,
    pub predicted_seconds: f64,
    pub actual_error: f64,
    pub actual_seconds: f64,
    pub met: bool,
    /// The fastest configuration that meets the budget at the full size, and the choice's
    /// time over its time.
    pub fastest: String,
    pub fastest_seconds: f64,
    pub slowdown: f64,
    pub pilot_seconds: f64,
}

#[derive(Serialize)]
pub struct Report {
    pub device: String,
    pub size: u32,
    pub pilot: u32,
    pub cases: Vec<Case>,
    pub met: usize,
    pub within_1_5x: usize,
}

pub fn run(args: &PlanCheckArgs, quiet: bool) -> Result<()> {
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        crate::term::notice(quiet, line);
    }
    let report = check(args, &compute, &|line| {
        crate::term::say(quiet, format_args!("{line}"))
    })?;
    crate::term::say(quiet, format_args!("{}", table(&report.cases)));
    crate::term::say(
        quiet,
        format_args!(
            "within budget in {} of {} cases ({:.0} %); within 1.5x of the fastest in {} of {}",
            report.met,
            report.cases.len(),
            100.0 * report.met as f64 / report.cases.len().max(1) as f64,
            report.within_1_5x,
            report.cases.len()
        ),
    );
    super::write_report(&args.json, &report, quiet)
}

/// Runs the validation (see the module docs).
pub fn check(args: &PlanCheckArgs, compute: &Compute, say: &dyn Fn(&str)) -> Result<Report> {
    if args.scenes.is_empty() || args.errors.is_empty() || args.repeats == 0 || args.spp < 2 {
        return Err(Error::param(
            "--scenes/--errors/--repeats/--spp",
            "need a scene, a budget, a repeat and at least 2 samples per pixel",
        ));
    }
    let mut cases = vec![];
    for path in &args.scenes {
        cases.extend(check_scene(path, args, compute, say)?);
    }
    let met = cases.iter().filter(|c| c.met).count();
    let within_1_5x = cases.iter().filter(|c| c.slowdown <= 1.5).count();
    Ok(Report {
        device: compute.describe(),
        size: args.size,
        pilot: args.pilot,
        cases,
        met,
        within_1_5x,
    })
}

fn check_scene(
    path: &std::path::Path,
    args: &PlanCheckArgs,
    compute: &Compute,
    say: &dyn Fn(&str),
) -> Result<Vec<Case>> {
    let name = occlux::pipeline::stem(path);
    let mut loaded = scene_to_plan(path)?.load()?;
    loaded.scene.camera = resized(&loaded.scene.camera, args.size);
    let (scene, volume) = (&loaded.scene, &loaded.volume);
    let lut = scene.classification.bake(volume);
    let subject = Subject {
        scene,
        volume,
        lut: &lut,
        compute,
    };
    let camera = scene.camera;
    let estimator = plan::truth_estimator(&scene.lighting, args.scattering);
    say(&format!("{name}: the truth at {} spp", args.spp));
    let (image, _) = monte_carlo(&subject, &camera, estimator, args.spp, 11)?;
    let truth = Truth::new(&subject, camera, &image)?;
    let mut methods = vec![];
    for choice in plan::method_candidates(&scene.lighting)? {
        let Choice::Method { method, .. } = &choice else {
            continue;
        };
        let label = choice.label();
        say(&format!("{name}: {label}"));
        let (timing, (image, _)) =
            timed_keeping(args.repeats, || render_method(&subject, method, &camera))?;
        methods.push(Measured {
            label,
            seconds: timing.median_ms / 1e3,
            error: truth.error(&image.rgba, 0.0)?.0,
        });
    }
    // Monte Carlo's noise per sample and cost law at the full size.
    let (_, few_seconds) = monte_carlo(&subject, &camera, estimator, 4, 13)?;
    let (more, more_seconds) = monte_carlo(&subject, &camera, estimator, 32, 15)?;
    let law = CostLaw::through(
        (pixels(&camera) * 4.0, few_seconds),
        (pixels(&camera) * 32.0, more_seconds),
    )?;
    let noise_per_sample = Truth::new(&subject, camera, &more)?.noise_per_sample;
    let mut cases = vec![];
    for &error in &args.errors {
        let budget = Budget {
            pilot: args.pilot,
            ..Budget::new(error, args.scattering)
        };
        say(&format!("{name}: planning for {error}"));
        let plan = plan::plan(&subject, &budget, &|_| {})?;
        let chosen = &plan.estimates[plan.chosen];
        let (actual_seconds, actual_error) = match &chosen.choice {
            Choice::Method { .. } => {
                let m = methods
                    .iter()
                    .find(|m| m.label == chosen.label)
                    .ok_or_else(|| Error::param("plan-check", "the choice was not measured"))?;
                (m.seconds, m.error)
            }
            Choice::MonteCarlo { estimator, spp } => {
                let (image, _) = monte_carlo(&subject, &camera, *estimator, *spp, 1)?;
                let seconds = law.seconds(pixels(&camera) * *spp as f64);
                (seconds, truth.error(&image.mean, 0.0)?.0)
            }
        };
        let spp = (noise_per_sample / error).powi(2).ceil().max(2.0);
        let mut fastest = Measured {
            label: Choice::MonteCarlo {
                estimator,
                spp: spp as u32,
            }
            .label(),
            seconds: law.seconds(pixels(&camera) * spp),
            error,
        };
        for m in methods.iter().filter(|m| m.error <= error) {
            if m.seconds < fastest.seconds {
                fastest = m.clone();
            }
        }
        cases.push(Case {
            scene: name.clone(),
            budget: error,
            chosen: chosen.label.clone(),
            predicted_error: chosen.error.unwrap_or(f64::NAN),
            predicted_seconds: chosen.seconds,
            actual_error,
            actual_seconds,
            met: actual_error <= error,
            slowdown: actual_seconds / fastest.seconds,
            fastest: fastest.label,
            fastest_seconds: fastest.seconds,
            pilot_seconds: plan.pilot_seconds,
        });
    }
    Ok(cases)
}

/// The cases as a Markdown table.
pub fn table(cases: &[Case]) -> String {
    let mut text = String::from(
        "| scene | budget | chosen | pred. error | error | pred. time | time | fastest within budget | its time | slowdown | pilot |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for c in cases {
        text += &format!(
            "| {} | {} | {} | {:.3} | {:.3}{} | {:.3} s | {:.3} s | {} | {:.3} s | {:.2}x | {:.1} s |\n",
            c.scene,
            c.budget,
            c.chosen,
            c.predicted_error,
            c.actual_error,
            if c.met { "" } else { " (over)" },
            c.predicted_seconds,
            c.actual_seconds,
            c.fastest,
            c.fastest_seconds,
            c.slowdown,
            c.pilot_seconds
        );
    }
    text
}
