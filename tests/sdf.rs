//! Fast sweeping signed distance (Zhao 2005) against the closed-form distance of a sphere, brute
//! force on the CT phantom, and bad input: no crossing, constant volumes, a one-voxel shell,
//! anisotropic and flat grids. Errors are stated in units of the grid spacing h.

use glam::Vec3;
use occlux::ao::sweep::sdf::{cpu::signed_distance, SdfParams, SdfResult};
use occlux::error::Error;
use occlux::progress::NoProgress;
use occlux::volume::{phantom, Volume};

fn params(iso: f32) -> SdfParams {
    SdfParams {
        iso,
        ..Default::default()
    }
}

/// Centres of voxel (i, j, k) of `v`.
fn centre(v: &Volume, i: usize, j: usize, k: usize) -> Vec3 {
    v.origin() + Vec3::new(i as f32, j as f32, k as f32) * v.spacing()
}

fn assert_finite(r: &SdfResult) {
    assert!(
        r.sdf.values().iter().all(|d| d.is_finite()),
        "NaN or infinity in the signed distance"
    );
}

/// A ball of radius `r` about `c` as the value field r - |p - c| (iso 0: inside where positive);
/// returns (max, RMS) of |sdf - (|p - c| - r)| over the grid, and checks every sign.
fn sphere_errors(dims: [usize; 3], spacing: Vec3, c: Vec3, r: f32) -> (f32, f32, SdfResult) {
    let n = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let origin = -0.5 * (n - 1.0) * spacing;
    let v = Volume::from_fn(dims, spacing, origin, |p| r - (p - c).length()).unwrap();
    let result = signed_distance(&v, &params(0.0), &NoProgress).unwrap();
    assert_finite(&result);
    let (mut max, mut sum) = (0f32, 0f64);
    let [nx, ny, nz] = dims;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let exact = (centre(&v, i, j, k) - c).length() - r;
                let d = result.sdf.values()[i + nx * (j + ny * k)];
                // Sign: negative inside, positive outside (zero allowed only on the surface).
                assert!(
                    d * exact >= 0.0 || exact.abs() < 1e-4,
                    "sign at ({i}, {j}, {k}): {d} vs {exact}"
                );
                let e = (d - exact).abs();
                max = max.max(e);
                sum += (e as f64).powi(2);
            }
        }
    }
    let rms = (sum / (nx * ny * nz) as f64).sqrt() as f32;
    (max, rms, result)
}

#[test]
fn sdf_sphere_cubic_spacing_within_first_order_bound() {
    // R = 15 voxels, centred off the lattice so no symmetry helps.
    let (max, rms, r) = sphere_errors([48; 3], Vec3::ONE, Vec3::new(0.3, -0.2, 0.15), 15.0);
    println!(
        "sphere 48^3, h = 1: max {max:.4} h, RMS {rms:.4} h, {} rounds, last change {}",
        r.iterations, r.max_change
    );
    // Measured: max 1.00 h (at the centre, where the distance has its kink), RMS 0.28 h.
    // First order: next to the surface the error is below 0.4 h; it grows along the diagonals
    // away from it (0.66 h at 27 h outside) and towards the centre (the converging front).
    assert!(max < 1.1, "max error {max} h");
    assert!(rms < 0.32, "RMS error {rms} h");
    // 3 rounds sequentially; two parallel teams may need a fourth.
    assert!(r.converged && r.iterations <= 4, "{} rounds", r.iterations);
}

#[test]
fn sdf_sphere_anisotropic_spacing_within_first_order_bound() {
    // 1 x 1 x 2 spacing: h = 2 along z. Errors in units of the largest spacing.
    let spacing = Vec3::new(1.0, 1.0, 2.0);
    let (max, rms, r) = sphere_errors([48; 3], spacing, Vec3::new(0.3, -0.2, 0.7), 15.0);
    let h = 2.0;
    println!(
        "sphere 48^3, spacing 1 x 1 x 2: max {:.4} h, RMS {:.4} h (h = 2), {} rounds",
        max / h,
        rms / h,
        r.iterations
    );
    // Measured: max 0.58 h, RMS 0.27 h.
    assert!(max / h < 0.65, "max error {} h", max / h);
    assert!(rms / h < 0.3, "RMS error {} h", rms / h);
    // Sequential sweeps converge in 3 rounds here; sweeps shared among two parallel teams
    // may need a fourth.
    assert!(r.converged && r.iterations <= 4, "{} rounds", r.iterations);

    // Strongly non-cubic spacing 0.5 x 1 x 3 (the radius only 4 voxels along z): finite, right
    // signs; measured max 0.78 h, RMS 0.25 h with h = 3.
    let spacing = Vec3::new(0.5, 1.0, 3.0);
    let (max, rms, r) = sphere_errors([64, 40, 16], spacing, Vec3::new(0.1, 0.2, 0.3), 12.0);
    println!(
        "sphere 64 x 40 x 16, spacing 0.5 x 1 x 3: max {:.4} h, RMS {:.4} h (h = 3), {} rounds",
        max / 3.0,
        rms / 3.0,
        r.iterations
    );
    assert!(max / 3.0 < 0.85 && rms / 3.0 < 0.3, "{max} {rms}");
    assert!(r.converged, "{} rounds", r.iterations);
}

/// Brute force: the signed distance from every voxel centre to the nearest of the crossing
/// points interpolated on the grid's edges (negative inside, where the value is above `iso`).
fn brute_force(v: &Volume, iso: f32) -> (Vec<f32>, usize) {
    let [nx, ny, nz] = v.dims();
    let values = v.values();
    let spacing = v.spacing();
    let mut points = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let a = i + nx * (j + ny * k);
                for (step, ok, stride) in [
                    (Vec3::X * spacing.x, i + 1 < nx, 1),
                    (Vec3::Y * spacing.y, j + 1 < ny, nx),
                    (Vec3::Z * spacing.z, k + 1 < nz, nx * ny),
                ] {
                    if !ok {
                        continue;
                    }
                    let (v0, v1) = (values[a], values[a + stride]);
                    if (v0 > iso) != (v1 > iso) {
                        let t = (iso - v0) / (v1 - v0);
                        points.push(centre(v, i, j, k) + t * step);
                    }
                }
            }
        }
    }
    let mut out = Vec::with_capacity(values.len());
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = centre(v, i, j, k);
                let d = points
                    .iter()
                    .map(|q| (*q - p).length_squared())
                    .fold(f32::INFINITY, f32::min)
                    .sqrt();
                out.push(if values[i + nx * (j + ny * k)] > iso {
                    -d
                } else {
                    d
                });
            }
        }
    }
    (out, points.len())
}

/// (max, RMS) of |a - b| / h, and (within 2 h of the surface) the max; checks the signs.
fn compare(sdf: &[f32], exact: &[f32], h: f32) -> (f32, f32, f32) {
    let (mut max, mut sum, mut max_near) = (0f32, 0f64, 0f32);
    for (index, (&d, &e)) in sdf.iter().zip(exact).enumerate() {
        assert!(d * e >= 0.0, "sign at voxel {index}: {d} vs {e}");
        let err = (d - e).abs() / h;
        max = max.max(err);
        if e.abs() < 2.0 * h {
            max_near = max_near.max(err);
        }
        sum += (err as f64).powi(2);
    }
    (max, (sum / sdf.len() as f64).sqrt() as f32, max_near)
}

#[test]
fn sdf_ct_phantom_matches_brute_force() {
    let v = phantom::by_name("ct", 24).unwrap();
    let h = v.spacing().x;
    // iso 0.2: the body's outline and its air cavities; iso 0.6: the thin bone shell and the
    // rod, small features whose distance spreads like a point source's, where first-order
    // sweeping overestimates most (its error grows with the distance: 0.3 h at 1 h, 0.9 h at
    // 10 h). Bounds (max, RMS) in h, a little above the measured (0.61, 0.17) and (0.96, 0.47).
    for (iso, max_bound, rms_bound) in [(0.2f32, 0.7, 0.2), (0.6, 1.05, 0.52)] {
        let (exact, crossings) = brute_force(&v, iso);
        let r = signed_distance(&v, &params(iso), &NoProgress).unwrap();
        assert_finite(&r);
        let (max, rms, max_near) = compare(r.sdf.values(), &exact, h);
        println!(
            "ct 24^3 iso {iso}: {crossings} crossings, max {max:.4} h (within 2 h of the \
             surface {max_near:.4} h), RMS {rms:.4} h, {} rounds",
            r.iterations
        );
        assert!(max < max_bound, "iso {iso}: max error {max} h");
        assert!(rms < rms_bound, "iso {iso}: RMS error {rms} h");
        assert!(r.converged && r.iterations <= 4, "{} rounds", r.iterations);
    }
}

#[test]
fn sdf_single_voxel_shell_is_finite_with_the_right_sign() {
    // Value 1 only in the voxels within half a voxel of radius 8: a shell one voxel thick,
    // every one of whose voxels is next to the surface on both sides.
    let n = 24;
    let origin = Vec3::splat(-0.5 * (n - 1) as f32);
    let v = Volume::from_fn([n; 3], Vec3::ONE, origin, |p| {
        if (p.length() - 8.0).abs() < 0.5 {
            1.0
        } else {
            0.0
        }
    })
    .unwrap();
    let r = signed_distance(&v, &params(0.5), &NoProgress).unwrap();
    assert_finite(&r);
    for (d, value) in r.sdf.values().iter().zip(v.values()) {
        if *value > 0.5 {
            // In the shell: within half a voxel of a crossing.
            assert!(*d < 0.0 && *d >= -0.5, "{d}");
        } else {
            assert!(*d > 0.0, "{d}");
        }
    }
    let (exact, _) = brute_force(&v, 0.5);
    let (max, rms, _) = compare(r.sdf.values(), &exact, 1.0);
    println!(
        "one-voxel shell 24^3: max {max:.4} h, RMS {rms:.4} h, {} rounds",
        r.iterations
    );
    assert!(max < 1.0 && rms < 0.4, "max {max} h, RMS {rms} h");
    assert!(r.converged);
}

#[test]
fn sdf_flat_and_tiny_grids() {
    // One voxel thick in z (a 2D slice of a disc): distances in the plane.
    let v = Volume::from_fn([32, 32, 1], Vec3::ONE, Vec3::new(-15.5, -15.5, 0.0), |p| {
        10.0 - p.length()
    })
    .unwrap();
    let r = signed_distance(&v, &params(0.0), &NoProgress).unwrap();
    assert_finite(&r);
    for j in 0..32 {
        for i in 0..32 {
            let exact = centre(&v, i, j, 0).length() - 10.0;
            let d = r.sdf.values()[i + 32 * j];
            assert!((d - exact).abs() < 0.6, "({i}, {j}): {d} vs {exact}");
        }
    }
    // Two voxels: the crossing between them, a quarter of the way.
    let v = Volume::new([2, 1, 1], Vec3::splat(2.0), Vec3::ZERO, vec![1.0, 0.0]).unwrap();
    let r = signed_distance(&v, &params(0.75), &NoProgress).unwrap();
    assert_eq!(r.sdf.values(), &[-0.5, 1.5]);
}

#[test]
fn sdf_no_surface_is_a_clear_error() {
    let v = phantom::by_name("sphere", 16).unwrap();
    for iso in [1.5f32, -0.5, 1.0] {
        let e = signed_distance(&v, &params(iso), &NoProgress).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, Error::Volume(_)), "{text}");
        assert!(
            text.contains("never crosses") && text.contains("[0, 1]"),
            "{text}"
        );
    }
    // Constant volumes: the same case, whatever the iso-value.
    let constant = Volume::new([8, 8, 8], Vec3::ONE, Vec3::ZERO, vec![0.5; 512]).unwrap();
    for iso in [0.5f32, 0.0, 1.0] {
        let e = signed_distance(&constant, &params(iso), &NoProgress).unwrap_err();
        assert!(e.to_string().contains("never crosses"), "{e}");
    }
    // A single voxel can never cross.
    let one = Volume::new([1, 1, 1], Vec3::ONE, Vec3::ZERO, vec![1.0]).unwrap();
    assert!(signed_distance(&one, &params(0.5), &NoProgress).is_err());
    // Bad parameters name the parameter.
    let e = signed_distance(
        &v,
        &SdfParams {
            tolerance: -1.0,
            ..Default::default()
        },
        &NoProgress,
    )
    .unwrap_err();
    assert!(e.to_string().contains("sdf.tolerance"), "{e}");
}

#[test]
fn sdf_iteration_limit_and_cancel_are_reported() {
    let v = phantom::by_name("ct", 24).unwrap();
    let one_round = SdfParams {
        max_iterations: 1,
        ..params(0.2)
    };
    let r = signed_distance(&v, &one_round, &NoProgress).unwrap();
    assert_finite(&r);
    assert_eq!(r.iterations, 1);
    assert!(!r.converged);

    struct Cancel;
    impl occlux::progress::Progress for Cancel {
        fn update(&self, _: u64, _: u64) {}
        fn cancelled(&self) -> bool {
            true
        }
    }
    assert!(matches!(
        signed_distance(&v, &params(0.2), &Cancel),
        Err(Error::Cancelled)
    ));
}

#[test]
fn sdf_is_the_same_bytes_with_any_number_of_threads() {
    // The rows of a wavefront run in parallel but each reads only rows no other one writes:
    // the distances, and the rounds they took, cannot depend on how many threads there are.
    let v = phantom::ct(40).unwrap();
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| signed_distance(&v, &params(0.25), &NoProgress).unwrap())
    };
    let bits = |r: &SdfResult| {
        r.sdf
            .values()
            .iter()
            .map(|d| d.to_bits())
            .collect::<Vec<_>>()
    };
    let one = on(1);
    for threads in [2, 3, 8] {
        let r = on(threads);
        assert_eq!(r.iterations, one.iterations, "{threads} threads");
        assert!(bits(&r) == bits(&one), "{threads} threads");
    }
}
