//! `occlux plan SCENE --error E`: plans a scene's render and says what it chose and why; the
//! scene's own `[render]` is not read.

use occlux::error::Result;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::plan::measure::Subject;
use occlux::plan::{scene_to_plan, Budget, Scattering, DEFAULT_PILOT};
use occlux_lab::term::{notice, say};
use occlux_lab::write_report;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    pub scene: PathBuf,
    /// The error budget: the largest relative RMSE over the volume's pixels against the
    /// scene's path-traced truth.
    #[arg(long)]
    pub error: f64,
    /// The truth's light transport: single (Cycles' default of no volume bounces) or
    /// multiple (8 bounces).
    #[arg(long, default_value = "single")]
    pub scattering: Scattering,
    /// The pilot's image size (longer side, pixels).
    #[arg(long, default_value_t = DEFAULT_PILOT)]
    pub pilot: u32,
    /// Where the methods run (the plan's times are for this device).
    #[arg(long, default_value = "auto")]
    pub device: DeviceChoice,
    /// Also write the plan as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

pub fn run(args: &PlanArgs, quiet: bool) -> Result<()> {
    let budget = Budget {
        pilot: args.pilot,
        ..Budget::new(args.error, args.scattering)
    };
    budget.validate()?;
    let (compute, device_notice) = Compute::resolve(args.device)?;
    if let Some(line) = device_notice {
        notice(quiet, line);
    }
    let loaded = scene_to_plan(&args.scene)?.load()?;
    for line in &loaded.notices {
        notice(quiet, line);
    }
    let lut = loaded.scene.classification.bake(&loaded.volume);
    let subject = Subject {
        scene: &loaded.scene,
        volume: &loaded.volume,
        lut: &lut,
        compute: &compute,
    };
    let plan = occlux::plan::plan(&subject, &budget, &|line: &str| say(quiet, line))?;
    // The plan is the command's answer: printed even when quiet.
    println!("{}", plan.explain());
    println!("{}", plan.choice().how());
    if let Some(path) = &args.json {
        write_report(path, &plan, quiet)?;
    }
    Ok(())
}
