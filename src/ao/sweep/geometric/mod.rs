//! Occlusion sweeping, geometric mode (the fast occlusion sweeping paper, seed 003): ambient
//! occlusion of an iso-surface from its signed distance, in eight octant sweeps.
//!
//! 1. The signed distance d to the iso-surface by fast sweeping ([`super::sdf`]), negative
//!    inside; its normalised gradient is the outward normal N (central differences).
//! 2. Transmittance from distance (the paper's Eq. 7): a voxel lets through the fraction of its
//!    width along N that lies outside the surface, tau = clamp(d / w + 1/2, 0, 1) with
//!    w = sum_i |N_i| h_i the voxel's width along N (so anisotropic spacing counts): 0 a half
//!    voxel inside, 1 a half voxel outside, linear across the surface.
//!    Translucency (Eq. 8): tau_trans = 1 - (1 - tau) alpha, alpha = 1 opaque.
//! 3. The octant visibilities (Eq. 6): light reaching x from octant s crossed one of the three
//!    face neighbours of x on that side; the paper averages them,
//!    V_s(x) = 1/3 sum_a tau(x + s_a e_a) V_s(x + s_a e_a), and V_s = 1 outside the grid. One
//!    pass per octant in the grid's order computes it (as in the physical mode, [`super::physical`]).
//! 4. The geometry term: G_s(N) = 1/pi int_{octant s} max(N . w, 0) dw, the share of a
//!    cosine-weighted hemisphere about N that octant s holds (sum_s G_s = 1), precomputed as a
//!    table over N's direction ([`GeometryTable`]); with translucency the surface is lit from
//!    both sides, g = |N . w| (Eq. 8), and G_s = 1 / (2 pi) int_{octant s} |N . w| dw.
//!    AO = sum_s I_s G_s(N) V_s, with the octants' intensities I_s (all 1: ambient occlusion;
//!    the four upper octants only: the paper's "cloudy day", low-frequency shadows under a sky);
//!    or the combined scalar AO without G_s, 1/8 sum_s I_s V_s.
//!    A voxel reads the octants one voxel out along N (the lattice neighbour nearest to
//!    x + N h): at the voxel itself, its neighbours in the surface layer are half opaque and
//!    would shade it from the grazing directions of its own octants (an open floor would read
//!    0.81 instead of 1); one voxel out it sees what its surface sees, as a Monte Carlo ray
//!    started off the surface does.
//! 5. AO^(1 / gamma) as a post-process (gamma 2 by default, the paper's choice to brighten the
//!    sweep's darkening).
//!
//! Twins: the signed distance on the CPU (rows by wavefronts) or the GPU
//! (src/ao/sweep/sdf/sweep_sdf.wgsl, plane by plane); the surface terms on the CPU
//! ([`SurfaceTerms`]); the octants and the shading on [`cpu`] (plane by plane, the four
//! octants of a z direction in lockstep, the surface terms made a plane at a time) or [`gpu`]
//! (src/ao/sweep/physical/sweep.wgsl, the physical mode's plane kernel with the paper's terms,
//! then `sweep_shade`, over the whole grid's [`Surface`]); they agree within the tolerances of
//! tests/sweep_twins.rs.
//!
//! Memory on the CPU ([`occlusion_from`] with an owned field): the field and the padded
//! distances while the signed distance is made, then the distance and the AO, a few planes
//! beside them: about twice the field. `keep_octants` adds the eight V_s it asks for (8 grids
//! more). The GPU path builds the whole [`Surface`] on the host (its transmittance and three
//! words a voxel), which the CPU path does not.
//!
//! The three-neighbour average follows the octant's diagonal and blurs directions (the paper's
//! diagonal streaks); the physical mode ([`super::physical`]) uses seven neighbours and real
//! extinction. This mode is the paper's, for iso-surface renderings.

pub mod cpu;
pub mod gpu;
mod table;

pub use table::{Cell, GeometryTable, TABLE_SIDE};

use super::padded::Padded;
use super::sdf::{signed_distance_on, SdfParams, SdfResult};
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::{NoProgress, Progress};
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;
use std::borrow::Cow;

/// The four octants that look up +z (world up): the paper's "cloudy day" sky.
pub const SKY: [f32; 8] = [1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0];

/// Parameters of the geometric occlusion sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeometricParams {
    /// AO^(1 / gamma) as a post-process. Default 2 (the paper). At least 0.1, at most 10.
    pub gamma: f32,
    /// Intensity of the light from each octant, in [0, 1], in the order of
    /// [`octant_signs`]; default all 1 (ambient occlusion). [`SKY`] is the paper's cloudy day.
    pub intensities: [f32; 8],
    /// alpha of Eq. 8: 1 = opaque surface (default), smaller lets light through the surface
    /// and lights it from both sides. In (0, 1].
    pub alpha: f32,
    /// Weight the octants by the geometry term G_s(N) (default); false gives the combined
    /// scalar AO, 1/8 sum_s I_s V_s.
    pub normal_weighted: bool,
}

impl Default for GeometricParams {
    fn default() -> Self {
        Self {
            gamma: 2.0,
            intensities: [1.0; 8],
            alpha: 1.0,
            normal_weighted: true,
        }
    }
}

impl GeometricParams {
    /// The eight octants' intensities from a list (as the command line and Python give them).
    pub fn intensities_from(list: &[f32]) -> Result<[f32; 8]> {
        <[f32; 8]>::try_from(list).map_err(|_| {
            Error::param(
                "octant_intensities",
                format!("eight values are needed, got {}", list.len()),
            )
        })
    }

    /// Checks the ranges above; errors name the parameter.
    pub fn validate(&self) -> Result<()> {
        if !(self.gamma.is_finite() && (0.1..=10.0).contains(&self.gamma)) {
            return Err(Error::param(
                "gamma",
                format!("must lie in [0.1, 10], got {}", self.gamma),
            ));
        }
        if let Some(i) = self
            .intensities
            .iter()
            .position(|i| !(0.0..=1.0).contains(i))
        {
            return Err(Error::param(
                "octant_intensities",
                format!(
                    "each intensity must lie in [0, 1]; octant {i} has {}",
                    self.intensities[i]
                ),
            ));
        }
        if self.intensities.iter().all(|&i| i == 0.0) {
            return Err(Error::param(
                "octant_intensities",
                "every octant is dark: at least one intensity must be above 0",
            ));
        }
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(Error::param(
                "alpha",
                format!(
                    "the surface's opacity alpha must lie in (0, 1], got {}",
                    self.alpha
                ),
            ));
        }
        Ok(())
    }
}

/// What the geometric sweep computes, on the field's grid.
pub struct Occlusion {
    /// The AO after gamma, in [0, 1].
    pub ao: Volume,
    /// The signed distance (negative inside) and how its sweeps ended.
    pub sdf: SdfResult,
    /// The octant visibilities V_s, when asked for (the `ao_oct0`..`ao_oct7` grids).
    pub octants: Option<Vec<Volume>>,
}

/// The geometric occlusion of the `surface.iso` surface of `field` (its signed distance by
/// `surface`) on `compute` (the surface terms on the CPU). `progress` counts planes; `keep_octants`
/// also returns each V_s.
pub fn occlusion(
    compute: &Compute,
    field: &Volume,
    surface: &SdfParams,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<Occlusion> {
    occlusion_from(
        compute,
        Cow::Borrowed(field),
        surface,
        params,
        keep_octants,
        progress,
    )
}

/// [`occlusion`] of a field that may be given away: an owned `field` is dropped once its signed
/// distance is made, so that the octants' peak holds the distance and the AO, not the field
/// beside them. On the CPU the peak is then the field and the padded distances during the
/// signed distance, the distance and the AO after it (and the eight V_s with `keep_octants`).
pub fn occlusion_from(
    compute: &Compute,
    field: Cow<'_, Volume>,
    surface: &SdfParams,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<Occlusion> {
    params.validate()?;
    let sdf = signed_distance_on(compute, &field, surface, &NoProgress)?;
    drop(field);
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    let table = if params.alpha < 1.0 {
        GeometryTable::two_sided()
    } else {
        GeometryTable::hemisphere()
    };
    let terms = SurfaceTerms::new(&sdf.sdf, table, params);
    let (ao, octants) = match compute {
        Compute::Cpu => cpu::octants(&terms, params, keep_octants, progress)?,
        Compute::Gpu(ctx) => {
            gpu::octants(ctx, &Surface::new(&terms), params, keep_octants, progress)?
        }
    };
    let d = &sdf.sdf;
    let grid = |values| Volume::new(d.dims(), d.spacing(), d.origin(), values);
    Ok(Occlusion {
        ao: grid(ao)?,
        octants: if keep_octants {
            Some(octants.into_iter().map(grid).collect::<Result<_>>()?)
        } else {
            None
        },
        sdf,
    })
}

/// What the GPU's octant sweeps read: the transmittance from distance, each voxel's surface
/// terms and the geometry table they index, for the whole grid at once (the CPU makes them a
/// plane at a time, [`SurfaceTerms::plane`]).
pub struct Surface {
    /// Eq. 7 and 8, padded with 1.
    pub transmittance: Padded,
    pub cells: Vec<Cell>,
    pub table: &'static GeometryTable,
}

impl Surface {
    /// The terms of every plane.
    pub fn new(terms: &SurfaceTerms) -> Self {
        let dims = terms.sdf.dims();
        let [nx, ny, nz] = dims;
        let mut cells = vec![Cell::NONE; nx * ny * nz];
        let mut transmittance = Padded::new(dims, 1.0);
        // The padded grid's first plane is padding.
        cells
            .par_chunks_mut(nx * ny)
            .zip(
                transmittance
                    .values
                    .par_chunks_mut((nx + 2) * (ny + 2))
                    .skip(1),
            )
            .enumerate()
            .for_each(|(k, (cells, tau))| terms.plane(k, tau, cells));
        Surface {
            transmittance,
            cells,
            table: terms.table,
        }
    }
}

/// The surface terms of a signed distance, voxel by voxel: where its normal falls in `table`
/// (the normal: the signed distance's gradient by central differences, one-sided at the grid's
/// faces; none where the gradient vanishes, a kink such as a ball's centre, or with the
/// combined scalar AO), the padded-grid step to the voxel its octants are read at, and the
/// transmittance from distance (Eq. 7 and 8).
pub struct SurfaceTerms<'a> {
    sdf: &'a Volume,
    pub table: &'static GeometryTable,
    alpha: f32,
    normal_weighted: bool,
}

impl<'a> SurfaceTerms<'a> {
    pub fn new(sdf: &'a Volume, table: &'static GeometryTable, params: &GeometricParams) -> Self {
        Self {
            sdf,
            table,
            alpha: params.alpha,
            normal_weighted: params.normal_weighted,
        }
    }

    /// The grid's dimensions.
    pub fn dims(&self) -> [usize; 3] {
        self.sdf.dims()
    }

    /// Plane `k`'s terms: its transmittance into the padded plane `tau` (whose border is left
    /// as it is) and its cells (x fastest), rows in parallel.
    pub fn plane(&self, k: usize, tau: &mut [f32], cells: &mut [Cell]) {
        let [nx, _, _] = self.dims();
        cells
            .par_chunks_mut(nx)
            .zip(tau[nx + 2..].par_chunks_mut(nx + 2))
            .enumerate()
            .for_each(|(j, (cells, tau))| {
                for (i, (cell, tau)) in cells.iter_mut().zip(&mut tau[1..]).enumerate() {
                    (*tau, *cell) = self.voxel(i, j, k);
                }
            });
    }

    /// Voxel (i, j, k)'s transmittance and cell.
    fn voxel(&self, i: usize, j: usize, k: usize) -> (f32, Cell) {
        let [nx, ny, nz] = self.dims();
        let h = self.sdf.spacing();
        let d = self.sdf.values();
        let index = i + nx * (j + ny * k);
        let mut g = Vec3::ZERO;
        for (axis, (at, n, stride)) in [(i, nx, 1), (j, ny, nx), (k, nz, nx * ny)]
            .into_iter()
            .enumerate()
        {
            // Central differences, one-sided at the grid's faces.
            let (below, above) = (at > 0, at + 1 < n);
            let lo = if below { index - stride } else { index };
            let hi = if above { index + stride } else { index };
            let steps = (below as u32 + above as u32) as f32;
            if steps > 0.0 {
                g[axis] = (d[hi] - d[lo]) / (steps * h[axis]);
            }
        }
        let normal = g.try_normalize();
        // The voxel's width along the normal; without one, the mean spacing.
        let width = normal.map_or(h.element_sum() / 3.0, |n| n.abs().dot(h));
        let t = (d[index] / width + 0.5).clamp(0.0, 1.0);
        let tau = 1.0 - (1.0 - t) * self.alpha;
        let mut cell = match normal {
            Some(n) if self.normal_weighted => self.table.cell(n),
            _ => Cell::NONE,
        };
        if let Some(n) = normal {
            // The lattice neighbour nearest to one voxel out along the normal.
            let o = (n / h * h.min_element()).round();
            let (px, py) = ((nx + 2) as i32, (ny + 2) as i32);
            cell.step = o.x as i32 + px * (o.y as i32 + py * o.z as i32);
        }
        (tau, cell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_out_of_range_are_named() {
        let bad = [
            (
                GeometricParams {
                    gamma: 0.0,
                    ..Default::default()
                },
                "gamma",
            ),
            (
                GeometricParams {
                    alpha: 0.0,
                    ..Default::default()
                },
                "alpha",
            ),
            (
                GeometricParams {
                    alpha: 1.5,
                    ..Default::default()
                },
                "alpha",
            ),
            (
                GeometricParams {
                    intensities: [0.0; 8],
                    ..Default::default()
                },
                "octant_intensities",
            ),
            (
                GeometricParams {
                    intensities: [2.0; 8],
                    ..Default::default()
                },
                "octant_intensities",
            ),
        ];
        for (p, key) in bad {
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
    }
}
