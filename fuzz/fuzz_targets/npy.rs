#![no_main]
//! NumPy `.npy`: any bytes.

use libfuzzer_sys::fuzz_target;
use occlux::volume::LoadOptions;

fuzz_target!(|data: &[u8]| {
    occlux_fuzz::load_as("npy", data, LoadOptions::default());
});
