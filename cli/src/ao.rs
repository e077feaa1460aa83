//! The bodies of `occlux ao` (a VAO volume) and `occlux ao-reference` (a Monte Carlo reference
//! AO volume): progress, timing, and the files they write.

use occlux::ao::reference::{ao_reference, AoReferenceParams, AoVariant};
use occlux::ao::{AoMethod, AoVolumeParams};
use occlux::error::{Error, Result};
use occlux::export::atomic::check_writable;
use occlux::export::vdb::{write_vdb, VdbGrid, VdbOptions};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{stem, write_ao};
use occlux::scene::Scene;
use occlux_lab::term::{notice, report_written, say, Bar};
use std::borrow::Cow;
use std::path::Path;
use std::time::Instant;

/// Computes an AO volume of the scene file's classified volume with progress and timing, and
/// writes `OUT/STEM-ao.{vdb,png,json}`.
pub fn ao_volume(
    scene: &Path,
    params: &AoVolumeParams,
    device: DeviceChoice,
    out: &Path,
    vdb: &VdbOptions,
    quiet: bool,
) -> Result<()> {
    params.validate()?;
    let parsed = Scene::from_file(scene)?;
    // A folder that cannot be written is found before the work, not after it.
    check_writable(out)?;
    let (compute, device_notice) = Compute::resolve(device)?;
    if let Some(line) = device_notice {
        notice(quiet, line);
    }
    let holder = format!("ao --method {}", params.method.name());
    let volume = parsed.load_volume_holding(params.peak_volumes(), &holder)?;
    let on = if params.method.cpu_only() {
        Compute::Cpu.describe()
    } else {
        compute.describe()
    };
    let bar = Bar::new(quiet, 1, "ao volume");
    let started = Instant::now();
    let dims = volume.dims();
    // The volume is given away: the method's field is made from it in place where it can be.
    let ao = occlux::ao::ao_volume(
        &compute,
        Cow::Owned(volume),
        &parsed.classification,
        params,
        &bar,
    )?;
    let ao_ms = started.elapsed().as_secs_f64() * 1e3;
    bar.finish();
    let reach = match params.method {
        AoMethod::Vao(_) => format!("radius {} voxels", params.radius),
        AoMethod::Sweep | AoMethod::SweepPhysical | AoMethod::Ordinates => {
            "the whole volume".to_owned()
        }
    };
    say(
        quiet,
        format_args!(
            "{} AO volume, {reach}: {ao_ms:.1} ms on {on}",
            params.method.name()
        ),
    );
    let record = serde_json::json!({
        "scene": scene.display().to_string(),
        "method": params.method,
        "radius_voxels": params.radius,
        "field": params.field,
        "convention": params.convention,
        "dims": dims,
        "device": on,
        "ao_ms": ao_ms,
    });
    let written = write_ao(&ao, &record, out, &stem(scene), vdb)?;
    report_written(&written, quiet);
    Ok(())
}

/// Estimates a reference AO volume of the scene file's classified volume and writes it as
/// `OUT/STEM-ao-VARIANT.vdb` (grids `ao` and, where the estimate is noisy, `ao_stderr`).
/// `radius` is in voxels of the smallest spacing.
pub fn ao_reference_volume(
    scene: &Path,
    variant: AoVariant,
    samples: u32,
    radius: Option<f32>,
    seed: u64,
    out: &Path,
    quiet: bool,
) -> Result<()> {
    let parsed = Scene::from_file(scene)?;
    let volume = parsed.load_volume()?;
    let params = AoReferenceParams {
        variant,
        samples,
        seed,
        radius: radius.map(|r| r * volume.spacing().min_element()),
    };
    let lut = parsed.classification.bake(&volume);
    let bar = Bar::new(quiet, volume.dims()[2] as u64, "sampling");
    let started = Instant::now();
    let ao = ao_reference(&volume, &lut, &params, &bar)?;
    bar.finish();
    let name = variant.name();
    say(
        quiet,
        format_args!(
            "{name} AO reference, {samples} samples per voxel, in {:.2} s",
            started.elapsed().as_secs_f64()
        ),
    );
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let path = out.join(format!("{}-ao-{name}.vdb", stem(scene)));
    let mut grids = vec![VdbGrid::from_volume("ao", &ao.openness)];
    // A noiseless estimate (e.g. every tangent-sphere sample tied) has no error grid.
    if ao.stderr.values().iter().any(|&e| e > 0.0) {
        grids.push(VdbGrid::from_volume("ao_stderr", &ao.stderr));
    }
    write_vdb(&path, &grids, &VdbOptions::default())?;
    report_written(&[path], quiet);
    Ok(())
}
