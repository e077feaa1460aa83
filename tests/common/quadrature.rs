//! Deterministic quadrature for the Monte Carlo closed-form tests: chords of the cube
//! [-1, 1]^3, Gauss-Legendre nodes, and means over cones of directions.

use std::f64::consts::PI;

/// Distance from `x` (inside the cube) to its surface along unit `w`.
pub fn chord(x: [f64; 3], w: [f64; 3]) -> f64 {
    (0..3)
        .filter(|&a| w[a] != 0.0)
        .map(|a| ((w[a].signum() - x[a]) / w[a]).max(0.0))
        .fold(f64::INFINITY, f64::min)
}

/// Gauss-Legendre nodes and weights on [0, 1] (Newton on the Legendre polynomial).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            (0.5 * (1.0 - x), 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Mean of `f` over directions within `cos_min` of `axis` (the whole sphere for -1): midpoint
/// rule in (cos theta, phi).
pub fn mean_over_directions(axis: [f64; 3], cos_min: f64, f: impl Fn([f64; 3]) -> f64) -> f64 {
    let a = glam::DVec3::from(axis);
    let (t, b) = a.any_orthonormal_pair();
    let (nu, nphi) = (96, 192);
    let mut sum = 0.0;
    for i in 0..nu {
        let c = 1.0 - (i as f64 + 0.5) / nu as f64 * (1.0 - cos_min);
        let s = (1.0 - c * c).sqrt();
        for k in 0..nphi {
            let phi = 2.0 * PI * (k as f64 + 0.5) / nphi as f64;
            sum += f((a * c + (t * phi.cos() + b * phi.sin()) * s).to_array());
        }
    }
    sum / (nu * nphi) as f64
}
