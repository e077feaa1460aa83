//! `occlux plan SCENE --error E`: plans a scene's render and says what it chose and why; the
//! scene's own `[render]` is not read.

use super::measure::Subject;
use super::{Budget, Scattering, DEFAULT_PILOT};
use crate::error::{Error, Result};
use crate::gpu::{Compute, DeviceChoice};
use crate::progress;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    pub scene: PathBuf,
    /// The error budget: the largest relative RMSE over the volume's pixels against the
    /// scene's path-traced truth.
    #[arg(long)]
    pub error: f64,
    /// The truth's light transport: single (Cycles' default of no volume bounces) or
    /// multiple (8 bounces).
    #[arg(long, value_enum, default_value = "single")]
    pub scattering: Scattering,
    /// The pilot's image size (longer side, pixels).
    #[arg(long, default_value_t = DEFAULT_PILOT)]
    pub pilot: u32,
    /// Where the methods run (the plan's times are for this device).
    #[arg(long, value_enum, default_value = "auto")]
    pub device: DeviceChoice,
    /// Also write the plan as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// A scene file without its `[render]`: the method is what the planner replaces, so whether
/// it suits the scene's lights does not matter.
pub fn scene_to_plan(path: &Path) -> Result<Scene> {
    let (mut tree, base) = Scene::file_tree(path)?;
    if let Some(table) = tree.as_object_mut() {
        table.remove("render");
    }
    Scene::from_value(tree, &base).map_err(|e| match e {
        Error::Param { .. } => Error::format(path, e.to_string()),
        other => other,
    })
}

pub fn run(args: &PlanArgs, quiet: bool) -> Result<()> {
    let budget = Budget {
        pilot: args.pilot,
        ..Budget::new(args.error, args.scattering)
    };
    budget.validate()?;
    let (compute, notice) = Compute::resolve(args.device)?;
    if let Some(line) = notice {
        progress::notice(quiet, line);
    }
    let loaded = scene_to_plan(&args.scene)?.load()?;
    for line in &loaded.notices {
        progress::notice(quiet, line);
    }
    let lut = loaded.scene.classification.bake(&loaded.volume);
    let subject = Subject {
        scene: &loaded.scene,
        volume: &loaded.volume,
        lut: &lut,
        compute: &compute,
    };
    let plan = super::plan(&subject, &budget, &|line: &str| {
        progress::say(quiet, format_args!("{line}"))
    })?;
    // The plan is the command's answer: printed even when quiet.
    println!("{}", plan.explain());
    println!("{}", plan.choice().how());
    if let Some(path) = &args.json {
        crate::eval::write_report(path, &plan, quiet)?;
    }
    Ok(())
}
