//! The openness F(v) of one voxel from the local statistics of its box: the paper's estimates
//! (a) and (b), and Penner and Mitchell's baseline (c). src/ao/vao/vao_estimate.wgsl mirrors this
//! file line for line.
//!
//! Degenerate inputs never give NaN and always give a value in [0, 1]:
//! - a constant box (max = min) gives 1/2, the tie rule of the exact count: every neighbour
//!   holds as much matter as x;
//! - a shaded value at or beyond the extremes clamps to t = 0 or 1 (CDF), or to the Gaussian's
//!   tails; a mean at an extreme (from rounding) saturates beta to [`BETA_MIN`, `BETA_MAX`];
//! - zero variance (from rounding, in a box that is not constant) gives the step function.

use crate::error::{Error, Result};
use std::f32::consts::PI;

/// How F(v) is estimated. In scene files and JSON by its name ([`Estimator::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "&'static str")]
pub enum Estimator {
    /// (a) F(t) = t^beta on t = (v - min) / (max - min), beta = (mean - min) / (max - mean),
    /// the power CDF whose mean is the box's mean.
    #[default]
    Cdf,
    /// (b) The normal CDF of the box's mean and variance, erf by Winitzki's approximation.
    Gauss,
    /// (b) with the exact erf, to measure what the approximation costs.
    GaussExactErf,
    /// (c) Penner and Mitchell's variance occlusion maps: the one-sided Chebyshev (Cantelli)
    /// bound on the occluded fraction P(V >= v) <= var / (var + (v - mean)^2) for v > mean, used
    /// as the estimate as in variance shadow maps; for v <= mean the bound is 1 (all occluded).
    /// It bounds occlusion from above, so its maps are too dark.
    Penner,
    /// (d) The exact CDF over the ball: voxels counted, ties one half (see `exact`).
    Exact,
}

/// Names on the command line and in scene files, in the order of [`Estimator::ALL`].
const NAMES: [&str; 5] = ["cdf", "gauss", "gauss-exact", "penner", "exact"];

impl Estimator {
    pub const ALL: [Estimator; 5] = [
        Estimator::Cdf,
        Estimator::Gauss,
        Estimator::GaussExactErf,
        Estimator::Penner,
        Estimator::Exact,
    ];

    pub fn name(self) -> &'static str {
        NAMES[Self::ALL.iter().position(|&e| e == self).unwrap_or(0)]
    }

    /// The shader's code for the estimator (`vao_estimate.wgsl`); None for the exact count.
    pub fn shader_code(self) -> Option<u32> {
        match self {
            Estimator::Cdf => Some(0),
            Estimator::Gauss => Some(1),
            Estimator::GaussExactErf => Some(2),
            Estimator::Penner => Some(3),
            Estimator::Exact => None,
        }
    }
}

impl std::str::FromStr for Estimator {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        NAMES
            .iter()
            .position(|&n| n == s)
            .map(|i| Self::ALL[i])
            .ok_or_else(|| {
                Error::param(
                    "method",
                    format!("unknown AO method '{s}'; known: {}", NAMES.join(", ")),
                )
            })
    }
}

impl TryFrom<String> for Estimator {
    type Error = Error;
    fn try_from(s: String) -> Result<Self> {
        s.parse()
    }
}

impl From<Estimator> for &'static str {
    fn from(e: Estimator) -> Self {
        e.name()
    }
}

/// The statistics of one voxel's box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxStats {
    pub min: f32,
    pub max: f32,
    pub mean: f32,
    /// Mean of the squared values.
    pub second: f32,
}

impl BoxStats {
    /// Variance from the moments, clamped at 0 against rounding.
    #[inline]
    pub fn variance(&self) -> f32 {
        variance(self.mean, self.second)
    }
}

/// The variance from the mean and the mean of the squares, at least 0 (rounding can make the
/// difference slightly negative).
#[inline]
pub fn variance(mean: f32, second: f32) -> f32 {
    (second - mean * mean).max(0.0)
}

/// Saturation of beta, the CDF reconstruction's exponent (a mean at an extreme would make it
/// 0 or infinite).
pub const BETA_MIN: f32 = 1.0e-6;
pub const BETA_MAX: f32 = 1.0e6;

/// Winitzki's constant a = 8 (pi - 3) / (3 pi (4 - pi)).
const WINITZKI_A: f32 = 8.0 * (PI - 3.0) / (3.0 * PI * (4.0 - PI));

/// |x| beyond which erf(x) is 1 in f32; clamping keeps x^4 finite in Winitzki's formula.
const ERF_SATURATION: f32 = 10.0;

/// The openness of a voxel of value `v` with box statistics `s` (not for [`Estimator::Exact`],
/// which needs the voxels themselves: it is treated as the CDF reconstruction here).
#[inline]
pub fn openness(estimator: Estimator, v: f32, s: &BoxStats) -> f32 {
    if s.max <= s.min {
        return 0.5;
    }
    let f = match estimator {
        Estimator::Cdf | Estimator::Exact => power_cdf(v, s),
        Estimator::Gauss => normal_cdf(v, s, erf_winitzki),
        Estimator::GaussExactErf => normal_cdf(v, s, libm::erff),
        Estimator::Penner => penner(v, s),
    };
    f.clamp(0.0, 1.0)
}

/// (a): t^beta.
#[inline]
fn power_cdf(v: f32, s: &BoxStats) -> f32 {
    let t = ((v - s.min) / (s.max - s.min)).clamp(0.0, 1.0);
    let below = (s.mean - s.min).max(0.0);
    let above = (s.max - s.mean).max(0.0);
    let beta = if above > 0.0 {
        (below / above).clamp(BETA_MIN, BETA_MAX)
    } else {
        BETA_MAX
    };
    t.powf(beta)
}

/// (b): Phi((v - mean) / sigma), the step function where the variance rounded to 0.
#[inline]
fn normal_cdf(v: f32, s: &BoxStats, erf: impl Fn(f32) -> f32) -> f32 {
    let variance = s.variance();
    let d = v - s.mean;
    if variance > 0.0 {
        let x = (d / (2.0 * variance).sqrt()).clamp(-ERF_SATURATION, ERF_SATURATION);
        0.5 * (1.0 + erf(x))
    } else if d > 0.0 {
        1.0
    } else if d < 0.0 {
        0.0
    } else {
        0.5
    }
}

/// (c): 1 - var / (var + (v - mean)^2) above the mean, 0 at or below it.
#[inline]
fn penner(v: f32, s: &BoxStats) -> f32 {
    let d = v - s.mean;
    if d <= 0.0 {
        return 0.0;
    }
    let variance = s.variance();
    let spread = variance + d * d;
    // Both terms may underflow to 0 for tiny spreads: no variance, all of the box below v.
    if spread > 0.0 {
        1.0 - variance / spread
    } else {
        1.0
    }
}

/// Winitzki's approximation of erf (maximum absolute error about 3.5e-4).
#[inline]
pub fn erf_winitzki(x: f32) -> f32 {
    let x2 = x * x;
    let ax2 = WINITZKI_A * x2;
    let e = (1.0 - (-x2 * (4.0 / PI + ax2) / (1.0 + ax2)).exp()).max(0.0);
    e.sqrt().copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(min: f32, max: f32, mean: f32, variance: f32) -> BoxStats {
        BoxStats {
            min,
            max,
            mean,
            second: variance + mean * mean,
        }
    }

    #[test]
    fn winitzki_is_within_its_stated_error_of_the_exact_erf() {
        let worst = (-4000..=4000)
            .map(|i| i as f32 * 1e-3)
            .map(|x| (erf_winitzki(x) - libm::erff(x)).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 3.6e-4 && worst > 1e-5, "worst error {worst}");
        assert_eq!(erf_winitzki(0.0), 0.0);
        assert_eq!(erf_winitzki(10.0), 1.0);
    }

    #[test]
    fn closed_forms_of_each_estimate() {
        // A box that is half 0, half 1: mean 1/2, variance 1/4, beta 1.
        let s = stats(0.0, 1.0, 0.5, 0.25);
        assert!((openness(Estimator::Cdf, 0.25, &s) - 0.25).abs() < 1e-6);
        assert!((openness(Estimator::GaussExactErf, 0.5, &s) - 0.5).abs() < 1e-6);
        // One sigma above the mean: Phi(1) = 0.841345.
        assert!((openness(Estimator::GaussExactErf, 1.0, &s) - 0.841_345).abs() < 1e-5);
        assert!((openness(Estimator::Gauss, 1.0, &s) - 0.841_345).abs() < 4e-4);
        // Cantelli at one sigma: occluded <= 1/2.
        assert!((openness(Estimator::Penner, 1.0, &s) - 0.5).abs() < 1e-6);
        assert_eq!(openness(Estimator::Penner, 0.5, &s), 0.0);
        // beta = (0.75 - 0) / (1 - 0.75) = 3.
        let skewed = stats(0.0, 1.0, 0.75, 0.05);
        assert!((openness(Estimator::Cdf, 0.5, &skewed) - 0.125).abs() < 1e-6);
    }

    #[test]
    fn degenerate_boxes_give_finite_values_in_the_unit_interval() {
        let cases = [
            stats(2.0, 2.0, 2.0, 0.0),       // constant
            stats(0.0, 1.0, 0.0, 0.0),       // mean at the minimum
            stats(0.0, 1.0, 1.0, 0.0),       // mean at the maximum
            stats(0.0, 1.0, 0.5, 0.0),       // zero variance
            stats(0.0, 1.0, 0.5, -1e-3),     // negative variance from rounding
            stats(0.0, 1e-30, 5e-31, 1e-61), // tiny spread
            stats(-1e30, 1e30, 0.0, 1e30),   // huge spread
        ];
        for s in cases {
            for v in [
                s.min - 1.0,
                s.min,
                s.mean,
                s.max,
                s.max + 1.0,
                0.0,
                1e30,
                -1e30,
            ] {
                for e in Estimator::ALL {
                    let o = openness(e, v, &s);
                    assert!((0.0..=1.0).contains(&o), "{e:?} v={v} {s:?}: {o}");
                }
            }
        }
        for e in Estimator::ALL {
            assert_eq!(openness(e, 2.0, &cases[0]), 0.5, "{e:?}: constant box");
        }
        // Zero variance in a box that is not constant: the step function.
        assert_eq!(openness(Estimator::Gauss, 0.7, &cases[3]), 1.0);
        assert_eq!(openness(Estimator::Gauss, 0.5, &cases[3]), 0.5);
        assert_eq!(openness(Estimator::Gauss, 0.2, &cases[3]), 0.0);
    }

    #[test]
    fn names_round_trip() {
        for e in Estimator::ALL {
            assert_eq!(e.name().parse::<Estimator>().unwrap(), e);
        }
        let err = "median".parse::<Estimator>().unwrap_err().to_string();
        assert!(err.contains("median") && err.contains("penner"), "{err}");
    }
}
