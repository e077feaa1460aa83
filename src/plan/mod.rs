//! The planner (`occlux plan SCENE --error E`, `method = "auto"`): the cheapest configuration
//! whose error against the scene's path-traced truth stays within a budget, Monte Carlo
//! included, and why.
//!
//! The truth is the scene's own lights with single scattering (Cycles' default of no volume
//! bounces: the `ambient`, `single` or, with both kinds of light, the `multiple` estimator at
//! 0 bounces) or, on request, multiple scattering (8 bounces).
//!
//! Errors are measured, not guessed: a pilot renders the scene at a small image size (the
//! same view, `pilot` pixels on the longer side), the truth at enough samples that its own
//! noise is a third of the budget, and every registered method at each of its chart settings
//! (`MethodSpec::chart`: a method joins by registering). A method's error is its relative
//! RMSE over the volume's pixels beyond the truth's noise, which carries over to the full
//! size because both sample the same rays through pixel centres. Monte Carlo's error is its
//! noise, known from the truth's per-sample variance: `noise_per_sample / sqrt(spp)`, so its
//! samples per pixel follow from the budget. Times are predicted from the pilot by a cost law
//! per configuration, a fixed cost (AO volumes, set-up) plus a cost per pixel (per pixel and
//! sample for Monte Carlo), fitted through renders at two sizes on this machine and device.
//! Statistics of the scene (lights, albedo, optical depths; [`stats`]) explain the choice.
//!
//! A fitted statistical model of error from scene statistics would be tuned to the volumes
//! it was fitted on; the pilot measures the scene at hand, for about the cost of a few
//! renders (printed).

pub mod measure;
pub mod stats;

pub use crate::budget::{Budget, Scattering, DEFAULT_PILOT};
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::lights::{LightKind, Lighting};
use crate::progress::Progress;
use crate::registry::{Method, METHODS};
use crate::render::reference::{Estimator, MAX_SPP};
use crate::render::Rendered;
use crate::scene::Scene;
use measure::{
    monte_carlo, pixels, render_method, render_through, resized, CostLaw, Subject, Truth,
};
use serde::Serialize;
use stats::SceneStats;
use std::path::Path;
use std::time::Instant;

/// Volume bounces of the multiple-scattering truth (the chart's and the engine references').
pub const BOUNCES: u32 = 8;
/// Share of the budget a method's pilot error may use: the rest covers what changes from the
/// pilot's size to the full size (edges, thin features a few pixels wide).
const METHOD_MARGIN: f64 = 0.9;
/// The same for Monte Carlo, whose error is predicted from many pixels' variance and carries
/// over closely: its time grows as 1 / margin^2, so the margin is slight.
const MONTE_CARLO_MARGIN: f64 = 0.95;
/// The least error budget for which an `auto` scene's exported grids are half floats: their
/// relative rounding, 2^-11 = 4.9e-4, is then a twentieth of the budget or less.
pub const HALF_FLOAT_BUDGET: f64 = 0.01;
/// Samples of the first pilot truth, from which the noise per sample and the needed samples
/// follow; and the most the pilot's truth takes.
const FIRST_PILOT_SPP: u32 = 64;
const MOST_PILOT_SPP: u32 = 8192;

/// The estimator of the truth of `lighting` under `scattering`.
pub fn truth_estimator(lighting: &Lighting, scattering: Scattering) -> Estimator {
    let ambient = lighting
        .lights
        .iter()
        .any(|l| l.kind() == LightKind::Ambient);
    let direct = lighting
        .lights
        .iter()
        .any(|l| l.kind() != LightKind::Ambient);
    match (scattering, ambient, direct) {
        (Scattering::Multiple, _, _) => Estimator::Multiple { bounces: BOUNCES },
        (Scattering::Single, true, false) => Estimator::Ambient,
        (Scattering::Single, false, true) => Estimator::Single,
        (Scattering::Single, _, _) => Estimator::Multiple { bounces: 0 },
    }
}

/// A configuration the planner can pick.
#[derive(Clone, Debug, PartialEq)]
pub enum Choice {
    /// A registered method at one of its chart settings (`[render]` keys, "" for defaults).
    Method { method: Method, setting: String },
    /// Occlux's Monte Carlo reference at `spp` samples per pixel.
    MonteCarlo { estimator: Estimator, spp: u32 },
}

impl Choice {
    /// Short text for tables: `ipsvi cache_size = 128`, `monte-carlo single 37 spp`.
    pub fn label(&self) -> String {
        match self {
            Choice::Method { method, setting } if setting.is_empty() => method.spec().name.into(),
            Choice::Method { method, setting } => format!("{} {setting}", method.spec().name),
            Choice::MonteCarlo { estimator, spp } => {
                format!("monte-carlo {} {spp} spp", estimator_label(*estimator))
            }
        }
    }

    /// What a scene file or command line says to get it.
    pub fn how(&self) -> String {
        match self {
            Choice::Method { method, setting } => {
                let mut text = format!("[render]\nmethod = \"{}\"\n", method.spec().name);
                for line in setting.split(", ").filter(|l| !l.is_empty()) {
                    text += line;
                    text += "\n";
                }
                text
            }
            Choice::MonteCarlo { estimator, spp } => {
                let bounces = match estimator {
                    Estimator::Multiple { bounces } => format!(" --bounces {bounces}"),
                    _ => String::new(),
                };
                format!(
                    "occlux reference SCENE --estimator {} --spp {spp}{bounces}\n",
                    estimator.name()
                )
            }
        }
    }

    /// Renders the choice through the scene's camera.
    pub fn render(&self, subject: &Subject, progress: &dyn Progress) -> Result<Rendered> {
        let camera = &subject.scene.camera;
        match self {
            Choice::Method { method, .. } => render_through(subject, method, camera, progress),
            Choice::MonteCarlo { estimator, spp } => {
                let (image, _) = monte_carlo(subject, camera, *estimator, *spp, 1)?;
                Ok(Rendered {
                    image: image.to_render(),
                    grids: vec![],
                })
            }
        }
    }
}

/// Every registered method worth weighing for `lighting` (`MethodSpec::weighs`: one of its
/// lights is what the method is for; any, in a scene lit by emission alone) at each of its
/// chart settings (`MethodSpec::chart`): the
/// configurations the planner weighs (beside Monte Carlo), its validation measures and the
/// gallery shows.
pub fn method_candidates(lighting: &Lighting) -> Result<Vec<Choice>> {
    let mut choices = vec![];
    for spec in METHODS {
        if !spec.weighs(lighting) {
            continue;
        }
        for setting in spec.chart {
            choices.push(Choice::Method {
                method: spec.at_setting(setting)?,
                setting: setting.replace('\n', ", "),
            });
        }
    }
    Ok(choices)
}

/// `single`, `multiple (8 bounces)`.
fn estimator_label(estimator: Estimator) -> String {
    match estimator {
        Estimator::Multiple { bounces } => format!("multiple ({bounces} bounces)"),
        other => other.name().to_owned(),
    }
}

/// A settled `auto` scene's plan: what renders it, and the record for the EXR header
/// ([`Plan::record`]: `occlux/plan`, and its `method` as `occlux/method`).
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    pub choice: Choice,
    pub record: serde_json::Value,
}

/// One configuration's prediction at the full size.
#[derive(Clone, Debug, Serialize)]
pub struct Estimate {
    #[serde(skip)]
    pub choice: Choice,
    pub label: String,
    /// Predicted relative RMSE beyond noise against the truth, and the relative bias; None
    /// when not measured: the configuration was slower at a quarter of the pilot's size than
    /// the best within budget at the full size, so it could not win.
    pub error: Option<f64>,
    pub bias: Option<f64>,
    /// Predicted wall time at the scene's image size, volume loaded; for a configuration
    /// over budget or not measured, a lower bound (a pilot render's time).
    pub seconds: f64,
    pub meets: bool,
}

/// The planner's answer.
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    pub budget: Budget,
    /// The truth's estimator, as `occlux reference --estimator` names it.
    pub truth: String,
    pub stats: SceneStats,
    /// Every configuration: those within budget fastest first, then the rest by error, then
    /// those not measured.
    pub estimates: Vec<Estimate>,
    /// The index into `estimates` of the choice.
    pub chosen: usize,
    /// What the pilot cost, and the noise of its truth.
    pub pilot_seconds: f64,
    pub pilot_noise: f64,
}

impl Plan {
    pub fn choice(&self) -> &Choice {
        &self.estimates[self.chosen].choice
    }

    /// What the choice is, for an EXR header: the method as a scene's `[render]` (or the
    /// Monte Carlo estimator and its samples), the budget and the predictions.
    pub fn record(&self) -> serde_json::Value {
        let chosen = &self.estimates[self.chosen];
        let method = match &chosen.choice {
            Choice::Method { method, .. } => method.to_json(),
            Choice::MonteCarlo { estimator, spp } => serde_json::json!({
                "method": "monte-carlo",
                "estimator": estimator.name(),
                "bounces": match estimator {
                    Estimator::Multiple { bounces } => Some(*bounces),
                    _ => None,
                },
                "spp": spp,
            }),
        };
        serde_json::json!({
            "method": method,
            "chosen": chosen.label,
            "budget": crate::json::tree(&self.budget),
            "truth": self.truth,
            "predicted_error": chosen.error,
            "predicted_seconds": chosen.seconds,
        })
    }

    /// What it chose and why, for people.
    pub fn explain(&self) -> String {
        let chosen = &self.estimates[self.chosen];
        let mut text = format!(
            "scene: {}\ntruth: {} scattering (the `{}` estimator); budget: relative RMSE {}\n\
             pilot: {:.2} s at {} px on the longer side (its truth's noise {:.3})\n\n",
            self.stats.describe(),
            self.budget.scattering.name(),
            self.truth,
            self.budget.error,
            self.pilot_seconds,
            self.budget.pilot,
            self.pilot_noise,
        );
        text += &format!(
            "{:<44} {:>10} {:>10} {:>9}\n",
            "configuration", "pred. time", "pred. err", "bias"
        );
        for (i, e) in self.estimates.iter().enumerate() {
            let (mark, at_least) = match (i == self.chosen, e.meets, e.error) {
                (true, _, _) => ("  <- chosen", " "),
                (false, true, _) => ("", " "),
                (false, false, Some(_)) => ("  (over budget)", ">"),
                (false, false, None) => ("  (slower at a quarter size: not measured)", ">"),
            };
            let number = |v: Option<f64>, scale: f64| {
                v.map_or("-".to_owned(), |v| format!("{:.3}", v * scale))
            };
            text += &format!(
                "{:<44} {at_least}{:>7.3} s {:>10} {:>9}{mark}\n",
                e.label,
                e.seconds,
                number(e.error, 1.0),
                e.bias
                    .map_or("-".to_owned(), |b| format!("{:+.1}%", 100.0 * b)),
            );
        }
        let cheaper: Vec<&str> = self
            .estimates
            .iter()
            .filter(|e| !e.meets && e.error.is_some() && e.seconds < chosen.seconds)
            .map(|e| e.label.as_str())
            .collect();
        let within = if chosen.meets {
            "the fastest predicted to stay within"
        } else {
            "nothing is predicted to stay within"
        };
        text += &format!(
            "\nchose {}: {within} {} ({:.3} predicted, in {:.3} s)",
            chosen.label,
            self.budget.error,
            chosen.error.unwrap_or(f64::NAN),
            chosen.seconds
        );
        if !cheaper.is_empty() {
            text += &format!(
                "; too far from the truth though faster at the pilot: {}",
                cheaper.join("; ")
            );
        }
        let mut grids = crate::pipeline::EXPORT_GRIDS.to_vec();
        if let Choice::Method { method, .. } = &chosen.choice {
            grids.extend(method.grids());
        }
        let precision = if self.budget.error >= HALF_FLOAT_BUDGET {
            "half floats where every value fits one (the budget allows their 2^-11 rounding)"
        } else {
            "float32 (the budget is below 0.01)"
        };
        text += &format!(
            "\nan export writes the grids {} as {precision}\n",
            grids.join(", ")
        );
        text
    }
}

/// Plans the render of a loaded scene (its camera settled) within `budget`.
pub fn plan(subject: &Subject, budget: &Budget, progress: &dyn Fn(&str)) -> Result<Plan> {
    budget.validate()?;
    let started = Instant::now();
    let scene = subject.scene;
    let full = pixels(&scene.camera);
    let stats = SceneStats::measure(subject.volume, subject.lut, &scene.camera, &scene.lighting);
    let estimator = truth_estimator(&scene.lighting, budget.scattering);
    let pilot = resized(&scene.camera, budget.pilot);
    let tiny = resized(&scene.camera, (budget.pilot / 4).max(4));
    progress("pilot: the truth");
    let (first, first_seconds) = monte_carlo(subject, &pilot, estimator, FIRST_PILOT_SPP, 1)?;
    let first_truth = Truth::new(subject, pilot, &first)?;
    // Enough samples that the truth's noise is half the budget: errors are taken beyond it
    // (in quadrature), so it only adds scatter to them, averaged over the pilot's pixels.
    let wanted = (2.0 * first_truth.noise_per_sample / budget.error)
        .powi(2)
        .ceil();
    let truth = if wanted > FIRST_PILOT_SPP as f64 {
        let spp = (wanted as u32).min(MOST_PILOT_SPP);
        let (image, _) = monte_carlo(subject, &pilot, estimator, spp, 3)?;
        Truth::new(subject, pilot, &image)?
    } else {
        first_truth
    };
    let (_, tiny_seconds) = monte_carlo(subject, &tiny, estimator, 2, 5)?;
    let law = CostLaw::through(
        (pixels(&tiny) * 2.0, tiny_seconds),
        (pixels(&pilot) * FIRST_PILOT_SPP as f64, first_seconds),
    )?;
    let mut estimates = vec![monte_carlo_estimate(
        estimator,
        truth.noise_per_sample,
        0.0,
        budget.error,
        &law,
        full,
    )];
    if let Estimator::Multiple { bounces } = estimator {
        if bounces > 0 {
            progress("pilot: single scattering");
            let lower = truth_estimator(&scene.lighting, Scattering::Single);
            estimates.push(lower_model(subject, &truth, lower, budget, full, &tiny)?);
        }
    }
    for choice in method_candidates(&scene.lighting)? {
        progress(&format!("pilot: {}", choice.label()));
        let best = estimates
            .iter()
            .filter(|e| e.meets)
            .map(|e| e.seconds)
            .fold(f64::INFINITY, f64::min);
        estimates.push(method_estimate(
            subject, choice, &truth, budget, full, &tiny, best,
        )?);
    }
    let unmeasured = |e: &Estimate| e.error.is_none();
    estimates.sort_by(|a, b| {
        b.meets
            .cmp(&a.meets)
            .then(unmeasured(a).cmp(&unmeasured(b)))
            .then(if a.meets {
                a.seconds.total_cmp(&b.seconds)
            } else {
                a.error.unwrap_or(0.0).total_cmp(&b.error.unwrap_or(0.0))
            })
    });
    // The truth's own estimator meets any budget given samples enough; if even it cannot
    // (more than MAX_SPP), the closest comes first.
    let chosen = 0;
    Ok(Plan {
        budget: *budget,
        truth: estimator.name().to_owned(),
        stats,
        estimates,
        chosen,
        pilot_seconds: started.elapsed().as_secs_f64(),
        pilot_noise: truth.noise,
    })
}

/// Monte Carlo with `estimator`, whose noise per sample and bias against the truth are known:
/// the fewest samples that meet the budget, if any do.
fn monte_carlo_estimate(
    estimator: Estimator,
    noise_per_sample: f64,
    bias_rmse: f64,
    budget: f64,
    law: &CostLaw,
    full: f64,
) -> Estimate {
    let room = (MONTE_CARLO_MARGIN * budget).powi(2) - bias_rmse * bias_rmse;
    let (spp, meets) = if room > 0.0 {
        let spp = (noise_per_sample * noise_per_sample / room).ceil();
        (spp.clamp(2.0, MAX_SPP as f64) as u32, spp <= MAX_SPP as f64)
    } else {
        (2, false)
    };
    let choice = Choice::MonteCarlo { estimator, spp };
    Estimate {
        label: choice.label(),
        choice,
        error: Some(
            (bias_rmse * bias_rmse + noise_per_sample * noise_per_sample / spp as f64).sqrt(),
        ),
        bias: Some(0.0),
        seconds: law.seconds(full * spp as f64),
        meets,
    }
}

/// Single scattering's Monte Carlo under a multiple-scattering truth: its bias from the pilot.
fn lower_model(
    subject: &Subject,
    truth: &Truth,
    lower: Estimator,
    budget: &Budget,
    full: f64,
    tiny: &crate::camera::Camera,
) -> Result<Estimate> {
    // As many samples as the truth, so its noise is as small.
    let spp = truth.spp;
    let (image, seconds) = monte_carlo(subject, &truth.camera, lower, spp, 7)?;
    let own = Truth::new(subject, truth.camera, &image)?;
    let (bias_rmse, bias) = truth.error(&image.mean, own.noise)?;
    let (_, tiny_seconds) = monte_carlo(subject, tiny, lower, 2, 9)?;
    let law = CostLaw::through(
        (pixels(tiny) * 2.0, tiny_seconds),
        (pixels(&truth.camera) * spp as f64, seconds),
    )?;
    let mut estimate = monte_carlo_estimate(
        lower,
        own.noise_per_sample,
        bias_rmse,
        budget.error,
        &law,
        full,
    );
    estimate.bias = Some(bias);
    Ok(estimate)
}

/// A method setting's error from the pilot. Its time: for a setting that meets the budget,
/// a cost law through the fastest of two renders at each of two sizes (the fastest, since
/// other work on the machine only ever adds time); for one that does not, the pilot's time,
/// a lower bound (no need to know more of what cannot be chosen). A setting slower at the
/// small size than `best`, the fastest full-size time within budget so far, cannot win and
/// is not measured further (branch and bound: what makes the pilot cheap where Monte Carlo
/// or a fast method already meets the budget).
fn method_estimate(
    subject: &Subject,
    choice: Choice,
    truth: &Truth,
    budget: &Budget,
    full: f64,
    tiny: &crate::camera::Camera,
    best: f64,
) -> Result<Estimate> {
    let render = |camera| match &choice {
        Choice::Method { method, .. } => render_method(subject, method, camera),
        Choice::MonteCarlo { .. } => Err(Error::param("plan", "a method was expected")),
    };
    if matches!(subject.compute, Compute::Gpu(_)) {
        // Shader compilation and first uploads are not the method's time.
        render(tiny)?;
    }
    let (_, tiny_seconds) = render(tiny)?;
    let mut estimate = Estimate {
        label: choice.label(),
        choice: choice.clone(),
        error: None,
        bias: None,
        seconds: tiny_seconds,
        meets: false,
    };
    if tiny_seconds >= best {
        return Ok(estimate);
    }
    let (image, pilot_seconds) = render(&truth.camera)?;
    let (error, bias) = truth.error(&image.rgba, 0.0)?;
    estimate.error = Some(error);
    estimate.bias = Some(bias);
    estimate.meets = error <= METHOD_MARGIN * budget.error;
    estimate.seconds = if estimate.meets {
        let pilot_seconds = pilot_seconds.min(render(&truth.camera)?.1);
        let tiny_seconds = tiny_seconds.min(render(tiny)?.1);
        CostLaw::through(
            (pixels(tiny), tiny_seconds),
            (pixels(&truth.camera), pilot_seconds),
        )?
        .seconds(full)
    } else {
        pilot_seconds
    };
    Ok(estimate)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::Light;
    use glam::Vec3;

    #[test]
    fn the_truth_models_the_scene_s_lights() {
        let ambient = Light::Ambient {
            radiance: Vec3::ONE,
        };
        let sun = Light::Directional {
            to_light: Vec3::Z,
            irradiance: Vec3::ONE,
        };
        let lit = |lights: Vec<Light>| Lighting {
            lights,
            background: Vec3::ZERO,
        };
        let single = |lights| truth_estimator(&lit(lights), Scattering::Single);
        assert_eq!(single(vec![ambient]), Estimator::Ambient);
        assert_eq!(single(vec![sun]), Estimator::Single);
        assert_eq!(
            single(vec![sun, ambient]),
            Estimator::Multiple { bounces: 0 }
        );
        assert_eq!(
            truth_estimator(&lit(vec![ambient]), Scattering::Multiple),
            Estimator::Multiple { bounces: BOUNCES }
        );
    }

    #[test]
    fn candidates_are_the_methods_that_render_the_lights() {
        let names = |lights: Vec<Light>| -> Vec<&'static str> {
            let lighting = Lighting {
                lights,
                background: Vec3::ZERO,
            };
            let mut names: Vec<_> = method_candidates(&lighting)
                .unwrap()
                .iter()
                .map(|c| match c {
                    Choice::Method { method, .. } => method.spec().name,
                    Choice::MonteCarlo { .. } => "monte-carlo",
                })
                .collect();
            names.dedup();
            names
        };
        let sun = Light::Directional {
            to_light: Vec3::Z,
            irradiance: Vec3::ONE,
        };
        let sun_methods = names(vec![sun]);
        assert!(sun_methods.contains(&"ipsvi") && !sun_methods.contains(&"dos"));
        // Emission alone: every method renders it.
        assert_eq!(names(vec![]).len(), METHODS.len());
    }

    #[test]
    fn monte_carlo_takes_the_fewest_samples_that_meet_the_budget() {
        let law = CostLaw {
            fixed: 0.1,
            per_unit: 1e-6,
        };
        let e = monte_carlo_estimate(Estimator::Single, 1.0, 0.0, 0.1, &law, 1e4);
        let Choice::MonteCarlo { spp, .. } = e.choice else {
            panic!("{e:?}")
        };
        // (1 / (0.95 * 0.1))^2 = 110.8
        assert_eq!(spp, 111);
        assert!(
            e.meets && e.error.unwrap() <= 0.095 && (e.seconds - (0.1 + 1e-2 * 111.0)).abs() < 1e-9
        );
        // A bias beyond the budget cannot be averaged away.
        let biased = monte_carlo_estimate(Estimator::Single, 1.0, 0.2, 0.1, &law, 1e4);
        assert!(!biased.meets);
    }
}
