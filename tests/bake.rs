//! Baked light (src/bake.rs) against closed forms: a sun through a homogeneous slab, a lamp in
//! empty space, the multiply scattered light per unit strength and per channel, and the grids
//! read back from the VDB `occlux bake` writes.

use glam::Vec3;
use occlux::bake::{bake, light_grid, multiple_grids, BakeParams, AO};
use occlux::classify::{
    Classification, ControlPoint, TransferFunction, TransferFunction1D, ValueUnits,
};
use occlux::export::vdb::VdbOptions;
use occlux::gpu::Compute;
use occlux::lights::{Light, Lighting};
use occlux::pipeline::write_bake;
use occlux::progress::NoProgress;
use occlux::volume::Volume;

mod common;
use common::vdb::read_with_vdb_rs;

/// Extinction `sigma` per world unit everywhere the value is 1, albedo `albedo`.
fn constant(sigma: f32, albedo: [f32; 3]) -> Classification {
    let tf = TransferFunction1D::new(vec![
        ControlPoint::new(0.0, sigma, albedo, [0.0; 3]),
        ControlPoint::new(2.0, sigma, albedo, [0.0; 3]),
    ])
    .unwrap();
    Classification::new(TransferFunction::OneD(tf), ValueUnits::Raw, 1.0).unwrap()
}

fn ones(dims: [usize; 3], h: f32) -> Volume {
    let len = dims.iter().product();
    Volume::new(dims, Vec3::splat(h), Vec3::ZERO, vec![1.0; len]).unwrap()
}

fn lighting(lights: Vec<Light>) -> Lighting {
    Lighting {
        lights,
        background: Vec3::ZERO,
    }
}

const NO_MULTIPLE: BakeParams = BakeParams {
    directions: 16,
    multiple: false,
    g: 0.0,
};

/// A sun straight above a slab: light{i} per unit irradiance is Beer-Lambert from the box's
/// top face, exp(-sigma h (k + 1/2)) at the k-th cell below it (the sweep is exact along an
/// axis), whatever the sun's strength; an ambient light before it takes no grid.
#[test]
fn a_sun_reaches_a_slab_as_beer_lambert_per_unit_irradiance() {
    let (sigma, h, depth) = (1.5, 0.1, 12);
    let volume = ones([4, 5, depth], h);
    let lights = lighting(vec![
        Light::Ambient {
            radiance: Vec3::ONE,
        },
        Light::Directional {
            to_light: Vec3::Z,
            irradiance: Vec3::new(5.0, 3.0, 1.0),
        },
    ]);
    let baked = bake(
        &Compute::Cpu,
        &volume,
        &constant(sigma, [0.8; 3]),
        &lights,
        &NO_MULTIPLE,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(baked.lights.len(), 1);
    assert_eq!(baked.lights[0].scene_index, 1);
    assert!(baked.lights[0].multiple.is_none());
    let names: Vec<String> = baked.grids().into_iter().map(|(n, _)| n).collect();
    assert_eq!(names, [AO.to_owned(), light_grid(0)]);
    let reaching = &baked.lights[0].reaching;
    for z in 0..depth {
        let below = (depth - 1 - z) as f32;
        let want = (-sigma * h * (below + 0.5)).exp();
        let got = reaching.at(2, 2, z);
        assert!((got - want).abs() < 2e-6, "z {z}: {got} against {want}");
    }
}

/// A lamp outside empty matter: light{i} per unit intensity is 1 / r^2 at every voxel.
#[test]
fn a_lamp_in_empty_space_reaches_as_the_inverse_square() {
    let volume = ones([6, 4, 5], 0.25);
    let lamp = Vec3::new(-1.0, 0.4, 2.0);
    let lights = lighting(vec![Light::Point {
        position: lamp,
        intensity: Vec3::splat(40.0),
    }]);
    let baked = bake(
        &Compute::Cpu,
        &volume,
        &constant(0.0, [0.8; 3]),
        &lights,
        &NO_MULTIPLE,
        &NoProgress,
    )
    .unwrap();
    let reaching = &baked.lights[0].reaching;
    for (cell, got) in reaching.values().iter().enumerate() {
        let want = 1.0 / (lamp - volume.centre(cell)).length_squared();
        assert!(
            (got - want).abs() < 1e-5 * want,
            "{cell}: {got} against {want}"
        );
    }
    // No matter, no occlusion.
    assert!(baked.ao.values().iter().all(|&v| (v - 1.0).abs() < 1e-6));
}

/// The multiply scattered light is per unit strength (a sun three times as bright bakes the
/// same grids), grows with each channel's albedo, and is on the solver's grid within the box.
#[test]
fn multiple_scattering_is_per_unit_strength_and_per_channel() {
    let volume = ones([10, 10, 10], 0.1);
    let classification = constant(4.0, [0.3, 0.6, 0.9]);
    let params = BakeParams {
        directions: 16,
        multiple: true,
        g: 0.0,
    };
    let sun = |e: f32| {
        lighting(vec![Light::Directional {
            to_light: Vec3::new(0.2, 0.3, 0.9).normalize(),
            irradiance: Vec3::splat(e),
        }])
    };
    let run = |e| {
        bake(
            &Compute::Cpu,
            &volume,
            &classification,
            &sun(e),
            &params,
            &NoProgress,
        )
    };
    let (one, three) = (run(1.0).unwrap(), run(3.0).unwrap());
    let [r, g, b] = one.lights[0].multiple.as_ref().unwrap();
    let thrice = three.lights[0].multiple.as_ref().unwrap();
    assert_eq!(r.values(), thrice[0].values());
    assert_eq!(b.values(), thrice[2].values());
    assert_eq!(r.dims(), volume.dims());
    for cell in 0..r.values().len() {
        let (x, y, z) = (r.values()[cell], g.values()[cell], b.values()[cell]);
        assert!(
            x > 0.0 && x < y && y < b.values()[cell],
            "{cell}: {x} {y} {z}"
        );
    }
    // Light scattered twice at albedo 0.9 is more than three times (0.9 / 0.3 squared, less
    // what escapes) that at 0.3.
    let mean = |v: &Volume| v.values().iter().sum::<f32>() / v.values().len() as f32;
    assert!(mean(b) > 3.0 * mean(r), "{} {}", mean(b), mean(r));
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let volume = ones([4, 4, 4], 0.1);
    let lights = lighting(vec![Light::Directional {
        to_light: Vec3::Z,
        irradiance: Vec3::ONE,
    }]);
    let classification = constant(1.0, [0.8; 3]);
    let run = |params: BakeParams| {
        bake(
            &Compute::Cpu,
            &volume,
            &classification,
            &lights,
            &params,
            &NoProgress,
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    let e = run(BakeParams {
        g: 1.0,
        ..BakeParams::default()
    });
    assert!(e.contains('g'), "{e}");
    let e = run(BakeParams {
        directions: 0,
        ..BakeParams::default()
    });
    assert!(e.contains("directions"), "{e}");
}

/// What `occlux bake` writes reads back, through vdb-rs, as the grids the bake computed, each
/// on its own grid (the multiply scattered light on the solver's cells): voxel (i, j, k) of a
/// grid at the index (i, j, k), its map the grid's spacing and origin.
#[test]
fn the_bake_vdb_reads_back_grid_for_grid() {
    let volume = ones([7, 6, 5], 0.2);
    let classification = constant(2.0, [0.7, 0.8, 0.9]);
    let lights = lighting(vec![
        Light::Directional {
            to_light: Vec3::new(1.0, 1.0, 1.0).normalize(),
            irradiance: Vec3::ONE,
        },
        Light::Point {
            position: Vec3::new(0.6, 0.5, 0.4),
            intensity: Vec3::ONE,
        },
    ]);
    let params = BakeParams {
        directions: 16,
        multiple: true,
        g: 0.4,
    };
    let baked = bake(
        &Compute::Cpu,
        &volume,
        &classification,
        &lights,
        &params,
        &NoProgress,
    )
    .unwrap();
    let out = tempfile::tempdir().unwrap();
    let record = serde_json::json!({"test": true});
    let written = write_bake(
        &baked,
        &volume,
        &record,
        out.path(),
        "s",
        &VdbOptions::default(),
    )
    .unwrap();
    let vdb = out.path().join("s-bake.vdb");
    assert!(written.contains(&vdb));
    let mut names = vec![AO.to_owned(), light_grid(0), light_grid(1)];
    names.extend(multiple_grids(1));
    for (name, grid) in baked.grids() {
        let (voxels, scale, translation) = read_with_vdb_rs(&vdb, &name);
        let close = |a: [f64; 3], b: Vec3| (Vec3::from(a.map(|x| x as f32)) - b).length() < 1e-6;
        assert!(close(scale, grid.spacing()), "{name}: {scale:?}");
        assert!(close(translation, grid.origin()), "{name}: {translation:?}");
        let [nx, ny, _] = grid.dims();
        for (cell, want) in grid.values().iter().enumerate() {
            let at = [cell % nx, (cell / nx) % ny, cell / (nx * ny)].map(|i| i as i32);
            // Zero voxels may be left inactive.
            let got = voxels.get(&at).copied().unwrap_or(0.0);
            assert_eq!(got, *want, "{name} at {at:?}");
        }
        names.retain(|n| n != &name);
    }
    assert!(names.is_empty(), "not baked: {names:?}");
}

/// The bake on the GPU is the bake on the CPU within its solvers' twin tolerances
/// (tests/transport_twins.rs: 1e-4 for the visibility, 1e-3 of the field's scale for the
/// multiply scattered light; the reaching light is computed on the CPU for both).
#[test]
fn cpu_and_gpu_bakes_agree() {
    let volume = occlux::volume::phantom::ct(20).unwrap();
    let classification = occlux::classify::presets::preset("ct-bone").unwrap();
    let lights = lighting(vec![
        Light::Directional {
            to_light: Vec3::new(-0.3, 0.5, 0.8).normalize(),
            irradiance: Vec3::ONE,
        },
        Light::Point {
            position: Vec3::new(0.1, -0.2, 0.3),
            intensity: Vec3::ONE,
        },
    ]);
    let params = BakeParams {
        directions: 32,
        multiple: true,
        g: 0.5,
    };
    let run = |compute: &Compute| {
        bake(
            compute,
            &volume,
            &classification,
            &lights,
            &params,
            &NoProgress,
        )
        .unwrap()
    };
    let cpu = run(&Compute::Cpu);
    let gpu = run(&Compute::Gpu(common::twins::ctx()));
    for ((name, a), (_, b)) in cpu.grids().into_iter().zip(gpu.grids()) {
        let scale = a.values().iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let tolerance = if name == AO { 1e-4 } else { 1e-3 * scale };
        for (x, y) in a.values().iter().zip(b.values()) {
            assert!((x - y).abs() <= tolerance, "{name}: CPU {x} vs GPU {y}");
        }
    }
}
