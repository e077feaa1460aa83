//! Phase functions and direction sampling. Directions are directions of propagation: light
//! travelling along `w_in` scatters into `w_out` with probability density p(w_in . w_out).

use crate::method::{ParamKind, ParamSpec, Range};
use glam::Vec3;
use rand::Rng;
use std::f32::consts::PI;

/// The `[render]` key of the methods that scatter with Henyey-Greenstein's phase function.
pub const G: ParamSpec = ParamSpec {
    key: "g",
    doc: "Henyey-Greenstein asymmetry of the phase function (0: isotropic)",
    kind: ParamKind::Float {
        range: Range {
            min: -1.0,
            max: 1.0,
            min_inclusive: false,
            max_inclusive: false,
        },
        optional: false,
    },
};

/// Henyey-Greenstein's phase function with asymmetry `g` (0: isotropic, 1/(4 pi)).
#[inline]
pub fn henyey_greenstein(g: f32, cos_theta: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

/// A unit vector at polar cosine `cos_theta` from `axis`, with azimuth `phi`.
#[inline]
fn around(axis: Vec3, cos_theta: f32, phi: f32) -> Vec3 {
    let (t, b) = axis.any_orthonormal_pair();
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    (t * phi.cos() + b * phi.sin()) * sin_theta + axis * cos_theta
}

/// Samples a direction of propagation after scattering light travelling along `w_in`,
/// exactly proportional to Henyey-Greenstein (so the estimator's weight is 1).
#[inline]
pub fn sample_henyey_greenstein(g: f32, w_in: Vec3, rng: &mut impl Rng) -> Vec3 {
    let u = rng.random::<f32>();
    let cos_theta = if g.abs() < 1e-3 {
        1.0 - 2.0 * u
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    around(w_in, cos_theta, 2.0 * PI * rng.random::<f32>())
}

/// A direction uniformly distributed over the sphere.
#[inline]
pub fn sample_sphere(rng: &mut impl Rng) -> Vec3 {
    around(
        Vec3::Z,
        1.0 - 2.0 * rng.random::<f32>(),
        2.0 * PI * rng.random::<f32>(),
    )
}

/// A direction uniformly distributed in the cone of half-angle acos(`cos_aperture`) around
/// `axis` (the DOS cone phase function, whose density is 1 / (2 pi (1 - cos_aperture)) there).
#[inline]
pub fn sample_cone(axis: Vec3, cos_aperture: f32, rng: &mut impl Rng) -> Vec3 {
    let cos_theta = 1.0 - rng.random::<f32>() * (1.0 - cos_aperture);
    around(axis, cos_theta, 2.0 * PI * rng.random::<f32>())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn henyey_greenstein_is_normalised_and_sampled_exactly() {
        for g in [0.0f32, 0.3, -0.6, 0.9] {
            // Integral over the sphere: 2 pi * int_{-1}^{1} p(mu) dmu, by the midpoint rule.
            let n = 200_000;
            let total: f64 = (0..n)
                .map(|i| {
                    let mu = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
                    henyey_greenstein(g, mu as f32) as f64 * 2.0 / n as f64
                })
                .sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            assert!((total - 1.0).abs() < 1e-3, "g {g}: {total}");
            // The sampled mean cosine is g.
            let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
            let w_in = Vec3::new(0.3, -0.5, 0.8).normalize();
            let m = 100_000;
            let mean: f32 = (0..m)
                .map(|_| sample_henyey_greenstein(g, w_in, &mut rng).dot(w_in))
                .sum::<f32>()
                / m as f32;
            assert!((mean - g).abs() < 0.01, "g {g}: mean cosine {mean}");
        }
    }

    #[test]
    fn cone_samples_stay_in_the_cone_and_fill_it() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
        let axis = Vec3::new(1.0, 2.0, -2.0).normalize();
        let cos_aperture = 0.8f32;
        let n = 50_000;
        let mut mean = 0.0;
        for _ in 0..n {
            let w = sample_cone(axis, cos_aperture, &mut rng);
            assert!((w.length() - 1.0).abs() < 1e-5);
            assert!(w.dot(axis) >= cos_aperture - 1e-5);
            mean += w.dot(axis) / n as f32;
        }
        // Uniform in solid angle: the mean cosine is halfway between 1 and cos_aperture.
        assert!((mean - 0.9).abs() < 2e-3, "{mean}");
    }
}
