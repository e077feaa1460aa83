#![no_main]
//! Headerless `.raw`: the first 12 bytes are the layout a user would give (dims, type, byte
//! order, header bytes, spacing, origin), the rest is the file.

use libfuzzer_sys::fuzz_target;
use occlux::volume::{LoadOptions, RawSpec, ScalarType};

fuzz_target!(|data: &[u8]| {
    if data.len() < 12 {
        return;
    }
    let (spec, file) = data.split_at(12);
    // Spacings and origins from a small set that includes the invalid (0, negative, NaN, inf).
    let number = |b: u8| [1.0, 0.5, 2.0, 0.0, -1.0, f32::NAN, f32::INFINITY, 1e-30][b as usize % 8];
    let raw = RawSpec {
        dims: [spec[0], spec[1], spec[2]].map(|d| d as usize),
        scalar: ScalarType::ALL[spec[3] as usize % ScalarType::ALL.len()],
        big_endian: spec[4] & 1 == 1,
        header_bytes: spec[5] as u64,
        spacing: glam::Vec3::new(number(spec[6]), number(spec[7]), number(spec[8])),
        origin: glam::Vec3::new(number(spec[9]), number(spec[10]), number(spec[11])),
    };
    let options = LoadOptions {
        raw: Some(raw),
        ..LoadOptions::default()
    };
    occlux_fuzz::load_as("raw", file, options);
});
