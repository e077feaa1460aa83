#![no_main]
//! NRRD with an attached header (`.nrrd`): any bytes.

use libfuzzer_sys::fuzz_target;
use occlux::volume::LoadOptions;

fuzz_target!(|data: &[u8]| {
    occlux_fuzz::load_as("nrrd", data, LoadOptions::default());
});
