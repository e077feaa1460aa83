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
//!    pass per octant in the grid's order computes it (as in the physical mode, [`super`]).
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
//! Twins: the signed distance on the CPU (rows, its eight orders shared between two teams) or the
//! GPU (src/ao/sweep/sweep_sdf.wgsl, plane by plane); the surface terms on the CPU; the octants and
//! the shading on the CPU (two parallel groups of four octants) or the GPU
//! (src/ao/sweep/sweep.wgsl, the physical mode's plane kernel with the paper's terms, then
//! `sweep_shade`); they agree within the tolerances of tests/sweep_twins.rs.
//!
//! The three-neighbour average follows the octant's diagonal and blurs directions (the paper's
//! diagonal streaks); the physical mode ([`super::cpu`]) uses seven neighbours and real
//! extinction. This mode is the paper's, for iso-surface renderings.

use super::padded::{octant_signs, sweep_order, Padded};
use super::sdf::{signed_distance_on, SdfParams, SdfResult};
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::{NoProgress, Progress};
use crate::volume::Volume;
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

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
/// `surface`) on `compute` (the surface terms on the CPU). `progress` counts the octants (planes on
/// the GPU); `keep_octants` also returns each V_s.
pub fn occlusion(
    compute: &Compute,
    field: &Volume,
    surface: &SdfParams,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<Occlusion> {
    params.validate()?;
    let sdf = signed_distance_on(compute, field, surface, &NoProgress)?;
    if progress.cancelled() {
        return Err(Error::Cancelled);
    }
    let table = if params.alpha < 1.0 {
        GeometryTable::two_sided()
    } else {
        GeometryTable::hemisphere()
    };
    let surface = surface_terms(&sdf.sdf, table, params);
    let (ao, octants) = match compute {
        Compute::Cpu => cpu_octants(&surface, params, keep_octants, progress)?,
        Compute::Gpu(ctx) => {
            super::gpu::geometric_octants(ctx, &surface, params, keep_octants, progress)?
        }
    };
    let grid = |values| Volume::new(field.dims(), field.spacing(), field.origin(), values);
    Ok(Occlusion {
        ao: grid(ao)?,
        sdf,
        octants: if keep_octants {
            Some(octants.into_iter().map(grid).collect::<Result<_>>()?)
        } else {
            None
        },
    })
}

/// The octant sweeps and the shading on the CPU: AO after gamma and, when `keep_octants`,
/// each V_s (unpadded).
fn cpu_octants(
    surface: &Surface,
    params: &GeometricParams,
    keep_octants: bool,
    progress: &dyn Progress,
) -> Result<(Vec<f32>, Vec<Vec<f32>>)> {
    let Surface {
        transmittance,
        cells,
        table,
    } = surface;
    let done = AtomicU64::new(0);
    let voxels = cells.len();
    // Two fixed groups of four octants, each summed in order into its own accumulator: the
    // sum does not depend on the number of threads, and at most two grids are in flight.
    let group = |octants: &[usize]| -> Result<(Vec<f32>, Vec<Vec<f32>>)> {
        let mut lit = vec![0.0f32; voxels];
        let mut kept = Vec::new();
        let mut v = Padded::new(transmittance.dims, 1.0);
        for &o in octants {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            let intensity = params.intensities[o];
            sweep_octant(transmittance, octant_signs()[o], &mut v);
            let [nx, ny, nz] = v.dims;
            for k in 0..nz {
                for j in 0..ny {
                    let start = v.index(0, j, k);
                    let at = (j + ny * k) * nx;
                    let sums = lit[at..at + nx].iter_mut().zip(&cells[at..at + nx]);
                    for (i, (sum, cell)) in sums.enumerate() {
                        let seen = v.values[(start + i).wrapping_add_signed(cell.step as isize)];
                        *sum += intensity * table.share(*cell, o) * seen;
                    }
                }
            }
            if keep_octants {
                kept.push(v.unpad(|x| x));
            }
            progress.update(done.fetch_add(1, Ordering::Relaxed) + 1, 8);
        }
        Ok((lit, kept))
    };
    let (first, second) = rayon::join(|| group(&[0, 1, 2, 3]), || group(&[4, 5, 6, 7]));
    let ((mut sum, mut kept), (other, more)) = (first?, second?);
    kept.extend(more);
    let exponent = 1.0 / params.gamma;
    sum.par_iter_mut()
        .zip(&other)
        .for_each(|(a, b)| *a = (*a + b).clamp(0.0, 1.0).powf(exponent));
    Ok((sum, kept))
}

/// What the octant sweeps read: the transmittance from distance, each voxel's surface terms and
/// the geometry table they index.
pub struct Surface {
    /// Eq. 7 and 8, padded with 1.
    pub transmittance: Padded,
    pub cells: Vec<Cell>,
    pub table: &'static GeometryTable,
}

/// Per voxel, where its normal falls in `table` (the normal: the signed distance's gradient by
/// central differences, one-sided at the grid's faces; none where the gradient vanishes, a
/// kink such as a ball's centre, or with the combined scalar AO), and the transmittance from
/// distance (Eq. 7 and 8).
fn surface_terms(sdf: &Volume, table: &'static GeometryTable, params: &GeometricParams) -> Surface {
    let [nx, ny, nz] = sdf.dims();
    let h = sdf.spacing();
    let d = sdf.values();
    let mut cells = vec![Cell::NONE; nx * ny * nz];
    let mut transmittance = Padded::new(sdf.dims(), 1.0);
    let plane = nx * ny;
    let padded_plane = (nx + 2) * (ny + 2);
    let (px, py) = ((nx + 2) as i32, (ny + 2) as i32);
    // Planes in parallel: each voxel's cell, and its transmittance straight into the padded
    // grid (whose first plane is padding).
    cells
        .par_chunks_mut(plane)
        .zip(transmittance.values.par_chunks_mut(padded_plane).skip(1))
        .enumerate()
        .for_each(|(k, (cells, tau))| {
            // The neighbours' indices and the steps between them along an axis: central
            // differences, one-sided at the grid's faces.
            let span = |at: usize, n: usize, stride: usize, index: usize| {
                let (below, above) = (at > 0, at + 1 < n);
                let lo = if below { index - stride } else { index };
                let hi = if above { index + stride } else { index };
                (lo, hi, (below as u32 + above as u32) as f32)
            };
            for j in 0..ny {
                let padded_row = 1 + (nx + 2) * (j + 1);
                for i in 0..nx {
                    let index = i + nx * (j + ny * k);
                    let mut g = Vec3::ZERO;
                    for (axis, (at, n, stride)) in [(i, nx, 1), (j, ny, nx), (k, nz, plane)]
                        .into_iter()
                        .enumerate()
                    {
                        let (lo, hi, steps) = span(at, n, stride, index);
                        if steps > 0.0 {
                            g[axis] = (d[hi] - d[lo]) / (steps * h[axis]);
                        }
                    }
                    let normal = g.try_normalize();
                    // The voxel's width along the normal; without one, the mean spacing.
                    let width = normal.map_or(h.element_sum() / 3.0, |n| n.abs().dot(h));
                    let t = (d[index] / width + 0.5).clamp(0.0, 1.0);
                    tau[padded_row + i] = 1.0 - (1.0 - t) * params.alpha;
                    let mut cell = match normal {
                        Some(n) if params.normal_weighted => table.cell(n),
                        _ => Cell::NONE,
                    };
                    if let Some(n) = normal {
                        // The lattice neighbour nearest to one voxel out along the normal.
                        let o = (n / h * h.min_element()).round();
                        cell.step = o.x as i32 + px * (o.y as i32 + py * o.z as i32);
                    }
                    cells[i + nx * j] = cell;
                }
            }
        });
    Surface {
        transmittance,
        cells,
        table,
    }
}

/// V_s by the three-neighbour average (Eq. 6) for the octant of `signs`, into `v` (whose
/// padding holds 1).
fn sweep_octant(transmittance: &Padded, signs: [i32; 3], v: &mut Padded) {
    let [nx, ny, nz] = transmittance.dims;
    let offset = |axis: usize| {
        let mut step = [0; 3];
        step[axis] = signs[axis];
        transmittance.offset(step)
    };
    let (dy, dz) = (offset(1), offset(2));
    let t = &transmittance.values;
    let mut off_row = vec![0.0f32; nx];
    for k in sweep_order(nz, signs[2]) {
        for j in sweep_order(ny, signs[1]) {
            let start = v.index(0, j, k);
            // The y and z neighbours lie on rows already swept: a plain loop over the row.
            let (fy, fz) = (
                (start as isize + dy) as usize,
                (start as isize + dz) as usize,
            );
            for (i, acc) in off_row.iter_mut().enumerate() {
                *acc = t[fy + i] * v.values[fy + i] + t[fz + i] * v.values[fz + i];
            }
            // The x neighbour is on this row: a recurrence, in the sweep's order.
            let row = &mut v.values[start - 1..start + nx + 1];
            let trow = &t[start - 1..start + nx + 1];
            let third = 1.0 / 3.0;
            if signs[0] > 0 {
                for i in (0..nx).rev() {
                    row[i + 1] = third * (off_row[i] + trow[i + 2] * row[i + 2]);
                }
            } else {
                for i in 0..nx {
                    row[i + 1] = third * (off_row[i] + trow[i] * row[i]);
                }
            }
        }
    }
}

/// Points per side of the octahedral table (its vertices; bilinear between them); the shader's
/// TABLE_SIDE.
pub const TABLE_SIDE: usize = 65;
/// Quadrature points per side of each cube face when the table is built.
const TABLE_QUADRATURE: usize = 32;

/// The geometry terms G_s(N) of the eight octants, tabulated over the directions of N by the
/// octahedral map (all eight per texel, so a voxel finds its place once). Built once per kind,
/// on first use.
pub struct GeometryTable {
    values: Vec<[f32; 8]>,
}

/// A voxel's surface terms (three words, as src/ao/sweep/sweep.wgsl reads them): where its normal
/// falls in the table (its cell's first texel and
/// the bilinear fractions in 1/65535; [`Cell::NONE`] for no normal, each octant then taking
/// 1/8), and the padded-grid offset of the neighbour the octants are read at.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Cell {
    texel: u32,
    frac: [u16; 2],
    step: i32,
}

impl Cell {
    pub const NONE: Cell = Cell {
        texel: u32::MAX,
        frac: [0; 2],
        step: 0,
    };
}

impl GeometryTable {
    /// 1/pi int_{octant} max(N . w, 0) dw: an opaque surface, lit from outside only.
    pub fn hemisphere() -> &'static Self {
        static TABLE: OnceLock<GeometryTable> = OnceLock::new();
        TABLE.get_or_init(|| Self::build(|c| c.max(0.0) / std::f64::consts::PI))
    }

    /// 1/(2 pi) int_{octant} |N . w| dw: a translucent surface, lit from both sides.
    pub fn two_sided() -> &'static Self {
        static TABLE: OnceLock<GeometryTable> = OnceLock::new();
        TABLE.get_or_init(|| Self::build(|c| c.abs() / (2.0 * std::f64::consts::PI)))
    }

    /// The table of int_{octant s} f(N . w) dw, by the cube-face quadrature of the stencil's
    /// weights (directions through a grid on the faces x, y, z = 1, weighted by solid angle),
    /// mirrored into each octant.
    fn build(f: impl Fn(f64) -> f64 + Sync) -> Self {
        let mut directions = Vec::with_capacity(3 * TABLE_QUADRATURE * TABLE_QUADRATURE);
        for face in 0..3 {
            for a in 0..TABLE_QUADRATURE {
                for b in 0..TABLE_QUADRATURE {
                    let mut p = [1.0; 3];
                    p[(face + 1) % 3] = (a as f64 + 0.5) / TABLE_QUADRATURE as f64;
                    p[(face + 2) % 3] = (b as f64 + 0.5) / TABLE_QUADRATURE as f64;
                    let p = DVec3::from(p);
                    let area = (1.0 / TABLE_QUADRATURE as f64).powi(2);
                    directions.push((p.normalize(), area * p.length().powi(-3)));
                }
            }
        }
        let signs = octant_signs().map(|s| DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64));
        let values = (0..TABLE_SIDE * TABLE_SIDE)
            .into_par_iter()
            .map(|t| {
                let uv = Vec2::new((t % TABLE_SIDE) as f32, (t / TABLE_SIDE) as f32)
                    / (TABLE_SIDE - 1) as f32
                    * 2.0
                    - 1.0;
                let n = crate::octahedral::decode(uv).as_dvec3();
                signs.map(|s| {
                    let mirrored = n * s;
                    directions
                        .iter()
                        .map(|(w, solid_angle)| f(mirrored.dot(*w)) * solid_angle)
                        .sum::<f64>() as f32
                })
            })
            .collect();
        Self { values }
    }

    /// The terms, eight per texel (octant order), texels row by row.
    pub fn values(&self) -> &[f32] {
        bytemuck::cast_slice(&self.values)
    }

    /// Where the unit `n` falls in the table.
    pub fn cell(&self, n: Vec3) -> Cell {
        let uv = (crate::octahedral::encode(n) + 1.0) * 0.5 * (TABLE_SIDE - 1) as f32;
        let last = (TABLE_SIDE - 2) as f32;
        let corner = uv.floor().clamp(Vec2::ZERO, Vec2::splat(last));
        let frac = ((uv - corner).clamp(Vec2::ZERO, Vec2::ONE) * 65535.0).round();
        Cell {
            texel: (corner.x as usize + TABLE_SIDE * corner.y as usize) as u32,
            frac: [frac.x as u16, frac.y as u16],
            step: 0,
        }
    }

    /// G_s at `cell` for octant `s` (the order of [`octant_signs`]), interpolated bilinearly.
    #[inline]
    pub fn share(&self, cell: Cell, s: usize) -> f32 {
        if cell.texel == u32::MAX {
            return 0.125;
        }
        let t = cell.texel as usize;
        let [fx, fy] = cell.frac.map(|f| f as f32 / 65535.0);
        let at = |d: usize| self.values[t + d][s];
        let bottom = at(0) + (at(1) - at(0)) * fx;
        let top = at(TABLE_SIDE) + (at(TABLE_SIDE + 1) - at(TABLE_SIDE)) * fx;
        bottom + (top - bottom) * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_term_matches_its_closed_form_in_the_octant() {
        // For N in the octant (+, +, +), N . w >= 0 over it, and Lambert's formula for the
        // spherical triangle of the three axes gives G_+(N) = (N_x + N_y + N_z) / 4; for N in
        // the opposite octant N . w <= 0 over it, so G_+ = 0 (and the two-sided term is half
        // of the closed form with |N|).
        let (one, two) = (GeometryTable::hemisphere(), GeometryTable::two_sided());
        let g = |table: &GeometryTable, n: Vec3| table.share(table.cell(n), 0);
        for n in crate::octahedral::test_directions() {
            let closed = n.element_sum() / 4.0;
            if n.min_element() >= 0.0 {
                assert!((g(one, n) - closed).abs() < 2e-3, "{n}: {}", g(one, n));
                assert!((g(two, n) - closed / 2.0).abs() < 2e-3, "{n}");
            }
            if n.max_element() <= 0.0 {
                assert!(g(one, n).abs() < 2e-3, "{n}: {}", g(one, n));
                assert!((g(two, n) + closed / 2.0).abs() < 2e-3, "{n}");
            }
        }
    }

    #[test]
    fn geometry_terms_of_the_eight_octants_sum_to_one() {
        for table in [GeometryTable::hemisphere(), GeometryTable::two_sided()] {
            for n in crate::octahedral::test_directions() {
                let cell = table.cell(n);
                let sum: f32 = (0..8).map(|s| table.share(cell, s)).sum();
                assert!((sum - 1.0).abs() < 3e-3, "{n}: {sum}");
                // Mirroring N mirrors the octants.
                for (s, signs) in octant_signs().iter().enumerate() {
                    let m = n * Vec3::new(signs[0] as f32, signs[1] as f32, signs[2] as f32);
                    let mirrored = table.share(table.cell(m), 0);
                    assert!((mirrored - table.share(cell, s)).abs() < 2e-3, "{n} {s}");
                }
            }
        }
    }

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
