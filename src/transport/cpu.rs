//! CPU twin of the ordinates sweep: per sweep order the planes in order, per plane each
//! direction's rows in parallel. Each plane's extinction and output are gathered into
//! contiguous padded planes once per sweep order, so the directions' loops run over
//! contiguous rows whatever the axis.
//!
//! Empty space is skipped: each padded row of a plane keeps the span of its values that may
//! differ from the padding's (T = 1, sigma = 0), and a direction computes a row only over the
//! voxels whose extinction or upwind points fall in those spans; the others get T = 1
//! without their interpolations and exp. That is exactly what the loop would compute
//! (exp(-0) = 1, and the upwind weights make exactly 1:
//! [`super::directions::Ordinate::upwind_weights`]), so the result is the same bytes as
//! sweeping every voxel; on a scan that is mostly air it skips the air around the matter and
//! on the light's side of it, for each direction.

use super::directions::{Ordinate, Ordinates};
use super::{total_planes, Planes};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::span::Span;
use crate::volume::Volume;
use rayon::prelude::*;

/// The visibility volume of `extinction` over `ordinates` (from [`super::prepare`]).
pub fn visibility(
    extinction: &Volume,
    ordinates: &Ordinates,
    progress: &dyn Progress,
) -> Result<Volume> {
    let dims = extinction.dims();
    let sigma = extinction.values();
    let mut sum = vec![0.0f32; sigma.len()];
    let total = total_planes(dims, ordinates);
    let mut done = 0;
    for group in ordinates.groups() {
        let planes = Planes::new(dims, group.axis);
        let members = &ordinates.all()[group.members.clone()];
        // Padding holds T = 1 and sigma = 0 (no matter outside the grid) and is never written.
        let mut upwind_t: Vec<Plane> = members.iter().map(|_| Plane::new(&planes, 1.0)).collect();
        let mut swept_t: Vec<Plane> = members.iter().map(|_| Plane::new(&planes, 1.0)).collect();
        let mut upwind_sigma = Plane::new(&planes, 0.0);
        let mut swept_sigma = Plane::new(&planes, 0.0);
        let mut lit = vec![0.0f32; planes.lateral[0] * planes.lateral[1]];
        for k in planes.order(group.sign) {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            gather(&planes, k, sigma, &mut swept_sigma, &mut lit, &sum);
            for (o, (upwind, swept)) in members.iter().zip(upwind_t.iter().zip(&mut swept_t)) {
                sweep_plane(
                    &planes,
                    o,
                    upwind,
                    &upwind_sigma,
                    &swept_sigma,
                    swept,
                    &mut lit,
                );
            }
            scatter(&planes, k, &lit, &mut sum);
            std::mem::swap(&mut upwind_t, &mut swept_t);
            std::mem::swap(&mut upwind_sigma, &mut swept_sigma);
            done += 1;
            progress.update(done, total);
        }
    }
    for v in &mut sum {
        *v = v.clamp(0.0, 1.0);
    }
    Volume::new(dims, extinction.spacing(), extinction.origin(), sum)
}

/// A padded plane of T or of extinction, and per padded row the span of its values that may
/// differ from the padding's (T = 1, sigma = 0): outside it, every value is the padding's. The
/// padding rows' spans are empty.
struct Plane {
    values: Vec<f32>,
    spans: Vec<Span>,
}

impl Plane {
    fn new(planes: &Planes, padding: f32) -> Self {
        Self {
            values: vec![padding; planes.padded_len()],
            spans: vec![Span::EMPTY; planes.lateral[1] + 2],
        }
    }
}

/// Plane `k`'s extinction into the padded `sigma` (and its spans) and its sum so far into
/// `lit`.
fn gather(
    planes: &Planes,
    k: usize,
    values: &[f32],
    sigma: &mut Plane,
    lit: &mut [f32],
    sum: &[f32],
) {
    let [nb, nc] = planes.lateral;
    let [sb, sc, sa] = planes.strides;
    let row = planes.padded_row();
    for c in 0..nc {
        let base = k * sa + c * sc;
        let padded = row * (c + 1);
        for b in 0..nb {
            sigma.values[padded + b + 1] = values[base + b * sb];
            lit[b + nb * c] = sum[base + b * sb];
        }
        sigma.spans[c + 1] = Span::of(&sigma.values[padded + 1..padded + 1 + nb], 1, |s| s != 0.0);
    }
}

/// `lit` back into plane `k` of `sum`.
fn scatter(planes: &Planes, k: usize, lit: &[f32], sum: &mut [f32]) {
    let [nb, nc] = planes.lateral;
    let [sb, sc, sa] = planes.strides;
    for c in 0..nc {
        let base = k * sa + c * sc;
        for b in 0..nb {
            sum[base + b * sb] = lit[b + nb * c];
        }
    }
}

/// One direction across one plane: T at each voxel from the upwind plane, into `swept`, and
/// its weighted share added to `lit`; voxels in empty space get T = 1 without the loop.
fn sweep_plane(
    planes: &Planes,
    o: &Ordinate,
    upwind: &Plane,
    upwind_sigma: &Plane,
    sigma: &Plane,
    swept: &mut Plane,
    lit: &mut [f32],
) {
    let [nb, nc] = planes.lateral;
    let row = planes.padded_row();
    let weights = o.upwind_weights();
    let shift = o.upwind_shift(row);
    let half_length = 0.5 * o.length;
    // The voxels of padded row r that need the loop: those of nonzero extinction, and those
    // whose upwind points (x + floor and the next, on rows r + floor and the next) fall in a
    // span of the upwind planes.
    let back = (-o.floor[0]) as usize;
    let needed = |r: usize| {
        let first = r.wrapping_add_signed(o.floor[1] as isize);
        let upwind_span = (first..first + 2)
            .map(|u| upwind.spans[u].hull(upwind_sigma.spans[u]))
            .fold(Span::EMPTY, Span::hull);
        // Padding is never in a span, so an upwind span starts at 1 or later.
        let reached = match upwind_span.is_empty() {
            true => Span::EMPTY,
            false => Span {
                start: upwind_span.start - 1 + back,
                end: upwind_span.end + back,
            },
        };
        sigma.spans[r].hull(reached).within(1, nb + 1)
    };
    swept.values[row..row * (nc + 1)]
        .par_chunks_mut(row)
        .zip(swept.spans[1..=nc].par_iter_mut())
        .zip(lit.par_chunks_mut(nb))
        .enumerate()
        .for_each(|(c, ((swept_row, span), lit_row))| {
            // Back to the padding where the row last differed from it, then the loop where
            // it is needed.
            swept_row[span.within(1, nb + 1)].fill(1.0);
            let compute = needed(c + 1);
            let start = row * (c + 1);
            for x in compute.clone() {
                let at = start + x;
                let p = (at as isize + shift) as usize;
                let bilinear = |f: &[f32]| {
                    weights[0] * f[p]
                        + weights[1] * f[p + 1]
                        + weights[2] * f[p + row]
                        + weights[3] * f[p + row + 1]
                };
                let depth = half_length * (sigma.values[at] + bilinear(&upwind_sigma.values));
                swept_row[x] = bilinear(&upwind.values) * (-depth).exp();
            }
            for (x, l) in lit_row.iter_mut().enumerate().map(|(b, l)| (b + 1, l)) {
                *l += o.weight * swept_row[x];
            }
            *span = Span::of(&swept_row[compute.clone()], compute.start, |t| t != 1.0);
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;
    use glam::Vec3;

    fn uniform(n: usize, sigma: f32, spacing: f32) -> Volume {
        Volume::new(
            [n; 3],
            Vec3::splat(spacing),
            Vec3::ZERO,
            vec![sigma; n * n * n],
        )
        .unwrap()
    }

    #[test]
    fn empty_space_sees_the_whole_sky() {
        let v = visibility(
            &uniform(6, 0.0, 1.0),
            &Ordinates::new(32, Vec3::ONE).unwrap(),
            &NoProgress,
        )
        .unwrap();
        assert!(v.values().iter().all(|&x| (x - 1.0).abs() < 1e-6));
    }

    #[test]
    fn axis_and_lattice_diagonal_directions_are_exact_in_a_homogeneous_medium() {
        // Straight up z, or along a voxel diagonal (each step lands on a voxel centre), through
        // sigma: T = exp(-sigma L (m + 1/2)) at the m-th plane from the top, L the step's
        // length (half a step of matter past the last centre, none outside).
        let (n, sigma, h) = (8, 0.3f32, 0.5f32);
        for (towards, floor, fraction, length) in [
            (Vec3::Z, [0, 0], [0.0, 0.0], h),
            (Vec3::ONE.normalize(), [0, 0], [1.0, 1.0], h * 3f32.sqrt()),
        ] {
            let o = Ordinate {
                towards,
                weight: 1.0,
                axis: 2,
                sign: 1,
                floor,
                fraction,
                length,
            };
            let planes = Planes::new([n; 3], 2);
            let (mut upwind, mut swept) = (Plane::new(&planes, 1.0), Plane::new(&planes, 1.0));
            let (mut upwind_sigma, mut swept_sigma) =
                (Plane::new(&planes, 0.0), Plane::new(&planes, 0.0));
            let volume = uniform(n, sigma, h);
            let mut lit = vec![0.0; n * n];
            let mut sum = vec![0.0; n * n * n];
            for (m, k) in planes.order(1).enumerate() {
                gather(
                    &planes,
                    k,
                    volume.values(),
                    &mut swept_sigma,
                    &mut lit,
                    &sum,
                );
                let planes_ = &planes;
                sweep_plane(
                    planes_,
                    &o,
                    &upwind,
                    &upwind_sigma,
                    &swept_sigma,
                    &mut swept,
                    &mut lit,
                );
                scatter(&planes, k, &lit, &mut sum);
                // Voxel (0, 0): its diagonal path stays in the grid for every plane above.
                let want = (-sigma * length * (m as f32 + 0.5)).exp();
                let got = swept.values[1 + planes.padded_row()];
                assert!(
                    (got - want).abs() < 1e-6,
                    "{towards} plane {k}: {got} vs {want}"
                );
                std::mem::swap(&mut upwind, &mut swept);
                std::mem::swap(&mut upwind_sigma, &mut swept_sigma);
            }
        }
    }

    #[test]
    fn skipping_empty_space_gives_the_bytes_of_sweeping_it() {
        // Matter in a corner and a slab, air elsewhere; the same with the air at 1e-30, where
        // no row is empty and every voxel is swept: exp(-1e-30 l) rounds to exactly 1, so
        // the sweeps must agree to the bit.
        assert_eq!((-1e-30f32).exp(), 1.0);
        let dims = [13, 11, 9];
        let matter = |i: usize, j: usize, k: usize| {
            let corner = i < 4 && j < 3 && k > 5;
            let slab = (5..7).contains(&j) && i > 6;
            if corner || slab {
                0.4 + 0.1 * ((i + 2 * j + 3 * k) % 5) as f32
            } else {
                0.0
            }
        };
        let field = |air: f32| {
            let mut values = Vec::new();
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let m = matter(i, j, k);
                        values.push(if m > 0.0 { m } else { air });
                    }
                }
            }
            Volume::new(dims, Vec3::new(1.0, 0.8, 1.2), Vec3::ZERO, values).unwrap()
        };
        let ordinates = Ordinates::new(32, Vec3::new(1.0, 0.8, 1.2)).unwrap();
        let skipped = visibility(&field(0.0), &ordinates, &NoProgress).unwrap();
        let swept = visibility(&field(1e-30), &ordinates, &NoProgress).unwrap();
        assert_eq!(skipped.values(), swept.values());
        assert!(skipped.values().iter().any(|&v| v < 0.9));
    }
}
