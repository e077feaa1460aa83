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
//! - keeps of the swept field, per cell, its first two angular moments m0 = sum_i w_i L_i and
//!   m1 = sum_i w_i L_i (-w_i), from which the light scattered once more is
//!   J(x, w) = m0 + 3 g m1 . w: the Henyey-Greenstein phase's expansion in Legendre
//!   polynomials (band l weighted g^l) cut after band 1, exact for g = 0 and for any field
//!   whose angular spread has no band above 1. The next bounce's source is sigma_s J.
//!
//! The sum of the J of bounces 2 to `bounces` + 1 is the in-scattered radiance of light that
//! has scattered at least once before: what a renderer that computes the first scattering
//! itself (IPSVI, with exact shadows and phase) adds, `albedo J(x, towards the eye)` per unit
//! opacity. `bounces` counts scatterings after the first as the `multiple` reference and
//! Cycles do, so the solver computes the reference's model; it stops earlier when a bounce
//! adds less than [`CONVERGED`] of the light found so far, whatever the albedo (at albedo 1
//! and no absorption the series is cut at `bounces`, as the reference's is).
//!
//! Errors: the angular ones of the visibility sweep (1 / N in the directions) and the band-1
//! phase (light scattered twice keeps the anisotropy of the first scattering, exact in the
//! source, through one swept field; the field's own bands above 1 are lost), the spatial ones
//! of the short characteristics, and those of the grid's coarsening ([`super::medium`]).
//! Memory: the medium (4 f32 per cell), two moment fields (12 f32 per cell each: m0 and m1 per
//! colour channel) and the in-scattered sum (12 f32), plus per direction of a sweep order four
//! padded planes of radiance and source.

pub mod cpu;
pub mod direct;

use super::medium::{trilinear, Medium};
use crate::error::{Error, Result};
use crate::lights::Light;
use crate::progress::Progress;
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

/// The in-scattered radiance of multiply scattered light on the solver's grid:
/// J(x, w) = `isotropic` + (`directional`[c] . w) per colour channel c, w the direction the
/// scattered light leaves in.
#[derive(Clone, Debug)]
pub struct InScattered {
    /// The grid (its extinction, which the solve read).
    pub grid: crate::volume::Volume,
    pub isotropic: Vec<Vec3>,
    /// Per cell, the red, green and blue channels' band-1 vectors.
    pub directional: Vec<[Vec3; 3]>,
    /// Bounces computed (fewer than asked when the series converged first).
    pub bounces: u32,
}

impl InScattered {
    /// J at world point `p` (trilinear, clamped to the grid's edge cells) towards `leaving`
    /// (unit), never negative.
    #[inline]
    pub fn at(&self, p: Vec3, leaving: Vec3) -> Vec3 {
        let mut j = Vec3::ZERO;
        for (cell, weight) in trilinear(&self.grid, p) {
            let d = &self.directional[cell];
            j += weight
                * (self.isotropic[cell]
                    + Vec3::new(d[0].dot(leaving), d[1].dot(leaving), d[2].dot(leaving)));
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
