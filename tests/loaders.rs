//! Volume loaders: the shared real volumes, round trips through every format, and bad input.

mod common;

use flate2::read::GzDecoder;
use flate2::write::GzEncoder;
use flate2::Compression;
use glam::Vec3;
use occlux::volume::{
    frame_count, load, load_with_info, Frame, LoadOptions, NonFinite, RawSpec, ScalarType, Volume,
};
use occlux::Error;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------------
// Helpers

/// Stored types and how each format spells them.
#[derive(Clone, Copy, Debug)]
struct Ty {
    scalar: ScalarType,
    nrrd: &'static str,
    nifti: i16,
    npy: &'static str,
}

const TYPES: [Ty; 8] = [
    Ty {
        scalar: ScalarType::U8,
        nrrd: "unsigned char",
        nifti: 2,
        npy: "u1",
    },
    Ty {
        scalar: ScalarType::I8,
        nrrd: "signed char",
        nifti: 256,
        npy: "i1",
    },
    Ty {
        scalar: ScalarType::U16,
        nrrd: "ushort",
        nifti: 512,
        npy: "u2",
    },
    Ty {
        scalar: ScalarType::I16,
        nrrd: "short",
        nifti: 4,
        npy: "i2",
    },
    Ty {
        scalar: ScalarType::U32,
        nrrd: "uint",
        nifti: 768,
        npy: "u4",
    },
    Ty {
        scalar: ScalarType::I32,
        nrrd: "int",
        nifti: 8,
        npy: "i4",
    },
    Ty {
        scalar: ScalarType::F32,
        nrrd: "float",
        nifti: 16,
        npy: "f4",
    },
    Ty {
        scalar: ScalarType::F64,
        nrrd: "double",
        nifti: 64,
        npy: "f8",
    },
];

fn ty(scalar: ScalarType) -> Ty {
    TYPES.into_iter().find(|t| t.scalar == scalar).unwrap()
}

/// Test values that every type holds exactly (and f32 represents exactly).
fn values_for(scalar: ScalarType, count: usize) -> Vec<f64> {
    (0..count)
        .map(|i| {
            let n = ((i * 37) % 101) as f64;
            match scalar {
                ScalarType::U8 => n * 2.0,
                ScalarType::I8 => n - 50.0,
                ScalarType::U16 => n * 600.0,
                ScalarType::I16 => n * 300.0 - 15000.0,
                ScalarType::U32 => n * 100_000.0,
                ScalarType::I32 => n * 100_000.0 - 5_000_000.0,
                ScalarType::F32 | ScalarType::F64 => n * 0.25 - 12.5,
            }
        })
        .collect()
}

/// Packs values in a type and byte order, independently of the library.
fn encode(scalar: ScalarType, values: &[f64], big_endian: bool) -> Vec<u8> {
    let mut out = Vec::new();
    for &v in values {
        let mut bytes = match scalar {
            ScalarType::U8 => vec![v as u8],
            ScalarType::I8 => (v as i8).to_le_bytes().to_vec(),
            ScalarType::U16 => (v as u16).to_le_bytes().to_vec(),
            ScalarType::I16 => (v as i16).to_le_bytes().to_vec(),
            ScalarType::U32 => (v as u32).to_le_bytes().to_vec(),
            ScalarType::I32 => (v as i32).to_le_bytes().to_vec(),
            ScalarType::F32 => (v as f32).to_le_bytes().to_vec(),
            ScalarType::F64 => v.to_le_bytes().to_vec(),
        };
        if big_endian {
            bytes.reverse();
        }
        out.extend(bytes);
    }
    out
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = GzEncoder::new(Vec::new(), Compression::fast());
    encoder.write_all(bytes).unwrap();
    encoder.finish().unwrap()
}

/// Writes a NRRD with an attached header: the magic, a comment, `fields`, a blank line, `data`.
fn write_nrrd(path: &Path, fields: &[(&str, &str)], data: &[u8]) {
    let mut file = b"NRRD0004\n# written by tests/loaders.rs\n".to_vec();
    for (name, value) in fields {
        file.extend(format!("{name}: {value}\n").bytes());
    }
    file.extend(b"key:=value\n\n");
    file.extend(data);
    std::fs::write(path, file).unwrap();
}

fn opts() -> LoadOptions {
    LoadOptions::default()
}

/// Loads a file that must fail and returns the message, checking that it names the file.
fn failure(path: &Path, opts: &LoadOptions) -> String {
    let message = match load(path, opts) {
        Ok(v) => panic!("{} loaded ({:?}) but should fail", path.display(), v.dims()),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains(&path.display().to_string()),
        "message does not name {}: {message}",
        path.display()
    );
    message
}

fn assert_mentions(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(message.contains(part), "expected {part:?} in: {message}");
    }
}

fn as_f32(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

/// Deterministic noise bytes.
fn garbage(count: usize) -> Vec<u8> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    (0..count)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 56) as u8
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// The shared real volumes

fn scivis(name: &str) -> PathBuf {
    common::scivis_dir().join(format!("{name}.nrrd"))
}

/// Decodes a shared volume without the library: the gzip payload after the header's blank
/// line, values little endian, x fastest.
fn independent_decode(path: &Path, scalar: ScalarType) -> Vec<f32> {
    let file = std::fs::read(path).unwrap();
    let start = file.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let mut payload = Vec::new();
    GzDecoder::new(&file[start..])
        .read_to_end(&mut payload)
        .unwrap();
    match scalar {
        ScalarType::U8 => payload.iter().map(|&b| b as f32).collect(),
        ScalarType::U16 => payload
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as f32)
            .collect(),
        ScalarType::F32 => payload
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
        other => panic!("no shared volume is {other:?}"),
    }
}

fn check_shared(name: &str, dims: [usize; 3], scalar: ScalarType, spacing: Vec3) {
    let path = scivis(name);
    let (volume, info) = load_with_info(&path, &opts()).unwrap();
    assert_eq!(volume.dims(), dims, "{name}");
    assert_eq!(info.format, "NRRD");
    assert_eq!(info.scalar, scalar.name(), "{name}");
    assert_eq!(volume.spacing(), spacing, "{name}");
    assert_eq!(volume.origin(), Vec3::ZERO, "{name}");
    let expected = independent_decode(&path, scalar);
    assert_eq!(expected.len(), dims.iter().product::<usize>(), "{name}");
    let values = volume.values();
    let n = values.len();
    for index in [0, n / 7, n / 3, n / 2, 2 * n / 3, n - 1] {
        assert_eq!(values[index], expected[index], "{name} voxel {index}");
    }
    if let Some(index) = (0..n).find(|&i| values[i] != expected[i]) {
        panic!(
            "{name}: voxel {index} is {} but the file holds {}",
            values[index], expected[index]
        );
    }
    let (lo, hi) = volume.value_range();
    assert!(hi > lo, "{name} is constant");
}

#[test]
fn shared_engine() {
    check_shared("engine", [256, 256, 128], ScalarType::U8, Vec3::ONE);
}

#[test]
fn shared_tooth() {
    check_shared("tooth", [103, 94, 161], ScalarType::U8, Vec3::ONE);
}

#[test]
fn shared_small_simulations() {
    for (name, dims) in [
        ("neghip", [64, 64, 64]),
        ("fuel", [64, 64, 64]),
        ("hydrogen_atom", [128, 128, 128]),
        ("marschner_lobb", [41, 41, 41]),
        ("nucleon", [41, 41, 41]),
        ("silicium", [98, 34, 34]),
    ] {
        check_shared(name, dims, ScalarType::U8, Vec3::ONE);
    }
}

#[test]
fn shared_stag_beetle_is_uint16() {
    check_shared(
        "stag_beetle",
        [416, 208, 124],
        ScalarType::U16,
        Vec3::new(2.0, 4.0, 3.983871),
    );
}

#[test]
fn shared_hcci_oh_is_float() {
    check_shared(
        "hcci_oh",
        [187, 187, 187],
        ScalarType::F32,
        Vec3::splat(2.994652),
    );
}

// ---------------------------------------------------------------------------------------------
// Round trips

#[test]
fn nrrd_round_trips_every_type_byte_order_and_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [3, 4, 5];
    for t in TYPES {
        let values = values_for(t.scalar, 60);
        for big_endian in [false, true] {
            for encoding in ["raw", "gzip"] {
                let path = dir
                    .path()
                    .join(format!("{}_{big_endian}_{encoding}.nrrd", t.scalar.name()));
                let packed = encode(t.scalar, &values, big_endian);
                let data = if encoding == "gzip" {
                    gzip(&packed)
                } else {
                    packed
                };
                write_nrrd(
                    &path,
                    &[
                        ("type", t.nrrd),
                        ("dimension", "3"),
                        ("sizes", "3 4 5"),
                        ("spacings", "0.5 2 1.25"),
                        ("endian", if big_endian { "big" } else { "little" }),
                        ("encoding", encoding),
                    ],
                    &data,
                );
                let (volume, info) = load_with_info(&path, &opts()).unwrap();
                assert_eq!(info.scalar, t.scalar.name());
                assert_eq!(volume.dims(), dims);
                assert_eq!(volume.spacing(), Vec3::new(0.5, 2.0, 1.25));
                assert_eq!(volume.origin(), Vec3::ZERO);
                assert_eq!(volume.values(), as_f32(&values), "{}", path.display());
            }
        }
    }
}

#[test]
fn nrrd_space_directions_set_spacing_origin_and_flip_negative_axes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("directions.nrrd");
    let values = values_for(ScalarType::F32, 24);
    write_nrrd(
        &path,
        &[
            ("type", "float"),
            ("dimension", "3"),
            ("space", "right-anterior-superior"),
            ("sizes", "2 3 4"),
            ("space directions", "(0.5,0,0) (0, 2, 0) (0,0,-1.5)"),
            ("space origin", "(10,20,30)"),
            ("endian", "little"),
            ("encoding", "raw"),
        ],
        &encode(ScalarType::F32, &values, false),
    );
    let volume = load(&path, &opts()).unwrap();
    assert_eq!(volume.spacing(), Vec3::new(0.5, 2.0, 1.5));
    // Stored slice k sits at z = 30 - 1.5 k, so the lowest one (k = 3, z = 25.5) comes first.
    assert_eq!(volume.origin(), Vec3::new(10.0, 20.0, 25.5));
    for k in 0..4 {
        for j in 0..3 {
            for i in 0..2 {
                let stored = values[i + 2 * (j + 3 * (3 - k))] as f32;
                assert_eq!(volume.at(i, j, k), stored, "voxel {i} {j} {k}");
                // Same world position as the file says: origin + index * step.
                let world =
                    volume.origin() + Vec3::new(i as f32, j as f32, k as f32) * volume.spacing();
                let file_world = Vec3::new(
                    10.0 + 0.5 * i as f32,
                    20.0 + 2.0 * j as f32,
                    30.0 - 1.5 * (3 - k) as f32,
                );
                assert!((world - file_world).length() < 1e-5);
            }
        }
    }
}

#[test]
fn nrrd_four_d_with_a_size_one_axis() {
    let dir = tempfile::tempdir().unwrap();
    let values = values_for(ScalarType::U16, 24);
    let data = encode(ScalarType::U16, &values, false);
    let cases: [(&str, &[(&str, &str)]); 2] = [
        (
            "leading",
            &[("sizes", "1 2 3 4"), ("spacings", "nan 1 2 3")],
        ),
        (
            "trailing",
            &[
                ("sizes", "2 3 4 1"),
                ("space directions", "(1,0,0) (0,2,0) (0,0,3) none"),
            ],
        ),
    ];
    for (name, extra) in cases {
        let path = dir.path().join(format!("{name}.nrrd"));
        let mut fields = vec![
            ("type", "uint16"),
            ("dimension", "4"),
            ("endian", "little"),
            ("encoding", "raw"),
        ];
        fields.extend_from_slice(extra);
        write_nrrd(&path, &fields, &data);
        let volume = load(&path, &opts()).unwrap();
        assert_eq!(volume.dims(), [2, 3, 4], "{name}");
        assert_eq!(volume.spacing(), Vec3::new(1.0, 2.0, 3.0), "{name}");
        assert_eq!(volume.values(), as_f32(&values), "{name}");
    }
}

#[test]
fn detached_nhdr_reads_its_data_file() {
    let dir = tempfile::tempdir().unwrap();
    let values = values_for(ScalarType::I16, 24);
    let packed = encode(ScalarType::I16, &values, true);
    // Raw data after 3 junk bytes, and gzip data in a second file.
    let mut raw = b"abc".to_vec();
    raw.extend(&packed);
    std::fs::write(dir.path().join("data.raw"), raw).unwrap();
    std::fs::write(dir.path().join("data.raw.gz"), gzip(&packed)).unwrap();
    for (name, data_file, encoding, skip) in [
        ("raw.nhdr", "data.raw", "raw", "3"),
        ("tail.nhdr", "data.raw", "raw", "-1"),
        ("gz.nhdr", "data.raw.gz", "gzip", "0"),
    ] {
        let header = format!(
            "NRRD0005\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: big\nencoding: {encoding}\n\
             byte skip: {skip}\ndata file: {data_file}\n"
        );
        let path = dir.path().join(name);
        std::fs::write(&path, header).unwrap();
        let volume = load(&path, &opts()).unwrap();
        assert_eq!(volume.dims(), [4, 3, 2], "{name}");
        assert_eq!(volume.values(), as_f32(&values), "{name}");
    }
}

/// A NIfTI-1 header, written by hand (348 bytes, then 4 bytes of extension flags).
struct Nifti {
    dim: [i16; 8],
    datatype: i16,
    bitpix: i16,
    pixdim: [f32; 8],
    slope: f32,
    inter: f32,
    qform_code: i16,
    sform_code: i16,
    quatern: [f32; 6],
    srow: [[f32; 4]; 3],
    magic: [u8; 4],
    big_endian: bool,
}

impl Nifti {
    fn new(dims: [i16; 3], t: Ty) -> Self {
        Self {
            dim: [3, dims[0], dims[1], dims[2], 1, 1, 1, 1],
            datatype: t.nifti,
            bitpix: 8 * t.scalar.size() as i16,
            pixdim: [1.0; 8],
            slope: 0.0,
            inter: 0.0,
            qform_code: 0,
            sform_code: 0,
            quatern: [0.0; 6],
            srow: [[0.0; 4]; 3],
            magic: *b"n+1\0",
            big_endian: false,
        }
    }

    fn bytes(&self, data: &[u8]) -> Vec<u8> {
        let mut h = vec![0u8; 352];
        let be = self.big_endian;
        let mut put = |offset: usize, bytes: &[u8]| {
            let mut bytes = bytes.to_vec();
            if be {
                bytes.reverse();
            }
            h[offset..offset + bytes.len()].copy_from_slice(&bytes);
        };
        put(0, &348i32.to_le_bytes());
        for (a, d) in self.dim.iter().enumerate() {
            put(40 + 2 * a, &d.to_le_bytes());
        }
        put(70, &self.datatype.to_le_bytes());
        put(72, &self.bitpix.to_le_bytes());
        for (a, p) in self.pixdim.iter().enumerate() {
            put(76 + 4 * a, &p.to_le_bytes());
        }
        put(108, &352f32.to_le_bytes());
        put(112, &self.slope.to_le_bytes());
        put(116, &self.inter.to_le_bytes());
        put(252, &self.qform_code.to_le_bytes());
        put(254, &self.sform_code.to_le_bytes());
        for (a, q) in self.quatern.iter().enumerate() {
            put(256 + 4 * a, &q.to_le_bytes());
        }
        for (r, row) in self.srow.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                put(280 + 16 * r + 4 * c, &v.to_le_bytes());
            }
        }
        h[344..348].copy_from_slice(&self.magic);
        h.extend(data);
        h
    }
}

#[test]
fn nifti_sform_scaling_and_spacing() {
    let dir = tempfile::tempdir().unwrap();
    let t = ty(ScalarType::I16);
    let values = values_for(t.scalar, 24);
    let mut header = Nifti::new([4, 3, 2], t);
    header.pixdim = [1.0, 0.5, 0.75, 2.0, 1.0, 1.0, 1.0, 1.0];
    header.slope = 2.0;
    header.inter = -1.0;
    header.sform_code = 1;
    header.srow = [
        [0.5, 0.0, 0.0, 1.0],
        [0.0, 0.75, 0.0, 2.0],
        [0.0, 0.0, 2.0, 3.0],
    ];
    let path = dir.path().join("sform.nii");
    std::fs::write(&path, header.bytes(&encode(t.scalar, &values, false))).unwrap();
    let (volume, info) = load_with_info(&path, &opts()).unwrap();
    assert_eq!(info.format, "NIfTI-1");
    assert_eq!(info.scalar, "int16");
    assert_eq!(volume.dims(), [4, 3, 2]);
    assert_eq!(volume.spacing(), Vec3::new(0.5, 0.75, 2.0));
    assert_eq!(volume.origin(), Vec3::new(1.0, 2.0, 3.0));
    let scaled: Vec<f32> = values.iter().map(|v| (v * 2.0 - 1.0) as f32).collect();
    assert_eq!(volume.values(), scaled);
}

#[test]
fn nifti_gz_big_endian_qform_with_qfac_flips_z() {
    let dir = tempfile::tempdir().unwrap();
    let t = ty(ScalarType::F32);
    let values = values_for(t.scalar, 24);
    let mut header = Nifti::new([2, 3, 4], t);
    header.big_endian = true;
    header.pixdim = [-1.0, 1.5, 1.0, 0.5, 1.0, 1.0, 1.0, 1.0];
    header.qform_code = 1;
    header.quatern = [0.0, 0.0, 0.0, 5.0, 6.0, 7.0];
    let path = dir.path().join("qform.nii.gz");
    std::fs::write(&path, gzip(&header.bytes(&encode(t.scalar, &values, true)))).unwrap();
    let volume = load(&path, &opts()).unwrap();
    assert_eq!(volume.spacing(), Vec3::new(1.5, 1.0, 0.5));
    // qfac = -1: stored slice k sits at z = 7 - 0.5 k; the last (z = 5.5) comes first.
    assert_eq!(volume.origin(), Vec3::new(5.0, 6.0, 5.5));
    for k in 0..4 {
        for j in 0..3 {
            for i in 0..2 {
                assert_eq!(volume.at(i, j, k), values[i + 2 * (j + 3 * (3 - k))] as f32);
            }
        }
    }
}

#[test]
fn nifti_negative_sform_x_flips_x_and_unscaled_types_load() {
    let dir = tempfile::tempdir().unwrap();
    for t in TYPES {
        let values = values_for(t.scalar, 24);
        let mut header = Nifti::new([4, 3, 2], t);
        header.dim[0] = 4; // 4-D with one time point
        header.slope = f32::NAN; // nibabel's "no scaling"
        header.sform_code = 2;
        header.srow = [
            [-2.0, 0.0, 0.0, 10.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let path = dir.path().join(format!("{}.nii", t.scalar.name()));
        std::fs::write(&path, header.bytes(&encode(t.scalar, &values, false))).unwrap();
        let (volume, info) = load_with_info(&path, &opts()).unwrap();
        assert_eq!(info.scalar, t.scalar.name());
        assert_eq!(volume.spacing(), Vec3::new(2.0, 1.0, 1.0));
        assert_eq!(volume.origin(), Vec3::new(4.0, 0.0, 0.0));
        for k in 0..2 {
            for j in 0..3 {
                for i in 0..4 {
                    assert_eq!(
                        volume.at(i, j, k),
                        values[(3 - i) + 4 * (j + 3 * k)] as f32,
                        "{t:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn nifti_without_transform_uses_pixdim() {
    let dir = tempfile::tempdir().unwrap();
    let t = ty(ScalarType::U8);
    let values = values_for(t.scalar, 8);
    let mut header = Nifti::new([2, 2, 2], t);
    header.pixdim = [1.0, 0.25, 0.5, 4.0, 1.0, 1.0, 1.0, 1.0];
    let path = dir.path().join("plain.nii");
    std::fs::write(&path, header.bytes(&encode(t.scalar, &values, false))).unwrap();
    let volume = load(&path, &opts()).unwrap();
    assert_eq!(volume.spacing(), Vec3::new(0.25, 0.5, 4.0));
    assert_eq!(volume.origin(), Vec3::ZERO);
    assert_eq!(volume.values(), as_f32(&values));
}

#[test]
fn raw_round_trips_with_header_bytes_and_byte_order() {
    let dir = tempfile::tempdir().unwrap();
    for (scalar, big_endian, header_bytes) in [
        (ScalarType::U16, true, 7u64),
        (ScalarType::F64, false, 0),
        (ScalarType::I8, false, 1),
    ] {
        let values = values_for(scalar, 30);
        let mut file = vec![0xAB; header_bytes as usize];
        file.extend(encode(scalar, &values, big_endian));
        let path = dir.path().join(format!("{}.raw", scalar.name()));
        std::fs::write(&path, file).unwrap();
        let options = LoadOptions {
            raw: Some(RawSpec {
                dims: [5, 3, 2],
                scalar,
                spacing: Vec3::new(0.1, 0.2, 0.3),
                origin: Vec3::new(-1.0, 0.0, 1.0),
                big_endian,
                header_bytes,
            }),
            ..opts()
        };
        let (volume, info) = load_with_info(&path, &options).unwrap();
        assert_eq!(info.format, "raw");
        assert_eq!(volume.dims(), [5, 3, 2]);
        assert_eq!(volume.spacing(), Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(volume.origin(), Vec3::new(-1.0, 0.0, 1.0));
        assert_eq!(volume.values(), as_f32(&values));
    }
}

/// Writes a .npy file the way numpy does: header padded with spaces to a multiple of 64 bytes.
fn write_npy(path: &Path, version: u8, descr: &str, fortran: bool, shape: &[usize], data: &[u8]) {
    let shape: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
    let fortran = if fortran { "True" } else { "False" };
    let mut dict = format!(
        "{{'descr': '{descr}', 'fortran_order': {fortran}, 'shape': ({}), }}",
        shape.join(", ")
    );
    let prelude = if version == 1 { 10 } else { 12 };
    while (prelude + dict.len() + 1) % 64 != 0 {
        dict.push(' ');
    }
    dict.push('\n');
    let mut file = b"\x93NUMPY".to_vec();
    file.extend([version, 0]);
    if version == 1 {
        file.extend((dict.len() as u16).to_le_bytes());
    } else {
        file.extend((dict.len() as u32).to_le_bytes());
    }
    file.extend(dict.bytes());
    file.extend(data);
    std::fs::write(path, file).unwrap();
}

#[test]
fn npy_c_order_maps_last_axis_to_x() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny, nz) = (4, 3, 2);
    // arr[z][y][x] = 100 z + 10 y + x, saved in C order with shape (nz, ny, nx).
    let values: Vec<f64> = (0..nz)
        .flat_map(|z| {
            (0..ny).flat_map(move |y| (0..nx).map(move |x| (100 * z + 10 * y + x) as f64))
        })
        .collect();
    for (version, scalar, big_endian) in [
        (1, ScalarType::F32, false),
        (2, ScalarType::F64, true),
        (1, ScalarType::I16, true),
        (3, ScalarType::U32, false),
    ] {
        let descr = format!("{}{}", if big_endian { '>' } else { '<' }, ty(scalar).npy);
        let path = dir.path().join(format!("c{version}{}.npy", scalar.name()));
        write_npy(
            &path,
            version,
            &descr,
            false,
            &[nz, ny, nx],
            &encode(scalar, &values, big_endian),
        );
        let (volume, info) = load_with_info(&path, &opts()).unwrap();
        assert_eq!(info.scalar, scalar.name());
        assert_eq!(volume.dims(), [nx, ny, nz]);
        assert_eq!(volume.spacing(), Vec3::ONE);
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    assert_eq!(volume.at(x, y, z), (100 * z + 10 * y + x) as f32, "{descr}");
                }
            }
        }
    }
}

#[test]
fn npy_in_fortran_order_loads_as_the_same_array_in_c_order() {
    // Issue 38: a Fortran-order file loaded transposed against the C-order file of the same
    // array (and against `occlux.Volume(array)` in Python, which reads logical order).
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny, nz) = (4, 3, 2);
    // The array a[z][y][x] = 100 z + 10 y + x, stored with x fastest (C) or z fastest (Fortran).
    let value = |x: usize, y: usize, z: usize| (100 * z + 10 * y + x) as u8;
    let mut c_bytes = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            c_bytes.extend((0..nx).map(|x| value(x, y, z)));
        }
    }
    let mut fortran_bytes = Vec::new();
    for x in 0..nx {
        for y in 0..ny {
            fortran_bytes.extend((0..nz).map(|z| value(x, y, z)));
        }
    }
    let (c_path, f_path) = (dir.path().join("c.npy"), dir.path().join("fortran.npy"));
    write_npy(&c_path, 1, "|u1", false, &[nz, ny, nx], &c_bytes);
    write_npy(&f_path, 1, "|u1", true, &[nz, ny, nx], &fortran_bytes);
    let (c, fortran) = (
        load(&c_path, &opts()).unwrap(),
        load(&f_path, &opts()).unwrap(),
    );
    assert_eq!(c.dims(), [nx, ny, nz]);
    assert_eq!(fortran.dims(), [nx, ny, nz]);
    assert_eq!(fortran.values(), c.values());
    assert_eq!(c.at(3, 2, 1), 123.0);
}

// ---------------------------------------------------------------------------------------------
// Time series: 4-D NRRD and NIfTI-1 files read a frame at a time.

/// Voxels of the test series: x, y, z, time steps.
const SERIES: [usize; 4] = [5, 4, 3, 3];

/// Every voxel of every frame of the series distinct: i + 10 j + 100 k + 1000 t.
fn series_value(i: usize, j: usize, k: usize, t: usize) -> f64 {
    (i + 10 * j + 100 * k + 1000 * t) as f64
}

/// The series as stored: x fastest, time slowest.
fn series_values() -> Vec<f64> {
    let [nx, ny, nz, nt] = SERIES;
    (0..nx * ny * nz * nt)
        .map(|n| series_value(n % nx, n / nx % ny, n / (nx * ny) % nz, n / (nx * ny * nz)))
        .collect()
}

/// Checks that `volume` is frame `t` of the series: world voxel n holds the value stored at
/// `stored(n)`, through `scale`.
fn assert_series_frame(
    volume: &Volume,
    t: usize,
    stored: impl Fn([usize; 3]) -> [usize; 3],
    scale: impl Fn(f64) -> f64,
    name: &str,
) {
    assert_eq!(volume.dims(), [5, 4, 3], "{name}");
    for k in 0..3 {
        for j in 0..4 {
            for i in 0..5 {
                let [si, sj, sk] = stored([i, j, k]);
                assert_eq!(
                    volume.at(i, j, k),
                    scale(series_value(si, sj, sk, t)) as f32,
                    "{name}: frame {t}, voxel [{i}, {j}, {k}]"
                );
            }
        }
    }
}

fn frame(t: usize) -> LoadOptions {
    LoadOptions {
        frame: Some(t),
        ..opts()
    }
}

/// A series of 3 read without a frame, and at frame 3, is refused with the count.
fn assert_series_needs_a_frame(path: &Path) {
    assert_mentions(
        &failure(path, &opts()),
        &[
            "holds 3 time steps",
            "a frame must be chosen",
            "occlux series",
        ],
    );
    assert_mentions(
        &failure(path, &frame(3)),
        &["frame 3 does not exist", "3 time steps (frames 0 to 2)"],
    );
}

/// NRRD fields of the series: stored z runs down (slice k at z = 3 - 2 k); the time axis'
/// `none` gives the frames no placement of their own.
const SERIES_NRRD: [(&str, &str); 8] = [
    ("type", "uint16"),
    ("dimension", "4"),
    ("sizes", "5 4 3 3"),
    ("endian", "little"),
    ("space", "right-anterior-superior"),
    ("space directions", "(0.5,0,0) (0,0.25,0) (0,0,-2) none"),
    ("space origin", "(1,2,3)"),
    ("kinds", "domain domain domain time"),
];

/// World voxel n of the NRRD series is stored at z reversed.
fn nrrd_series_stored([i, j, k]: [usize; 3]) -> [usize; 3] {
    [i, j, 2 - k]
}

#[test]
fn nrrd_series_reads_each_frame_raw_gzip_and_detached() {
    let dir = tempfile::tempdir().unwrap();
    let data = encode(ScalarType::U16, &series_values(), false);
    let raw = with(&SERIES_NRRD, "encoding", "raw");
    let attached = small_nrrd(dir.path(), "raw.nrrd", &raw, &data);
    let gzipped = small_nrrd(
        dir.path(),
        "gzip.nrrd",
        &with(&SERIES_NRRD, "encoding", "gzip"),
        &gzip(&data),
    );
    // Detached, the series ending a data file after other bytes (byte skip -1).
    let mut tail = b"junk".to_vec();
    tail.extend(&data);
    std::fs::write(dir.path().join("series.raw"), tail).unwrap();
    let detached = small_nrrd(
        dir.path(),
        "tail.nhdr",
        &with(&with(&raw, "data file", "series.raw"), "byte skip", "-1"),
        &[],
    );
    for path in [&attached, &gzipped, &detached] {
        let name = path.display().to_string();
        assert_eq!(frame_count(path, &opts()).unwrap(), 3, "{name}");
        for t in 0..3 {
            let volume = load(path, &frame(t)).unwrap();
            assert_eq!(volume.spacing(), Vec3::new(0.5, 0.25, 2.0), "{name}");
            assert_eq!(volume.origin(), Vec3::new(1.0, 2.0, -1.0), "{name}");
            assert_series_frame(&volume, t, nrrd_series_stored, |v| v, &name);
        }
        assert_series_needs_a_frame(path);
    }
}

#[test]
fn nrrd_series_frames_are_read_alone() {
    let dir = tempfile::tempdir().unwrap();
    let data = encode(ScalarType::U16, &series_values(), false);
    let raw = with(&SERIES_NRRD, "encoding", "raw");
    // Cut inside the last frame: the others read, the last says what is missing.
    let cut = small_nrrd(dir.path(), "cut.nrrd", &raw, &data[..data.len() - 10]);
    let volume = load(&cut, &frame(1)).unwrap();
    assert_series_frame(&volume, 1, nrrd_series_stored, |v| v, "cut");
    assert_mentions(
        &failure(&cut, &frame(2)),
        &[
            "raw data of frame 2 of 3 truncated",
            "need 120 bytes, found 110",
        ],
    );
    // Bytes left over after the series show when its last frame is read.
    let long = small_nrrd(
        dir.path(),
        "long.nrrd",
        &raw,
        &[&data[..], &[7, 7]].concat(),
    );
    let volume = load(&long, &frame(0)).unwrap();
    assert_series_frame(&volume, 0, nrrd_series_stored, |v| v, "long");
    assert_mentions(
        &failure(&long, &frame(2)),
        &["raw data of frame 2 of 3 longer than expected"],
    );
}

#[test]
fn nifti_series_reads_each_frame_scaled_from_nii_and_gz() {
    let dir = tempfile::tempdir().unwrap();
    let t = ty(ScalarType::I16);
    let mut header = Nifti::new([5, 4, 3], t);
    header.dim[0] = 4;
    header.dim[4] = 3;
    header.pixdim[4] = 0.7; // seconds between frames: nothing to a frame's placement
    header.slope = 2.0;
    header.inter = -1.0;
    header.sform_code = 1;
    // Stored x runs toward -x: column i sits at x = 4 - 0.5 i.
    header.srow = [
        [-0.5, 0.0, 0.0, 4.0],
        [0.0, 0.25, 0.0, 2.0],
        [0.0, 0.0, 2.0, 3.0],
    ];
    let file = header.bytes(&encode(t.scalar, &series_values(), false));
    let nii = dir.path().join("series.nii");
    std::fs::write(&nii, &file).unwrap();
    let gz = dir.path().join("series.nii.gz");
    std::fs::write(&gz, gzip(&file)).unwrap();
    for path in [&nii, &gz] {
        let name = path.display().to_string();
        assert_eq!(frame_count(path, &opts()).unwrap(), 3, "{name}");
        for t in 0..3 {
            let volume = load(path, &frame(t)).unwrap();
            assert_eq!(volume.spacing(), Vec3::new(0.5, 0.25, 2.0), "{name}");
            assert_eq!(volume.origin(), Vec3::new(2.0, 2.0, 3.0), "{name}");
            assert_series_frame(
                &volume,
                t,
                |[i, j, k]| [4 - i, j, k],
                |v| v * 2.0 - 1.0,
                &name,
            );
        }
        assert_series_needs_a_frame(path);
    }
}

#[test]
fn files_without_a_series_hold_one_frame() {
    let dir = tempfile::tempdir().unwrap();
    let values = values_for(ScalarType::U16, 64);
    let data = encode(ScalarType::U16, &values, false);
    let u8_data = encode(ScalarType::U8, &values_for(ScalarType::U8, 64), false);
    let four_d = with(&U16_4X4X4, "dimension", "4");
    let nifti = dir.path().join("volume.nii");
    std::fs::write(
        &nifti,
        Nifti::new([4, 4, 4], ty(ScalarType::U8)).bytes(&u8_data),
    )
    .unwrap();
    let mut one_time_point = Nifti::new([4, 4, 4], ty(ScalarType::U8));
    one_time_point.dim[0] = 4;
    let nifti_4d = dir.path().join("one.nii");
    std::fs::write(&nifti_4d, one_time_point.bytes(&u8_data)).unwrap();
    let npy = dir.path().join("volume.npy");
    write_npy(&npy, 1, "<u2", false, &[4, 4, 4], &data);
    let raw = dir.path().join("volume.raw");
    std::fs::write(&raw, &data).unwrap();
    let raw_spec = LoadOptions {
        raw: Some(RawSpec {
            dims: [4, 4, 4],
            scalar: ScalarType::U16,
            spacing: Vec3::ONE,
            origin: Vec3::ZERO,
            big_endian: false,
            header_bytes: 0,
        }),
        ..opts()
    };
    let files = [
        (small_nrrd(dir.path(), "3d.nrrd", &U16_4X4X4, &data), opts()),
        // 4-D with one time step, or a size-1 first axis (a vector of one component, not
        // 4 steps of a 1-voxel-wide volume).
        (
            small_nrrd(
                dir.path(),
                "last.nrrd",
                &with(&four_d, "sizes", "4 4 4 1"),
                &data,
            ),
            opts(),
        ),
        (
            small_nrrd(
                dir.path(),
                "first.nrrd",
                &with(&four_d, "sizes", "1 4 4 4"),
                &data,
            ),
            opts(),
        ),
        (nifti, opts()),
        (nifti_4d, opts()),
        (npy, opts()),
        (raw, raw_spec),
    ];
    for (path, options) in &files {
        let name = path.display().to_string();
        assert_eq!(frame_count(path, options).unwrap(), 1, "{name}");
        let whole = load(path, options).unwrap();
        let first = LoadOptions {
            frame: Some(0),
            ..options.clone()
        };
        assert_eq!(load(path, &first).unwrap(), whole, "{name}");
        assert_eq!(whole.dims(), [4, 4, 4], "{name}");
        let second = LoadOptions {
            frame: Some(1),
            ..options.clone()
        };
        assert_mentions(
            &failure(path, &second),
            &["frame 1 does not exist", "1 time step (frame 0 only)"],
        );
    }
    assert_eq!(
        load(&files[0].0, &opts()).unwrap().values(),
        as_f32(&values)
    );
    // frame_count fails as the loaders do.
    let missing = dir.path().join("missing.npy");
    assert!(matches!(
        frame_count(&missing, &opts()),
        Err(Error::Io { .. })
    ));
    let unknown = dir.path().join("volume.tiff");
    assert!(frame_count(&unknown, &opts())
        .unwrap_err()
        .to_string()
        .contains("unsupported file extension"));
}

// ---------------------------------------------------------------------------------------------
// Bad input: each names the file and the problem, and none panics.

fn small_nrrd(dir: &Path, name: &str, fields: &[(&str, &str)], data: &[u8]) -> PathBuf {
    let path = dir.join(name);
    write_nrrd(&path, fields, data);
    path
}

const U16_4X4X4: [(&str, &str); 5] = [
    ("type", "uint16"),
    ("dimension", "3"),
    ("sizes", "4 4 4"),
    ("endian", "little"),
    ("encoding", "raw"),
];

/// NRRD header fields, in order.
type Fields = Vec<(&'static str, &'static str)>;

/// Replaces (or adds) a field of a header.
fn with(
    fields: &[(&'static str, &'static str)],
    name: &'static str,
    value: &'static str,
) -> Fields {
    let mut out: Vec<_> = fields.iter().copied().filter(|(n, _)| *n != name).collect();
    out.push((name, value));
    out
}

/// The loaders decode a payload a few MiB at a time: a volume of several such chunks (doubles,
/// so a chunk holds half as many values as bytes) must come out whole, in order, and a file cut
/// in a later chunk must say how much of it arrived.
#[test]
fn payloads_of_several_decode_chunks_load_whole_and_truncate_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [97, 89, 211]; // 1.8 M doubles, 14.6 MB: four chunks, none aligned to a row
    let count = dims.iter().product::<usize>();
    let values: Vec<f64> = (0..count).map(|i| (i % 65_521) as f64 - 3e4).collect();
    let packed = encode(ScalarType::F64, &values, true);
    let sizes = format!("{} {} {}", dims[0], dims[1], dims[2]);
    for encoding in ["raw", "gzip"] {
        let fields = [
            ("type", "double"),
            ("dimension", "3"),
            ("sizes", sizes.as_str()),
            ("endian", "big"),
            ("encoding", encoding),
        ];
        let data = |bytes: &[u8]| match encoding {
            "gzip" => gzip(bytes),
            _ => bytes.to_vec(),
        };
        let path = dir.path().join(format!("whole-{encoding}.nrrd"));
        write_nrrd(&path, &fields, &data(&packed));
        let volume = load(&path, &opts()).unwrap();
        assert_eq!(volume.values(), as_f32(&values), "{encoding}");

        let cut_at = packed.len() - 1_000_003;
        let cut = dir.path().join(format!("cut-{encoding}.nrrd"));
        write_nrrd(&cut, &fields, &data(&packed[..cut_at]));
        assert_mentions(
            &failure(&cut, &opts()),
            &[
                "truncated",
                &format!("need {} bytes, found {cut_at}", packed.len()),
            ],
        );
    }
}

#[test]
fn truncated_payloads_state_expected_and_found_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let full = encode(ScalarType::U16, &values_for(ScalarType::U16, 64), false);

    let raw = small_nrrd(dir.path(), "short.nrrd", &U16_4X4X4, &full[..100]);
    assert_mentions(
        &failure(&raw, &opts()),
        &[
            "raw data truncated",
            "4x4x4 uint16",
            "128 bytes",
            "found 100",
        ],
    );

    let compressed = gzip(&full);
    let gz_fields = with(&U16_4X4X4, "encoding", "gzip");
    let cut = small_nrrd(
        dir.path(),
        "cut.nrrd",
        &gz_fields,
        &compressed[..compressed.len() / 2],
    );
    assert_mentions(
        &failure(&cut, &opts()),
        &["gzip data", "truncated", "128 bytes"],
    );

    // A complete gzip stream that holds less than the header claims.
    let less = small_nrrd(dir.path(), "less.nrrd", &gz_fields, &gzip(&full[..64]));
    assert_mentions(
        &failure(&less, &opts()),
        &["gzip data truncated", "need 128 bytes, found 64"],
    );

    let mut long = full.clone();
    long.extend([0, 0]);
    let more = small_nrrd(dir.path(), "more.nrrd", &U16_4X4X4, &long);
    assert_mentions(
        &failure(&more, &opts()),
        &["longer than expected", "128 bytes"],
    );

    let raw_file = dir.path().join("short.raw");
    std::fs::write(&raw_file, &full[..100]).unwrap();
    let spec = RawSpec {
        dims: [4, 4, 4],
        scalar: ScalarType::U16,
        spacing: Vec3::ONE,
        origin: Vec3::ZERO,
        big_endian: false,
        header_bytes: 7,
    };
    let options = LoadOptions {
        raw: Some(spec),
        ..opts()
    };
    assert_mentions(
        &failure(&raw_file, &options),
        &[
            "file is 100 bytes, too small",
            "a 7-byte header and",
            "need 135",
        ],
    );

    // A file longer than the layout is said to be too large, by how much.
    let raw_file = dir.path().join("long.raw");
    std::fs::write(&raw_file, vec![0u8; 135 + 9]).unwrap();
    assert_mentions(
        &failure(&raw_file, &options),
        &["file is 144 bytes, too large", "need 135, 9 fewer"],
    );
}

#[test]
fn bad_nrrd_fields_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let data = vec![0u8; 128];
    let cases: Vec<(&str, Fields, &[&str])> = vec![
        (
            "complex",
            with(&U16_4X4X4, "type", "complex"),
            &["type: 'complex' is not supported", "uint8"],
        ),
        (
            "int64",
            with(&U16_4X4X4, "type", "long long"),
            &["type: 'long long' is not supported"],
        ),
        (
            "notype",
            U16_4X4X4
                .iter()
                .copied()
                .filter(|f| f.0 != "type")
                .collect(),
            &["missing required field 'type'"],
        ),
        (
            "dim2",
            with(&with(&U16_4X4X4, "dimension", "2"), "sizes", "8 8"),
            &["dimension: only 3-D", "got 2"],
        ),
        (
            "vectorfirst",
            with(
                &with(&with(&U16_4X4X4, "dimension", "4"), "sizes", "2 2 4 4"),
                "kinds",
                "vector domain domain domain",
            ),
            &["kinds: axis 0", "'vector'", "per-voxel components"],
        ),
        (
            "colourlast",
            with(
                &with(&with(&U16_4X4X4, "dimension", "4"), "sizes", "2 2 4 4"),
                "kinds",
                "domain domain domain RGBA-color",
            ),
            &["kinds: axis 3", "'RGBA-color'", "per-voxel components"],
        ),
        (
            "zero",
            with(&U16_4X4X4, "sizes", "4 0 4"),
            &["sizes: each size must be a positive integer, got '0'"],
        ),
        (
            "negative",
            with(&U16_4X4X4, "sizes", "4 4 -4"),
            &["sizes", "got '-4'"],
        ),
        (
            "count",
            with(&U16_4X4X4, "sizes", "4 4"),
            &["sizes", "2 values for dimension 3"],
        ),
        (
            "spacing0",
            with(&U16_4X4X4, "spacings", "1 0 1"),
            &["spacings: axis 1", "positive and finite, got 0"],
        ),
        (
            "spacingneg",
            with(&U16_4X4X4, "spacings", "-1 1 1"),
            &["spacings: axis 0", "got -1"],
        ),
        (
            "spacingnan",
            with(&U16_4X4X4, "spacings", "1 1 nan"),
            &["spacings: axis 2", "got NaN"],
        ),
        (
            "spacingtext",
            with(&U16_4X4X4, "spacings", "1 one 1"),
            &["spacings: expected numbers"],
        ),
        (
            "direction0",
            with(&U16_4X4X4, "space directions", "(1,0,0) (0,1,0) (0,0,0)"),
            &["space directions: axis 2"],
        ),
        (
            "directionnone",
            with(&U16_4X4X4, "space directions", "(1,0,0) none (0,0,1)"),
            &["space directions: axis 1 is 'none'"],
        ),
        (
            "origin",
            with(&U16_4X4X4, "space origin", "(1,2)"),
            &["space origin: expected a vector"],
        ),
        (
            "endian",
            U16_4X4X4
                .iter()
                .copied()
                .filter(|f| f.0 != "endian")
                .collect(),
            &["endian: missing", "uint16"],
        ),
        (
            "encoding",
            with(&U16_4X4X4, "encoding", "bzip2"),
            &["encoding: 'bzip2' is not supported"],
        ),
        (
            "skip",
            with(&U16_4X4X4, "byte skip", "500"),
            &["byte skip", "ends after"],
        ),
    ];
    for (name, fields, parts) in cases {
        let path = small_nrrd(dir.path(), &format!("{name}.nrrd"), &fields, &data);
        assert_mentions(&failure(&path, &opts()), parts);
    }
}

#[test]
fn non_finite_values_are_rejected_or_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let mut values = values_for(ScalarType::F32, 24);
    values[1 + 2 * (2 + 3 * 3)] = f64::NAN; // voxel (1, 2, 3) of 2x3x4
    values[5] = f64::INFINITY; // voxel (1, 2, 0)
    let data = encode(ScalarType::F32, &values, false);
    let fields = [
        ("type", "float"),
        ("dimension", "3"),
        ("sizes", "2 3 4"),
        ("endian", "little"),
        ("encoding", "raw"),
    ];
    let path = small_nrrd(dir.path(), "nan.nrrd", &fields, &data);
    assert_mentions(
        &failure(&path, &opts()),
        &["voxel [1, 2, 0]", "inf", "non-finite"],
    );

    let npy = dir.path().join("nan.npy");
    write_npy(&npy, 1, "<f4", false, &[4, 3, 2], &data);
    assert_mentions(&failure(&npy, &opts()), &["voxel [1, 2, 0]", "non-finite"]);

    let replaced = LoadOptions {
        non_finite: NonFinite::Replace(0.5),
        ..opts()
    };
    let volume = load(&path, &replaced).unwrap();
    assert_eq!(volume.at(1, 2, 3), 0.5);
    assert_eq!(volume.at(1, 2, 0), 0.5);
    assert_eq!(volume.at(0, 0, 0), values[0] as f32);
    assert_eq!(
        volume.values().iter().filter(|&&v| v == 0.5).count(),
        2 + values.iter().filter(|&&v| v == 0.5).count()
    );
}

#[test]
fn absurd_sizes_fail_on_the_budget_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    // Garbage in place of gzip data: reading it would fail differently.
    for encoding in ["raw", "gzip"] {
        let fields = [
            ("type", "uchar"),
            ("dimension", "3"),
            ("sizes", "100000 100000 100000"),
            ("encoding", encoding),
        ];
        let path = small_nrrd(
            dir.path(),
            &format!("huge_{encoding}.nrrd"),
            &fields,
            &garbage(16),
        );
        let started = std::time::Instant::now();
        assert_mentions(
            &failure(&path, &opts()),
            &["100000x100000x100000", "available"],
        );
        assert!(started.elapsed().as_secs_f32() < 1.0);
    }
    let npy = dir.path().join("huge.npy");
    write_npy(
        &npy,
        1,
        "<f4",
        false,
        &[100_000, 100_000, 100_000],
        &[0; 16],
    );
    assert_mentions(&failure(&npy, &opts()), &["available ("]);

    let nii = dir.path().join("huge.nii");
    std::fs::write(
        &nii,
        Nifti::new([30000, 30000, 30000], ty(ScalarType::U8)).bytes(&[0; 16]),
    )
    .unwrap();
    assert_mentions(&failure(&nii, &opts()), &["available ("]);

    let raw = dir.path().join("huge.raw");
    std::fs::write(&raw, [0u8; 16]).unwrap();
    let spec = RawSpec {
        dims: [100_000, 100_000, 100_000],
        scalar: ScalarType::U8,
        spacing: Vec3::ONE,
        origin: Vec3::ZERO,
        big_endian: false,
        header_bytes: 0,
    };
    assert_mentions(
        &failure(
            &raw,
            &LoadOptions {
                raw: Some(spec),
                ..opts()
            },
        ),
        &["available ("],
    );

    // A small budget applies to small files too.
    let fields = [
        ("type", "uchar"),
        ("dimension", "3"),
        ("sizes", "4 4 4"),
        ("encoding", "raw"),
    ];
    let path = small_nrrd(dir.path(), "small.nrrd", &fields, &[0; 64]);
    let tight = LoadOptions {
        memory: cap(100),
        ..opts()
    };
    assert_mentions(&failure(&path, &tight), &["available (a test's cap)"]);
    assert!(load(
        &path,
        &LoadOptions {
            memory: cap(256),
            ..opts()
        }
    )
    .is_ok());
}

#[test]
fn empty_garbage_and_wrong_magic_files() {
    let dir = tempfile::tempdir().unwrap();
    let raw_spec = RawSpec {
        dims: [2, 2, 2],
        scalar: ScalarType::U8,
        spacing: Vec3::ONE,
        origin: Vec3::ZERO,
        big_endian: false,
        header_bytes: 0,
    };
    let raw_opts = LoadOptions {
        raw: Some(raw_spec),
        ..opts()
    };
    let cases: Vec<(&str, Vec<u8>, &[&str])> = vec![
        ("empty.nrrd", vec![], &["file is empty", "NRRD"]),
        ("empty.nhdr", vec![], &["file is empty"]),
        (
            "empty.nii",
            vec![],
            &["NIfTI-1 header", "empty or truncated"],
        ),
        ("empty.nii.gz", vec![], &["NIfTI-1 header"]),
        ("empty.npy", vec![], &["too short for a .npy header"]),
        ("empty.raw", vec![], &["file is 0 bytes", "need 8"]),
        ("garbage.nrrd", garbage(5000), &["not a NRRD file"]),
        ("garbage.nii", garbage(5000), &["NIfTI-1"]),
        ("garbage.nii.gz", garbage(5000), &["not start as gzip does"]),
        ("garbage.npy", garbage(5000), &["not a .npy file"]),
        (
            "magic.nrrd",
            b"NRRD0009\ntype: uchar\n\n".to_vec(),
            &["not a NRRD file", "NRRD0009"],
        ),
        (
            "magic2.nrrd",
            b"NRRX0004\ntype: uchar\n\n".to_vec(),
            &["not a NRRD file"],
        ),
        (
            "magic.npy",
            b"\x93NUMPZ\x01\x00\x10\x00{}".to_vec(),
            &["not a .npy file"],
        ),
        (
            "version.npy",
            b"\x93NUMPY\x09\x00\x10\x00{}".to_vec(),
            &["format version 9.0"],
        ),
        (
            "header.npy",
            b"\x93NUMPY\x01\x00\x40\x00{'descr'".to_vec(),
            &["too short"],
        ),
        (
            "noline.nrrd",
            b"NRRD0004\ntype uchar\n\n".to_vec(),
            &["header line 2", "field: value"],
        ),
        (
            "twice.nrrd",
            b"NRRD0004\ntype: uchar\ntype: uchar\n\n".to_vec(),
            &["'type' given twice"],
        ),
    ];
    for (name, bytes, parts) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        assert_mentions(&failure(&path, &raw_opts), parts);
    }
}

#[test]
fn bad_nifti_headers_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let t = ty(ScalarType::U8);
    let data = [0u8; 8];
    let mut cases: Vec<(&str, Nifti, &[&str])> = Vec::new();
    let mut pair = Nifti::new([2, 2, 2], t);
    pair.magic = *b"ni1\0";
    cases.push(("pair", pair, &["hdr/.img pair"]));
    let mut magic = Nifti::new([2, 2, 2], t);
    magic.magic = *b"xyz\0";
    cases.push(("magic", magic, &["not a NIfTI-1 file"]));
    let mut complex = Nifti::new([2, 2, 2], t);
    complex.datatype = 32;
    cases.push((
        "complex",
        complex,
        &["datatype 32 is not supported", "512 (uint16)"],
    ));
    let mut flat = Nifti::new([2, 2, 2], t);
    flat.dim[0] = 2;
    cases.push(("flat", flat, &["dim[0] = 2", "3-D"]));
    // dim[0] outside 1..=7 made the nifti crate read the header byte-swapped, and the error
    // named a sizeof_hdr of 1543569408.
    let mut nine = Nifti::new([2, 2, 2], t);
    nine.dim[0] = 9;
    cases.push(("nine", nine, &["dim[0] = 9", "1 to 7"]));
    let mut series = Nifti::new([2, 2, 2], t);
    series.dim[0] = 4;
    series.dim[4] = 3;
    cases.push((
        "series",
        series,
        &["holds 3 time steps", "frame must be chosen"],
    ));
    let mut components = Nifti::new([2, 2, 2], t);
    components.dim[0] = 5;
    components.dim[5] = 3;
    cases.push((
        "components",
        components,
        &["dim[5] = 3", "per-voxel components"],
    ));
    let mut negative = Nifti::new([2, -2, 2], t);
    negative.pixdim[1] = 1.0;
    cases.push(("negative", negative, &["dim[2] = -2", "positive"]));
    let mut pixdim = Nifti::new([2, 2, 2], t);
    pixdim.pixdim[2] = 0.0;
    cases.push(("pixdim", pixdim, &["pixdim", "axis 1", "positive"]));
    let mut nan = Nifti::new([2, 2, 2], t);
    nan.sform_code = 1;
    nan.srow = [
        [1.0, 0.0, 0.0, f32::NAN],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ];
    cases.push(("nan", nan, &["sform", "not finite"]));
    for (name, header, parts) in cases {
        let path = dir.path().join(format!("{name}.nii"));
        std::fs::write(&path, header.bytes(&data)).unwrap();
        assert_mentions(&failure(&path, &opts()), parts);
    }
    let truncated = dir.path().join("truncated.nii");
    std::fs::write(&truncated, Nifti::new([2, 2, 3], t).bytes(&data)).unwrap();
    assert_mentions(
        &failure(&truncated, &opts()),
        &["NIfTI data truncated", "need 12 bytes, found 8"],
    );
    // Incompressible data, so that cutting the stream's end cuts the data, not the header.
    let gz = dir.path().join("truncated.nii.gz");
    let compressed = gzip(&Nifti::new([8, 8, 8], t).bytes(&garbage(512)));
    std::fs::write(&gz, &compressed[..compressed.len() - 100]).unwrap();
    assert_mentions(&failure(&gz, &opts()), &["NIfTI data", "truncated"]);
    // A .nii.gz that is not gzip: was Rust's Debug text of the decoder's error.
    let plain = dir.path().join("plain.nii.gz");
    std::fs::write(&plain, Nifti::new([2, 2, 2], t).bytes(&data)).unwrap();
    let message = failure(&plain, &opts());
    assert_mentions(&message, &["gzip", "name it .nii"]);
    assert!(!message.contains("Custom"), "{message}");
}

#[test]
fn bad_npy_headers_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, &[usize], &[&str]); 4] = [
        (
            "complex",
            "<c8",
            &[2, 2, 2],
            &["dtype '<c8' is not supported"],
        ),
        ("int64", "<i8", &[2, 2, 2], &["dtype '<i8'"]),
        ("flat", "<f4", &[4, 4], &["shape [4, 4]", "3-D"]),
        ("zero", "<f4", &[2, 0, 2], &["shape [2, 0, 2]"]),
    ];
    for (name, descr, shape, parts) in cases {
        let path = dir.path().join(format!("{name}.npy"));
        write_npy(&path, 1, descr, false, shape, &[0; 32]);
        assert_mentions(&failure(&path, &opts()), parts);
    }
    let path = dir.path().join("dict.npy");
    let mut file = b"\x93NUMPY\x01\x00\x0c\x00".to_vec();
    file.extend(b"{'descr': 3}");
    std::fs::write(&path, file).unwrap();
    assert_mentions(&failure(&path, &opts()), &["bad .npy header", "descr"]);
}

#[test]
fn missing_files_unknown_extensions_and_raw_without_a_spec() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "missing.nrrd",
        "missing.nii",
        "missing.nii.gz",
        "missing.npy",
        "missing.vdb",
    ] {
        let path = dir.path().join(name);
        let error = load(&path, &opts()).unwrap_err();
        assert!(
            matches!(error, Error::Io { .. }) || name.ends_with(".vdb"),
            "{name}: {error}"
        );
        assert!(
            error.to_string().contains(&path.display().to_string()),
            "{error}"
        );
    }
    let nhdr = dir.path().join("detached.nhdr");
    std::fs::write(
        &nhdr,
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: gone.raw\n",
    )
    .unwrap();
    let error = load(&nhdr, &opts()).unwrap_err();
    assert!(matches!(error, Error::Io { .. }), "{error}");
    assert!(error.to_string().contains("gone.raw"), "{error}");

    let unknown = dir.path().join("volume.xyz");
    std::fs::write(&unknown, [0u8; 8]).unwrap();
    assert_mentions(
        &failure(&unknown, &opts()),
        &["unsupported file extension", ".nrrd", ".nii.gz", ".npy"],
    );

    let raw = dir.path().join("volume.raw");
    std::fs::write(&raw, [0u8; 8]).unwrap();
    assert_mentions(
        &failure(&raw, &opts()),
        &["no header", "dims", "type", "spacing"],
    );
    let bad_spacing = RawSpec {
        dims: [2, 2, 2],
        scalar: ScalarType::U8,
        spacing: Vec3::new(1.0, f32::NAN, 1.0),
        origin: Vec3::ZERO,
        big_endian: false,
        header_bytes: 0,
    };
    assert_mentions(
        &failure(
            &raw,
            &LoadOptions {
                raw: Some(bad_spacing),
                ..opts()
            },
        ),
        &["raw spacing: axis 1", "positive and finite"],
    );
}

#[test]
fn loaded_volumes_match_a_direct_construction() {
    // The loader's output is an ordinary Volume: equal to one built from the same numbers.
    let dir = tempfile::tempdir().unwrap();
    let values = values_for(ScalarType::U8, 8);
    let path = small_nrrd(
        dir.path(),
        "cube.nrrd",
        &[
            ("type", "uint8"),
            ("dimension", "3"),
            ("sizes", "2 2 2"),
            ("spacings", "3 3 3"),
            ("encoding", "raw"),
        ],
        &encode(ScalarType::U8, &values, false),
    );
    let direct = Volume::new([2, 2, 2], Vec3::splat(3.0), Vec3::ZERO, as_f32(&values)).unwrap();
    assert_eq!(load(&path, &opts()).unwrap(), direct);
}

/// A world grid and the same grid stored with its axes in another order and direction: the
/// stored array, its dims, and its frame (the world step of each stored axis and the world
/// position of stored voxel 0), with `axes[a]` the world axis of stored axis a.
struct Stored {
    dims: [usize; 3],
    values: Vec<f32>,
    steps: [[f64; 3]; 3],
    origin: [f64; 3],
}

fn stored_as(world: &Volume, axes: [usize; 3], flip: [bool; 3]) -> Stored {
    let w = world.dims();
    let dims = axes.map(|a| w[a]);
    let spacing = world.spacing();
    let mut values = Vec::with_capacity(world.values().len());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let stored = [i, j, k];
                let mut n = [0; 3];
                for a in 0..3 {
                    n[axes[a]] = if flip[a] {
                        dims[a] - 1 - stored[a]
                    } else {
                        stored[a]
                    };
                }
                values.push(world.at(n[0], n[1], n[2]));
            }
        }
    }
    let mut steps = [[0.0; 3]; 3];
    let mut origin = world.origin().to_array().map(f64::from);
    for a in 0..3 {
        let sign = if flip[a] { -1.0 } else { 1.0 };
        steps[a][axes[a]] = sign * spacing[axes[a]] as f64;
        if flip[a] {
            origin[axes[a]] += (dims[a] - 1) as f64 * spacing[axes[a]] as f64;
        }
    }
    Stored {
        dims,
        values,
        steps,
        origin,
    }
}

fn write_nifti_frame(path: &Path, stored: &Stored) {
    let t = ty(ScalarType::F32);
    let d = stored.dims.map(|n| n as i16);
    let mut header = Nifti::new(d, t);
    header.sform_code = 1;
    for r in 0..3 {
        header.srow[r] = [
            stored.steps[0][r] as f32,
            stored.steps[1][r] as f32,
            stored.steps[2][r] as f32,
            stored.origin[r] as f32,
        ];
    }
    let data: Vec<u8> = stored.values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, header.bytes(&data)).unwrap();
}

/// The frame in LPS (x and y negated), as 3D Slicer writes NRRD.
fn write_nrrd_lps(path: &Path, stored: &Stored) {
    let lps = |v: [f64; 3]| format!("({},{},{})", -v[0], -v[1], v[2]);
    let directions: Vec<String> = stored.steps.iter().map(|&s| lps(s)).collect();
    let sizes = format!("{} {} {}", stored.dims[0], stored.dims[1], stored.dims[2]);
    let data: Vec<u8> = stored.values.iter().flat_map(|v| v.to_le_bytes()).collect();
    write_nrrd(
        path,
        &[
            ("type", "float"),
            ("dimension", "3"),
            ("space", "left-posterior-superior"),
            ("sizes", &sizes),
            ("space directions", &directions.join(" ")),
            ("space origin", &lps(stored.origin)),
            ("endian", "little"),
            ("encoding", "raw"),
        ],
        &data,
    );
}

#[test]
fn a_volume_stored_in_any_axis_order_and_direction_loads_to_the_same_world_grid() {
    let dir = tempfile::tempdir().unwrap();
    // Every voxel distinct, so any transposition or mirror shows.
    let dims = [5, 4, 3];
    let values: Vec<f32> = (0..60).map(|v| (v * 7 % 61) as f32 + 0.5).collect();
    let world = Volume::new(
        dims,
        Vec3::new(0.5, 1.0, 2.0),
        Vec3::new(1.0, -2.0, 3.0),
        values,
    )
    .unwrap();
    let orders = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for axes in orders {
        for flips in 0..8 {
            let flip = [0, 1, 2].map(|a| flips >> a & 1 == 1);
            let stored = stored_as(&world, axes, flip);
            let nifti = dir.path().join("scan.nii");
            let nrrd = dir.path().join("scan.nrrd");
            write_nifti_frame(&nifti, &stored);
            write_nrrd_lps(&nrrd, &stored);
            for path in [&nifti, &nrrd] {
                let case = format!(
                    "{} stored as axes {axes:?} flipped {flip:?}",
                    path.display()
                );
                let (volume, info) = load_with_info(path, &opts()).unwrap();
                assert_eq!(info.frame, Frame::Reordered { axes, flip }, "{case}");
                assert_eq!(volume.dims(), world.dims(), "{case}");
                assert_eq!(volume.spacing(), world.spacing(), "{case}");
                assert!(
                    (volume.origin() - world.origin()).length() < 1e-5,
                    "{case}: origin {} against {}",
                    volume.origin(),
                    world.origin()
                );
                assert_eq!(volume.values(), world.values(), "{case}");
            }
        }
    }
}

#[test]
fn an_oblique_frame_is_resampled_onto_world_axes_exactly_for_a_linear_field() {
    let dir = tempfile::tempdir().unwrap();
    // A slab tilted 25 degrees about z and 15 about x, with anisotropic voxels.
    let (a, b) = (25f64.to_radians(), 15f64.to_radians());
    let rz = |v: [f64; 3]| {
        [
            v[0] * a.cos() - v[1] * a.sin(),
            v[0] * a.sin() + v[1] * a.cos(),
            v[2],
        ]
    };
    let rx = |v: [f64; 3]| {
        [
            v[0],
            v[1] * b.cos() - v[2] * b.sin(),
            v[1] * b.sin() + v[2] * b.cos(),
        ]
    };
    let spacing = [1.0, 1.5, 2.0];
    let steps = [0, 1, 2].map(|i| {
        let mut e = [0.0; 3];
        e[i] = spacing[i];
        rx(rz(e))
    });
    let origin = [4.0, -3.0, 2.0];
    let dims = [9usize, 8, 7];
    let field = |p: [f64; 3]| 0.3 * p[0] - 0.2 * p[1] + 0.5 * p[2] + 10.0;
    let world_of = |i: [f64; 3]| {
        [0, 1, 2].map(|w| origin[w] + (0..3).map(|c| i[c] * steps[c][w]).sum::<f64>())
    };
    let mut values = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                values.push(field(world_of([i as f64, j as f64, k as f64])) as f32);
            }
        }
    }
    let stored = Stored {
        dims,
        values: values.clone(),
        steps,
        origin,
    };
    let path = dir.path().join("oblique.nii");
    write_nifti_frame(&path, &stored);
    let (volume, info) = load_with_info(&path, &opts()).unwrap();
    let Frame::Resampled { degrees } = info.frame else {
        panic!("an oblique frame must be resampled, got {:?}", info.frame);
    };
    assert!((20.0..=30.0).contains(&degrees), "{degrees}");
    assert!(info.frame.to_string().contains("oblique"), "{}", info.frame);
    // Each world axis as fine as the stored axis nearest it (x, y, z here).
    assert!((volume.spacing() - Vec3::new(1.0, 1.5, 2.0)).length() < 1e-6);
    let lowest = values.iter().copied().fold(f32::INFINITY, f32::min);
    let inverse = glam::DMat3::from_cols_array_2d(&steps).inverse();
    let (mut inside, mut outside) = (0, 0);
    let [nx, ny, nz] = volume.dims();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = (volume.origin()
                    + Vec3::new(i as f32, j as f32, k as f32) * volume.spacing())
                .as_dvec3();
                let index = inverse * (p - glam::DVec3::from_array(origin));
                let d = glam::DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
                let v = volume.at(i, j, k);
                if index.cmpge(glam::DVec3::ZERO).all() && index.cmple(d - 1.0).all() {
                    // Trilinear interpolation reproduces a linear field.
                    let expected = field(p.to_array()) as f32;
                    assert!(
                        (v - expected).abs() < 1e-4 * expected.abs(),
                        "{v} vs {expected} at {p}"
                    );
                    inside += 1;
                } else if index.cmplt(glam::DVec3::splat(-0.5)).any() || index.cmpgt(d - 0.5).any()
                {
                    assert_eq!(v, lowest, "outside the stored box at {p}");
                    outside += 1;
                }
            }
        }
    }
    assert!(
        inside > 100 && outside > 100,
        "{inside} inside, {outside} outside"
    );
    // Every stored centre lies within the resampled box.
    let (lo, hi) = volume.bounds();
    for c in 0..8 {
        let corner = [0, 1, 2].map(|a| {
            if c >> a & 1 == 1 {
                (dims[a] - 1) as f64
            } else {
                0.0
            }
        });
        let p = Vec3::from_array(world_of(corner).map(|x| x as f32));
        assert!(
            p.cmpge(lo).all() && p.cmple(hi).all(),
            "{p} outside {lo} .. {hi}"
        );
    }
}

#[test]
fn frames_that_cannot_be_placed_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.nrrd");
    let case = |space: &str, directions: &str| {
        let mut fields = vec![
            ("type", "uchar"),
            ("dimension", "3"),
            ("sizes", "2 2 2"),
            ("space directions", directions),
            ("encoding", "raw"),
        ];
        if !space.is_empty() {
            fields.push(("space", space));
        }
        write_nrrd(&path, &fields, &[1, 2, 3, 4, 5, 6, 7, 8]);
        failure(&path, &opts())
    };
    let parallel = case("", "(1,0,0) (2,0,0) (0,0,1)");
    assert_mentions(&parallel, &["space directions", "parallel"]);
    let left = case("3D-left-handed", "(1,0,0) (0,1,0) (0,0,1)");
    assert_mentions(&left, &["space", "left-handed", "mirror"]);
    let unknown = case("right-posterior-inferior", "(1,0,0) (0,1,0) (0,0,1)");
    assert_mentions(&unknown, &["space", "right-posterior-inferior"]);
    // An oblique frame whose world-aligned grid would exceed the memory budget.
    let small = LoadOptions {
        memory: cap(64),
        ..opts()
    };
    write_nrrd(
        &path,
        &[
            ("type", "uchar"),
            ("dimension", "3"),
            ("sizes", "2 2 2"),
            ("space directions", "(0.6,0.8,0) (-0.8,0.6,0) (0,0,1)"),
            ("encoding", "raw"),
        ],
        &[1, 2, 3, 4, 5, 6, 7, 8],
    );
    assert_mentions(
        &failure(&path, &small),
        &["oblique", "world-aligned grid", "available (a test's cap)"],
    );
}

/// Found by fuzzing (fuzz/README.md): an sform with spacings of 3e38 and 3e-29 loaded, and its
/// box overflowed to infinity.
#[test]
fn a_frame_whose_box_f32_cannot_hold_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let t = ty(ScalarType::U8);
    let cases: [([f32; 3], [f32; 3], &[&str]); 2] = [
        ([1.0, 1.0, 3.3e38], [0.0; 3], &["box", "overflows"]),
        ([1e-3, 1.0, 1.0], [1e5, 0.0, 0.0], &["too small", "spacing"]),
    ];
    for (spacing, origin, words) in cases {
        let mut header = Nifti::new([2, 2, 2], t);
        header.sform_code = 1;
        for r in 0..3 {
            header.srow[r][r] = spacing[r];
            header.srow[r][3] = origin[r];
        }
        let path = dir.path().join("huge.nii");
        std::fs::write(&path, header.bytes(&[0u8; 8])).unwrap();
        assert_mentions(&failure(&path, &opts()), words);
    }
}

/// Every input fuzzing found (fuzz/README.md), kept as found: each must be refused with an
/// error that names the problem, not abort or load.
#[test]
fn inputs_found_by_fuzzing_are_refused_by_name() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz");
    let cases = [
        // vdb-rs would allocate 8e18 bytes for a block and abort the process.
        (
            "vdb-block-of-8e18-bytes.vdb",
            &["corrupt OpenVDB", "claims 8314045559560208389 bytes"][..],
        ),
        // Loaded with a box that overflowed f32.
        ("nifti-spacing-3e38.nii", &["box", "overflows"][..]),
        // 4e9 grids whose offsets point back: the header check re-read one region for minutes.
        (
            "vdb-grid-offsets-pointing-back.vdb",
            &["corrupt OpenVDB", "does not follow its descriptor"][..],
        ),
    ];
    for (name, words) in cases {
        assert_mentions(&failure(&folder.join(name), &opts()), words);
    }
}

/// Files that say their values are Hounsfield units are recognised: a CT's DICOM rescale on
/// integer data or a description naming HU in NIfTI, `sample units` in NRRD; other rescales,
/// float data with the same intercept, and files without a word about it are not.
#[test]
fn files_that_say_their_values_are_hounsfield_units_are_recognised() {
    let dir = tempfile::tempdir().unwrap();
    let nifti = |name: &str, t: Ty, slope: f32, inter: f32, descrip: &[u8]| {
        let values = values_for(t.scalar, 8);
        let mut header = Nifti::new([2, 2, 2], t);
        header.slope = slope;
        header.inter = inter;
        let mut bytes = header.bytes(&encode(t.scalar, &values, false));
        bytes[148..148 + descrip.len()].copy_from_slice(descrip);
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        load_with_info(&path, &opts()).unwrap().1.hounsfield
    };
    let int16 = ty(ScalarType::I16);
    let why = nifti("ct.nii", int16, 1.0, -1024.0, b"").expect("a CT rescale");
    assert!(why.contains("scl_inter -1024"), "{why}");
    assert!(nifti("mr.nii", int16, 2.0, -1024.0, b"").is_none());
    assert!(nifti("float.nii", ty(ScalarType::F32), 1.0, -1024.0, b"").is_none());
    assert!(nifti("plain.nii", int16, 1.0, 0.0, b"T1 MPRAGE").is_none());
    let why = nifti("described.nii", int16, 0.0, 0.0, b"CT abdomen (HU)").expect("descrip");
    assert!(why.contains("descrip"), "{why}");
    // "HU" only as a word: not inside another.
    assert!(nifti("word.nii", int16, 0.0, 0.0, b"SHUTTLE scan").is_none());

    let nrrd = |name: &str, units: Option<&str>| {
        let mut fields = vec![
            ("type", "short"),
            ("dimension", "3"),
            ("sizes", "2 2 2"),
            ("encoding", "raw"),
            ("endian", "little"),
        ];
        if let Some(u) = units {
            fields.push(("sample units", u));
        }
        let path = small_nrrd(dir.path(), name, &fields, &[0u8; 16]);
        load_with_info(&path, &opts()).unwrap().1.hounsfield
    };
    assert!(nrrd("hu.nrrd", Some("HU"))
        .unwrap()
        .contains("sample units"));
    assert!(nrrd("hounsfield.nrrd", Some("Hounsfield units")).is_some());
    assert!(nrrd("mm.nrrd", Some("mm")).is_none());
    assert!(nrrd("none.nrrd", None).is_none());
}

/// A memory budget of `bytes`, as a user's cap.
fn cap(bytes: u64) -> occlux::memory::MemoryBudget {
    occlux::memory::MemoryBudget {
        limit: occlux::memory::MemoryLimit::Bytes(bytes, "a test's cap"),
        ..Default::default()
    }
}
