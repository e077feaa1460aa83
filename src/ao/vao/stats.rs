//! Local statistics of a field over the box of side w = 2R + 1 around every voxel: minimum,
//! maximum, mean and second moment, by three separable 1D passes (x, then y, then z) at a cost
//! per voxel that does not depend on R:
//! - means by a running sum: add the value entering the window, subtract the one leaving it.
//!   The sum is recomputed from scratch every w steps, so rounding drift stays bounded in f32
//!   while the amortised cost stays three additions per value, and it sums deviations from a
//!   local offset (the line's value where it restarts), so that the drift scales with the
//!   local spread of the values rather than their size: the variance E[x^2] - E[x]^2 comes
//!   out within about 2e-3 of an f64 computation at R = 64 where plain f32 sums miss it by 3e-2.
//!   Each pass divides by w, so a mean of means is the box mean and the outside value is the
//!   same in every pass.
//! - extremes by van Herk/Gil-Werman: prefix and suffix extremes within blocks of w values;
//!   a window spans at most two blocks, so its extreme is one comparison of a suffix and a
//!   prefix (three comparisons per value in all).
//!
//! Windows that reach beyond the grid see the field's outside value there (see the module docs
//! of `vao`); the lines themselves are never padded, so the work does not grow with R.
//!
//! The CPU twin streams the z pass ([`stream_stats`]): slices are filtered in x and y in
//! batches and fed to the z pass in order, which gives each slice's statistics once the slices
//! its boxes reach are in, with the same arithmetic in the same order as a z pass over whole
//! columns, so that beyond the field it holds O(R) slices, not four dense grids.
//!
//! [`window_pass`] filters `n` elements of `lanes` contiguous values each, lane by lane, so
//! that the inner loops run over contiguous memory and vectorise; the x pass transposes each
//! slice to make x the element axis. src/ao/vao/vao_stats.wgsl runs the same arithmetic in the
//! same order, one invocation per line.

use super::estimate::BoxStats;
use super::{ScalarField, UnitMap};
use crate::error::{Error, Result};
use crate::progress::Progress;
use rayon::prelude::*;

/// The statistics of every voxel's box, on the field's grid (x fastest).
#[derive(Clone, Debug, PartialEq)]
pub struct LocalStats {
    pub min: Vec<f32>,
    pub max: Vec<f32>,
    pub mean: Vec<f32>,
    /// Mean of the squared values.
    pub second: Vec<f32>,
}

impl LocalStats {
    /// The whole grid's statistics as one run of voxels (flat index).
    pub fn view(&self) -> SliceStats<'_> {
        SliceStats {
            min: &self.min,
            max: &self.max,
            mean: &self.mean,
            second: &self.second,
        }
    }
}

/// What a pass computes over each window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    Min,
    Max,
    Mean,
}

impl Reduce {
    /// The shader's code for the reduction.
    pub fn shader_code(self) -> u32 {
        match self {
            Reduce::Mean => 0,
            Reduce::Min => 1,
            Reduce::Max => 2,
        }
    }
}

/// The quantities, in the order of [`LocalStats`]'s fields: reduction, and whether the field
/// is squared before the first pass.
pub const QUANTITIES: [(Reduce, bool); 4] = [
    (Reduce::Min, false),
    (Reduce::Max, false),
    (Reduce::Mean, false),
    (Reduce::Mean, true),
];

/// The statistics of a run of voxels' boxes (one slice as the stream gives it, or a whole
/// grid), each x fastest.
pub struct SliceStats<'a> {
    pub min: &'a [f32],
    pub max: &'a [f32],
    pub mean: &'a [f32],
    pub second: &'a [f32],
}

impl SliceStats<'_> {
    /// The statistics of voxel `i` of the run.
    #[inline]
    pub fn at(&self, i: usize) -> BoxStats {
        BoxStats {
            min: self.min[i],
            max: self.max[i],
            mean: self.mean[i],
            second: self.second[i],
        }
    }
}

/// Computes the statistics of `field` mapped by `map` over boxes of radius `radius` voxels, as
/// dense grids (what the tests and the accuracy tables compare; the AO volume streams them).
pub fn local_stats(
    field: &ScalarField,
    map: UnitMap,
    radius: usize,
    progress: &dyn Progress,
) -> Result<LocalStats> {
    let dims = field.values.dims();
    let len = field.values.values().len();
    let slice = dims[0] * dims[1];
    let mut out: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; len]);
    let mut values = field.values.values().to_vec();
    stream_stats(
        &mut values,
        dims,
        map,
        field.outside,
        radius,
        progress,
        |k, stats, _| {
            let range = k * slice..(k + 1) * slice;
            for (dst, src) in out
                .iter_mut()
                .zip([stats.min, stats.max, stats.mean, stats.second])
            {
                dst[range.clone()].copy_from_slice(src);
            }
        },
    )?;
    let [min, max, mean, second] = out;
    Ok(LocalStats {
        min,
        max,
        mean,
        second,
    })
}

/// Streams the statistics of the boxes of `values` (a grid of `dims`, x fastest; `outside`
/// beyond it, both before `map`) slice by slice in z order: `finish(k, stats, slice_k)` gets
/// slice k's statistics and slice k of `values`, which it may overwrite (the stream has read
/// it by then), so the AO volume is written over its own field.
///
/// The x and y passes run on a batch of slices at once in parallel, all four quantities each;
/// the z pass takes the filtered slices in order, holding the last 2R + 2 of each mean and up
/// to three blocks of 2R + 1 of each extreme: beyond `values`, about 8 (2R + 1) slices, not
/// four dense grids (`occlux ao --method cdf --radius 10` on the 512^3 phantom peaks at 1.40x the
/// dense volume; 6.1x with the four grids).
pub fn stream_stats(
    values: &mut [f32],
    dims: [usize; 3],
    map: UnitMap,
    outside: f32,
    radius: usize,
    progress: &dyn Progress,
    mut finish: impl FnMut(usize, &SliceStats, &mut [f32]),
) -> Result<()> {
    let [nx, ny, nz] = dims;
    let slice = nx * ny;
    let outside = map.apply(outside);
    let outsides = QUANTITIES.map(|(_, squared)| if squared { outside * outside } else { outside });
    let mut z = ZPass {
        means: [2, 3].map(|q| ZMean::new(nz, slice, radius, outsides[q])),
        extremes: [(0, f32::min as fn(f32, f32) -> f32), (1, f32::max)]
            .map(|(q, op)| ZExtreme::new(nz, slice, radius, outsides[q], op)),
    };
    let batch = rayon::current_num_threads().max(1);
    let mut staged: Vec<[Vec<f32>; 4]> = Vec::new();
    let mut stats: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; slice]);
    let mut next = 0;
    for s0 in (0..nz).step_by(batch) {
        check_cancelled(progress)?;
        let s1 = (s0 + batch).min(nz);
        staged.resize_with(s1 - s0, || std::array::from_fn(|_| vec![0.0f32; slice]));
        staged
            .par_iter_mut()
            .zip(values[s0 * slice..s1 * slice].par_chunks(slice))
            .for_each_init(Scratch::default, |scratch, (quads, src)| {
                xy_filter(src, [nx, ny], map, radius, &outsides, scratch, quads);
            });
        for (s, quads) in (s0..s1).zip(staged.iter_mut()) {
            z.feed(s, quads);
            // Slice k's boxes reach slice k + R: every slice up to it is in.
            while next < nz && (next + radius).min(nz - 1) <= s {
                z.window(next, &mut stats);
                let [min, max, mean, second] = &stats;
                let view = SliceStats {
                    min,
                    max,
                    mean,
                    second,
                };
                finish(next, &view, &mut values[next * slice..][..slice]);
                next += 1;
                progress.update(next as u64, nz as u64);
            }
        }
    }
    Ok(())
}

/// The x and y passes of one slice `src` (of `nx` x `ny`), for the four quantities into
/// `dst`: the mapped slice transposed so that x becomes the element axis, the x pass, back,
/// the y pass.
fn xy_filter(
    src: &[f32],
    [nx, ny]: [usize; 2],
    map: UnitMap,
    radius: usize,
    outsides: &[f32; 4],
    scratch: &mut Scratch,
    dst: &mut [Vec<f32>; 4],
) {
    let mut transposed = std::mem::take(&mut scratch.transposed);
    transposed.resize(src.len(), 0.0);
    transpose(src, nx, &mut transposed, |v| map.apply(v));
    let mut work = std::mem::take(&mut scratch.work);
    for ((dst, (reduce, squared)), &outside) in dst.iter_mut().zip(QUANTITIES).zip(outsides) {
        work.clear();
        work.extend(transposed.iter().map(|&v| if squared { v * v } else { v }));
        let mut rows: Vec<&mut [f32]> = work.chunks_mut(ny).collect();
        window_pass(&mut rows, reduce, radius, outside, scratch);
        transpose(&work, ny, dst, |v| v);
        let mut rows: Vec<&mut [f32]> = dst.chunks_mut(nx).collect();
        window_pass(&mut rows, reduce, radius, outside, scratch);
    }
    scratch.transposed = transposed;
    scratch.work = work;
}

/// The z pass over x- and y-filtered slices fed in order: the means (mean, second moment) and
/// the extremes (minimum, maximum), each quantity on its own thread.
struct ZPass {
    means: [ZMean; 2],
    extremes: [ZExtreme; 2],
}

impl ZPass {
    /// Takes slice `s` of each quantity (in the order of [`QUANTITIES`]), leaving spare
    /// buffers of the same size in `quads`.
    fn feed(&mut self, s: usize, quads: &mut [Vec<f32>; 4]) {
        let [min, max, mean, second] = quads;
        let ([lo, hi], [m, q]) = (&mut self.extremes, &mut self.means);
        rayon::join(
            || rayon::join(|| lo.feed(s, min), || hi.feed(s, max)),
            || rayon::join(|| m.feed(s, mean), || q.feed(s, second)),
        );
    }

    /// Slice `k`'s statistics into `out` (the order of [`QUANTITIES`]), once every slice up to
    /// k + R is fed.
    fn window(&mut self, k: usize, out: &mut [Vec<f32>; 4]) {
        let [min, max, mean, second] = out;
        let ([lo, hi], [m, q]) = (&self.extremes, &mut self.means);
        rayon::join(
            || rayon::join(|| lo.window(k, min), || hi.window(k, max)),
            || rayon::join(|| m.window(k, mean), || q.window(k, second)),
        );
    }
}

/// `running_mean` along z, streamed: the same restarts every w = 2R + 1 slices and the same
/// additions in the same order, over a ring of the last w + 1 slices fed.
struct ZMean {
    n: usize,
    radius: usize,
    ring: Vec<Vec<f32>>,
    outside: Vec<f32>,
    acc: Vec<f32>,
    offset: Vec<f32>,
}

impl ZMean {
    fn new(n: usize, lanes: usize, radius: usize, outside: f32) -> Self {
        Self {
            n,
            radius,
            ring: vec![vec![0.0; lanes]; 2 * radius + 2],
            outside: vec![outside; lanes],
            acc: vec![0.0; lanes],
            offset: vec![0.0; lanes],
        }
    }

    fn feed(&mut self, s: usize, slice: &mut Vec<f32>) {
        let slots = self.ring.len();
        std::mem::swap(&mut self.ring[s % slots], slice);
    }

    fn window(&mut self, k: usize, out: &mut [f32]) {
        let Self {
            n,
            radius,
            ring,
            outside,
            acc,
            offset,
        } = self;
        let (r, w) = (*radius as isize, 2 * *radius + 1);
        let element = |j: isize| -> &[f32] {
            if j < 0 || j as usize >= *n {
                outside
            } else {
                &ring[j as usize % ring.len()]
            }
        };
        let k = k as isize;
        if (k as usize).is_multiple_of(w) {
            offset.copy_from_slice(element(k));
            acc.fill(0.0);
            for j in k - r..=k + r {
                for ((a, v), c) in acc.iter_mut().zip(element(j)).zip(offset.iter()) {
                    *a += v - c;
                }
            }
        } else {
            // The window moved on by one since slice k - 1's.
            let (entering, leaving) = (element(k + r), element(k - 1 - r));
            for ((a, e), l) in acc.iter_mut().zip(entering).zip(leaving) {
                *a += e - l;
            }
        }
        let wf = w as f32;
        for ((o, a), c) in out.iter_mut().zip(acc.iter()).zip(offset.iter()) {
            *o = c + a / wf;
        }
    }
}

/// `van_herk` along z, streamed: the prefix extreme of the block being filled, and the suffix
/// extremes of the last two blocks completed (made backwards in place when a block's last
/// slice arrives); a window spans at most two blocks, the second one's prefix ending at the
/// slice fed last.
struct ZExtreme {
    n: usize,
    radius: usize,
    outside: f32,
    op: fn(f32, f32) -> f32,
    prefix: Vec<f32>,
    filling: Vec<Vec<f32>>,
    /// (block index, its suffix extremes), oldest first.
    done: std::collections::VecDeque<(usize, Vec<Vec<f32>>)>,
    spare: Vec<Vec<f32>>,
}

impl ZExtreme {
    fn new(n: usize, lanes: usize, radius: usize, outside: f32, op: fn(f32, f32) -> f32) -> Self {
        Self {
            n,
            radius,
            outside,
            op,
            prefix: vec![0.0; lanes],
            filling: Vec::new(),
            done: Default::default(),
            spare: Vec::new(),
        }
    }

    fn feed(&mut self, s: usize, slice: &mut Vec<f32>) {
        let (w, op) = (2 * self.radius + 1, self.op);
        if s.is_multiple_of(w) {
            self.prefix.copy_from_slice(slice);
        } else {
            for (p, x) in self.prefix.iter_mut().zip(slice.iter()) {
                *p = op(*p, *x);
            }
        }
        let spare = self.spare.pop().unwrap_or_else(|| vec![0.0; slice.len()]);
        self.filling.push(std::mem::replace(slice, spare));
        if s % w == w - 1 || s == self.n - 1 {
            for t in (0..self.filling.len() - 1).rev() {
                let (head, after) = self.filling.split_at_mut(t + 1);
                for (o, a) in head[t].iter_mut().zip(&after[0]) {
                    *o = op(*a, *o);
                }
            }
            self.done
                .push_back((s / w, std::mem::take(&mut self.filling)));
            if self.done.len() > 2 {
                let (_, old) = self.done.pop_front().expect("three blocks are held");
                self.spare.extend(old);
            }
        }
    }

    fn suffix(&self, t: usize) -> &[f32] {
        let w = 2 * self.radius + 1;
        let (_, block) = self
            .done
            .iter()
            .find(|(b, _)| *b == t / w)
            .expect("a window's first block is complete when the window is");
        &block[t % w]
    }

    fn window(&self, k: usize, out: &mut [f32]) {
        let (r, w, op) = (self.radius, 2 * self.radius + 1, self.op);
        let lo = k.saturating_sub(r);
        let hi = (k + r).min(self.n - 1);
        if lo / w == hi / w {
            // One block: the window starts it (prefix) or ends at the grid's end (suffix).
            out.copy_from_slice(if lo % w == 0 {
                &self.prefix
            } else {
                self.suffix(lo)
            });
        } else {
            for ((o, s), p) in out.iter_mut().zip(self.suffix(lo)).zip(&self.prefix) {
                *o = op(*s, *p);
            }
        }
        if k < r || k + r >= self.n {
            for o in out.iter_mut() {
                *o = op(*o, self.outside);
            }
        }
    }
}

/// Side of the tiles of [`transpose`]: a tile's rows and columns stay in L1.
const TILE: usize = 16;

/// Writes `f` of the matrix `src` (rows of `cols` values) transposed into `dst`, tile by tile.
fn transpose(src: &[f32], cols: usize, dst: &mut [f32], f: impl Fn(f32) -> f32) {
    let rows = src.len() / cols;
    for r0 in (0..rows).step_by(TILE) {
        for c0 in (0..cols).step_by(TILE) {
            for r in r0..(r0 + TILE).min(rows) {
                let line = &src[r * cols..(r + 1) * cols];
                for c in c0..(c0 + TILE).min(cols) {
                    dst[c * rows + r] = f(line[c]);
                }
            }
        }
    }
}

fn check_cancelled(progress: &dyn Progress) -> Result<()> {
    if progress.cancelled() {
        Err(Error::Cancelled)
    } else {
        Ok(())
    }
}

/// Buffers a job reuses between calls.
#[derive(Default)]
pub struct Scratch {
    transposed: Vec<f32>,
    work: Vec<f32>,
    a: Vec<f32>,
    b: Vec<f32>,
    c: Vec<f32>,
}

/// Replaces each of the `rows.len()` elements (each a slice of the same number of lanes) by the
/// reduction of the window of `radius` elements either side, lane by lane; elements beyond
/// either end are `outside`.
pub fn window_pass(
    rows: &mut [&mut [f32]],
    reduce: Reduce,
    radius: usize,
    outside: f32,
    scratch: &mut Scratch,
) {
    let Some(lanes) = rows.first().map(|r| r.len()) else {
        return;
    };
    match reduce {
        Reduce::Mean => running_mean(rows, lanes, radius, outside, scratch),
        Reduce::Min => van_herk(rows, lanes, radius, outside, scratch, f32::min),
        Reduce::Max => van_herk(rows, lanes, radius, outside, scratch, f32::max),
    }
}

fn running_mean(
    rows: &mut [&mut [f32]],
    lanes: usize,
    radius: usize,
    outside: f32,
    scratch: &mut Scratch,
) {
    let n = rows.len();
    let w = 2 * radius + 1;
    let wf = w as f32;
    // The input, kept because the rows are overwritten as the window moves on.
    let src = &mut scratch.a;
    src.clear();
    for row in rows.iter() {
        src.extend_from_slice(row);
    }
    // The sum runs over deviations from a local offset, a value of the line near the window,
    // so that its rounding error scales with the local spread, not with the values: the
    // variance, E[x^2] - E[x]^2, is a small difference of the two means wherever the values
    // vary little, and absolute errors in the means would swamp it at large radii.
    let (acc, offset) = (&mut scratch.b, &mut scratch.c);
    acc.clear();
    acc.resize(lanes, 0.0);
    offset.clear();
    offset.resize(lanes, 0.0);
    let outside_row = vec![outside; lanes];
    let element = |j: isize| -> &[f32] {
        if j < 0 || j as usize >= n {
            &outside_row
        } else {
            &src[j as usize * lanes..(j as usize + 1) * lanes]
        }
    };
    for (i, row) in rows.iter_mut().enumerate() {
        if i % w == 0 {
            offset.copy_from_slice(element(i as isize));
            acc.fill(0.0);
            for j in i as isize - radius as isize..=(i + radius) as isize {
                for ((a, v), c) in acc.iter_mut().zip(element(j)).zip(offset.iter()) {
                    *a += v - c;
                }
            }
        }
        for ((out, a), c) in row.iter_mut().zip(acc.iter()).zip(offset.iter()) {
            *out = c + a / wf;
        }
        let entering = element((i + radius + 1) as isize);
        let leaving = element(i as isize - radius as isize);
        for ((a, e), l) in acc.iter_mut().zip(entering).zip(leaving) {
            *a += e - l;
        }
    }
}

fn van_herk(
    rows: &mut [&mut [f32]],
    lanes: usize,
    radius: usize,
    outside: f32,
    scratch: &mut Scratch,
    op: impl Fn(f32, f32) -> f32 + Copy,
) {
    let n = rows.len();
    let w = 2 * radius + 1;
    // prefix[i]: extreme from the start of i's block to i; suffix[i]: from i to its block's end.
    let (prefix, suffix) = (&mut scratch.a, &mut scratch.b);
    prefix.clear();
    prefix.resize(n * lanes, 0.0);
    suffix.clear();
    suffix.resize(n * lanes, 0.0);
    for i in 0..n {
        let (done, rest) = prefix.split_at_mut(i * lanes);
        let out = &mut rest[..lanes];
        if i % w == 0 {
            out.copy_from_slice(rows[i]);
        } else {
            let before = &done[(i - 1) * lanes..];
            for ((o, b), x) in out.iter_mut().zip(before).zip(rows[i].iter()) {
                *o = op(*b, *x);
            }
        }
    }
    for i in (0..n).rev() {
        let (head, after) = suffix.split_at_mut((i + 1) * lanes);
        let out = &mut head[i * lanes..];
        if i % w == w - 1 || i == n - 1 {
            out.copy_from_slice(rows[i]);
        } else {
            for ((o, a), x) in out.iter_mut().zip(&after[..lanes]).zip(rows[i].iter()) {
                *o = op(*a, *x);
            }
        }
    }
    for (i, row) in rows.iter_mut().enumerate() {
        let lo = i.saturating_sub(radius);
        let hi = (i + radius).min(n - 1);
        let pre = &prefix[hi * lanes..(hi + 1) * lanes];
        let suf = &suffix[lo * lanes..(lo + 1) * lanes];
        if lo / w == hi / w {
            // One block: the window starts it (prefix) or ends at its end or the line's (suffix).
            row.copy_from_slice(if lo % w == 0 { pre } else { suf });
        } else {
            for ((o, s), p) in row.iter_mut().zip(suf).zip(pre) {
                *o = op(*s, *p);
            }
        }
        if i < radius || i + radius >= n {
            for o in row.iter_mut() {
                *o = op(*o, outside);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reduction of each window by brute force, `outside` beyond the ends.
    fn brute(line: &[f32], reduce: Reduce, radius: usize, outside: f32) -> Vec<f32> {
        let n = line.len() as isize;
        (0..n)
            .map(|i| {
                let window = (i - radius as isize..=i + radius as isize).map(|j| {
                    if (0..n).contains(&j) {
                        line[j as usize]
                    } else {
                        outside
                    }
                });
                match reduce {
                    Reduce::Min => window.fold(f32::INFINITY, f32::min),
                    Reduce::Max => window.fold(f32::NEG_INFINITY, f32::max),
                    Reduce::Mean => window.sum::<f32>() / (2 * radius + 1) as f32,
                }
            })
            .collect()
    }

    #[test]
    fn window_pass_matches_brute_force_for_every_length_and_radius() {
        let mut scratch = Scratch::default();
        for n in 1..=23usize {
            let line: Vec<f32> = (0..n).map(|i| ((i * 7919) % 13) as f32 - 4.0).collect();
            for radius in 1..=12 {
                for reduce in [Reduce::Min, Reduce::Max, Reduce::Mean] {
                    // Two lanes: the line and its negation.
                    let mut data: Vec<f32> = line.iter().flat_map(|&v| [v, -v]).collect();
                    let mut rows: Vec<&mut [f32]> = data.chunks_mut(2).collect();
                    window_pass(&mut rows, reduce, radius, 1.5, &mut scratch);
                    let negated: Vec<f32> = line.iter().map(|v| -v).collect();
                    for (lane, input) in [line.clone(), negated].iter().enumerate() {
                        let want = brute(input, reduce, radius, 1.5);
                        for i in 0..n {
                            let got = data[2 * i + lane];
                            assert!(
                                (got - want[i]).abs() <= 1e-5,
                                "{reduce:?} n={n} r={radius} lane {lane} i={i}: {got} vs {}",
                                want[i]
                            );
                        }
                    }
                }
            }
        }
    }
}
