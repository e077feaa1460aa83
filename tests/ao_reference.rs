//! Reference AO volumes against closed forms: transmittance means over spheres and hemispheres
//! of directions (quadrature), and tangent-sphere fractions (ball and cap volumes).

use glam::Vec3;
use occlux::ao::reference::{ao_reference, AoReference, AoReferenceParams, AoVariant};
use occlux::classify::{
    Classification, ControlPoint, Lut, TransferFunction, TransferFunction1D, ValueUnits,
};
use occlux::progress::NoProgress;
use occlux::volume::Volume;

mod common;
use common::quadrature::{chord, mean_over_directions};

/// The cube [-1, 1]^3 sampled with `nz` slices along z, holding the value -z.
fn ramp_cube(nz: usize) -> Volume {
    let spacing = Vec3::new(0.25, 0.25, 2.0 / nz as f32);
    let origin = Vec3::splat(-1.0) + 0.5 * spacing;
    Volume::from_fn([8, 8, nz], spacing, origin, |p| -p.z).unwrap()
}

/// A raw-units transfer function through (value, sigma_t) points, grey albedo.
fn lut(volume: &Volume, points: &[(f32, f32)]) -> Lut {
    let tf = TransferFunction1D::new(
        points
            .iter()
            .map(|&(v, s)| ControlPoint::new(v, s, [0.8; 3], [0.0; 3]))
            .collect(),
    )
    .unwrap();
    Classification::new(TransferFunction::OneD(tf), ValueUnits::Raw, 1.0)
        .unwrap()
        .bake(volume)
}

fn run(volume: &Volume, lut: &Lut, variant: AoVariant, radius: Option<f32>) -> AoReference {
    let params = AoReferenceParams {
        variant,
        samples: 3000,
        seed: 11,
        radius,
    };
    ao_reference(volume, lut, &params, &NoProgress).unwrap()
}

/// Checks the voxels `at` (index coordinates) against `exact`, in units of their standard
/// errors.
fn assert_matches(ao: &AoReference, at: &[[usize; 3]], exact: impl Fn(Vec3) -> f64, what: &str) {
    let mut z2 = 0.0;
    for &[i, j, k] in at {
        let x =
            ao.openness.origin() + Vec3::new(i as f32, j as f32, k as f32) * ao.openness.spacing();
        let (got, se) = (ao.openness.at(i, j, k) as f64, ao.stderr.at(i, j, k) as f64);
        let want = exact(x);
        let z = (got - want) / se.max(1e-9);
        assert!(z.abs() < 4.5, "{what} at {x}: {got} vs {want} ({z:.1} se)");
        z2 += z * z;
    }
    let rms = (z2 / at.len() as f64).sqrt();
    assert!(rms < 1.8, "{what}: RMS z {rms:.2}");
}

const VOXELS: [[usize; 3]; 6] = [
    [3, 4, 16],
    [0, 0, 0],
    [7, 2, 30],
    [4, 4, 5],
    [2, 6, 24],
    [5, 1, 10],
];

#[test]
fn sphere_openness_is_the_mean_transmittance_over_directions() {
    let volume = ramp_cube(32);
    // A homogeneous medium, sigma_t = 1.2 everywhere.
    let lut = lut(&volume, &[(-2.0, 1.2), (2.0, 1.2)]);
    for radius in [None, Some(0.6)] {
        let ao = run(&volume, &lut, AoVariant::Sphere, radius);
        let reach = radius.map_or(f64::INFINITY, f64::from);
        assert_matches(
            &ao,
            &VOXELS,
            |x| {
                let x = x.as_dvec3().to_array();
                mean_over_directions([0.0, 0.0, 1.0], -1.0, |w| {
                    (-1.2 * chord(x, w).min(reach)).exp()
                })
            },
            &format!("sphere, radius {radius:?}"),
        );
    }
}

#[test]
fn hemisphere_openness_looks_towards_less_matter() {
    // sigma_t = 1.5 - z rises downwards, so the outward normal is +z everywhere; the optical
    // depth of a segment is its length times sigma_t at its midpoint.
    let volume = ramp_cube(64);
    let lut = lut(&volume, &[(-1.5, 0.0), (1.5, 3.0)]);
    let ao = run(&volume, &lut, AoVariant::Hemisphere, None);
    // Interior voxels: at the box's faces the empty outside tilts the normal outwards.
    let voxels = [
        [3, 4, 33],
        [1, 1, 2],
        [6, 2, 61],
        [4, 4, 11],
        [2, 6, 49],
        [5, 1, 21],
    ];
    assert_matches(
        &ao,
        &voxels,
        |x| {
            let x = x.as_dvec3().to_array();
            mean_over_directions([0.0, 0.0, 1.0], 0.0, |w| {
                let c = chord(x, w);
                (-c * (1.5 - (x[2] + 0.5 * c * w[2]))).exp()
            })
        },
        "hemisphere",
    );
    // Facing up, it sees less matter than the whole sphere does.
    let sphere = run(&volume, &lut, AoVariant::Sphere, None);
    let [i, j, k] = voxels[0];
    assert!(ao.openness.at(i, j, k) > sphere.openness.at(i, j, k) + 0.05);
}

#[test]
fn tangent_sphere_openness_is_a_ball_fraction() {
    // sigma_t = 2 max(-z, 0): matter below z = 0, nothing above.
    let volume = ramp_cube(64);
    let lut = lut(&volume, &[(0.0, 0.0), (1.0, 2.0)]);
    let radius = 0.5f32;
    let ao = run(&volume, &lut, AoVariant::TangentSphere, Some(radius));
    let r = radius as f64;
    // Above the interface (sigma_t = 0 at x): only the empty part of the ball ties with x, and
    // ties count one half. The ball around height h > 0 loses a cap of height r - h below z = 0.
    let above = |h: f64| {
        let cap = std::f64::consts::PI * (r - h).powi(2) * (3.0 * r - (r - h)) / 3.0;
        0.5 * (1.0 - cap / (4.0 / 3.0 * std::f64::consts::PI * r.powi(3)))
    };
    // In the matter, where sigma_t falls linearly upwards: exactly the upper half is less dense.
    let voxels = [[4usize, 4, 41], [3, 4, 44], [4, 3, 22], [4, 4, 27]];
    assert_matches(
        &ao,
        &voxels,
        |x| if x.z > 0.0 { above(x.z as f64) } else { 0.5 },
        "tangent sphere",
    );
}

#[test]
fn parameters_are_checked() {
    let volume = ramp_cube(8);
    let lut = lut(&volume, &[(0.0, 0.0), (1.0, 2.0)]);
    for (params, key) in [
        (
            AoReferenceParams {
                variant: AoVariant::Sphere,
                samples: 1,
                seed: 0,
                radius: None,
            },
            "samples",
        ),
        (
            AoReferenceParams {
                variant: AoVariant::TangentSphere,
                samples: 8,
                seed: 0,
                radius: None,
            },
            "radius",
        ),
        (
            AoReferenceParams {
                variant: AoVariant::Sphere,
                samples: 8,
                seed: 0,
                radius: Some(-1.0),
            },
            "radius",
        ),
    ] {
        let err = ao_reference(&volume, &lut, &params, &NoProgress)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains(key), "{err}");
    }
}
