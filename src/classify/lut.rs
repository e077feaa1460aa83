//! The baked classification table shared by the CPU and GPU renderers.

use glam::Vec3;

/// Optical properties at one point of the volume.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Optical {
    /// Extinction per world unit.
    pub sigma_t: f32,
    /// Single-scattering albedo (sigma_s = albedo * sigma_t).
    pub albedo: Vec3,
    /// Emitted radiance per world unit of path.
    pub emission: Vec3,
}

impl Optical {
    pub(super) fn scaled(self, density_scale: f32) -> Self {
        Self {
            sigma_t: self.sigma_t * density_scale,
            ..self
        }
    }
}

/// f32s per table entry: sigma_t, albedo rgb, emission rgb, padding (matches the WGSL struct).
pub const LUT_STRIDE: usize = 8;

/// A 1D (value) or 2D (value x gradient magnitude) table of [`Optical`], read with linear
/// interpolation and clamped at the ends.
#[derive(Clone, Debug, PartialEq)]
pub struct Lut {
    value_range: [f32; 2],
    gradient_max: Option<f32>,
    size: [usize; 2],
    /// `size[0] * size[1]` entries of LUT_STRIDE f32s, value axis fastest.
    data: Vec<f32>,
}

impl Lut {
    pub(super) fn new(
        value_range: [f32; 2],
        gradient_max: Option<f32>,
        size: [usize; 2],
        entries: Vec<Optical>,
    ) -> Self {
        let data = entries
            .iter()
            .flat_map(|o| {
                [
                    o.sigma_t,
                    o.albedo.x,
                    o.albedo.y,
                    o.albedo.z,
                    o.emission.x,
                    o.emission.y,
                    o.emission.z,
                    0.0,
                ]
            })
            .collect();
        Self {
            value_range,
            gradient_max,
            size,
            data,
        }
    }

    pub fn value_range(&self) -> [f32; 2] {
        self.value_range
    }
    /// The gradient-magnitude axis' maximum, for a 2D table.
    pub fn gradient_max(&self) -> Option<f32> {
        self.gradient_max
    }
    pub fn size(&self) -> [usize; 2] {
        self.size
    }
    /// Raw entries for upload to the GPU.
    pub fn data(&self) -> &[f32] {
        &self.data
    }
    /// The largest extinction in the table: a majorant of every lookup, since lookups
    /// interpolate between entries.
    pub fn max_sigma_t(&self) -> f32 {
        self.data
            .chunks_exact(LUT_STRIDE)
            .map(|e| e[0])
            .fold(0.0, f32::max)
    }

    /// Whether some entry emits light where its extinction is zero (emission without matter).
    pub fn emits_without_extinction(&self) -> bool {
        self.data
            .chunks_exact(LUT_STRIDE)
            .any(|e| e[0] <= 0.0 && (e[4] > 0.0 || e[5] > 0.0 || e[6] > 0.0))
    }

    /// Whether any value in [lo, hi] (at any gradient magnitude) can have non-zero extinction
    /// or emission: checks every entry that linear interpolation over that range touches.
    pub fn may_contribute(&self, lo: f32, hi: f32) -> bool {
        let (first, last) = self.entries_between(lo, hi);
        (0..self.size[1]).any(|j| {
            (first..=last).any(|i| {
                let e = self.entry(i, j);
                e[0] != 0.0 || e[4] != 0.0 || e[5] != 0.0 || e[6] != 0.0
            })
        })
    }

    /// The least and the greatest extinction of any value in [lo, hi] at any gradient
    /// magnitude: the extreme entries that linear interpolation over that range touches (a
    /// minorant and a majorant there, since an interpolated value lies between its entries).
    pub fn sigma_t_bounds_between(&self, lo: f32, hi: f32) -> [f32; 2] {
        let (first, last) = self.entries_between(lo, hi);
        (0..self.size[1])
            .flat_map(|j| (first..=last).map(move |i| (i, j)))
            .map(|(i, j)| self.entry(i, j)[0])
            .fold([f32::INFINITY, 0.0], |[min, max], s| {
                [min.min(s), max.max(s)]
            })
    }

    /// The first and last entries along the value axis that lookups in [lo, hi] interpolate
    /// between.
    fn entries_between(&self, lo: f32, hi: f32) -> (usize, usize) {
        let [vmin, vmax] = self.value_range;
        let (first, _, _) = Self::coord(lo, vmin, vmax, self.size[0]);
        let (last0, last1, f) = Self::coord(hi, vmin, vmax, self.size[0]);
        (first, if f > 0.0 { last1 } else { last0 })
    }

    /// Continuous table coordinate along an axis of `n` entries for `x` in [lo, hi].
    #[inline]
    fn coord(x: f32, lo: f32, hi: f32, n: usize) -> (usize, usize, f32) {
        // `max` and `min` rather than `clamp`: they return the number where the quotient is NaN
        // (an infinite gradient over an infinite maximum), which `clamp` passes through.
        let u = ((x - lo) / (hi - lo) * (n - 1) as f32)
            .max(0.0)
            .min((n - 1) as f32);
        // u >= 0, so truncation is the floor.
        let i0 = u as usize;
        let i1 = (i0 + 1).min(n - 1);
        (i0, i1, u - i0 as f32)
    }

    #[inline]
    fn entry(&self, i: usize, j: usize) -> &[f32] {
        let at = (i + self.size[0] * j) * LUT_STRIDE;
        &self.data[at..at + LUT_STRIDE]
    }

    /// The extinction of [`Lut::lookup`] alone (light paths need nothing else).
    #[inline]
    pub fn sigma_t(&self, v: f32, g: f32) -> f32 {
        let [lo, hi] = self.value_range;
        let (i0, i1, fv) = Self::coord(v, lo, hi, self.size[0]);
        let along = |j: usize| {
            let (a, b) = (self.entry(i0, j)[0], self.entry(i1, j)[0]);
            a + (b - a) * fv
        };
        match self.gradient_max {
            None => along(0),
            Some(gmax) => {
                let (j0, j1, fg) = Self::coord(g, 0.0, gmax, self.size[1]);
                let (a, b) = (along(j0), along(j1));
                a + (b - a) * fg
            }
        }
    }

    /// Optical properties at value `v` and gradient magnitude `g` (ignored by a 1D table).
    #[inline]
    pub fn lookup(&self, v: f32, g: f32) -> Optical {
        let [lo, hi] = self.value_range;
        let (i0, i1, fv) = Self::coord(v, lo, hi, self.size[0]);
        let (j0, j1, fg) = match self.gradient_max {
            Some(gmax) => Self::coord(g, 0.0, gmax, self.size[1]),
            None => (0, 0, 0.0),
        };
        let mut out = [0.0f32; 7];
        let weights = [
            (i0, j0, (1.0 - fv) * (1.0 - fg)),
            (i1, j0, fv * (1.0 - fg)),
            (i0, j1, (1.0 - fv) * fg),
            (i1, j1, fv * fg),
        ];
        for (i, j, w) in weights {
            for (o, e) in out.iter_mut().zip(self.entry(i, j)) {
                *o += w * e;
            }
        }
        Optical {
            sigma_t: out[0],
            albedo: Vec3::new(out[1], out[2], out[3]),
            emission: Vec3::new(out[4], out[5], out[6]),
        }
    }
}
