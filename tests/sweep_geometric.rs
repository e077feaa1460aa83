//! Occlusion sweeping, geometric mode (the paper's): against Monte Carlo AO of the iso-surface
//! on the box-and-sphere phantom (the paper's Fig. 3 scene) and the CT phantom, the closed form
//! of an open floor, the shading options (gamma, sky octants, translucency), and bad input.

use glam::Vec3;
use occlux::ao::surface_reference::{surface_ao, surface_points};
use occlux::ao::sweep::geometric::{occlusion, GeometricParams, Occlusion, SKY};
use occlux::ao::sweep::sdf::SdfParams;
use occlux::gpu::Compute;
use occlux::progress::NoProgress;
use occlux::volume::{phantom, Volume};

fn surface(iso: f32) -> SdfParams {
    SdfParams {
        iso,
        ..Default::default()
    }
}

/// Gamma 1: the AO itself, as the Monte Carlo reference estimates it.
fn linear() -> GeometricParams {
    GeometricParams {
        gamma: 1.0,
        ..Default::default()
    }
}

fn run(field: &Volume, iso: f32, params: &GeometricParams) -> Occlusion {
    let o = occlusion(
        &Compute::Cpu,
        field,
        &surface(iso),
        params,
        true,
        &NoProgress,
    )
    .unwrap();
    for v in [&o.ao, &o.sdf.sdf]
        .into_iter()
        .chain(o.octants.iter().flatten())
    {
        assert!(v.values().iter().all(|x| x.is_finite()), "NaN or infinity");
    }
    o
}

/// RMSE, mean difference and correlation of the sweep's AO against Monte Carlo at surface
/// points.
fn against_monte_carlo(field: &Volume, iso: f32, points: usize) -> (f32, f32, f32) {
    let o = run(field, iso, &linear());
    let picked = surface_points(field, &o.sdf.sdf, points);
    assert!(picked.len() > points / 2, "{} points", picked.len());
    let reference = surface_ao(field, iso, &picked, 256, 7).unwrap();
    let swept: Vec<f32> = picked.iter().map(|p| o.ao.values()[p.voxel]).collect();
    let n = swept.len() as f32;
    let (ms, mr) = (
        swept.iter().sum::<f32>() / n,
        reference.iter().sum::<f32>() / n,
    );
    let (mut sxy, mut sxx, mut syy, mut se) = (0.0, 0.0, 0.0, 0.0);
    for (a, b) in swept.iter().zip(&reference) {
        sxy += (a - ms) * (b - mr);
        sxx += (a - ms) * (a - ms);
        syy += (b - mr) * (b - mr);
        se += (a - b) * (a - b);
    }
    ((se / n).sqrt(), ms - mr, sxy / (sxx * syy).sqrt())
}

#[test]
fn geometric_sweep_follows_monte_carlo_on_the_box_and_sphere() {
    let field = phantom::box_and_sphere([64, 64, 48]).unwrap();
    let (rmse, bias, corr) = against_monte_carlo(&field, 0.5, 400);
    println!("box and sphere 64 x 64 x 48: RMSE {rmse:.3}, bias {bias:+.3}, correlation {corr:.3}");
    // Measured: RMSE 0.120, bias -0.084, correlation 0.940 (Monte Carlo noise at 256 rays:
    // at most 0.031). Within an octant the three-neighbour walk weights the directions by how
    // it wanders, not by the cosine, so low occluders (the cube seen from the floor) darken
    // more than they should; creases and the overhang come out smoother than they are.
    assert!(rmse < 0.15, "RMSE {rmse}");
    assert!(bias.abs() < 0.11, "bias {bias}");
    assert!(corr > 0.9, "correlation {corr}");
}

#[test]
fn geometric_sweep_follows_monte_carlo_on_a_ct() {
    // The bone of the CT phantom (tissue 0.35, bone 0.9): cavities, a rod, a shell.
    let field = phantom::ct(64).unwrap();
    let (rmse, bias, corr) = against_monte_carlo(&field, 0.6, 400);
    println!("CT phantom 64^3, bone: RMSE {rmse:.3}, bias {bias:+.3}, correlation {corr:.3}");
    // Measured: RMSE 0.083, bias -0.054, correlation 0.996.
    assert!(rmse < 0.11, "RMSE {rmse}");
    assert!(bias.abs() < 0.08, "bias {bias}");
    assert!(corr > 0.97, "correlation {corr}");
}

#[test]
fn an_open_floor_sees_the_whole_sky() {
    // A floor alone (inside below z = 0.3, anti-aliased) under an open sky: AO 1 on its surface
    // (the voxels within half a voxel of it), read one voxel out along the normal, where the
    // four upper octants see no matter and hold the whole cosine lobe.
    let h = 1.0 / 32.0;
    let field = Volume::from_fn([32, 24, 40], Vec3::splat(h), Vec3::ZERO, |p| {
        phantom::coverage(p.z - 0.3, h)
    })
    .unwrap();
    let o = run(&field, 0.5, &linear());
    let mut checked = 0;
    for (v, &d) in o.sdf.sdf.values().iter().enumerate() {
        if d.abs() < 0.5 * h {
            let ao = o.ao.values()[v];
            assert!((ao - 1.0).abs() < 0.005, "voxel {v}: AO {ao}");
            checked += 1;
        }
    }
    assert_eq!(checked, 32 * 24, "one layer of surface voxels");
}

#[test]
fn gamma_sky_and_translucency_shape_the_ao() {
    let field = phantom::box_and_sphere([48, 48, 32]).unwrap();
    let base = run(&field, 0.5, &linear());
    // Gamma 2 is the square root of the AO.
    let gamma = run(&field, 0.5, &GeometricParams::default());
    for (a, b) in base.ao.values().iter().zip(gamma.ao.values()) {
        assert!((a.sqrt() - b).abs() < 1e-5, "{a} {b}");
    }
    // The sky (the four upper octants) lights no more than all eight, and the octant grids
    // are V_s in the order of the intensities.
    let sky = run(
        &field,
        0.5,
        &GeometricParams {
            intensities: SKY,
            ..linear()
        },
    );
    assert!(sky
        .ao
        .values()
        .iter()
        .zip(base.ao.values())
        .all(|(s, a)| *s <= a + 1e-6));
    let octants = base.octants.as_ref().unwrap();
    assert_eq!(octants.len(), 8);
    // Straight above the ball's top (x = 0.4, y = 0, z = 0.3) nothing occludes the upper
    // octants, and the ball blocks the lower ones.
    let [nx, ny, _] = field.dims();
    let above = field.to_index(Vec3::new(0.4, 0.0, 0.35)).round();
    let v = above.x as usize + nx * (above.y as usize + ny * above.z as usize);
    for (s, octant) in octants.iter().enumerate() {
        let seen = octant.values()[v];
        if s < 4 {
            assert!(seen > 0.9, "octant {s}: {seen}");
        } else {
            assert!(seen < 0.5, "octant {s}: {seen}");
        }
    }
    // Translucency lets light through: never darker, and brighter where it was occluded.
    let translucent = run(
        &field,
        0.5,
        &GeometricParams {
            alpha: 0.5,
            normal_weighted: false,
            ..linear()
        },
    );
    let opaque = run(
        &field,
        0.5,
        &GeometricParams {
            normal_weighted: false,
            ..linear()
        },
    );
    let mut brighter = 0;
    for (t, o) in translucent.ao.values().iter().zip(opaque.ao.values()) {
        assert!(*t >= o - 1e-6);
        brighter += (*t > o + 0.05) as usize;
    }
    assert!(brighter > 100, "{brighter}");
}

#[test]
fn bad_input_gets_named_errors_and_hard_cases_stay_finite() {
    // A constant volume has no surface.
    let flat = Volume::new([8, 8, 8], Vec3::ONE, Vec3::ZERO, vec![0.3; 512]).unwrap();
    let err = occlusion(
        &Compute::Cpu,
        &flat,
        &surface(0.5),
        &linear(),
        false,
        &NoProgress,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(err.contains("never crosses"), "{err}");
    // A single-voxel-thick shell and strongly non-cubic spacing: finite, within [0, 1].
    let shell = Volume::from_fn([24, 24, 24], Vec3::new(0.5, 1.0, 2.0), Vec3::ZERO, |p| {
        let r = (p - Vec3::new(6.0, 12.0, 24.0)).length();
        if (r - 5.0).abs() < 0.6 {
            1.0
        } else {
            0.0
        }
    })
    .unwrap();
    let o = run(&shell, 0.5, &GeometricParams::default());
    assert!(o.ao.values().iter().all(|a| (0.0..=1.0).contains(a)));
    // Out-of-range shading parameters are named.
    let e = occlusion(
        &Compute::Cpu,
        &shell,
        &surface(0.5),
        &GeometricParams {
            gamma: -1.0,
            ..Default::default()
        },
        false,
        &NoProgress,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("gamma"), "{e}");
}

#[test]
fn both_sweeps_give_the_same_bytes_with_one_and_two_threads() {
    // Work is shared among fixed teams and groups, never by thread count.
    let field = phantom::box_and_sphere([40, 40, 32]).unwrap();
    let extinction = Volume::new(
        field.dims(),
        field.spacing(),
        field.origin(),
        field.values().iter().map(|v| 8.0 * v).collect(),
    )
    .unwrap();
    let run_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let o = run(&field, 0.5, &GeometricParams::default());
            let physical =
                occlux::ao::sweep::physical::cpu::visibility(&extinction, &NoProgress).unwrap();
            let bits = |v: &Volume| v.values().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (bits(&o.sdf.sdf), bits(&o.ao), bits(&physical))
        })
    };
    let (one, two) = (run_with(1), run_with(2));
    assert!(one.0 == two.0, "signed distance");
    assert!(one.1 == two.1, "geometric AO");
    assert!(one.2 == two.2, "physical visibility");
}
