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
//! Twins: [`cpu`] and [`gpu`] sweep the planes, directions and cells in the same order from
//! the same first source, and [`iterate`] sums their bounces for both (tests/transport_twins.rs
//! holds them within 1e-3 of the field's scale; lavapipe measures 4e-7).
//! Memory: the medium (4 f32 per cell), three band fields (the last bounce's, the one being
//! swept and the sum: 27 f32 per cell each, 3 at g = 0), plus per direction of a sweep order
//! four padded planes of radiance and source.

pub mod bands;
pub mod cpu;
pub mod direct;
pub mod gpu;

use super::directions::Ordinates;
use super::medium::{trilinear, Medium};
use super::total_planes;
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::lights::Light;
use crate::optics::phase::henyey_greenstein;
use crate::progress::{Part, Progress};
use crate::volume::Volume;
use bands::{basis, coefficients_for, Bands};
use direct::{direct, Direct};
use glam::Vec3;
use rayon::prelude::*;

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
/// `medium`, on the GPU of `gpu` or, without one, on the CPU. Ambient light is refused here:
/// [`ambient_in_scattered`] takes it, with its visibility.
pub fn in_scattered(
    gpu: Option<&GpuContext>,
    medium: &Medium,
    light: &Light,
    params: &ScatteringParams,
    progress: &dyn Progress,
) -> Result<InScattered> {
    if matches!(light, Light::Ambient { .. }) {
        return Err(Error::param(
            "lights",
            "multiple scattering of ambient light starts from its visibility (ao): the bake \
             solves it from its `ao` grid",
        ));
    }
    solve(gpu, medium, &Lit::Light(light), params, progress)
}

/// The in-scattered radiance of uniform white ambient light of unit radiance that has
/// scattered at least once, in `medium`, given its `visibility` V (the mean transmittance over
/// all directions, on any grid over the same box: read trilinearly at the medium's cells).
/// Its light scattered once is V itself for an isotropic phase, J_1(x) = V(x), which the first
/// bounce sweeps as it sweeps any earlier bounce's field; for g != 0 that first field's
/// anisotropy (g times V's first angular moment) is left out: at most g times its band 1, and
/// only in the first of the bounces.
pub fn ambient_in_scattered(
    gpu: Option<&GpuContext>,
    medium: &Medium,
    visibility: &Volume,
    params: &ScatteringParams,
    progress: &dyn Progress,
) -> Result<InScattered> {
    let visible: Vec<f32> = (0..medium.scattering.len())
        .into_par_iter()
        .map(|cell| {
            trilinear(visibility, medium.centre(cell))
                .iter()
                .map(|&(i, w)| w * visibility.values()[i])
                .sum()
        })
        .collect();
    solve(gpu, medium, &Lit::Ambient(&visible), params, progress)
}

fn solve(
    gpu: Option<&GpuContext>,
    medium: &Medium,
    lit: &Lit,
    params: &ScatteringParams,
    progress: &dyn Progress,
) -> Result<InScattered> {
    crate::optics::phase::G.check(params.g as f64)?;
    let ordinates = super::prepare(&medium.extinction, params.directions)?;
    match gpu {
        Some(ctx) => gpu::solve(ctx, medium, lit, &ordinates, params, progress),
        None => cpu::solve(medium, lit, &ordinates, params, progress),
    }
}

/// What lights the medium: a sun or a lamp, or unit ambient light with its visibility on the
/// medium's cells.
pub enum Lit<'a> {
    Light(&'a Light),
    Ambient(&'a [f32]),
}

/// What a bounce sweeps: the light scattered for the first time (per cell the direction
/// towards the light and sigma_s E T over the ordinates' sum of the phase, which the exact
/// phase then multiplies), or the previous bounce's field J, which sigma_s multiplies (for
/// ambient light the first bounce's too: its J_1 is the visibility).
pub enum Source {
    Direct(Direct),
    Bands(Bands),
}

/// The source iteration both twins run: `sweep` computes one bounce's field from its source,
/// counting its planes on the progress it is given; the fields are summed on the CPU in the
/// same order whichever twin swept them.
pub fn iterate(
    medium: &Medium,
    lit: &Lit,
    ordinates: &Ordinates,
    params: &ScatteringParams,
    progress: &dyn Progress,
    mut sweep: impl FnMut(Source, &dyn Progress) -> Result<Bands>,
) -> Result<InScattered> {
    let dims = medium.dims();
    let cells = medium.scattering.len();
    let per_channel = coefficients_for(params.g);
    let per_bounce = total_planes(dims, ordinates);
    let first = match lit {
        Lit::Light(light) => dims[ordinates_axis_of(light, medium)] as u64,
        Lit::Ambient(_) => 0,
    };
    let total = first + per_bounce * params.bounces as u64;
    let mut source = match lit {
        Lit::Light(light) => Source::Direct(first_source(
            medium,
            light,
            ordinates,
            params.g,
            &Part {
                whole: progress,
                offset: 0,
                total,
            },
        )?),
        Lit::Ambient(visible) => Source::Bands(isotropic(visible, per_channel)),
    };
    let mut sum = Bands::zeros(cells, per_channel);
    // Band 0 summed over the cells: the light a field holds, and that of the sum so far.
    let band_0 = |bands: &Bands| -> f64 {
        (0..cells)
            .map(|cell| bands.mean(cell).element_sum() as f64)
            .sum()
    };
    let mut found = 0.0;
    let mut bounces = 0;
    for bounce in 0..params.bounces {
        let part = Part {
            whole: progress,
            offset: first + per_bounce * bounce as u64,
            total,
        };
        let field = sweep(source, &part)?;
        bounces += 1;
        sum.add(&field);
        let added = band_0(&field);
        found += added;
        if added <= CONVERGED as f64 * found || bounce + 1 == params.bounces {
            break;
        }
        source = Source::Bands(field);
    }
    Ok(InScattered {
        grid: medium.extinction.clone(),
        bands: sum,
        bounces,
    })
}

/// A white field of the same J towards every direction: `values` per cell in each channel's
/// band 0.
fn isotropic(values: &[f32], per_channel: usize) -> Bands {
    let mut bands = Bands::zeros(values.len(), per_channel);
    let stride = 3 * per_channel;
    for (cell, v) in bands.values_mut().chunks_exact_mut(stride).zip(values) {
        for channel in 0..3 {
            cell[channel * per_channel] = *v;
        }
    }
    bands
}

/// The light that reaches each cell, with its irradiance times sigma_s over the ordinates'
/// sum of the phase towards it.
fn first_source(
    medium: &Medium,
    light: &Light,
    ordinates: &Ordinates,
    g: f32,
    progress: &dyn Progress,
) -> Result<Direct> {
    let mut d = direct(medium, light, progress)?;
    // The first source's phase as the ordinates integrate it: a forward lobe (g = 0.6 peaks
    // at ten times the isotropic phase) falls between few directions, and its sum over them
    // would gain or lose light with the light's direction; divided by that sum, the first
    // scattering keeps exactly the light it takes, whatever the set.
    let norms: Vec<f32> = d
        .towards
        .par_iter()
        .map(|t| {
            let sum: f32 = ordinates
                .all()
                .iter()
                .map(|o| o.weight * henyey_greenstein(g, t.dot(o.towards)))
                .sum();
            4.0 * std::f32::consts::PI * sum
        })
        .collect();
    for ((e, s), n) in d.irradiance.iter_mut().zip(&medium.scattering).zip(norms) {
        *e *= *s / n;
    }
    Ok(d)
}

/// The axis the light's own sweep steps across (a lamp's march counts as one plane's worth
/// per plane of z), for progress.
fn ordinates_axis_of(light: &Light, medium: &Medium) -> usize {
    match *light {
        Light::Directional { to_light, .. } => {
            Ordinates::single(to_light.normalize(), medium.extinction.spacing()).all()[0].axis
        }
        _ => 2,
    }
}
