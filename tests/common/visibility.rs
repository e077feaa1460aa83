//! What the tests of the visibility (the mean transmittance over all directions) share: a
//! homogeneous ball, small scenes under ambient light, and the Monte Carlo sphere reference.

use glam::Vec3;
use occlux::ao::reference::{ao_reference_at, AoReferenceParams, AoVariant};
use occlux::scene::Scene;
use occlux::volume::Volume;
use rand::{Rng, SeedableRng};
use std::path::Path;

/// A ball of radius `r` (world units) of extinction `sigma` in the cube [-1, 1]^3, `n`^3 voxels.
pub fn ball(n: usize, r: f32, sigma: f32) -> Volume {
    let h = 2.0 / n as f32;
    let origin = Vec3::splat(-1.0 + 0.5 * h);
    Volume::from_fn([n; 3], Vec3::splat(h), origin, |p| {
        if p.length() <= r {
            sigma
        } else {
            0.0
        }
    })
    .unwrap()
}

/// RMSE and mean difference of the visibility that `visibility` computes from the extinction,
/// against the sphere reference over `count` random voxels holding matter, and the
/// reference's own noise.
pub fn against_reference(
    volume: &Volume,
    scene: &Scene,
    count: usize,
    visibility: impl Fn(&Volume) -> Volume,
) -> (f64, f64, f64) {
    let extinction = scene.classification.extinction(volume).unwrap();
    let swept = visibility(&extinction);
    let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
    let [nx, ny, nz] = volume.dims();
    let mut voxels = vec![];
    while voxels.len() < count {
        let v = [
            rng.random_range(0..nx),
            rng.random_range(0..ny),
            rng.random_range(0..nz),
        ];
        if extinction.at(v[0], v[1], v[2]) > 0.0 {
            voxels.push(v);
        }
    }
    let params = AoReferenceParams {
        variant: AoVariant::Sphere,
        samples: 512,
        seed: 3,
        radius: None,
    };
    let lut = scene.classification.bake(volume);
    let reference = ao_reference_at(volume, &lut, &params, &voxels).unwrap();
    let (mut sq, mut diff, mut noise) = (0.0, 0.0, 0.0);
    for (&[i, j, k], (want, se)) in voxels.iter().zip(&reference) {
        let d = (swept.at(i, j, k) - want) as f64;
        sq += d * d;
        diff += d;
        noise += (*se as f64).powi(2);
    }
    let n = voxels.len() as f64;
    ((sq / n).sqrt(), diff / n, (noise / n).sqrt())
}

pub fn scene_for(volume_section: &str) -> Scene {
    let text = format!(
        "{volume_section}\n[camera]\nposition = [3.2, -3.2, 2.6]\nwidth = 32\nheight = 32\n\
         [[lights]]\ntype = \"ambient\"\nradiance = 1\n"
    );
    Scene::parse(
        &text,
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("examples")
            .as_path(),
    )
    .unwrap()
}
