//! Volumetric ambient occlusion: statistics against brute force and closed forms, the CPU and
//! GPU twins against each other, degenerate inputs, and the fast estimates against the exact
//! count. The GPU tests need a Vulkan (or Metal/DX12) adapter and fail without one.
//!
//! Thresholds, set from measurement on the CT phantom at 40^3 (printed by the tests):
//! - twins: statistics within 1e-5 relative to the field's range (both sum in f32 in the same
//!   order; only the division and fused multiply-adds may round differently), openness within
//!   2e-3 (pow, exp and the erf formulas of the two devices round differently);
//! - fast vs exact over voxels with matter and a non-constant box: see `fast_estimates_*`.

mod common;

use glam::Vec3;
use occlux::ao::vao::stats::{local_stats, LocalStats};
use occlux::ao::vao::{self, exact, Estimator, FieldKind, ScalarField, UnitMap, VaoParams};
use occlux::classify::presets::preset;
use occlux::gpu::Compute;
use occlux::pipeline::Settled;
use occlux::progress::NoProgress;
use occlux::volume::{phantom, Volume};
use std::borrow::Cow;

fn gpu() -> Compute {
    Compute::Gpu(common::twins::ctx())
}

fn field(values: Volume, outside: f32) -> ScalarField {
    ScalarField { values, outside }
}

/// A volume of pseudo-random values in [0, 4) with some exact ties.
fn noise(dims: [usize; 3]) -> Volume {
    let n = dims[0] * dims[1] * dims[2];
    let values = (0..n)
        .map(|i| ((i as u64 * 2_654_435_761) % 97) as f32 / 24.0)
        .collect();
    Volume::new(dims, Vec3::ONE, Vec3::ZERO, values).unwrap()
}

/// The CT phantom's extinction under the soft-tissue preset.
fn ct_field(n: usize) -> ScalarField {
    let volume = phantom::ct(n).unwrap();
    ScalarField::new(
        Cow::Owned(volume),
        &preset("ct-soft-tissue").unwrap(),
        FieldKind::Extinction,
    )
    .unwrap()
}

/// Box statistics at voxel (i, j, k) by brute force.
fn brute_stats(f: &ScalarField, r: usize, [i, j, k]: [usize; 3]) -> [f64; 4] {
    let [nx, ny, nz] = f.values.dims();
    let r = r as isize;
    let (mut lo, mut hi, mut s1, mut s2) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0.0);
    for dk in -r..=r {
        for dj in -r..=r {
            for di in -r..=r {
                let (x, y, z) = (i as isize + di, j as isize + dj, k as isize + dk);
                let inside = (0..nx as isize).contains(&x)
                    && (0..ny as isize).contains(&y)
                    && (0..nz as isize).contains(&z);
                let v = if inside {
                    f.values.at(x as usize, y as usize, z as usize) as f64
                } else {
                    f.outside as f64
                };
                lo = lo.min(v);
                hi = hi.max(v);
                s1 += v;
                s2 += v * v;
            }
        }
    }
    let count = ((2 * r + 1) as f64).powi(3);
    [lo, hi, s1 / count, s2 / count]
}

fn stat_at(s: &LocalStats, i: usize) -> [f32; 4] {
    [s.min[i], s.max[i], s.mean[i], s.second[i]]
}

#[test]
fn statistics_match_brute_force_including_the_boundary() {
    let f = field(noise([13, 9, 11]), 0.75);
    for r in [1, 2, 4, 7] {
        let s = local_stats(&f, UnitMap::IDENTITY, r, &NoProgress).unwrap();
        let [nx, ny, _] = f.values.dims();
        for (n, _) in f.values.values().iter().enumerate() {
            let ijk = [n % nx, (n / nx) % ny, n / (nx * ny)];
            let want = brute_stats(&f, r, ijk);
            let got = stat_at(&s, n);
            for q in 0..4 {
                assert!(
                    (got[q] as f64 - want[q]).abs() < 1e-5 * (1.0 + want[q].abs()),
                    "r={r} voxel {ijk:?} statistic {q}: {} vs {}",
                    got[q],
                    want[q]
                );
            }
        }
    }
}

#[test]
fn statistics_of_a_linear_ramp_have_closed_forms() {
    // v = k along z on a grid narrower than the box in x and y: at the x-y centre the box
    // holds 6 x 5 columns of the ramp and outside (0) elsewhere.
    let r = 5usize;
    let rf = r as f32;
    let narrow = Volume::from_fn([6, 5, 40], Vec3::ONE, Vec3::ZERO, |p| p.z).unwrap();
    let f = field(narrow, 0.0);
    let s = local_stats(&f, UnitMap::IDENTITY, r, &NoProgress).unwrap();
    let inside_fraction = (6.0 * 5.0) / ((2.0 * rf + 1.0) * (2.0 * rf + 1.0));
    for k in r..40 - r {
        let kf = k as f32;
        let n = 2 + 6 * (2 + 5 * k);
        let mean = s.mean[n];
        assert!(
            (mean - kf * inside_fraction).abs() < 1e-4 * kf.max(1.0),
            "k={k}: mean {mean} vs {}",
            kf * inside_fraction
        );
        assert_eq!(s.min[n], 0.0, "outside (0) is in the box");
        assert_eq!(s.max[n], kf + rf);
    }
    // On a grid wide enough that the centre's box stays inside: the uniform distribution over
    // k-r..=k+r, of variance r(r+1)/3.
    let wide = [11, 11, 40];
    let ramp = Volume::from_fn(wide, Vec3::ONE, Vec3::ZERO, |p| p.z).unwrap();
    let f = field(ramp, 0.0);
    let s = local_stats(&f, UnitMap::IDENTITY, r, &NoProgress).unwrap();
    for k in r..40 - r {
        let kf = k as f32;
        let n = 5 + 11 * (5 + 11 * k);
        let second = kf * kf + (rf * (rf + 1.0)) / 3.0;
        assert_eq!(s.min[n], kf - rf);
        assert_eq!(s.max[n], kf + rf);
        assert!((s.mean[n] - kf).abs() < 1e-4 * kf.max(1.0));
        assert!((s.second[n] - second).abs() < 1e-4 * second);
        // At the box's mean with symmetric spread, (a) and (b) give exactly one half and
        // Penner's bound gives full occlusion.
        let open = |e| vao::estimate::openness(e, kf, &s.view().at(n));
        assert!(
            (open(Estimator::Cdf) - 0.5).abs() < 1e-3,
            "{}",
            open(Estimator::Cdf)
        );
        assert!((open(Estimator::Gauss) - 0.5).abs() < 1e-3);
        assert_eq!(open(Estimator::Penner), 0.0);
    }
    // And the exact count is one half by symmetry.
    let interior: Vec<[usize; 3]> = (r..40 - r).map(|k| [5, 5, k]).collect();
    for o in exact::exact_at(&f, r as u32, &interior) {
        assert_eq!(o, 0.5);
    }
}

#[test]
fn exact_volume_matches_the_pointwise_count() {
    let f = field(noise([9, 8, 7]), 0.5);
    let all = exact::exact_volume(&f, 3, &NoProgress).unwrap();
    let [nx, ny, nz] = f.values.dims();
    let voxels: Vec<[usize; 3]> = (0..nx * ny * nz)
        .map(|n| [n % nx, (n / nx) % ny, n / (nx * ny)])
        .collect();
    let pointwise = exact::exact_at(&f, 3, &voxels);
    for (a, b) in all.values().iter().zip(&pointwise) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
}

#[test]
fn twins_agree_on_statistics_and_every_estimate() {
    let compute = gpu();
    let Compute::Gpu(ctx) = &compute else {
        unreachable!()
    };
    for (name, f) in [
        ("ct 40", ct_field(40)),
        ("noise", field(noise([21, 17, 13]), 0.25)),
    ] {
        let range = {
            let (lo, hi) = f.values.value_range();
            (hi - lo).max(1e-6)
        };
        for r in [2u32, 7] {
            let cpu = local_stats(&f, UnitMap::IDENTITY, r as usize, &NoProgress).unwrap();
            let gpu = vao::gpu::local_stats(ctx, &f, UnitMap::IDENTITY, r).unwrap();
            let mut worst = [0.0f32; 4];
            for i in 0..cpu.min.len() {
                let (a, b) = (stat_at(&cpu, i), stat_at(&gpu, i));
                for q in 0..4 {
                    let scale = if q == 3 { range * range } else { range };
                    worst[q] = worst[q].max((a[q] - b[q]).abs() / scale);
                }
            }
            println!("{name} r={r}: worst relative statistic differences {worst:?}");
            assert!(
                worst[0] == 0.0 && worst[1] == 0.0,
                "extremes are exact: {worst:?}"
            );
            assert!(worst[2] < 1e-5 && worst[3] < 1e-5, "{worst:?}");
            for estimator in Estimator::ALL
                .into_iter()
                .filter(|e| *e != Estimator::Exact)
            {
                let params = VaoParams {
                    radius: r,
                    estimator,
                    variance: true,
                };
                let c =
                    vao::ao_volume(&Compute::Cpu, Cow::Borrowed(&f), &params, &NoProgress).unwrap();
                let g = vao::ao_volume(&compute, Cow::Borrowed(&f), &params, &NoProgress).unwrap();
                let diff = max_diff(c.openness.values(), g.openness.values());
                let var_diff = max_diff(
                    c.variance.as_ref().unwrap().values(),
                    g.variance.as_ref().unwrap().values(),
                ) / (range * range);
                println!(
                    "{name} r={r} {estimator:?}: openness {diff:.2e}, variance {var_diff:.2e}"
                );
                assert!(diff < 2e-3, "{name} r={r} {estimator:?}: {diff}");
                assert!(var_diff < 1e-5, "{name} r={r} {estimator:?}: {var_diff}");
            }
        }
    }
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn degenerate_volumes_give_one_half_or_values_in_the_unit_interval() {
    let compute = [Compute::Cpu, gpu()];
    // Constant (inside equals outside): every box is constant.
    let constant = field(
        Volume::new([7, 6, 5], Vec3::ONE, Vec3::ZERO, vec![3.0; 210]).unwrap(),
        3.0,
    );
    // One spike in an empty volume, and a volume of huge values.
    let mut spike = vec![0.0; 9 * 9 * 9];
    spike[4 + 9 * (4 + 9 * 4)] = 1.0;
    let spike = field(
        Volume::new([9, 9, 9], Vec3::ONE, Vec3::ZERO, spike).unwrap(),
        0.0,
    );
    let huge = field(
        Volume::from_fn([8, 8, 8], Vec3::ONE, Vec3::ZERO, |p| 1e18 * (p.x + p.y)).unwrap(),
        0.0,
    );
    for c in &compute {
        for estimator in Estimator::ALL {
            if matches!(c, Compute::Gpu(_)) && estimator == Estimator::Exact {
                continue;
            }
            let params = VaoParams {
                radius: 2,
                estimator,
                variance: false,
            };
            let o = vao::ao_volume(c, Cow::Borrowed(&constant), &params, &NoProgress).unwrap();
            assert!(
                o.openness.values().iter().all(|&v| v == 0.5),
                "{estimator:?}"
            );
            for f in [&spike, &huge] {
                let o = vao::ao_volume(c, Cow::Borrowed(f), &params, &NoProgress).unwrap();
                assert!(
                    o.openness.values().iter().all(|v| (0.0..=1.0).contains(v)),
                    "{estimator:?}"
                );
            }
            // The spike's own voxel holds the box's maximum: fully open for every estimate.
            let o = vao::ao_volume(c, Cow::Borrowed(&spike), &params, &NoProgress).unwrap();
            let at_spike = o.openness.at(4, 4, 4);
            assert!(at_spike > 0.95, "{estimator:?}: {at_spike}");
        }
    }
}

#[test]
fn invalid_parameters_are_named() {
    let f = field(noise([4, 4, 4]), 0.0);
    for (params, key) in [
        (
            VaoParams {
                radius: 0,
                ..VaoParams::default()
            },
            "radius",
        ),
        (
            VaoParams {
                radius: 100_000,
                ..VaoParams::default()
            },
            "radius",
        ),
        (
            VaoParams {
                estimator: Estimator::Exact,
                variance: true,
                ..VaoParams::default()
            },
            "variance",
        ),
    ] {
        let err = vao::ao_volume(&Compute::Cpu, Cow::Borrowed(&f), &params, &NoProgress)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains(key), "{err}");
    }
}

#[test]
fn cancelling_stops_the_statistics() {
    struct Cancel;
    impl occlux::progress::Progress for Cancel {
        fn update(&self, _: u64, _: u64) {}
        fn cancelled(&self) -> bool {
            true
        }
    }
    let f = ct_field(24);
    for c in [Compute::Cpu, gpu()] {
        let err = vao::ao_volume(&c, Cow::Borrowed(&f), &VaoParams::default(), &Cancel).err();
        assert!(matches!(err, Some(occlux::Error::Cancelled)));
    }
}

#[test]
fn ao_shading_scales_the_ambient_light_by_the_openness() {
    use occlux::camera::{Camera, Projection};
    use occlux::lights::{Light, Lighting};
    use occlux::render::raycast::{cpu, AoFactors, RaycastInput, RaycastParams, Shading};
    let volume = phantom::ct(32).unwrap();
    let lut = preset("ct-soft-tissue").unwrap().bake(&volume);
    let camera = Camera::look_at(
        Vec3::new(2.5, -3.0, 1.5),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective { fov_y: 0.7 },
        24,
        24,
    )
    .unwrap();
    let lighting = Lighting {
        lights: vec![Light::Ambient {
            radiance: Vec3::new(0.5, 0.6, 0.7),
        }],
        background: Vec3::ZERO,
    };
    let grid = |v: f32| {
        Volume::new(
            volume.dims(),
            volume.spacing(),
            volume.origin(),
            vec![v; volume.values().len()],
        )
        .unwrap()
    };
    let render = |shading, ao: Option<AoFactors>| {
        let params = RaycastParams {
            shading,
            ..RaycastParams::default()
        };
        let input = RaycastInput {
            volume: &volume,
            lut: &lut,
            camera: &camera,
            lighting: &lighting,
            params: &params,
            ao,
        };
        cpu::render(&input, &NoProgress).unwrap()
    };
    let plain = render(Shading::Unshaded, None);
    let (c, one, zero) = (grid(0.3), grid(1.0), grid(0.0));
    let ao_only = Shading::AmbientOcclusion { direct: None };
    let scaled = render(
        ao_only,
        Some(AoFactors {
            openness: &c,
            opacity: None,
        }),
    );
    let unmodulated = render(
        ao_only,
        Some(AoFactors {
            openness: &c,
            opacity: Some(&one),
        }),
    );
    let cleared = render(
        ao_only,
        Some(AoFactors {
            openness: &c,
            opacity: Some(&zero),
        }),
    );
    assert!(
        plain.rgba.iter().any(|p| p[3] > 0.5),
        "the phantom is visible"
    );
    for ((p, s), (u, z)) in plain
        .rgba
        .iter()
        .zip(&scaled.rgba)
        .zip(unmodulated.rgba.iter().zip(&cleared.rgba))
    {
        for ch in 0..3 {
            assert!(
                (s[ch] - 0.3 * p[ch]).abs() <= 1e-5 * p[ch].max(1.0),
                "{s:?} vs {p:?}"
            );
        }
        assert_eq!(s[3], p[3], "openness changes no opacity");
        assert_eq!(u, s, "a modulation factor of 1 changes nothing");
        assert_eq!(*z, [0.0, 0.0, 0.0, 0.0], "a factor of 0 clears the volume");
    }
}

/// A linear classification of values 0..1 onto sigma_t 0..40 per unit: opaque in a voxel or
/// two of 1/24.
fn opaque() -> occlux::classify::Classification {
    occlux::scene::Scene::parse(
        "[volume]\nphantom = \"sphere\"\nsize = 8\n[classification]\nunits = \"raw\"\n\
         points = [{ value = 0, sigma_t = 0 }, { value = 1, sigma_t = 40 }]\n\
         [camera]\nposition = [3, -3, 2]\nwidth = 8\nheight = 8\n\
         [[lights]]\ntype = \"ambient\"\nradiance = 1\n",
        std::path::Path::new("."),
    )
    .unwrap()
    .classification
}

/// The `ao` grid `occlux ao` writes for `volume` classified by [`opaque`], read back from the
/// VDB file.
fn written_ao(volume: &Volume, method: &str, convention: &str) -> Volume {
    use occlux::ao::{ao_volume, AoMethod, AoVolumeParams};
    use occlux::export::vdb::VdbOptions;
    let parsed = method.parse().unwrap();
    let params = AoVolumeParams {
        method: parsed,
        // A radius for VAO's estimators; the sweeps and ordinates reach the whole volume.
        radius: match parsed {
            AoMethod::Vao(_) => 4,
            _ => AoVolumeParams::default().radius,
        },
        convention: convention.parse().unwrap(),
        ..Default::default()
    };
    let ao = ao_volume(
        &Compute::Cpu,
        Cow::Borrowed(volume),
        &opaque(),
        &params,
        &NoProgress,
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let record = serde_json::json!({ "method": method });
    occlux::pipeline::write_ao(&ao, &record, dir.path(), "t", &VdbOptions::default()).unwrap();
    let file = std::fs::File::open(dir.path().join("t-ao.vdb")).unwrap();
    let mut reader = vdb_rs::VdbReader::new(std::io::BufReader::new(file)).unwrap();
    let grid = reader.read_grid::<f32>("ao").unwrap();
    let [nx, ny, nz] = volume.dims();
    let mut values = vec![0.0f32; nx * ny * nz]; // inactive voxels read 0
    for (p, v, _) in grid.iter() {
        let c = [p.x as i32, p.y as i32, p.z as i32];
        let inside = c
            .iter()
            .zip([nx, ny, nz])
            .all(|(&c, n)| (0..n as i32).contains(&c));
        if inside {
            values[p.x as usize + nx * (p.y as usize + ny * p.z as usize)] = v;
        } else {
            // The padding repeats the border (src/export/vdb.rs).
            assert_eq!(
                v,
                common::padded_at(&ao.openness, c),
                "{method}: padding at {c:?}"
            );
        }
    }
    assert_eq!(
        values,
        ao.openness.values(),
        "{method}: the file holds the grid"
    );
    Volume::new(volume.dims(), volume.spacing(), volume.origin(), values).unwrap()
}

const AO_METHODS: [&str; 7] = [
    "cdf",
    "gauss",
    "gauss-exact",
    "penner",
    "exact",
    "sweep",
    "sweep-physical",
];

/// Minimum, mean and maximum of `ao` over the voxels where `pick` holds.
fn summary(ao: &Volume, pick: impl Fn([usize; 3]) -> bool) -> [f32; 3] {
    let [nx, ny, nz] = ao.dims();
    let (mut lo, mut sum, mut hi, mut n) = (f32::INFINITY, 0.0f64, f32::NEG_INFINITY, 0);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if pick([i, j, k]) {
                    let v = ao.at(i, j, k);
                    (lo, hi, sum, n) = (lo.min(v), hi.max(v), sum + v as f64, n + 1);
                }
            }
        }
    }
    assert!(n > 0);
    [lo, (sum / n as f64) as f32, hi]
}

#[test]
fn written_ao_grids_read_one_in_empty_space_and_less_by_matter_for_every_method() {
    // The sweep paper's box and sphere on a floor, 48^3 voxels of 1/24: the floor's top layer
    // is k = 16 (coverage 0.8), the air above it starts at k = 17, the ball's top is near
    // k = 31; the ball touches the floor at (0.4, 0), about i = 33, j = 23.5.
    let scene = phantom::box_and_sphere([48; 3]).unwrap();
    // A ball of radius 0.1 alone: from its far air it covers under 0.2 % of the directions.
    let ball = phantom::sphere(48, 0.1).unwrap();
    let open_air = |[_, _, k]: [usize; 3]| k >= 38; // 7 voxels above anything
    let far_air = |[i, j, k]: [usize; 3]| {
        let c = |n: usize| (n as f32 + 0.5) / 24.0 - 1.0;
        Vec3::new(c(i), c(j), c(k)).length() >= 1.2
    };
    // The floor's top layer and the air on it, R + 2 voxels from the objects (|y| >= 0.5) and
    // the faces; the floor's top layer where the ball touches it.
    let floor = |layer| {
        move |[i, j, k]: [usize; 3]| k == layer && (6..42).contains(&i) && (6..12).contains(&j)
    };
    let crease = |[i, j, k]: [usize; 3]| (31..36).contains(&i) && (21..27).contains(&j) && k == 16;
    let matter = |[i, j, k]: [usize; 3]| scene.at(i, j, k) >= 0.5;
    // The exact count's air on a flat floor: the ball's share above the floor, all of it tied.
    let (mut above, mut all) = (0, 0);
    for dk in -4i32..=4 {
        for dj in -4i32..=4 {
            for di in -4i32..=4 {
                if di * di + dj * dj + dk * dk <= 16 {
                    all += 1;
                    above += (dk >= 0) as usize;
                }
            }
        }
    }
    let air_share = above as f32 / all as f32;
    for method in AO_METHODS {
        let ao = written_ao(&scene, method, "unoccluded");
        assert!(
            ao.values().iter().all(|v| (0.0..=1.0).contains(v)),
            "{method}"
        );
        let air = summary(&ao, open_air);
        let alone = summary(&written_ao(&ball, method, "unoccluded"), far_air);
        let (flat, flat_air) = (summary(&ao, floor(16)), summary(&ao, floor(17)));
        let (creased, matter) = (summary(&ao, crease), summary(&ao, matter));
        println!(
            "{method}: open air {air:?}, far from a lone ball {alone:?}, floor's top layer \
             {flat:?}, the air on it {flat_air:?}, crease {creased:?}, matter {matter:?}"
        );
        match method {
            "sweep" => {
                // The cosine-weighted hemisphere about the normal.
                assert!(air[0] >= 0.98 && alone[0] >= 0.99, "{method}");
                assert!(flat[1] > 0.8 && creased[1] < 0.5, "{method}");
                assert!(matter[1] < 0.2, "{method}: inside an opaque surface");
            }
            "sweep-physical" => {
                // The mean transmittance over all directions: 1 where nothing occludes (exactly
                // at least 0.998 in the lone ball's far air; the lattice walk's streaks darken
                // single voxels by up to 0.06), at most 1/2 on an opaque floor (the floor hides
                // the lower half, grazing steps through its top layer some more), darker by
                // matter.
                assert!(alone[0] >= 0.94 && alone[1] >= 0.99, "{method}: {alone:?}");
                assert!(
                    flat_air[2] <= 0.5 && flat_air[1] > 0.35,
                    "{method}: {flat_air:?}"
                );
                assert!(creased[2] < 0.1 && matter[1] < 0.1, "{method}");
            }
            _ => {
                let raw = written_ao(&scene, method, "raw");
                println!(
                    "{method} raw: open air {:?}, floor's top layer {:?}, the air on it {:?}, \
                     crease {:?}",
                    summary(&raw, open_air),
                    summary(&raw, floor(16)),
                    summary(&raw, floor(17)),
                    summary(&raw, crease)
                );
                // VAO: a voxel whose whole tangent sphere is empty reads exactly 1.
                assert_eq!(air, [1.0; 3], "{method}");
                assert_eq!(alone, [1.0; 3], "{method}");
                // Where the ball touches the floor, the floor's surface is occluded.
                assert!(creased[1] < 0.95 && creased[1] < flat[1] - 0.05, "{method}");
                if method == "penner" {
                    // Its bound counts the whole box as occluding: too dark even when flat.
                    assert!(flat[1] < 0.6, "{method}");
                } else {
                    // An unoccluded flat surface reads 1, the air on it the ball's empty share.
                    assert_eq!(flat, [1.0; 3], "{method}");
                    assert!(flat_air[2] <= air_share + 0.02, "{method}: {air_share}");
                }
                if method == "exact" {
                    assert!(
                        flat_air.iter().all(|v| (v - air_share).abs() < 1e-6),
                        "{method}: {air_share}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_raw_convention_keeps_vaos_openness_and_the_default_doubles_it_up_to_one() {
    let scene = phantom::box_and_sphere([48; 3]).unwrap();
    let field = ScalarField::new(Cow::Borrowed(&scene), &opaque(), FieldKind::Extinction).unwrap();
    for estimator in Estimator::ALL {
        let method = estimator.name();
        let params = VaoParams {
            radius: 4,
            estimator,
            variance: false,
        };
        let paper =
            vao::ao_volume(&Compute::Cpu, Cow::Borrowed(&field), &params, &NoProgress).unwrap();
        let raw = written_ao(&scene, method, "raw");
        let unoccluded = written_ao(&scene, method, "unoccluded");
        // The paper's convention, unchanged: 1/2 in empty space and on a flat interface.
        assert!(raw.values() == paper.openness.values(), "{method}");
        assert_eq!(raw.at(20, 20, 44), 0.5, "{method}: open air");
        if estimator == Estimator::Exact {
            assert_eq!(raw.at(20, 8, 16), 0.5, "{method}: a flat floor");
        }
        for (r, u) in raw.values().iter().zip(unoccluded.values()) {
            assert!(*u == (2.0 * r).min(1.0), "{method}: {r} -> {u}");
        }
    }
    // The sweeps have no raw form: asking for one is an error that names it.
    for method in ["sweep", "sweep-physical"] {
        let params = occlux::ao::AoVolumeParams {
            method: method.parse().unwrap(),
            convention: occlux::ao::AoConvention::Raw,
            ..Default::default()
        };
        let err = params.validate().unwrap_err().to_string();
        assert!(err.contains("convention"), "{err}");
    }
    assert!("blender"
        .parse::<occlux::ao::AoConvention>()
        .unwrap_err()
        .to_string()
        .contains("unoccluded, raw"));
}

#[test]
fn ao_shaded_images_shade_with_the_raw_openness_whatever_the_grids_convention() {
    use occlux::pipeline;
    use occlux::scene::Scene;
    let render = |convention: &str| {
        let scene = Scene::parse(
            &format!(
                "[volume]\nphantom = \"box-sphere\"\nsize = 24\n[classification]\nunits = \"raw\"\n\
                 points = [{{ value = 0, sigma_t = 0 }}, {{ value = 1, sigma_t = 20 }}]\n\
                 [camera]\nposition = [3, -3, 2]\nwidth = 12\nheight = 10\n\
                 [[lights]]\ntype = \"ambient\"\nradiance = 1\n\
                 [render]\nmethod = \"ao\"\nao_method = \"gauss\"\nao_radius = 3\n\
                 ao_convention = \"{convention}\"\n"
            ),
            std::path::Path::new("."),
        )
        .unwrap();
        let volume = scene.load_volume().unwrap();
        pipeline::render(&Settled::named(&scene), &volume, &Compute::Cpu, &NoProgress).unwrap()
    };
    let (unoccluded, raw) = (render("unoccluded"), render("raw"));
    assert!(
        unoccluded.image.rgba == raw.image.rgba,
        "the image is the same"
    );
    let grid = |r: &occlux::render::Rendered| {
        r.grids
            .iter()
            .find(|g| g.name == "ao")
            .unwrap()
            .volume
            .values()
            .to_vec()
    };
    let (u, r) = (grid(&unoccluded), grid(&raw));
    assert!(r.contains(&0.5) && u.contains(&1.0));
    for (r, u) in r.iter().zip(&u) {
        assert!(*u == (2.0 * r).min(1.0), "{r} -> {u}");
    }
}

/// Box means of `values` (x fastest, `dims`) over boxes of radius `r`, `outside` beyond the
/// grid, in f64: three separable passes of exact window sums from prefix sums (a mean of means
/// over equal counts is the box mean, and the outside's mean is `outside` in every pass).
fn box_means_f64(values: &[f64], dims: [usize; 3], r: usize, outside: f64) -> Vec<f64> {
    let mut out = values.to_vec();
    let strides = [1, dims[0], dims[0] * dims[1]];
    let w = (2 * r + 1) as f64;
    for axis in 0..3 {
        let (n, stride) = (dims[axis], strides[axis]);
        let starts: Vec<usize> = (0..values.len())
            .filter(|&i| (i / stride) % n == 0)
            .collect();
        let mut prefix = vec![0.0f64; n + 1];
        for start in starts {
            for k in 0..n {
                prefix[k + 1] = prefix[k] + out[start + k * stride];
            }
            for k in 0..n {
                let lo = k.saturating_sub(r);
                let hi = (k + r).min(n - 1);
                let missing = (2 * r + 1 - (hi + 1 - lo)) as f64;
                out[start + k * stride] = (prefix[hi + 1] - prefix[lo] + missing * outside) / w;
            }
        }
    }
    out
}

#[test]
fn variance_at_large_radii_matches_an_f64_reference_on_both_twins() {
    // Values near 0.8 that vary by a few percent: the variance is a small difference of two
    // large moments, which plain f32 running sums miss by 3e-2 at R = 64.
    let compute = gpu();
    let Compute::Gpu(ctx) = &compute else {
        unreachable!()
    };
    let dims = [72, 72, 72];
    let values = Volume::from_fn(dims, Vec3::ONE, Vec3::ZERO, |p| {
        let wave = (0.21 * p.x).sin() * (0.13 * p.y).cos() + (0.17 * p.z).sin();
        let hash = ((p.x * 12.9898 + p.y * 78.233 + p.z * 37.719).sin() * 43758.547).fract();
        0.8 + 0.02 * wave + 0.01 * hash
    })
    .unwrap();
    let f = field(values, 0.79);
    let x: Vec<f64> = f.values.values().iter().map(|&v| v as f64).collect();
    let x2: Vec<f64> = x.iter().map(|v| v * v).collect();
    for r in [64usize, 100] {
        let mean = box_means_f64(&x, dims, r, f.outside as f64);
        let second = box_means_f64(&x2, dims, r, (f.outside as f64).powi(2));
        let cpu = local_stats(&f, UnitMap::IDENTITY, r, &NoProgress).unwrap();
        let gpu = vao::gpu::local_stats(ctx, &f, UnitMap::IDENTITY, r as u32).unwrap();
        for (twin, s) in [("cpu", cpu), ("gpu", gpu)] {
            let s = s.view();
            let (mut worst, mut smallest) = (0.0f64, f64::INFINITY);
            for i in 0..x.len() {
                let want = second[i] - mean[i] * mean[i];
                let got = s.at(i).variance() as f64;
                smallest = smallest.min(want);
                worst = worst.max((got - want).abs() / want);
            }
            println!(
                "{twin} r={r}: variance worst relative error {worst:.2e} \
                 (smallest variance {smallest:.2e})"
            );
            // Storing the two means in f32 alone costs about 1e-3 here (an f32 ulp of 0.64
            // against a variance of 5e-5); the bound leaves 5x for the sums' own rounding.
            assert!(worst < 5e-3, "{twin} r={r}: {worst}");
        }
    }
}
