//! The angular form of in-scattered radiance per cell: its real spherical harmonics of bands 0
//! to 2, in Cartesian form, per colour channel,
//!   J(w) = a + b . w + w^T C w,  C symmetric and traceless,
//! held as nine coefficients against the basis [1, x, y, z, x^2 - z^2, y^2 - z^2, 2xy, 2xz, 2yz]
//! of the unit direction w = (x, y, z) (with C traceless, w^T C w = Cxx (x^2 - z^2) +
//! Cyy (y^2 - z^2) + 2 Cxy xy + 2 Cxz xz + 2 Cyz yz on the sphere).
//!
//! The Henyey-Greenstein phase's Legendre coefficients are g^l, so light of radiance L(w')
//! scatters into J(w) = sum_l (2l + 1) g^l (1 / 4 pi) int L(w') P_l(w' . w) dw': band 0 is the
//! mean m0, band 1 is 3 g m1 . w with m1 the mean of L w', and band 2 is
//! (15 g^2 / 2) w^T Q w with Q the mean of L (w' w'^T - I / 3). The ordinates' sums stand for
//! the means; each moment is taken about the set's own sum of w' and of w' w'^T (for 16
//! Fibonacci directions w' w'^T sums to I / 3 within 0.012), so that an isotropic field has
//! exactly no band 1 or 2 and none of its light is read as anisotropy.
//!
//! At g = 0 bands 1 and 2 vanish, and the field holds band 0 alone (one coefficient per
//! channel instead of nine).

use crate::transport::directions::Ordinates;
use glam::Vec3;

/// Coefficients per colour channel through band 2.
pub const THROUGH_BAND_2: usize = 9;

/// The basis functions at unit direction `w`.
#[inline]
pub fn basis(w: Vec3) -> [f32; THROUGH_BAND_2] {
    let (x, y, z) = (w.x, w.y, w.z);
    [
        1.0,
        x,
        y,
        z,
        x * x - z * z,
        y * y - z * z,
        2.0 * x * y,
        2.0 * x * z,
        2.0 * y * z,
    ]
}

/// Coefficients per colour channel the phase of asymmetry `g` needs: band 0 alone when
/// isotropic, else bands 0 to 2.
pub fn coefficients_for(g: f32) -> usize {
    if g == 0.0 {
        1
    } else {
        THROUGH_BAND_2
    }
}

/// Per ordinate (in [`Ordinates::all`]'s order), what its radiance L adds to the coefficients
/// of the J it scatters into with asymmetry `g`: L times these, the first `coefficients_for(g)`
/// of them.
pub fn gathering(ordinates: &Ordinates, g: f32) -> Vec<[f32; THROUGH_BAND_2]> {
    let all = ordinates.all();
    // The set's own sums of w' and w' w'^T (w' the travel direction, -towards).
    let mut mean = glam::DVec3::ZERO;
    let mut second = [0.0f64; 6];
    for o in all {
        let w = -o.towards.as_dvec3();
        let weight = o.weight as f64;
        mean += weight * w;
        for (s, v) in second.iter_mut().zip(quadratic_terms(w)) {
            *s += weight * v;
        }
    }
    let g = g as f64;
    let (band_1, band_2) = (3.0 * g, 7.5 * g * g);
    all.iter()
        .map(|o| {
            let w = -o.towards.as_dvec3();
            let weight = o.weight as f64;
            let d = w - mean;
            // [xx, yy, zz, xy, xz, yz] about the set's sums: C's coefficients are Qxx, Qyy,
            // Qxy, Qxz, Qyz (Qzz follows from the trace).
            let terms = quadratic_terms(w);
            let q: [f64; 6] = std::array::from_fn(|i| terms[i] - second[i]);
            [
                weight,
                weight * band_1 * d.x,
                weight * band_1 * d.y,
                weight * band_1 * d.z,
                weight * band_2 * q[0],
                weight * band_2 * q[1],
                weight * band_2 * q[3],
                weight * band_2 * q[4],
                weight * band_2 * q[5],
            ]
            .map(|c| c as f32)
        })
        .collect()
}

/// [xx, yy, zz, xy, xz, yz] of `w`.
fn quadratic_terms(w: glam::DVec3) -> [f64; 6] {
    [
        w.x * w.x,
        w.y * w.y,
        w.z * w.z,
        w.x * w.y,
        w.x * w.z,
        w.y * w.z,
    ]
}

/// Per cell of a grid, per colour channel, `per_channel` coefficients of J (cell-major, then
/// red, green, blue): the layout the GPU reads as it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Bands {
    per_channel: usize,
    values: Vec<f32>,
}

impl Bands {
    pub fn zeros(cells: usize, per_channel: usize) -> Self {
        Self {
            per_channel,
            values: vec![0.0; cells * 3 * per_channel],
        }
    }

    /// Bands from `values` in [`Bands`]' layout (a whole number of cells of `per_channel`
    /// coefficients per channel, as the GPU twin reads them back).
    pub fn from_values(per_channel: usize, values: Vec<f32>) -> Self {
        debug_assert!(values.len().is_multiple_of(3 * per_channel));
        Self {
            per_channel,
            values,
        }
    }

    pub fn per_channel(&self) -> usize {
        self.per_channel
    }

    /// Every cell's coefficients, in order.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    pub fn values_mut(&mut self) -> &mut [f32] {
        &mut self.values
    }

    /// The coefficients of `cell`: red's, green's, blue's.
    #[inline]
    pub fn cell(&self, cell: usize) -> &[f32] {
        let n = 3 * self.per_channel;
        &self.values[cell * n..(cell + 1) * n]
    }

    /// Band 0 of `cell`: J's mean over the sphere.
    #[inline]
    pub fn mean(&self, cell: usize) -> Vec3 {
        let c = self.cell(cell);
        let n = self.per_channel;
        Vec3::new(c[0], c[n], c[2 * n])
    }

    /// J of `cell` at the direction whose basis is `basis`, unclamped.
    #[inline]
    pub fn eval(&self, cell: usize, basis: &[f32; THROUGH_BAND_2]) -> Vec3 {
        let c = self.cell(cell);
        let n = self.per_channel;
        let channel = |k: usize| -> f32 {
            c[k * n..(k + 1) * n]
                .iter()
                .zip(basis)
                .map(|(a, b)| a * b)
                .sum()
        };
        Vec3::new(channel(0), channel(1), channel(2))
    }

    /// Adds `other` (the same grid and coefficients) to this.
    pub fn add(&mut self, other: &Bands) {
        for (a, b) in self.values.iter_mut().zip(&other.values) {
            *a += b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Light arriving in one narrow beam scatters into J(w) = p(w' . w) times its power; the
    /// bands through 2 keep that phase's first three Legendre terms exactly, whatever the
    /// beam's direction.
    #[test]
    fn a_beam_scatters_into_the_phase_cut_after_band_2() {
        let ordinates = Ordinates::new(64, Vec3::ONE).unwrap();
        let g = 0.6;
        let gather = gathering(&ordinates, g);
        let beam = 17;
        let travel = -ordinates.all()[beam].towards;
        let weight = ordinates.all()[beam].weight;
        for leaving in [
            travel,
            -travel,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
        ] {
            let b = basis(leaving);
            let j: f32 = gather[beam].iter().zip(&b).map(|(a, b)| a * b).sum();
            let mu = travel.dot(leaving);
            // sum_{l <= 2} (2l + 1) g^l P_l(mu), per unit of the beam's share of the sphere.
            let want = 1.0 + 3.0 * g * mu + 5.0 * g * g * (1.5 * mu * mu - 0.5);
            // The set's own sums shift the moments by at most their departure from the
            // sphere's (below 1e-3 for 64 directions).
            assert!(
                (j / weight - want).abs() < 0.02 * want.abs().max(1.0),
                "{mu}: {j}"
            );
        }
    }

    #[test]
    fn an_isotropic_field_has_no_band_above_0() {
        for count in [16, 33] {
            let ordinates = Ordinates::new(count, Vec3::new(1.0, 2.0, 0.5)).unwrap();
            let gather = gathering(&ordinates, 0.8);
            let mut sum = [0.0f64; THROUGH_BAND_2];
            for row in &gather {
                for (s, v) in sum.iter_mut().zip(row) {
                    *s += *v as f64;
                }
            }
            assert!((sum[0] - 1.0).abs() < 1e-6, "{sum:?}");
            assert!(sum[1..].iter().all(|v| v.abs() < 1e-6), "{sum:?}");
        }
    }

    #[test]
    fn cells_hold_their_channels_coefficients_in_order() {
        let mut bands = Bands::zeros(2, THROUGH_BAND_2);
        let n = 3 * THROUGH_BAND_2;
        bands.values_mut()[n] = 1.0;
        bands.values_mut()[n + THROUGH_BAND_2 + 3] = 2.0;
        assert_eq!(bands.mean(1), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(bands.eval(1, &basis(Vec3::Z)), Vec3::new(1.0, 2.0, 0.0));
        assert_eq!(bands.eval(0, &basis(Vec3::Z)), Vec3::ZERO);
    }
}
