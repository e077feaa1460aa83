//! The planner (`occlux plan`, `method = "auto"`) validated against exhaustive search on small
//! scenes it was not tuned on: phantoms under a sun, ambient light, and a lamp with ambient
//! light (`occlux plan-check`). tests/plan.rs renders a plan end to end.
//!
//! Run: `cargo test --release -p occlux-lab --test plan_check -- --nocapture` (prints the
//! validation table).

use occlux::gpu::{Compute, DeviceChoice};
use occlux::plan::Scattering;
use occlux_lab::plan_check::{self, PlanCheckArgs};
use std::path::{Path, PathBuf};

const CAMERA: &str = "[camera]\nposition = [2.4, -2.6, 1.4]\ntarget = [0, 0, 0]\nfov_deg = 40\n\
                      width = 40\nheight = 40\n";

/// Three small scenes, each lit another way: a CT phantom under a sun, a cloud under ambient
/// light, nested shells under a lamp and ambient light (a mix no fast method renders whole).
fn scenes(dir: &Path) -> Vec<PathBuf> {
    let files = [
        (
            "ct-sun",
            "[volume]\nphantom = \"ct\"\nsize = 32\nfit = 2.0\n\
             [classification]\npreset = \"ct-soft-tissue\"\ndensity_scale = 0.35\n\
             [[lights]]\ntype = \"directional\"\ndirection = [-0.3, -1.0, 1.2]\nirradiance = 3\n",
        ),
        (
            "cloud-ambient",
            "[volume]\nphantom = \"cloud\"\nsize = 32\nfit = 2.0\n\
             [classification]\npreset = \"simulation\"\n\
             [[lights]]\ntype = \"ambient\"\nradiance = 1\n",
        ),
        (
            "shells-lamp",
            "[volume]\nphantom = \"shells\"\nsize = 32\nfit = 2.0\n\
             [classification]\npreset = \"simulation\"\ndensity_scale = 0.5\n\
             [[lights]]\ntype = \"point\"\nposition = [1.5, -2.0, 2.0]\nintensity = 8\n\
             [[lights]]\ntype = \"ambient\"\nradiance = 0.3\n",
        ),
    ];
    files
        .iter()
        .map(|(name, text)| {
            let path = dir.join(format!("{name}.toml"));
            std::fs::write(&path, format!("{text}{CAMERA}")).unwrap();
            path
        })
        .collect()
}

#[test]
fn the_plans_meet_their_budgets_against_exhaustive_search() {
    let dir = tempfile::tempdir().unwrap();
    let args = PlanCheckArgs {
        scenes: scenes(dir.path()),
        errors: vec![0.1, 0.15, 0.25, 0.4],
        size: 40,
        pilot: 20,
        spp: 2048,
        scattering: Scattering::Single,
        repeats: 1,
        device: DeviceChoice::Cpu,
        json: dir.path().join("check.json"),
    };
    let report = plan_check::check(&args, &Compute::Cpu, &|_| {}).unwrap();
    println!("{}", plan_check::table(&report.cases));
    let n = report.cases.len();
    assert_eq!(n, 12);
    for case in &report.cases {
        assert!(
            case.actual_error.is_finite() && case.predicted_error.is_finite(),
            "{case:?}"
        );
    }
    // The goal: within budget in at least 90 % of cases. (The time goal, within 1.5x
    // of the fastest, is measured by `occlux plan-check`, a benchmark: times are noisy here.)
    assert!(
        report.met * 10 >= n * 9,
        "within budget in {} of {n} cases",
        report.met
    );
}
