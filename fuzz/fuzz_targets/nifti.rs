#![no_main]
//! NIfTI-1: the first byte picks a plain `.nii` or a gzipped `.nii.gz`, the rest is the file.

use libfuzzer_sys::fuzz_target;
use occlux::volume::LoadOptions;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, file)) = data.split_first() else {
        return;
    };
    let extension = if pick & 1 == 0 { "nii" } else { "nii.gz" };
    occlux_fuzz::load_as(extension, file, LoadOptions::default());
});
