//! The geometry term of the geometric mode: per octant s the share G_s(N) of the cosine-weighted
//! hemisphere about the normal N that s holds (or of both sides, for a translucent surface),
//! tabulated over N's direction by the octahedral map, as both twins read it.

use super::super::padded::octant_signs;
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::OnceLock;

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

/// A voxel's surface terms (three words, as src/ao/sweep/physical/sweep.wgsl reads them): where
/// its normal falls in the table (its cell's first texel and the bilinear fractions in 1/65535;
/// [`Cell::NONE`] for no normal, each octant then taking 1/8), and the padded-grid offset of the
/// neighbour the octants are read at.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Cell {
    texel: u32,
    frac: [u16; 2],
    pub(super) step: i32,
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
}
