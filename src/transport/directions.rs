//! The discrete ordinates: a set of directions that covers the sphere, each with its share of
//! the solid angle, and what a sweep across a grid needs of each (its upwind plane and the
//! point on it a voxel's characteristic comes from).
//!
//! The set is the spherical Fibonacci lattice: N points of equal area (z evenly spaced, the
//! azimuth turned by the golden angle), so each direction stands for 4 pi / N of the sphere,
//! any N is possible, and doubling N halves the area each stands for on every part of the
//! sphere alike, with no preferred axis (a product or level-symmetric set would align its
//! directions with the grid's axes, where a volume's straight walls are).

use crate::error::{Error, Result};
use glam::{DVec3, Vec3};
use std::ops::Range;

/// The fewest directions accepted: fewer leave whole octants of the sphere without one.
pub const MIN_DIRECTIONS: u32 = 8;
/// The most: beyond this the angular error is far below the grid's own (see the module docs
/// of [`super`]), and the time grows linearly.
pub const MAX_DIRECTIONS: u32 = 4096;

/// One direction as a sweep over a grid reads it. The light arrives travelling along -w, so the
/// transmittance at x looks upwind towards x + t w; the sweep visits the planes across `axis`
/// (the direction's dominant axis in voxel units) from the side w points to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ordinate {
    /// The unit direction towards the light, in world space.
    pub towards: Vec3,
    /// Its share of the sphere (the weights sum to 1).
    pub weight: f32,
    /// The axis whose planes the sweep steps across.
    pub axis: usize,
    /// +1 when the light lies towards the axis's last plane (the sweep starts there), else -1.
    pub sign: i32,
    /// Where the characteristic through a voxel meets the upwind plane, in voxels along the
    /// plane's two axes ([`lateral_axes`]), split into the floor and the fraction: the lattice
    /// point it lies beyond (-1 or 0) and the bilinear weights (in [0, 1]) of the four around
    /// it. |offset| <= 1, so a plane padded by one voxel holds every point read.
    pub floor: [i32; 2],
    pub fraction: [f32; 2],
    /// The world length of the characteristic from the voxel to the upwind plane.
    pub length: f32,
}

impl Ordinate {
    /// The bilinear weights of the four upwind lattice points, in the order the sweeps read
    /// them: (0, 0), (1, 0), (0, 1), (1, 1) from the floor. The last is what the first three
    /// leave of 1 (within an ulp of fb fc), so that the four added in that order make exactly
    /// 1 in f32: an upwind plane of T = 1 then gives exactly 1, and empty space stays at
    /// exactly 1 however many planes it spans, which lets the sweeps skip it
    /// ([`super::cpu`]).
    pub fn upwind_weights(&self) -> [f32; 4] {
        let [fb, fc] = self.fraction;
        let first = [(1.0 - fb) * (1.0 - fc), fb * (1.0 - fc), (1.0 - fb) * fc];
        // first[0..3] sum to at most 1 (each rounding is monotonic and 1 is exact), and
        // s + fl(1 - s) rounds to 1 for any such s (its error is within half an ulp of 1).
        let last = 1.0 - ((first[0] + first[1]) + first[2]);
        [first[0], first[1], first[2], last]
    }

    /// The first of the four upwind points, relative to the voxel, in a plane padded by one
    /// voxel with rows of `row` values.
    pub fn upwind_shift(&self, row: usize) -> isize {
        self.floor[0] as isize + row as isize * self.floor[1] as isize
    }
}

/// The two axes of the planes across `axis`, in increasing order (the first runs fastest in a
/// plane's layout).
pub fn lateral_axes(axis: usize) -> [usize; 2] {
    match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

/// The directions of one sweep order: all ordinates sharing a dominant axis and sign, so that
/// they step across the same planes in the same order.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    pub axis: usize,
    pub sign: i32,
    /// Indices into [`Ordinates::all`].
    pub members: Range<usize>,
}

/// A direction set laid out for a grid of some spacing, grouped by sweep order.
#[derive(Clone, Debug)]
pub struct Ordinates {
    all: Vec<Ordinate>,
    groups: Vec<Group>,
}

impl Ordinates {
    /// `count` Fibonacci directions for a grid of `spacing` (world units per voxel).
    pub fn new(count: u32, spacing: Vec3) -> Result<Self> {
        if !(MIN_DIRECTIONS..=MAX_DIRECTIONS).contains(&count) {
            return Err(Error::param(
                "directions",
                format!(
                    "the ambient light needs {MIN_DIRECTIONS} to {MAX_DIRECTIONS} directions \
                     (fewer leave parts of the sphere unlit), got {count}"
                ),
            ));
        }
        if !(spacing.is_finite() && spacing.min_element() > 0.0) {
            return Err(Error::Volume(format!(
                "spacing {spacing} must be positive and finite for light transport on the grid"
            )));
        }
        Self::from_directions(&fibonacci(count), spacing)
    }

    /// The ordinates of the unit vectors `towards` (equal weights) for a grid of `spacing`;
    /// refused when some octant of the sphere holds none of them.
    pub fn from_directions(towards: &[DVec3], spacing: Vec3) -> Result<Self> {
        let mut octants = [false; 8];
        for w in towards {
            let o =
                (w.x < 0.0) as usize | ((w.y < 0.0) as usize) << 1 | ((w.z < 0.0) as usize) << 2;
            octants[o] = true;
        }
        if let Some(empty) = octants.iter().position(|&o| !o) {
            return Err(Error::param(
                "directions",
                format!(
                    "the direction set does not cover the sphere: octant {empty} (signs x {}, y \
                     {}, z {}) holds none",
                    sign_name(empty & 1),
                    sign_name(empty & 2),
                    sign_name(empty & 4)
                ),
            ));
        }
        let h = spacing.as_dvec3();
        let weight = 1.0 / towards.len() as f32;
        let mut all: Vec<Ordinate> = towards.iter().map(|&w| ordinate(w, h, weight)).collect();
        // Group by sweep order, keeping the set's order within a group (the sum's order, which
        // the twins share).
        all.sort_by_key(|o| (o.axis, o.sign));
        let mut groups: Vec<Group> = Vec::new();
        for (i, o) in all.iter().enumerate() {
            match groups.last_mut() {
                Some(g) if g.axis == o.axis && g.sign == o.sign => g.members.end = i + 1,
                _ => groups.push(Group {
                    axis: o.axis,
                    sign: o.sign,
                    members: i..i + 1,
                }),
            }
        }
        Ok(Self { all, groups })
    }

    /// The one direction `towards` (unit, world) with all the weight: a sweep of it is the
    /// transmittance towards a sun. Not a set that covers the sphere.
    pub fn single(towards: Vec3, spacing: Vec3) -> Self {
        let o = ordinate(towards.as_dvec3(), spacing.as_dvec3(), 1.0);
        let groups = vec![Group {
            axis: o.axis,
            sign: o.sign,
            members: 0..1,
        }];
        Self {
            all: vec![o],
            groups,
        }
    }

    pub fn all(&self) -> &[Ordinate] {
        &self.all
    }

    pub fn groups(&self) -> &[Group] {
        &self.groups
    }
}

fn sign_name(bit: usize) -> &'static str {
    if bit == 0 {
        "+"
    } else {
        "-"
    }
}

/// The spherical Fibonacci lattice of `count` points.
pub fn fibonacci(count: u32) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Direction `w` (unit, world) on a grid of spacing `h`.
fn ordinate(w: DVec3, h: DVec3, weight: f32) -> Ordinate {
    let voxels = w / h;
    let axis = (0..3)
        .max_by(|&a, &b| voxels[a].abs().total_cmp(&voxels[b].abs()))
        .unwrap_or(2);
    let along = voxels[axis].abs();
    let [b, c] = lateral_axes(axis);
    let offset = [voxels[b] / along, voxels[c] / along];
    // Floors in {-1, 0} (an offset of exactly 1 is 0 plus a whole voxel's fraction), so the
    // four points read lie within one voxel of the plane.
    let floor = offset.map(|o| o.floor().min(0.0));
    Ordinate {
        towards: w.as_vec3(),
        weight,
        axis,
        sign: if voxels[axis] > 0.0 { 1 } else { -1 },
        floor: floor.map(|f| f as i32),
        fraction: [(offset[0] - floor[0]) as f32, (offset[1] - floor[1]) as f32],
        length: (h[axis] / w[axis].abs()) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibonacci_points_are_unit_and_balanced() {
        let points = fibonacci(64);
        let mean: DVec3 = points.iter().copied().sum::<DVec3>() / 64.0;
        assert!(mean.length() < 0.02, "{mean}");
        assert!(points.iter().all(|p| (p.length() - 1.0).abs() < 1e-12));
    }

    #[test]
    fn ordinates_reach_the_upwind_plane_within_one_voxel() {
        let spacing = Vec3::new(1.0, 0.5, 2.0);
        let set = Ordinates::new(128, spacing).unwrap();
        let total: f32 = set.all().iter().map(|o| o.weight).sum();
        assert!((total - 1.0).abs() < 1e-5);
        for o in set.all() {
            let [b, c] = lateral_axes(o.axis);
            // The step to the upwind plane: one voxel along the axis, the offsets across it.
            let mut step = Vec3::ZERO;
            step[o.axis] = o.sign as f32 * spacing[o.axis];
            step[b] = (o.floor[0] as f32 + o.fraction[0]) * spacing[b];
            step[c] = (o.floor[1] as f32 + o.fraction[1]) * spacing[c];
            assert!((step.length() - o.length).abs() < 1e-4 * o.length, "{o:?}");
            assert!(step.normalize().dot(o.towards) > 1.0 - 1e-5, "{o:?}");
            for (f, x) in o.floor.iter().zip(o.fraction) {
                assert!((-1..=0).contains(f) && (0.0..=1.0).contains(&x), "{o:?}");
            }
        }
        // Groups partition the set, one per sweep order present.
        let covered: usize = set.groups().iter().map(|g| g.members.len()).sum();
        assert_eq!(covered, 128);
        assert_eq!(set.groups().len(), 6);
    }

    #[test]
    fn upwind_weights_make_exactly_one_in_the_sweeps_order() {
        let mut fractions: Vec<[f32; 2]> = Ordinates::new(1024, Vec3::new(1.0, 0.7, 1.3))
            .unwrap()
            .all()
            .iter()
            .map(|o| o.fraction)
            .collect();
        fractions.extend([
            [0.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [1e-7, 0.9999999],
            [0.3, 0.7],
        ]);
        for fraction in fractions {
            let o = Ordinate {
                towards: Vec3::Z,
                weight: 1.0,
                axis: 2,
                sign: 1,
                floor: [0, 0],
                fraction,
                length: 1.0,
            };
            let w = o.upwind_weights();
            assert_eq!(((w[0] + w[1]) + w[2]) + w[3], 1.0, "{fraction:?}: {w:?}");
            let [fb, fc] = fraction;
            assert!(
                (w[3] - fb * fc).abs() <= 2.0 * f32::EPSILON,
                "{fraction:?}: {w:?}"
            );
            assert!(
                w.iter().all(|x| (0.0..=1.0).contains(x)),
                "{fraction:?}: {w:?}"
            );
        }
    }

    #[test]
    fn too_few_directions_or_an_uncovered_octant_are_refused() {
        for n in [0, 1, 7, MAX_DIRECTIONS + 1] {
            let e = Ordinates::new(n, Vec3::ONE).unwrap_err().to_string();
            assert!(e.contains("directions"), "{e}");
        }
        let upper: Vec<DVec3> = fibonacci(64).into_iter().filter(|w| w.z > 0.0).collect();
        let e = Ordinates::from_directions(&upper, Vec3::ONE)
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not cover the sphere"), "{e}");
        assert!(Ordinates::new(64, Vec3::new(1.0, 0.0, 1.0)).is_err());
    }
}
