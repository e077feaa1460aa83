//! CPU sweeps of the source iteration: per bounce, per sweep order the planes in order, per
//! plane each direction's source and radiance row by row in parallel. Planes are gathered into
//! contiguous padded buffers once per sweep order and plane, as the visibility sweep does.

use super::bands::{basis, coefficients_for, gathering, Bands, THROUGH_BAND_2};
use super::{iterate, InScattered, Lit, ScatteringParams, Source};
use crate::error::{Error, Result};
use crate::optics::phase::henyey_greenstein;
use crate::progress::Progress;
use crate::transport::directions::{Ordinate, Ordinates};
use crate::transport::medium::Medium;
use crate::transport::Planes;
use glam::Vec3;
use rayon::prelude::*;

/// A bounce's source as the sweep reads it, per cell and direction.
struct Reading<'a> {
    source: &'a Source,
    g: f32,
    scattering: &'a [Vec3],
}

impl Reading<'_> {
    /// The radiance source at `cell` for light leaving along `leaving` (`basis` its basis
    /// functions), never negative.
    #[inline]
    fn at(&self, cell: usize, leaving: Vec3, basis: &[f32; THROUGH_BAND_2]) -> Vec3 {
        match self.source {
            // The light travels along -towards and leaves along `leaving`.
            Source::Direct(d) => {
                d.irradiance[cell] * henyey_greenstein(self.g, -d.towards[cell].dot(leaving))
            }
            Source::Bands(field) => self.scattering[cell] * field.eval(cell, basis).max(Vec3::ZERO),
        }
    }
}

pub fn solve(
    medium: &Medium,
    lit: &Lit,
    ordinates: &Ordinates,
    params: &ScatteringParams,
    progress: &dyn Progress,
) -> Result<InScattered> {
    let g = params.g;
    let per_channel = coefficients_for(g);
    let gather = gathering(ordinates, g);
    iterate(medium, lit, ordinates, params, progress, |source, part| {
        let reading = Reading {
            source: &source,
            g,
            scattering: &medium.scattering,
        };
        sweep(medium, ordinates, &gather, per_channel, &reading, part)
    })
}

/// One bounce: every ordinate swept with `source`; the bands of the J its radiance scatters
/// into (`gather` per ordinate, `per_channel` coefficients).
fn sweep(
    medium: &Medium,
    ordinates: &Ordinates,
    gather: &[[f32; THROUGH_BAND_2]],
    per_channel: usize,
    source: &Reading,
    progress: &dyn Progress,
) -> Result<Bands> {
    let dims = medium.dims();
    let sigma = medium.extinction.values();
    let cells = sigma.len();
    let stride = 3 * per_channel;
    let mut field = Bands::zeros(cells, per_channel);
    let mut done = 0;
    for group in ordinates.groups() {
        let planes = Planes::new(dims, group.axis);
        let members = &ordinates.all()[group.members.clone()];
        let gathers = &gather[group.members.clone()];
        let len = planes.padded_len();
        // Padding holds no scattered light and no matter, and is never written.
        let blank = Swept {
            radiance: vec![Vec3::ZERO; len],
            source: vec![Vec3::ZERO; len],
        };
        let mut upwind = vec![blank.clone(); members.len()];
        let mut swept = upwind.clone();
        let mut upwind_sigma = vec![0.0f32; len];
        let mut swept_sigma = vec![0.0f32; len];
        let lateral = planes.lateral[0] * planes.lateral[1];
        let mut plane = vec![0.0f32; lateral * stride];
        let mut index = vec![0usize; lateral];
        for k in planes.order(group.sign) {
            if progress.cancelled() {
                return Err(Error::Cancelled);
            }
            gather_plane(&planes, k, sigma, &mut swept_sigma, &mut index);
            let values = field.values_mut();
            for (i, &cell) in index.iter().enumerate() {
                plane[i * stride..(i + 1) * stride]
                    .copy_from_slice(&values[cell * stride..(cell + 1) * stride]);
            }
            for ((o, weights), (up, now)) in members
                .iter()
                .zip(gathers)
                .zip(upwind.iter().zip(&mut swept))
            {
                fill_source(&planes, o, source, &index, &mut now.source);
                let coefficients = &weights[..per_channel];
                step(
                    &planes,
                    o,
                    coefficients,
                    up,
                    &upwind_sigma,
                    &swept_sigma,
                    now,
                    &mut plane,
                );
            }
            for (i, &cell) in index.iter().enumerate() {
                values[cell * stride..(cell + 1) * stride]
                    .copy_from_slice(&plane[i * stride..(i + 1) * stride]);
            }
            std::mem::swap(&mut upwind, &mut swept);
            std::mem::swap(&mut upwind_sigma, &mut swept_sigma);
            done += 1;
            progress.update(done, 0);
        }
    }
    Ok(field)
}

/// One direction's padded plane: the radiance it carries and its source.
#[derive(Clone)]
struct Swept {
    radiance: Vec<Vec3>,
    source: Vec<Vec3>,
}

/// Plane `k`'s extinction into the padded `sigma`, and the grid index of each of its cells.
fn gather_plane(planes: &Planes, k: usize, values: &[f32], sigma: &mut [f32], index: &mut [usize]) {
    let [nb, nc] = planes.lateral;
    let [sb, sc, sa] = planes.strides;
    let row = planes.padded_row();
    for c in 0..nc {
        let base = k * sa + c * sc;
        for b in 0..nb {
            let cell = base + b * sb;
            sigma[(b + 1) + row * (c + 1)] = values[cell];
            index[b + nb * c] = cell;
        }
    }
}

/// The source of direction `o` at each cell of the plane (`index`), into the padded `out`.
fn fill_source(planes: &Planes, o: &Ordinate, source: &Reading, index: &[usize], out: &mut [Vec3]) {
    let [nb, _] = planes.lateral;
    let row = planes.padded_row();
    let leaving = -o.towards;
    let basis = basis(leaving);
    out[row..row * (planes.lateral[1] + 1)]
        .par_chunks_mut(row)
        .zip(index.par_chunks(nb))
        .for_each(|(out_row, cells)| {
            for (b, &cell) in cells.iter().enumerate() {
                out_row[b + 1] = source.at(cell, leaving, &basis);
            }
        });
}

/// One direction across one plane: the radiance at each cell from the upwind plane and the
/// segment between (see the module docs of [`super`]), into `now`; what it scatters into,
/// `coefficients` per unit radiance and colour channel, added to `plane`.
#[allow(clippy::too_many_arguments)]
fn step(
    planes: &Planes,
    o: &Ordinate,
    coefficients: &[f32],
    up: &Swept,
    upwind_sigma: &[f32],
    sigma: &[f32],
    now: &mut Swept,
    plane: &mut [f32],
) {
    let [nb, _] = planes.lateral;
    let row = planes.padded_row();
    let weights = o.upwind_weights();
    let shift = o.upwind_shift(row);
    let ds = o.length;
    let n = coefficients.len();
    let source = &now.source;
    now.radiance[row..row * (planes.lateral[1] + 1)]
        .par_chunks_mut(row)
        .zip(plane.par_chunks_mut(nb * 3 * n))
        .enumerate()
        .for_each(|(c, (radiance_row, bands_row))| {
            let start = row * (c + 1) + 1;
            for (b, bands) in bands_row.chunks_exact_mut(3 * n).enumerate() {
                let at = start + b;
                let p = (at as isize + shift) as usize;
                let corners = [p, p + 1, p + row, p + row + 1];
                let mut l_up = Vec3::ZERO;
                let mut q_up = Vec3::ZERO;
                let mut s_up = 0.0;
                for (&i, &wt) in corners.iter().zip(&weights) {
                    l_up += wt * up.radiance[i];
                    q_up += wt * up.source[i];
                    s_up += wt * upwind_sigma[i];
                }
                let tau = 0.5 * ds * (sigma[at] + s_up);
                let (e1, e2) = segment_weights(tau);
                let l = l_up * (-tau).exp() + ds * (source[at] * (e1 - e2) + q_up * e2);
                radiance_row[b + 1] = l;
                for (channel, l) in bands.chunks_exact_mut(n).zip(l.to_array()) {
                    for (a, k) in channel.iter_mut().zip(coefficients) {
                        *a += l * k;
                    }
                }
            }
        });
}

/// E1 = (1 - e^-tau) / tau and E2 = (1 - e^-tau (1 + tau)) / tau^2: a segment's weights of a
/// source constant along it and of the upwind end's share of a linear one. Below tau = 1/2
/// by their series (the closed forms lose digits to cancellation there): seven terms leave
/// an error below 2e-7.
#[inline]
fn segment_weights(tau: f32) -> (f32, f32) {
    if tau < 0.5 {
        // E1 = sum (-tau)^n / (n + 1)!, E2 = sum (-tau)^n (n + 1) / (n + 2)!.
        let t = -tau;
        let e1 = 1.0
            + t * (1.0 / 2.0
                + t * (1.0 / 6.0
                    + t * (1.0 / 24.0 + t * (1.0 / 120.0 + t * (1.0 / 720.0 + t / 5040.0)))));
        let e2 = 0.5
            + t * (2.0 / 6.0
                + t * (3.0 / 24.0
                    + t * (4.0 / 120.0
                        + t * (5.0 / 720.0 + t * (6.0 / 5040.0 + t * 7.0 / 40320.0)))));
        (e1, e2)
    } else {
        let e = (-tau).exp();
        ((1.0 - e) / tau, (1.0 - e * (1.0 + tau)) / (tau * tau))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_weights_meet_their_closed_forms_across_the_switch() {
        for tau in [1e-6f64, 1e-3, 0.1, 0.3, 0.49, 0.51, 1.0, 5.0, 80.0] {
            let e = (-tau).exp();
            let want = ((1.0 - e) / tau, (1.0 - e * (1.0 + tau)) / (tau * tau));
            let want = if tau < 1e-3 {
                (1.0 - tau / 2.0, 0.5 - tau / 3.0)
            } else {
                want
            };
            let (e1, e2) = segment_weights(tau as f32);
            assert!((e1 as f64 - want.0).abs() < 4e-7 * want.0, "{tau}: {e1}");
            assert!((e2 as f64 - want.1).abs() < 4e-7 * want.1, "{tau}: {e2}");
        }
    }
}
