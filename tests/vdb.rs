//! The OpenVDB writer and loader: files written by Occlux read back with vdb-rs directly and
//! through `occlux::volume::load`, values and transforms equal; bad files are clear errors.

use glam::Vec3;
use occlux::export::vdb::{write_vdb, Compression, VdbGrid, VdbOptions};
use occlux::volume::{load, LoadOptions, Volume};

mod common;
use common::vdb::read_with_vdb_rs;

/// A sparse field: a ball of varying density in a larger empty box, spanning several leaves
/// and (at 150 voxels) more than one 128^3 internal node along x.
fn ball(dims: [usize; 3], spacing: Vec3, origin: Vec3) -> Volume {
    Volume::from_fn(dims, spacing, origin, |p| {
        let q = (p - origin) / spacing - Vec3::new(100.0, 12.0, 9.0);
        let r = q.length();
        if r < 8.0 {
            1.0 + 0.01 * q.x + 0.002 * q.y * q.z
        } else {
            0.0
        }
    })
    .unwrap()
}

/// Every storage option: zlib or not, float32 or half. Half-float files hold each value rounded
/// to the nearest f16.
fn all_options() -> Vec<VdbOptions> {
    let mut all = Vec::new();
    for compression in [Compression::None, Compression::Zip] {
        for half in [false, true] {
            all.push(VdbOptions { compression, half });
        }
    }
    all
}

#[test]
fn vdb_rs_reads_back_values_and_transform() {
    let dims = [150, 30, 20];
    let spacing = Vec3::new(0.5, 0.25, 2.0);
    let origin = Vec3::new(-3.0, 1.5, 10.0);
    let volume = ball(dims, spacing, origin);
    let dir = tempfile::tempdir().unwrap();
    let mut sizes = Vec::new();
    for options in all_options() {
        let path = dir.path().join(format!("ball-{options:?}.vdb"));
        write_vdb(&path, &[VdbGrid::from_volume("density", &volume)], &options).unwrap();
        sizes.push(std::fs::metadata(&path).unwrap().len());
        let (voxels, scale, translation) = read_with_vdb_rs(&path, "density");
        assert_eq!(scale, spacing.as_dvec3().to_array());
        assert_eq!(translation, origin.as_dvec3().to_array());
        let nonzero = volume.values().iter().filter(|v| **v != 0.0).count();
        assert_eq!(
            voxels.len(),
            nonzero,
            "exactly the non-background voxels are active ({options:?})"
        );
        for (&[i, j, k], &v) in &voxels {
            let mut want = volume.at(i as usize, j as usize, k as usize);
            if options.half {
                want = half::f16::from_f32(want).to_f32();
            }
            assert_eq!(v, want, "{options:?}");
        }
    }
    // Active-mask compression stores only the ~2100 active values: the uncompressed float file
    // holds their 8.6 kB plus about 12 kB of node masks (8 kB for the top node alone) and
    // headers, where full leaves would add another 2 kB per leaf.
    let active = volume.values().iter().filter(|v| **v != 0.0).count() as u64;
    assert!(
        sizes[0] < 4 * active + 14_000,
        "float32 file: {} bytes",
        sizes[0]
    );
    assert!(
        sizes[1] < sizes[0] - active,
        "half floats save 2 bytes a value: {sizes:?}"
    );
    assert!(sizes[2] < sizes[0], "zip shrinks the file: {sizes:?}");
}

#[test]
fn occlux_loads_what_it_wrote_at_the_same_world_positions() {
    let volume = ball(
        [150, 30, 20],
        Vec3::new(0.5, 0.25, 2.0),
        Vec3::new(-3.0, 1.5, 10.0),
    );
    let shells = occlux::volume::phantom::shells(24).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.vdb");
    write_vdb(
        &path,
        &[
            VdbGrid::from_volume("shells", &shells),
            VdbGrid::from_volume("density", &volume),
        ],
        &VdbOptions::default(),
    )
    .unwrap();
    // The default is the grid named density; the dense box is the active voxels' box.
    let back = load(&path, &LoadOptions::default()).unwrap();
    let (lo, hi) = back.bounds();
    for k in 0..back.dims()[2] {
        for j in 0..back.dims()[1] {
            for i in 0..back.dims()[0] {
                let p = back.origin() + Vec3::new(i as f32, j as f32, k as f32) * back.spacing();
                let src = volume.to_index(p).round();
                let want = volume.at(src.x as usize, src.y as usize, src.z as usize);
                assert_eq!(back.at(i, j, k), want, "voxel {i} {j} {k}");
            }
        }
    }
    assert!(
        lo.x > volume.bounds().0.x,
        "the empty margin is not part of the dense box"
    );
    assert!(hi.x < volume.bounds().1.x);
    // A named grid: the shells phantom, whose active box is the whole cube less empty corners.
    let opts = LoadOptions {
        grid: Some("shells".into()),
        ..LoadOptions::default()
    };
    let back = load(&path, &opts).unwrap();
    assert_eq!(back.spacing(), shells.spacing());
    let c = back.origin() + 5.0 * back.spacing();
    assert_eq!(back.sample(c), shells.sample(c));
}

#[test]
fn bad_files_and_grids_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let volume = occlux::volume::phantom::sphere(16, 0.5).unwrap();
    let path = dir.path().join("s.vdb");
    write_vdb(
        &path,
        &[VdbGrid::from_volume("s", &volume)],
        &VdbOptions::default(),
    )
    .unwrap();
    let missing = LoadOptions {
        grid: Some("density".into()),
        ..LoadOptions::default()
    };
    let err = load(&path, &missing).unwrap_err().to_string();
    assert!(
        err.contains("no grid named 'density'") && err.contains("s"),
        "{err}"
    );

    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.vdb");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = load(&cut, &LoadOptions::default()).unwrap_err().to_string();
    assert!(err.contains("cut.vdb"), "{err}");
    let junk = dir.path().join("junk.vdb");
    std::fs::write(&junk, b"definitely not a vdb file").unwrap();
    let err = load(&junk, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("junk.vdb") && err.contains("magic"), "{err}");

    let tight = LoadOptions {
        memory: cap(100),
        ..LoadOptions::default()
    };
    let err = load(&path, &tight).unwrap_err().to_string();
    assert!(err.contains("available (a test's cap)"), "{err}");
}

#[test]
fn the_writer_refuses_bad_grids_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.vdb");
    let mut values = vec![1.0f32; 8];
    let grid = |name: &'static str, values: &'static [f32]| VdbGrid {
        name,
        dims: [2, 2, 2],
        spacing: Vec3::ONE,
        origin: Vec3::ZERO,
        values,
        map: None,
        background: 0.0,
        class: Default::default(),
        padded: true,
    };
    let ok: &'static [f32] = &[1.0; 8];
    for (grids, what) in [
        (vec![grid("", ok)], "non-empty"),
        (vec![grid("a\nb", ok)], "printable"),
        (vec![grid("a", ok), grid("a", ok)], "two grids"),
        (vec![grid("a", &[1.0; 7])], "do not match"),
    ] {
        let err = write_vdb(&path, &grids, &VdbOptions::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains(what), "{err}");
    }
    values[3] = f32::NAN;
    let nan = VdbGrid {
        values: &values,
        ..grid("n", ok)
    };
    let err = write_vdb(&path, &[nan], &VdbOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("not finite") && err.contains("[1, 1, 0]"),
        "{err}"
    );

    let huge: &'static [f32] = &[1.0, 7e4, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
    let half = VdbOptions {
        half: true,
        ..VdbOptions::default()
    };
    let err = write_vdb(&path, &[grid("h", huge)], &half)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("half float") && err.contains("[1, 0, 0]"),
        "{err}"
    );
    write_vdb(&path, &[grid("h", huge)], &VdbOptions::default()).expect("float32 holds 7e4");
    std::fs::remove_file(&path).unwrap();
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
}

#[test]
fn empty_grids_are_written_as_valid_grids_without_voxels() {
    // An all-transparent classification's density, or a constant variance: every voxel equals
    // the background. OpenVDB writes such a grid as a root without children and an inverted
    // bounding box; so does Occlux, beside a grid that holds voxels, in every storage option.
    let dir = tempfile::tempdir().unwrap();
    let empty = Volume::new([4, 4, 4], Vec3::splat(0.5), Vec3::ONE, vec![0.0; 64]).unwrap();
    let full = ball([150, 30, 20], Vec3::ONE, Vec3::ZERO);
    for options in all_options() {
        let path = dir.path().join("empty.vdb");
        write_vdb(
            &path,
            &[
                VdbGrid::from_volume("ao_variance", &empty),
                VdbGrid::from_volume("density", &full),
            ],
            &options,
        )
        .unwrap();
        let (voxels, scale, translation) = read_with_vdb_rs(&path, "ao_variance");
        assert!(voxels.is_empty(), "{options:?}: {} voxels", voxels.len());
        assert_eq!(
            (scale, translation),
            ([0.5; 3], [1.0; 3]),
            "{options:?}: {scale:?} {translation:?}"
        );
        // The grid after it is intact.
        let (voxels, _, _) = read_with_vdb_rs(&path, "density");
        assert!(!voxels.is_empty(), "{options:?}");
    }
}

/// The writer encodes leaves a batch at a time (4096 leaves) to bound its memory: a grid of
/// 17^3 = 4913 leaves, every one active, spans two batches and reads back voxel for voxel, in
/// the right leaves.
#[test]
fn grids_of_more_leaves_than_a_batch_read_back_exactly() {
    let dims = [136, 136, 136];
    let volume = Volume::from_fn(dims, Vec3::ONE, Vec3::ZERO, |p| {
        // Distinct per voxel, and 0 (inactive) on one voxel in seven.
        let n = p.x + 136.0 * (p.y + 136.0 * p.z);
        if (n as u64).is_multiple_of(7) {
            0.0
        } else {
            1.0 + n
        }
    })
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("many-leaves.vdb");
    let options = VdbOptions {
        compression: Compression::Zip,
        half: false,
    };
    write_vdb(&path, &[VdbGrid::from_volume("density", &volume)], &options).unwrap();
    let (voxels, _, _) = read_with_vdb_rs(&path, "density");
    // The grid and its padding (one voxel on every side repeating the border).
    let nonzero = common::padded_nonzero(&volume);
    assert_eq!(voxels.len(), nonzero);
    for (&c, &v) in &voxels {
        assert_eq!(v, common::padded_at(&volume, c), "at {c:?}");
    }
}

#[test]
fn fog_volumes_are_padded_by_their_border_and_read_back_unpadded() {
    // Matter up to every face (values differ per voxel), over more than one leaf per axis.
    let dims = [19, 9, 12];
    let (spacing, origin) = (Vec3::new(0.5, 0.25, 2.0), Vec3::new(-3.0, 1.5, 10.0));
    let volume = Volume::from_fn(dims, spacing, origin, |p| {
        let q = (p - origin) / spacing;
        1.0 + q.x + 10.0 * q.y + 100.0 * q.z
    })
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("padded.vdb");
    let sdf = VdbGrid::level_set("sdf", &volume);
    write_vdb(
        &path,
        &[VdbGrid::from_volume("density", &volume), sdf],
        &VdbOptions::default(),
    )
    .unwrap();
    // What a renderer reads: one more voxel on every side, each its neighbour on the border.
    let (voxels, _, translation) = read_with_vdb_rs(&path, "density");
    assert_eq!(
        translation,
        origin.as_dvec3().to_array(),
        "voxels keep their places"
    );
    let padded: usize = dims.iter().map(|d| d + 2).product();
    assert_eq!(voxels.len(), padded);
    for (&c, &v) in &voxels {
        assert_eq!(v, common::padded_at(&volume, c));
    }
    // A distance is not padded: beyond the grid the narrow band ends.
    let (sdf_voxels, _, _) = read_with_vdb_rs(&path, "sdf");
    assert!(sdf_voxels.keys().all(|c| c.iter().all(|&x| x >= 0)));
    // Occlux reads the grid itself back, at the same world positions.
    let back = load(
        &path,
        &LoadOptions {
            grid: Some("density".into()),
            ..LoadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(back.dims(), dims);
    assert_eq!(back.origin(), origin);
    assert_eq!(back.values(), volume.values());
}

/// A memory budget of `bytes`, as a user's cap.
fn cap(bytes: u64) -> occlux::memory::MemoryBudget {
    occlux::memory::MemoryBudget {
        limit: occlux::memory::MemoryLimit::Bytes(bytes, "a test's cap"),
        ..Default::default()
    }
}
