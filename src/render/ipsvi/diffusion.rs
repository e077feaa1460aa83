//! IPSVI's multiple-scattering term: the fluence of scattered light along a light ray, from
//! the diffusion (P1) solution for a collimated beam crossing a slab.
//!
//! Light that has scattered once or more is not in the shadow transmittance T the cache
//! carries. The paper blends single and forward-scattered light by the albedo; this module
//! gives that blend a physical form. Along each light ray the medium is taken as a slab
//! across the ray: it begins where the light enters the volume, the sample lies at the optical
//! depth tau = -ln T travelled so far, and it ends where the light ray leaves the volume,
//! tau + tau_ahead (tau_ahead: the optical depth ahead of the sample, away from the light),
//! with the sample's albedo a and Henyey-Greenstein g throughout. Diffuse light also leaves
//! the body sideways; with nothing known of its width, the body is taken as wide as the slab
//! is deep, and the two directions across the light lose light as the lowest diffusion mode of
//! such a width does: an extra absorption D B^2, B^2 = 2 (pi / (L + 4 D))^2 (faces extrapolated
//! by 2 D). Without this the half-space alone overshot the `multiple` reference by +17 % on the
//! engine and +30 % on the bonsai and the tooth, whose bone (albedo near 1) loses its light
//! mostly sideways; with it, within a few per cent (docs/ipsvi.md). In units of the extinction, with
//! D = 1 / (3 (1 - a g)) (the reduced scattering of the similarity relation) and
//! mu = sqrt(3 (1 - a) (1 - a g) + B^2) (the diffuse light's effective attenuation), the
//! diffuse fluence per unit irradiance solves
//!
//!   -D phi'' + D mu^2 phi = a (1 + 3 D g) exp(-tau)
//!
//! (absorption and sideways escape; the first scattering as an isotropic source plus its
//! forward moment) with no diffuse light
//! entering either face (Marshak's conditions: phi - 2 D phi' = -6 D g a at tau = 0 and
//! phi + 2 D phi' = 6 D g a exp(-L) at tau = L), whence
//!
//!   phi(tau) = A exp(-tau) + P exp(-mu tau) + Q exp(-mu (L - tau)),  A = a (1 + 3 D g) / (D (mu^2 - 1)),
//!
//! P and Q from the two conditions. A, P and Q diverge where mu = 1 (a = 2/3 at g = 0) while
//! phi stays finite, so [`fluence`] evaluates them in a form without that cancellation. The
//! diffuse light is taken as isotropic: it scatters towards the eye with phase 1 / (4 pi).
//! What the slab leaves out, light escaping sideways and light arriving from other
//! directions, is measured against the path-traced `multiple` reference (docs/ipsvi.md,
//! "Multiple scattering").

/// Optical depths beyond this are treated as this (the fluence there is below 1e-30 unless
/// the albedo is 1).
const MAX_DEPTH: f32 = 1e4;

/// Albedos above this are treated as this: at 1 the slab's two diffuse modes merge (mu = 0)
/// and its conditions become singular; the fluence changes by < 0.1 % of itself.
const MAX_ALBEDO: f32 = 0.999;

/// B^2 of the two directions across the light for a body as wide as the slab is deep: the
/// lowest mode of each, (pi / (L + 4 D))^2, its faces extrapolated by 2 D.
#[inline]
fn lateral_escape(l: f32, d: f32) -> f32 {
    let w = std::f32::consts::PI / (l + 4.0 * d);
    2.0 * w * w
}

/// exp(-t) t h((1 - mu) t) with h(x) = expm1(x) / x: finite for mu near 1 and for large t.
#[inline]
fn spread(t: f32, mu: f32) -> f32 {
    let x = (1.0 - mu) * t;
    if x.abs() < 1e-4 {
        (-t).exp() * t * (1.0 + 0.5 * x)
    } else if x < 50.0 {
        (-t).exp() * x.exp_m1() / (1.0 - mu)
    } else {
        // = (exp(-mu t) - exp(-t)) / (1 - mu), which cannot overflow.
        ((-mu * t).exp() - (-t).exp()) / (1.0 - mu)
    }
}

/// Diffuse fluence per unit irradiance at optical depth `tau` along a light ray, in a slab
/// `tau + ahead` deep, for albedo `a` in [0, 1] and asymmetry `g` in (-1, 1); 0 where the P1
/// solution dips below it (strongly forward phases near a face).
#[inline]
pub fn fluence(tau: f32, ahead: f32, a: f32, g: f32) -> f32 {
    if a <= 0.0 {
        return 0.0;
    }
    let a = a.min(MAX_ALBEDO);
    // T = 0 (an opaque path) is tau = infinity: as deep as matters, and no inf * 0.
    let tau = tau.min(MAX_DEPTH);
    let l = (tau + ahead.max(0.0)).min(MAX_DEPTH);
    let d = 1.0 / (3.0 * (1.0 - a * g));
    let mu = (3.0 * (1.0 - a) * (1.0 - a * g) + lateral_escape(l, d)).sqrt();
    // A = F / (mu - 1) with F = a (1 + 3 D g) / (D (mu + 1)); writing P = P' - A, the pair
    // A (exp(-tau) - exp(-mu tau)) = F spread(tau), and the A-parts of P' and Q carry a factor
    // (mu - 1) that cancels analytically (module docs).
    let f = a * (1.0 + 3.0 * d * g) / (d * (mu + 1.0));
    let moment = 6.0 * d * g * a;
    let p = 1.0 + 2.0 * d * mu;
    let m = 1.0 - 2.0 * d * mu;
    let far = (-mu * l).exp();
    let beam_out = (-l).exp();
    let spread_l = spread(l, mu);
    let det = p * p - m * m * far * far;
    let near_face = (-p * moment - m * far * moment * beam_out
        + f * (2.0 * d * p + m * far * (m * spread_l + 2.0 * d * beam_out)))
        / det;
    let far_face = (p * moment * beam_out + m * far * moment
        - f * (4.0 * d * beam_out + m * (1.0 + 2.0 * d) * spread_l))
        / det;
    let phi =
        f * spread(tau, mu) + near_face * (-mu * tau).exp() + far_face * (-mu * (l - tau)).exp();
    phi.max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form solved directly in f64 (valid away from mu = 1): the particular part
    /// and the 2 x 2 system of the two faces' conditions.
    fn direct(tau: f64, l: f64, a: f64, g: f64) -> f64 {
        let d = 1.0 / (3.0 * (1.0 - a * g));
        let b2 = 2.0 * (std::f64::consts::PI / (l + 4.0 * d)).powi(2);
        let mu = (3.0 * (1.0 - a) * (1.0 - a * g) + b2).sqrt();
        let big_a = a * (1.0 + 3.0 * d * g) / (d * (mu * mu - 1.0));
        let moment = 6.0 * d * g * a;
        // [1 + 2 D mu, (1 - 2 D mu) E; (1 - 2 D mu) E, 1 + 2 D mu] [P; Q] = [r1; r2]
        let (p, m, e) = (1.0 + 2.0 * d * mu, 1.0 - 2.0 * d * mu, (-mu * l).exp());
        let r1 = -moment - big_a * (1.0 + 2.0 * d);
        let r2 = (-l).exp() * (moment - big_a * (1.0 - 2.0 * d));
        let det = p * p - m * m * e * e;
        let big_p = (p * r1 - m * e * r2) / det;
        let big_q = (p * r2 - m * e * r1) / det;
        big_a * (-tau).exp() + big_p * (-mu * tau).exp() + big_q * (-mu * (l - tau)).exp()
    }

    const CASES: [(f64, f64); 6] = [
        (0.3, 0.0),
        (0.8, 0.0),
        (0.95, 0.0),
        (0.5, 0.4),
        (0.9, -0.3),
        (0.99, 0.6),
    ];

    #[test]
    fn the_stable_form_is_the_closed_form() {
        for (a, g) in CASES {
            for l in [0.5, 2.0, 8.0, 40.0] {
                for tau in [0.0, 0.1 * l, 0.5 * l, l] {
                    let want = direct(tau, l, a, g).max(0.0);
                    let got = fluence(tau as f32, (l - tau) as f32, a as f32, g as f32) as f64;
                    assert!(
                        (got - want).abs() <= 2e-4 * (1.0 + want.abs()),
                        "a {a} g {g} L {l} tau {tau}: {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn it_solves_the_diffusion_equation_and_both_faces_conditions() {
        // Finite differences on the f32 evaluation, including mu = 1 (a = 0.7179 at g = 0 and
        // L = 10, with the sideways escape), where only the stable form is finite.
        for (a, g) in [(0.8, 0.0), (0.7179, 0.0), (0.6, 0.3), (0.99, 0.0)] {
            let d = 1.0 / (3.0 * (1.0 - a * g));
            let moment = 6.0 * d * g * a;
            for l in [3.0f64, 10.0] {
                let escape = 2.0 * d * (std::f64::consts::PI / (l + 4.0 * d)).powi(2);
                let phi = |t: f64| fluence(t as f32, (l - t) as f32, a as f32, g as f32) as f64;
                let h = 0.05;
                for tau in [0.3 * l, 0.5 * l, 0.8 * l] {
                    let second = (phi(tau + h) - 2.0 * phi(tau) + phi(tau - h)) / (h * h);
                    let lhs = -d * second + (1.0 - a + escape) * phi(tau);
                    let rhs = a * (1.0 + 3.0 * d * g) * (-tau).exp();
                    assert!(
                        (lhs - rhs).abs() < 0.01 * rhs.max(0.02) + 2e-3 * phi(tau),
                        "a {a} g {g} L {l} tau {tau}: {lhs} vs {rhs}"
                    );
                }
                let slope_in = (-3.0 * phi(0.0) + 4.0 * phi(h) - phi(2.0 * h)) / (2.0 * h);
                let near = phi(0.0) - 2.0 * d * slope_in + moment;
                let slope_out = (3.0 * phi(l) - 4.0 * phi(l - h) + phi(l - 2.0 * h)) / (2.0 * h);
                let far = phi(l) + 2.0 * d * slope_out - moment * (-l).exp();
                assert!(
                    near.abs() < 0.01 && far.abs() < 0.01,
                    "a {a} g {g} L {l}: faces {near} {far}"
                );
            }
        }
    }

    #[test]
    fn a_deep_slab_is_a_half_space_and_a_thin_one_holds_less_light() {
        // Isotropic, albedo 0.8: 0.59 of the irradiance at the surface of a half-space (the P1
        // solution's value), rising below it, then falling as exp(-mu tau).
        let deep = |tau: f32| fluence(tau, 1e4, 0.8, 0.0);
        assert!((deep(0.0) - 0.5945).abs() < 1e-3, "{}", deep(0.0));
        assert!(deep(1.0) > deep(0.0));
        let mu = (3.0f32 * 0.2).sqrt();
        let ratio = deep(21.0) / deep(20.0);
        assert!((ratio - (-mu).exp()).abs() < 1e-3, "{ratio}");
        // Light leaves a thin slab through its far face.
        for l in [0.5, 1.0, 2.0, 4.0] {
            assert!(fluence(0.25, l - 0.25, 0.9, 0.0) < fluence(0.25, 2.0 * l, 0.9, 0.0));
        }
        assert_eq!(fluence(2.0, 1.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn every_value_is_finite_and_not_negative() {
        for a in [0.0, 0.2, 0.5, 2.0 / 3.0, 0.9, 0.999, 1.0] {
            for g in [-0.95, -0.5, 0.0, 0.5, 0.95] {
                for tau in [0.0, 1e-3, 1.0, 50.0, 1e4, f32::INFINITY] {
                    for ahead in [0.0, 1e-3, 1.0, 64.0, f32::INFINITY] {
                        let v = fluence(tau, ahead, a, g);
                        assert!(
                            v.is_finite() && v >= 0.0,
                            "a {a} g {g} tau {tau} ahead {ahead}: {v}"
                        );
                    }
                }
            }
        }
    }
}
