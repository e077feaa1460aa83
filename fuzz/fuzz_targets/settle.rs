#![no_main]
//! The scene target's next step: scene text that parses is loaded against a small built-in
//! volume and settled (placement, classification window, content, framing), as `occlux render`
//! does before it renders. The first byte picks the phantom and its side (8 to 16 voxels), so
//! that a scene naming a file, or a 1024^3 phantom, still settles in microseconds; the rest is
//! the scene. Errors are fine; a panic, or a settled scene that breaks what the renderers and
//! the EXR header rely on, is a finding.

use libfuzzer_sys::fuzz_target;
use occlux::registry::Method;
use occlux::scene::{Scene, SourceKind};
use occlux::volume::phantom::PHANTOMS;
use serde_json::Value;

fuzz_target!(init: occlux_fuzz::one_thread(), |data: &[u8]| {
    let Some((&pick, text)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(text) else {
        return;
    };
    let Ok(mut scene) = Scene::parse(text, std::path::Path::new("/nonexistent-occlux-fuzz")) else {
        return;
    };
    let name = PHANTOMS[pick as usize % PHANTOMS.len()];
    let size = 8 + (pick as usize / PHANTOMS.len()) % 9;
    scene.volume.kind = SourceKind::Phantom {
        name: name.into(),
        size,
    };
    // Scene::load: the phantom placed by `fit` and `centre`, then framing::settle.
    let Ok(loaded) = scene.load() else {
        return;
    };
    occlux_fuzz::check(&loaded.volume);
    let settled = &loaded.scene;
    // The classification with its window resolved is what the EXR header records and what a
    // scene may give back as `range`: it must be one a scene accepts.
    settled
        .classification
        .validate()
        .expect("the settled classification validates");
    let camera = &settled.camera;
    assert!(
        [camera.position, camera.forward, camera.right, camera.up]
            .iter()
            .all(|v| v.is_finite()),
        "the settled camera is finite: {camera:?}"
    );
    assert!(
        camera.forward.is_normalized() && camera.right.is_normalized() && camera.up.is_normalized(),
        "the settled camera's frame is unit: {camera:?}"
    );
    settled
        .lighting
        .validate()
        .expect("the settled lights validate");
    if settled.auto.is_none() {
        settled
            .method
            .spec()
            .check_lights(&settled.lighting)
            .expect("the method renders the settled lights");
    }
    // The method as the EXR header's `occlux/method` records it reads back as a `[render]`.
    let Value::Object(table) = settled.method.to_json() else {
        panic!("a method is a JSON object");
    };
    if let Err(e) = Method::from_table(table) {
        panic!("the settled method's own parameters are refused: {e}");
    }
    let _ = settled.describe().to_string();
});
