#![no_main]
//! OpenVDB (`.vdb`): any bytes.

use libfuzzer_sys::fuzz_target;
use occlux::volume::LoadOptions;

fuzz_target!(init: occlux_fuzz::quiet_caught_panics(), |data: &[u8]| {
    occlux_fuzz::load_as("vdb", data, LoadOptions::default());
});
