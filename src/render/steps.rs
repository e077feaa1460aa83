//! The steps of a view ray through the volume's box, shared by the ray casters (unshaded,
//! gradient and AO-shaded DVR, IPSVI) on the CPU; `shaders/shared/common.wgsl` mirrors it for their
//! GPU twins (`step_offset`, `view_steps`, `step_segment`).

use crate::optics::occupancy::March;
use glam::Vec3;

/// The fraction of a step, in [0, 1), by which the view ray through pixel `(x, y)` shifts its
/// steps back ([`ViewSteps`]).
///
/// Why: marching every ray in steps that start where it enters the box puts the samples of
/// neighbouring rays at nearly the same places relative to the box, so the error of each ray's
/// sum changes smoothly across the image and draws concentric rings that follow the entry
/// face ("step banding", wood grain). An offset that is independent from pixel to pixel turns
/// the rings into fine noise of the same size, which the eye and any blur average away.
///
/// Deterministic: a hash of the pixel (the PCG output permutation of Jarzynski and Olano 2020,
/// "Hash Functions for GPU Rendering", applied as `pcg(x + pcg(y))`) in wrapping u32
/// arithmetic, its top 24 bits scaled by 2^-24, which is exact in f32, so the GPU twins
/// compute the very same offset.
#[inline]
pub fn step_offset(x: u32, y: u32) -> f32 {
    (pcg(x.wrapping_add(pcg(y))) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// PCG's state step and output permutation of one u32 (`pcg_hash` in shaders/shared/common.wgsl).
#[inline]
fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The steps of a view ray that enters the box at distance `near` and leaves it at `far`: the
/// lattice of steps of length `step` that starts `offset * step` before `near`, clipped to
/// `[near, far]`. The first step is `(1 - offset) * step` long, the last one ends at `far`,
/// the others are whole; each is sampled at its midpoint. The steps cover the segment exactly,
/// so a homogeneous medium gives the same transmittance whatever the offset, and opacity stays
/// `1 - exp(-sigma_t dt)` per step. Offset 0 is the unshifted march.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewSteps {
    pub near: f32,
    pub far: f32,
    /// Where the lattice starts: `near - offset * step`.
    pub start: f32,
    pub step: f32,
    /// Steps up to the one that reaches `far`.
    pub count: u32,
}

impl ViewSteps {
    #[inline]
    pub fn new(near: f32, far: f32, step: f32, offset: f32) -> Self {
        let start = near - offset * step;
        Self {
            near,
            far,
            start,
            step,
            count: ((far - start) / step).ceil() as u32,
        }
    }

    /// Step `k`'s start and length.
    #[inline]
    pub fn segment(&self, k: u32) -> (f32, f32) {
        let a = (self.start + k as f32 * self.step).max(self.near);
        let b = if k + 1 >= self.count {
            self.far
        } else {
            (self.start + (k + 1) as f32 * self.step).min(self.far)
        };
        (a, (b - a).max(0.0))
    }

    /// The march the occupancy grid skips along (a ray in index coordinates): the lattice's
    /// steps, whose midpoints are the samples but for the clipped first step (where the march
    /// starts, never skipped over) and last (its sample lies before its lattice midpoint, so
    /// never beyond the cell a skip leaves): skipping passes over exactly the samples in
    /// empty cells.
    #[inline]
    pub fn march(&self, index_origin: Vec3, index_dir: Vec3) -> March {
        March {
            index_origin,
            index_dir,
            start: self.start,
            step: self.step,
            steps: self.count,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_are_fractions_spread_over_the_unit_interval() {
        let mut bins = [0u32; 16];
        for y in 0..64 {
            for x in 0..64 {
                let u = step_offset(x, y);
                assert!((0.0..1.0).contains(&u), "{u}");
                bins[(u * 16.0) as usize] += 1;
            }
        }
        // 4096 offsets, 256 expected per bin.
        assert!(bins.iter().all(|&n| (200..=312).contains(&n)), "{bins:?}");
        // Neighbours differ: no smooth pattern across the image.
        assert_ne!(step_offset(10, 10), step_offset(11, 10));
        assert_ne!(step_offset(10, 10), step_offset(10, 11));
    }

    #[test]
    fn steps_cover_the_segment_whatever_the_offset() {
        for offset in [0.0, 0.25, 0.5, 0.999] {
            let steps = ViewSteps::new(1.0, 2.03, 0.1, offset);
            let mut end = steps.near;
            let mut total = 0.0;
            for k in 0..steps.count {
                let (a, dt) = steps.segment(k);
                assert!(
                    (a - end).abs() < 1e-6,
                    "offset {offset}, step {k}: {a} after {end}"
                );
                assert!(dt <= steps.step + 1e-6);
                end = a + dt;
                total += dt;
            }
            assert_eq!(end, steps.far);
            assert!((total - 1.03).abs() < 1e-5, "offset {offset}: {total}");
            let first = steps.segment(0).1;
            assert!((first - (1.0 - offset) * 0.1).abs() < 1e-6, "{first}");
        }
        // No offset: whole steps from the entry, as before.
        assert_eq!(ViewSteps::new(1.0, 2.03, 0.1, 0.0).count, 11);
    }
}
