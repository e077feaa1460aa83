//! Accuracy of the fast VAO estimates (`occlux ao-accuracy`): the CDF reconstruction, the
//! Gaussian CDF (Winitzki's and the exact erf) and Penner's Chebyshev bound, each against the
//! exact voxel count over the ball and against the Monte Carlo tangent-sphere reference
//! (`ao::reference`, continuous trilinear extinction), with the exact count against Monte Carlo
//! too. Measured at a seeded sample of voxels that hold matter and whose box is not constant:
//! elsewhere every estimate is exactly 1/2 or shades nothing.

use occlux::ao::reference::{ao_reference_at, AoReferenceParams, AoVariant};
use occlux::ao::vao::estimate::openness;
use occlux::ao::vao::stats::{local_stats, LocalStats};
use occlux::ao::vao::{exact, Estimator, FieldKind, ScalarField};
use occlux::classify::Classification;
use occlux::error::{Error, Result};
use occlux::progress::NoProgress;
use occlux::scene::Scene;
use occlux::volume::Volume;
use rand::Rng;
use rand_pcg::Pcg32;
use serde::Serialize;
use std::borrow::Cow;
use std::path::PathBuf;

/// How one estimate agrees with one reference over the sampled voxels.
#[derive(Clone, Debug, Serialize)]
pub struct Agreement {
    pub estimate: &'static str,
    pub reference: &'static str,
    /// Pearson correlation.
    pub correlation: f64,
    pub rmse: f64,
    /// Mean of estimate - reference: negative is too dark.
    pub bias: f64,
}

/// The measurements of one volume at one radius.
#[derive(Clone, Debug, Serialize)]
pub struct AccuracyRow {
    pub dataset: String,
    pub field: &'static str,
    pub radius: u32,
    pub points: usize,
    pub mean_exact: f64,
    /// None where Monte Carlo is not measured (the raw-value field).
    pub mean_monte_carlo: Option<f64>,
    /// Root mean square of the Monte Carlo standard errors.
    pub monte_carlo_stderr: Option<f64>,
    pub agreements: Vec<Agreement>,
}

impl AccuracyRow {
    pub fn agreement(&self, estimate: &str, reference: &str) -> Option<&Agreement> {
        self.agreements
            .iter()
            .find(|a| a.estimate == estimate && a.reference == reference)
    }
}

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct AccuracyParams {
    /// The field the estimates run on; Monte Carlo (on extinction) is measured for
    /// `Extinction` only.
    pub field: FieldKind,
    pub radius: u32,
    /// Voxels sampled.
    pub points: usize,
    /// Monte Carlo samples per voxel.
    pub samples: u32,
    pub seed: u64,
}

/// The fast estimates measured.
const FAST: [Estimator; 4] = [
    Estimator::Cdf,
    Estimator::Gauss,
    Estimator::GaussExactErf,
    Estimator::Penner,
];

/// Measures the estimates on `volume` classified by `classification` (extinction field).
pub fn measure(
    dataset: &str,
    volume: &Volume,
    classification: &Classification,
    params: &AccuracyParams,
) -> Result<AccuracyRow> {
    let field = ScalarField::new(Cow::Borrowed(volume), classification, params.field)?;
    // Matter is positive extinction, whatever field the estimates run on.
    let value_field_extinction;
    let matter = match params.field {
        FieldKind::Extinction => field.values.values(),
        FieldKind::Value => {
            value_field_extinction = classification.extinction(volume)?;
            value_field_extinction.values()
        }
    };
    // One set of statistics serves the sampling and every estimate, as `ao_volume` computes
    // them (the same map onto [0, 1]), so the figures are those of the AO volumes.
    let map = field.unit_map();
    let stats = local_stats(&field, map, params.radius as usize, &NoProgress)?;
    let voxels = sample_voxels(&field, matter, &stats, params)?;
    let exact = exact::exact_at(&field, params.radius, &voxels);
    let (mc, mc_err): (Vec<f32>, Vec<f32>) = if params.field == FieldKind::Extinction {
        let lut = classification.bake(volume);
        let reference = ao_reference_at(
            volume,
            &lut,
            &AoReferenceParams {
                variant: AoVariant::TangentSphere,
                samples: params.samples,
                seed: params.seed,
                radius: Some(params.radius as f32 * volume.spacing().min_element()),
            },
            &voxels,
        )?;
        reference.into_iter().unzip()
    } else {
        (vec![], vec![])
    };
    let mut agreements = vec![];
    if !mc.is_empty() {
        agreements.push(agreement("exact", "monte-carlo", &exact, &mc));
    }
    let [nx, ny, _] = field.values.dims();
    let stats = stats.view();
    for estimator in FAST {
        let at: Vec<f32> = voxels
            .iter()
            .map(|&[i, j, k]| {
                let n = i + nx * (j + ny * k);
                openness(estimator, map.apply(field.values.at(i, j, k)), &stats.at(n))
            })
            .collect();
        agreements.push(agreement(estimator.name(), "exact", &at, &exact));
        if !mc.is_empty() {
            agreements.push(agreement(estimator.name(), "monte-carlo", &at, &mc));
        }
    }
    Ok(AccuracyRow {
        dataset: dataset.to_owned(),
        field: match params.field {
            FieldKind::Extinction => "extinction",
            FieldKind::Value => "value",
        },
        radius: params.radius,
        points: voxels.len(),
        mean_exact: mean(&exact),
        mean_monte_carlo: (!mc.is_empty()).then(|| mean(&mc)),
        monte_carlo_stderr: (!mc.is_empty()).then(|| {
            (mc_err.iter().map(|e| (*e as f64).powi(2)).sum::<f64>() / mc_err.len() as f64).sqrt()
        }),
        agreements,
    })
}

/// Up to `params.points` voxels, uniformly without replacement (seeded), among those with
/// matter (positive extinction, whatever the field) and a box of the field that is not
/// constant.
fn sample_voxels(
    field: &ScalarField,
    matter: &[f32],
    stats: &LocalStats,
    params: &AccuracyParams,
) -> Result<Vec<[usize; 3]>> {
    let mut candidates: Vec<usize> = (0..matter.len())
        .filter(|&i| matter[i] > 0.0 && stats.max[i] > stats.min[i])
        .collect();
    if candidates.is_empty() {
        return Err(Error::param(
            "classification",
            "no voxel holds matter: nothing to measure",
        ));
    }
    let mut rng = Pcg32::new(params.seed, 0x5851_f42d_4c95_7f2d);
    let count = params.points.min(candidates.len());
    // Partial Fisher-Yates: the first `count` entries become the sample.
    for n in 0..count {
        let m = rng.random_range(n..candidates.len());
        candidates.swap(n, m);
    }
    let [nx, ny, _] = field.values.dims();
    Ok(candidates[..count]
        .iter()
        .map(|&i| [i % nx, (i / nx) % ny, i / (nx * ny)])
        .collect())
}

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64
}

fn agreement(estimate: &'static str, reference: &'static str, a: &[f32], b: &[f32]) -> Agreement {
    let (ma, mb) = (mean(a), mean(b));
    let (mut cov, mut va, mut vb, mut sq) = (0.0, 0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (dx, dy) = (x as f64 - ma, y as f64 - mb);
        cov += dx * dy;
        va += dx * dx;
        vb += dy * dy;
        sq += (x as f64 - y as f64).powi(2);
    }
    let correlation = if va > 0.0 && vb > 0.0 {
        cov / (va * vb).sqrt()
    } else {
        0.0
    };
    Agreement {
        estimate,
        reference,
        correlation,
        rmse: (sq / a.len().max(1) as f64).sqrt(),
        bias: ma - mb,
    }
}

#[derive(clap::Args, Debug)]
pub struct AccuracyArgs {
    /// Scene files whose volume and classification are measured.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "examples/engine.toml,examples/bonsai.toml,examples/hydrogen_atom.toml"
    )]
    pub scenes: Vec<PathBuf>,
    #[arg(long, value_delimiter = ',', default_value = "5,10,16")]
    pub radii: Vec<u32>,
    /// Voxels sampled per volume and radius.
    #[arg(long, default_value_t = 2000)]
    pub points: usize,
    /// Monte Carlo samples per voxel.
    #[arg(long, default_value_t = 1024)]
    pub samples: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Fields to measure on: extinction (with Monte Carlo) and/or value.
    #[arg(long, value_delimiter = ',', default_value = "extinction,value")]
    pub fields: Vec<String>,
    #[arg(short, long, default_value = "occlux-ao-accuracy.json")]
    pub out: PathBuf,
}

/// Runs the measurements, prints a Markdown table unless `quiet`, writes the JSON.
pub fn run(args: &AccuracyArgs, quiet: bool) -> Result<()> {
    if args.points == 0 || args.radii.is_empty() || args.scenes.is_empty() {
        return Err(Error::param(
            "--points/--radii/--scenes",
            "need at least one point, radius and scene",
        ));
    }
    let fields: Vec<FieldKind> = args
        .fields
        .iter()
        .map(|f| f.parse())
        .collect::<Result<_>>()?;
    let mut rows = vec![];
    if !quiet {
        println!("| dataset | field | R | estimate | corr. vs exact | RMSE vs exact | bias vs exact | corr. vs MC | RMSE vs MC | bias vs MC |");
        println!("|---|---|---|---|---|---|---|---|---|---|");
    }
    for path in &args.scenes {
        let scene = Scene::from_file(path)?;
        let occlux::scene::Loaded { scene, volume, .. } = scene.load()?;
        let name = path.file_stem().map_or_else(
            || path.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        for field in &fields {
            for &radius in &args.radii {
                let row = measure(
                    &name,
                    &volume,
                    &scene.classification,
                    &AccuracyParams {
                        field: *field,
                        radius,
                        points: args.points,
                        samples: args.samples,
                        seed: args.seed,
                    },
                )?;
                if !quiet {
                    print_row(&row);
                }
                rows.push(row);
            }
        }
    }
    super::write_report(&args.out, &rows, quiet)
}

fn print_row(row: &AccuracyRow) {
    let cells = |a: Option<&Agreement>| {
        a.map_or_else(
            || "| - | - | -".to_owned(),
            |a| format!("| {:.3} | {:.3} | {:+.3}", a.correlation, a.rmse, a.bias),
        )
    };
    for estimate in FAST.iter().map(|e| e.name()).chain(["exact"]) {
        let (e, m) = (
            row.agreement(estimate, "exact"),
            row.agreement(estimate, "monte-carlo"),
        );
        if e.is_none() && m.is_none() {
            continue;
        }
        println!(
            "| {} | {} | {} | {} {} {} |",
            row.dataset,
            row.field,
            row.radius,
            estimate,
            cells(e),
            cells(m),
        );
    }
}
