//! Multiple scattering on the grid by source iteration over the discrete ordinates.
//!
//! A light (a sun or a lamp) reaches a cell x with irradiance E(x) T(x), T its transmittance
//! from where it enters the grid ([`direct`]). The light scattered once at x leaves towards w
//! with radiance source sigma_s(x) E T p(l . w) (Henyey-Greenstein p, l the direction towards
//! the light): the first source, exact in angle. Each bounce then
//! - sweeps every ordinate w_i across the grid in its upwind order ([`cpu`]), carrying the
//!   radiance L_i that travels along -w_i from cell to cell by short characteristics: the
//!   upwind radiance and source bilinear on the upwind plane as the visibility sweep reads its
//!   transmittance ([`super`]), and along the segment the exact solution for an extinction
//!   constant and a source linear between its ends,
//!   L(x) = L(p) e^-tau + ds [Q(x) (E1 - E2) + Q(p) E2], E1 = (1 - e^-tau) / tau,
//!   E2 = (1 - e^-tau (1 + tau)) / tau^2,
//!   which holds for optically thick cells too (L tends to Q / sigma_t) where a trapezoid rule
//!   would overshoot by tau / 2;
//! - gathers of the swept field, per cell, the light it scatters into: the Henyey-Greenstein
//!   phase's expansion in Legendre polynomials (band l weighted (2l + 1) g^l) cut after band 2
//!   ([`bands`]), J(x, w) = a + b . w + w^T C w, exact for g = 0 and for any field whose
//!   angular spread has no band above 2. The next bounce's source is sigma_s J.
//!
//! The sum of the J of bounces 2 to `bounces` + 1 is the in-scattered radiance of light that
//! has scattered at least once before: what a renderer that computes the first scattering
//! itself (IPSVI, with exact shadows and phase) adds, `albedo J(x, towards the eye)` per unit
//! opacity. `bounces` counts scatterings after the first as the `multiple` reference and
//! Cycles do, so the solver computes the reference's model; it stops earlier when a bounce
//! adds less than [`CONVERGED`] of the light found so far, whatever the albedo (at albedo 1
//! and no absorption the series is cut at `bounces`, as the reference's is).
//!
//! Errors: the angular ones of the visibility sweep (1 / N in the directions) and the band-2
//! phase (light scattered twice keeps the anisotropy of the first scattering, exact in the
//! source, through one swept field; the field's own bands above 2 are lost: their weight in
//! the phase falls as g^l, 0.22 of band 0's at l = 3 for g = 0.6), the spatial ones of the
//! short characteristics, and those of the grid's coarsening ([`super::medium`]).
//! Memory: the medium (4 f32 per cell), three band fields (the last bounce's, the one being
//! swept and the sum: 27 f32 per cell each, 3 at g = 0), plus per direction of a sweep order
//! four padded planes of radiance and source.

pub mod bands;
pub mod cpu;
pub mod direct;

use super::medium::{trilinear, Medium};
use crate::error::{Error, Result};
use crate::lights::Light;
use crate::progress::Progress;
use bands::{basis, Bands};
use glam::Vec3;

/// A bounce that adds less than this fraction of the in-scattered light found so far ends the
/// iteration: the bounces left would add at most that fraction again times the bounce's ratio
/// to the one before over one minus it, below the solver's other errors for any albedo below
/// 0.999.
pub const CONVERGED: f32 = 1e-4;

/// What the solver is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScatteringParams {
    /// Discrete ordinates ([`super::DEFAULT_DIRECTIONS`] by default).
    pub directions: u32,
    /// Scatterings after the first (the `multiple` reference's count).
    pub bounces: u32,
    /// Henyey-Greenstein asymmetry, in (-1, 1).
    pub g: f32,
}

/// The in-scattered radiance J(x, w) of multiply scattered light on the solver's grid, w the
/// direction the scattered light leaves in: per cell and colour channel its bands 0 to 2
/// ([`bands`]).
#[derive(Clone, Debug)]
pub struct InScattered {
    /// The grid (its extinction, which the solve read).
    pub grid: crate::volume::Volume,
    pub bands: Bands,
    /// Bounces computed (fewer than asked when the series converged first).
    pub bounces: u32,
}

impl InScattered {
    /// J at world point `p` (trilinear, clamped to the grid's edge cells) towards `leaving`
    /// (unit), never negative.
    #[inline]
    pub fn at(&self, p: Vec3, leaving: Vec3) -> Vec3 {
        let basis = basis(leaving);
        let mut j = Vec3::ZERO;
        for (cell, weight) in trilinear(&self.grid, p) {
            j += weight * self.bands.eval(cell, &basis);
        }
        j.max(Vec3::ZERO)
    }
}

/// The in-scattered radiance of light from `light` that has scattered at least once, in
/// `medium`. Ambient light is refused (its first scattering is the ambient visibility's).
pub fn in_scattered(
    medium: &Medium,
    light: &Light,
    params: &ScatteringParams,
    progress: &dyn Progress,
) -> Result<InScattered> {
    crate::optics::phase::G.check(params.g as f64)?;
    if matches!(light, Light::Ambient { .. }) {
        return Err(Error::param(
            "lights",
            "multiple scattering on the grid takes suns and lamps; ambient light's first \
             scattering is the ambient visibility (ao)",
        ));
    }
    let ordinates = super::prepare(&medium.extinction, params.directions)?;
    cpu::solve(medium, light, &ordinates, params, progress)
}
