//! `occlux bench-sweep`: times occlusion sweeping's geometric mode at the paper's sizes (its
//! Table 2: 101 x 101 x 61 up to 250^3) on the box-and-sphere phantom, on the CPU, medians
//! after a warm-up: the signed distance alone, the signed distance with the combined scalar
//! occlusion, and with the eight octants weighted by the geometry terms. Prints a table with
//! the occlusion's cost over the signed distance's and writes JSON.

use super::bench::{timed, Timing};
use occlux::ao::sweep::geometric::{occlusion, GeometricParams};
use occlux::ao::sweep::sdf::{cpu::signed_distance, SdfParams};
use occlux::error::{Error, Result};
use occlux::gpu::Compute;
use occlux::progress::NoProgress;
use occlux::volume::phantom::box_and_sphere;
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SweepBenchArgs {
    /// Grid sizes, NXxNYxNZ, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "101x101x61,128x128x128,250x250x250"
    )]
    pub sizes: Vec<String>,
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    #[arg(short, long, default_value = "occlux-bench-sweep.json")]
    pub out: PathBuf,
}

#[derive(Serialize, Debug)]
struct Row {
    dims: [usize; 3],
    sdf: Timing,
    sdf_and_combined: Timing,
    sdf_and_octants: Timing,
    /// Medians over the signed distance's: the occlusion's cost (the paper's goal: <= 1.3).
    combined_over_sdf: f64,
    octants_over_sdf: f64,
    sdf_rounds: u32,
}

#[derive(Serialize)]
struct Report<'a> {
    phantom: &'static str,
    cpu_threads: usize,
    repeats: usize,
    rows: &'a [Row],
}

fn parse_dims(text: &str) -> Result<[usize; 3]> {
    let parts: Vec<usize> = text
        .split('x')
        .map(|p| p.trim().parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| Error::param("--sizes", format!("'{text}' is not NXxNYxNZ")))?;
    <[usize; 3]>::try_from(parts)
        .map_err(|_| Error::param("--sizes", format!("'{text}' is not NXxNYxNZ")))
}

pub fn run(args: &SweepBenchArgs, quiet: bool) -> Result<()> {
    if args.repeats == 0 || args.sizes.is_empty() {
        return Err(Error::param(
            "--repeats/--sizes",
            "need at least one repeat and one size",
        ));
    }
    let sizes = args
        .sizes
        .iter()
        .map(|s| parse_dims(s))
        .collect::<Result<Vec<_>>>()?;
    let surface = SdfParams::default();
    let mut rows = vec![];
    for dims in sizes {
        let volume = box_and_sphere(dims)?;
        let sdf_timing = timed(args.repeats, || {
            signed_distance(&volume, &surface, &NoProgress)
        })?;
        let rounds = signed_distance(&volume, &surface, &NoProgress)?.iterations;
        let with = |normal_weighted| {
            let params = GeometricParams {
                normal_weighted,
                ..Default::default()
            };
            timed(args.repeats, || {
                occlusion(
                    &Compute::Cpu,
                    &volume,
                    &surface,
                    &params,
                    false,
                    &NoProgress,
                )
            })
        };
        let (combined, octants) = (with(false)?, with(true)?);
        let row = Row {
            dims,
            sdf: sdf_timing,
            sdf_and_combined: combined,
            sdf_and_octants: octants,
            combined_over_sdf: combined.median_ms / sdf_timing.median_ms,
            octants_over_sdf: octants.median_ms / sdf_timing.median_ms,
            sdf_rounds: rounds,
        };
        if !quiet {
            println!(
                "{:>4} x {:>4} x {:>4}: sdf {:.1} ms ({} rounds), + combined {:.1} ms (x{:.2}), \
                 + octants {:.1} ms (x{:.2})",
                dims[0],
                dims[1],
                dims[2],
                row.sdf.median_ms,
                row.sdf_rounds,
                row.sdf_and_combined.median_ms,
                row.combined_over_sdf,
                row.sdf_and_octants.median_ms,
                row.octants_over_sdf
            );
        }
        rows.push(row);
    }
    let report = Report {
        phantom: "box-sphere",
        cpu_threads: rayon::current_num_threads(),
        repeats: args.repeats,
        rows: &rows,
    };
    super::write_report(&args.out, &report, quiet)
}
