#![no_main]
//! Scene files: any text, parsed and validated (paths resolve against a folder that does not
//! exist, so no volume is read).

use libfuzzer_sys::fuzz_target;
use occlux::scene::Scene;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(scene) = Scene::parse(text, std::path::Path::new("/nonexistent-occlux-fuzz")) {
        // What `occlux scene` prints must be producible for anything that parses.
        let _ = scene.describe().to_string();
    }
});
