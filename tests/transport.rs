//! The discrete-ordinates visibility (src/transport/) against closed forms (a homogeneous ball
//! and slab), against the Monte Carlo sphere reference on a phantom and a real CT beside the
//! occlusion sweep's lattice walk, and its refusals of bad input.

#[path = "common/visibility.rs"]
mod visibility_common;
use visibility_common::{against_reference, ball, scene_for};

use glam::Vec3;
use occlux::ao::sweep;
use occlux::error::Error;
use occlux::gpu::Compute;
use occlux::progress::{NoProgress, Progress};
use occlux::transport::{self, DEFAULT_DIRECTIONS};
use occlux::volume::Volume;
use std::sync::atomic::{AtomicU64, Ordering};

fn visibility(extinction: &Volume, directions: u32) -> Volume {
    transport::visibility(&Compute::Cpu, extinction, directions, &NoProgress).unwrap()
}

#[test]
fn the_centre_of_a_uniform_ball_sees_exp_of_minus_sigma_r() {
    // Every direction from the centre crosses exactly r of matter: V = exp(-sigma r), along
    // straight paths with no lattice bias (the lattice walk crosses 15-22 % more optical depth:
    // tests/sweep.rs). The voxelised edge moves r by up to half a voxel (1/64 of the side).
    for (sigma, r) in [(1.0f32, 0.8f32), (3.0, 0.6), (0.3, 0.9), (8.0, 0.8)] {
        let n = 64;
        let v = visibility(&ball(n, r, sigma), DEFAULT_DIRECTIONS);
        let centre = 0.25
            * (v.at(n / 2, n / 2, n / 2)
                + v.at(n / 2 - 1, n / 2, n / 2)
                + v.at(n / 2, n / 2 - 1, n / 2)
                + v.at(n / 2, n / 2, n / 2 - 1));
        let want = (-sigma * r).exp();
        let ratio = (centre.ln() / want.ln()) as f64;
        println!("sigma {sigma} r {r}: {centre} vs {want} (optical depth ratio {ratio:.4})");
        let edge = 1.0 / (n as f64 * r as f64);
        assert!(
            (ratio - 1.0).abs() < edge,
            "sigma {sigma} r {r}: {centre} vs {want} (ratio {ratio})"
        );
    }
}

/// E_2(x) = int_0^1 exp(-x / mu) dmu, by the midpoint rule.
fn e2(x: f64) -> f64 {
    let n = 20_000;
    (0..n)
        .map(|i| (-x / ((i as f64 + 0.5) / n as f64)).exp())
        .sum::<f64>()
        / n as f64
}

#[test]
fn a_homogeneous_slab_matches_its_closed_form_and_its_error_falls_with_the_voxel_size() {
    // A slab of thickness 6 (matter to half a voxel past the outer centres, as the trapezoid
    // rule with no matter outside reads it), wide enough in x and y that grazing paths leaving
    // through the sides have crossed an optical depth of 8 or more: at depth d_up below the
    // top and d_down above the bottom, V = (E_2(sigma d_up) + E_2(sigma d_down)) / 2.
    // Laterally uniform, so the directions stepping across z are exact; those stepping across
    // x or y (grazing) interpolate T across the slab's depth (numerical diffusion: too bright
    // inside, too dark in the voxel layer at the faces), and that error falls with the voxel
    // size, while more directions do not change it. Measured: worst 0.010 at 1 voxel per unit
    // (inside 0.0055), 0.0040 inside at 2.
    let sigma = 0.5f32;
    let mut worst_by_resolution = vec![];
    for (n, h, directions) in [(6usize, 1.0f32, 64), (6, 1.0, 256), (12, 0.5, 256)] {
        let side = (64.0 / h) as usize;
        let slab = Volume::new(
            [side, side, n],
            Vec3::splat(h),
            Vec3::ZERO,
            vec![sigma; side * side * n],
        )
        .unwrap();
        let v = visibility(&slab, directions);
        let (mut worst, mut interior) = (0.0f64, 0.0f64);
        for m in 0..n {
            let s = (sigma * h) as f64;
            let up = (n - 1 - m) as f64 + 0.5;
            let down = m as f64 + 0.5;
            let want = 0.5 * (e2(s * up) + e2(s * down));
            let got = v.at(side / 2, side / 2, m) as f64;
            worst = worst.max((got - want).abs());
            // The voxels at least a world unit inside, where both grids sample the same depths.
            if up.min(down) * h as f64 >= 1.0 {
                interior = interior.max((got - want).abs());
            }
        }
        println!(
            "{n} voxels of {h}, {directions} directions: worst {worst:.5}, {interior:.5} inside"
        );
        assert!(worst < 0.02, "{worst}");
        worst_by_resolution.push(interior);
    }
    let [coarse, more_directions, fine] = worst_by_resolution[..] else {
        unreachable!()
    };
    assert!(coarse < 0.008, "{coarse}");
    assert!(
        (more_directions - coarse).abs() < 0.2 * coarse,
        "{more_directions} vs {coarse}"
    );
    assert!(fine < 0.75 * more_directions, "{fine} vs {more_directions}");
}

#[test]
fn visibility_matches_the_sphere_reference_better_than_the_lattice_walk() {
    let ct = scene_for(
        "[volume]\nphantom = \"ct\"\nsize = 48\n[classification]\npreset = \"ct-bone\"\ndensity_scale = 0.05",
    );
    let engine = scene_for(
        "[volume]\npath = \"../../shared/data/scivis/engine.nrrd\"\nfit = 2.0\ncentre = [0, 0, 0]\n\
         [classification]\nunits = \"raw\"\npoints = [{ value = 60, sigma_t = 0 }, { value = 120, sigma_t = 20 }]",
    );
    for (name, scene) in [("ct phantom", ct), ("engine", engine)] {
        let volume = scene.load_volume().unwrap();
        let ordinates =
            against_reference(&volume, &scene, 300, |e| visibility(e, DEFAULT_DIRECTIONS));
        let lattice = against_reference(&volume, &scene, 300, |e| {
            sweep::physical::cpu::visibility(e, &NoProgress).unwrap()
        });
        println!(
            "{name}: ordinates RMSE {:.4} mean difference {:+.4}; lattice walk RMSE {:.4} \
             mean difference {:+.4}; reference noise {:.4}",
            ordinates.0, ordinates.1, lattice.0, lattice.1, ordinates.2
        );
        assert!(ordinates.0 < 0.03, "{name}: RMSE {}", ordinates.0);
        assert!(ordinates.1.abs() < 0.01, "{name}: bias {}", ordinates.1);
        assert!(
            ordinates.0 < lattice.0,
            "{name}: {ordinates:?} vs {lattice:?}"
        );
    }
}

#[test]
fn bad_input_is_refused_by_name() {
    let mut values = vec![0.5f32; 64];
    let fine = Volume::new([4; 3], Vec3::ONE, Vec3::ZERO, values.clone()).unwrap();
    for directions in [0, 7, 5000] {
        let e = transport::visibility(&Compute::Cpu, &fine, directions, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(e.contains("directions"), "{e}");
    }
    // (A volume never holds NaN or infinity: Volume::new refuses them.)
    values[5] = -1.0;
    let negative = Volume::new([4; 3], Vec3::ONE, Vec3::ZERO, values).unwrap();
    let e = transport::visibility(&Compute::Cpu, &negative, 64, &NoProgress)
        .unwrap_err()
        .to_string();
    assert!(e.contains("voxel 5") && e.contains("-1"), "{e}");
}

/// Counts updates and cancels after `cancel_after` of them.
struct Counting {
    updates: AtomicU64,
    last: AtomicU64,
    cancel_after: u64,
}

impl Progress for Counting {
    fn update(&self, done: u64, total: u64) {
        self.updates.fetch_add(1, Ordering::Relaxed);
        self.last.store(done, Ordering::Relaxed);
        assert!(done <= total);
    }
    fn cancelled(&self) -> bool {
        self.updates.load(Ordering::Relaxed) >= self.cancel_after
    }
}

#[test]
fn progress_counts_planes_and_cancelling_stops() {
    let volume = ball(12, 0.5, 1.0);
    let all = Counting {
        updates: AtomicU64::new(0),
        last: AtomicU64::new(0),
        cancel_after: u64::MAX,
    };
    transport::visibility(&Compute::Cpu, &volume, 32, &all).unwrap();
    // Each of the six sweep orders visits the 12 planes across its axis.
    assert_eq!(all.last.load(Ordering::Relaxed), 6 * 12);
    let stop = Counting {
        updates: AtomicU64::new(0),
        last: AtomicU64::new(0),
        cancel_after: 5,
    };
    assert!(matches!(
        transport::visibility(&Compute::Cpu, &volume, 32, &stop),
        Err(Error::Cancelled)
    ));
}
