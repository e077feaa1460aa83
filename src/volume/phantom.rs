//! Synthetic phantoms with analytic features, for tests, the demo and stress cases.
//!
//! Every phantom fills the cube [-1, 1]^3 with `n^3` voxels (spacing 2/n, centres at
//! -1 + (i + 1/2) * 2/n). Sharp interfaces are anti-aliased over one voxel: the value is
//! `clamp(1/2 - d / h, 0, 1)` for a signed distance d (negative inside) and spacing h, so the
//! trilinear reconstruction integrates like the sharp interface at d = 0 (exactly so for planes
//! on voxel faces), which the closed-form transmittance tests rely on.

use super::Volume;
use crate::error::{Error, Result};
use glam::Vec3;

/// The phantom names `by_name` accepts.
pub const PHANTOMS: &[&str] = &[
    "ct",
    "marschner-lobb",
    "shells",
    "slab",
    "sphere",
    "cloud",
    "box-sphere",
];

/// Smallest phantom side (a trilinear cell needs two voxels a side).
pub const MIN_SIDE: usize = 2;

/// Largest phantom side (2048^3 f32 would be 32 GiB).
pub const MAX_SIDE: usize = 1024;

/// A phantom by name at `n` voxels a side.
pub fn by_name(name: &str, n: usize) -> Result<Volume> {
    match name {
        "ct" => ct(n),
        "marschner-lobb" => marschner_lobb(n),
        "shells" => shells(n),
        "slab" => slab(n, 0.5),
        "sphere" => sphere(n, 0.75),
        "cloud" => cloud(n, 1),
        "box-sphere" => box_and_sphere([n; 3]),
        other => Err(unknown(other)),
    }
}

/// Checks a phantom name without building it.
pub fn check_name(name: &str) -> Result<()> {
    if PHANTOMS.contains(&name) {
        Ok(())
    } else {
        Err(unknown(name))
    }
}

fn unknown(name: &str) -> Error {
    Error::param(
        "volume.phantom",
        format!("unknown phantom '{name}'; known: {}", PHANTOMS.join(", ")),
    )
}

fn cube(n: usize, f: impl Fn(Vec3) -> f32 + Sync) -> Result<Volume> {
    if !(MIN_SIDE..=MAX_SIDE).contains(&n) {
        return Err(Error::param(
            "volume.size",
            format!("phantom side must be in {MIN_SIDE}..={MAX_SIDE}, got {n}"),
        ));
    }
    let h = 2.0 / n as f32;
    Volume::from_fn([n; 3], Vec3::splat(h), Vec3::splat(-1.0 + 0.5 * h), f)
}

/// A ball resting on a floor next to a cube standing on it, values 1 inside and 0 outside
/// (anti-aliased): the occlusion sweeping paper's test scene, with contact creases, a cast
/// overhang and open sky. Cubic voxels of 2 / nx; x and y span [-1, 1], z is centred; the floor
/// is z < -0.3, the ball of radius 0.3 sits at (0.4, 0, 0), the cube of half side 0.25 at
/// (-0.4, 0, -0.05). Any dims from 16 a side (the ball needs z in [-0.3, 0.3]: nz >= 0.6 nx).
pub fn box_and_sphere(dims: [usize; 3]) -> Result<Volume> {
    let [nx, ny, nz] = dims;
    if dims.iter().any(|&d| !(16..=MAX_SIDE).contains(&d)) || 10 * nz < 6 * nx {
        return Err(Error::param(
            "volume.size",
            format!(
                "the box-and-sphere phantom needs sides in 16..={MAX_SIDE} and nz >= 0.6 nx, \
                 got {dims:?}"
            ),
        ));
    }
    let h = 2.0 / nx as f32;
    let origin = Vec3::new(
        -1.0 + 0.5 * h,
        -(ny as f32 - 1.0) * 0.5 * h,
        -(nz as f32 - 1.0) * 0.5 * h,
    );
    Volume::from_fn(dims, Vec3::splat(h), origin, |p| {
        let floor = p.z + 0.3;
        let ball = (p - Vec3::new(0.4, 0.0, 0.0)).length() - 0.3;
        let q = (p - Vec3::new(-0.4, 0.0, -0.05)).abs() - Vec3::splat(0.25);
        let cube = q.max(Vec3::ZERO).length() + q.max_element().min(0.0);
        coverage(floor.min(ball).min(cube), h)
    })
}

/// Anti-aliased inside indicator of a signed distance over voxels of spacing `h`.
#[inline]
pub fn coverage(signed_distance: f32, h: f32) -> f32 {
    (0.5 - signed_distance / h).clamp(0.0, 1.0)
}

/// Marschner and Lobb's (1994) test signal, f_M = 6, alpha = 1/4, on [-1, 1]^3; values in [0, 1].
pub fn marschner_lobb(n: usize) -> Result<Volume> {
    use std::f32::consts::PI;
    const FM: f32 = 6.0;
    const ALPHA: f32 = 0.25;
    cube(n, |p| {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let rho_r = (2.0 * PI * FM * (PI * r / 2.0).cos()).cos();
        (1.0 - (PI * p.z / 2.0).sin() + ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + ALPHA))
    })
}

/// Value 1 for |z| < `half_thickness`, 0 elsewhere: transmittance along z is exp(-sigma 2a).
pub fn slab(n: usize, half_thickness: f32) -> Result<Volume> {
    let h = 2.0 / n as f32;
    cube(n, |p| coverage(p.z.abs() - half_thickness, h))
}

/// Value 1 inside a centred sphere of `radius`: a chord at impact b has length 2 sqrt(R^2 - b^2).
pub fn sphere(n: usize, radius: f32) -> Result<Volume> {
    let h = 2.0 / n as f32;
    cube(n, |p| coverage(p.length() - radius, h))
}

/// Three nested spherical shells of values 0.3, 0.6 and 1.0 (outer to inner).
pub fn shells(n: usize) -> Result<Volume> {
    let h = 2.0 / n as f32;
    let shell = |r: f32, radius: f32| coverage((r - radius).abs() - 0.06, h);
    cube(n, |p| {
        let r = p.length();
        (0.3 * shell(r, 0.85))
            .max(0.6 * shell(r, 0.55))
            .max(shell(r, 0.25))
    })
}

/// A CT-like phantom: soft tissue (about 0.35) in an ellipsoid, a bone shell (about 0.9) around
/// it, two air cavities (0) inside, and a dense bone rod (1.0) through the middle; tissue and
/// bone carry a mild (+-6 %) smooth texture.
pub fn ct(n: usize) -> Result<Volume> {
    // Interfaces ramp over two voxels, like a scanner's point-spread, so gradient normals are
    // smooth (one-voxel ramps alias into rings under gradient shading).
    let h = 4.0 / n as f32;
    let radii = Vec3::new(0.85, 0.7, 0.6);
    cube(n, |p| {
        // Approximate signed distance of an ellipsoid: good enough for anti-aliasing.
        let q = p / radii;
        let k = q.length();
        let d_outer = (k - 1.0) * radii.min_element();
        let outer = coverage(d_outer, h);
        let inner = coverage(d_outer + 0.08, h);
        let tissue = 0.35 * inner;
        let bone = 0.9 * (outer - inner).max(0.0);
        let cavity_a = coverage((p - Vec3::new(0.35, 0.1, 0.1)).length() - 0.18, h);
        let cavity_b = coverage((p - Vec3::new(-0.3, -0.15, -0.05)).length() - 0.12, h);
        let rod = coverage(Vec3::new(p.x, p.y + 0.2, 0.0).length() - 0.07, h) * inner;
        let soft = tissue * (1.0 - cavity_a.max(cavity_b));
        // Mild texture, as real tissue has: gradients inside materials, not only at interfaces.
        let texture = 1.0 + 0.12 * (value_noise(p * 9.0, 11) - 0.5);
        ((soft + bone) * texture).max(rod).min(1.0)
    })
}

/// A deterministic fractal value-noise cloud in [0, 1], fading out towards the cube's faces.
pub fn cloud(n: usize, seed: u32) -> Result<Volume> {
    cube(n, |p| {
        let mut sum = 0.0;
        let mut amplitude = 0.5;
        let mut frequency = 3.0;
        for octave in 0..4 {
            sum += amplitude * value_noise(p * frequency, seed.wrapping_add(octave));
            amplitude *= 0.5;
            frequency *= 2.0;
        }
        let fade = (1.0 - p.length()).clamp(0.0, 0.3) / 0.3;
        ((sum - 0.35) * 2.5).clamp(0.0, 1.0) * fade
    })
}

/// Smoothly interpolated lattice noise in [0, 1].
fn value_noise(p: Vec3, seed: u32) -> f32 {
    let base = p.floor();
    let f = p - base;
    let s = f * f * (3.0 - 2.0 * f);
    let corner = |dx: i32, dy: i32, dz: i32| {
        lattice_hash(
            base.x as i32 + dx,
            base.y as i32 + dy,
            base.z as i32 + dz,
            seed,
        )
    };
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), s.x);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), s.x);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), s.x);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// A hash of a lattice point to [0, 1] (integer mixing, so it is the same on every platform).
fn lattice_hash(x: i32, y: i32, z: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f)
        ^ seed.wrapping_mul(0x9e37_79b9);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    h as f32 / u32::MAX as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phantoms_stay_in_unit_range_and_are_not_constant() {
        for name in PHANTOMS {
            let v = by_name(name, 24).unwrap();
            let (lo, hi) = v.value_range();
            assert!(
                lo >= 0.0 && hi <= 1.0 && hi - lo > 0.2,
                "{name}: {lo}..{hi}"
            );
            let (blo, bhi) = v.bounds();
            assert!((blo + Vec3::ONE).length() < 1e-5 && (bhi - Vec3::ONE).length() < 1e-5);
        }
    }

    #[test]
    fn marschner_lobb_matches_its_formula_at_the_centre() {
        // At the origin: r = 0, rho_r = cos(2 pi 6) = 1, so rho = (1 + 2 alpha) / (2 (1 + alpha)) = 0.6.
        let v = marschner_lobb(41).unwrap();
        assert!((v.sample(Vec3::ZERO) - 0.6).abs() < 1e-5);
    }

    #[test]
    fn bad_sizes_are_rejected() {
        assert!(by_name("ct", 1)
            .unwrap_err()
            .to_string()
            .contains("volume.size"));
        assert!(by_name("ct", 100_000).is_err());
        assert!(by_name("teapot", 8)
            .unwrap_err()
            .to_string()
            .contains("known"));
    }
}
