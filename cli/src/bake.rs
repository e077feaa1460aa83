//! The body of `occlux bake`: the baked light grids of a scene (src/bake.rs), with progress and
//! timing, into OUT/STEM-bake.vdb and OUT/STEM-bake.json.

use occlux::bake::{
    ambient_multiple_grids, bake, light_grid, multiple_grids, stages, BakeParams, AO,
};
use occlux::error::Result;
use occlux::export::atomic::check_writable;
use occlux::export::vdb::VdbOptions;
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{stem, write_bake};
use occlux::scene::Scene;
use occlux_lab::term::{notice, report_written, say, Bar};
use std::path::Path;
use std::time::Instant;

pub fn bake_scene(
    scene: &Path,
    params: &BakeParams,
    device: DeviceChoice,
    out: &Path,
    vdb: &VdbOptions,
    quiet: bool,
) -> Result<()> {
    let parsed = Scene::from_file(scene)?;
    check_writable(out)?;
    let (compute, device_notice) = Compute::resolve(device)?;
    if let Some(line) = device_notice {
        notice(quiet, line);
    }
    let volume = parsed.load_volume()?;
    let bar = Bar::new(quiet, stages(&parsed.lighting, params), "bake");
    let started = Instant::now();
    let baked = bake(
        &compute,
        &volume,
        &parsed.classification,
        &parsed.lighting,
        params,
        &bar,
    )?;
    let bake_ms = started.elapsed().as_secs_f64() * 1e3;
    bar.finish();
    say(
        quiet,
        format_args!(
            "baked the ambient visibility and {} light(s): {bake_ms:.1} ms on {}",
            baked.lights.len(),
            compute.describe()
        ),
    );
    let lights: Vec<serde_json::Value> = baked
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            serde_json::json!({
                "scene_index": l.scene_index,
                "light": l.light,
                "grid": light_grid(i),
                "multiple": l.multiple.as_ref().map(|_| multiple_grids(i)),
            })
        })
        .collect();
    let record = serde_json::json!({
        "scene": scene.display().to_string(),
        "dims": volume.dims(),
        "ao": AO,
        "ao_multiple": baked.ao_multiple.as_ref().map(|_| ambient_multiple_grids()),
        "directions": params.directions,
        "g": params.g,
        "lights": lights,
        "grids": baked.grids().iter().map(|(name, _)| name.clone()).collect::<Vec<_>>(),
        "device": compute.describe(),
        "bake_ms": bake_ms,
    });
    let written = write_bake(&baked, &volume, &record, out, &stem(scene), vdb)?;
    report_written(&written, quiet);
    Ok(())
}
