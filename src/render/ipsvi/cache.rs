//! The illumination cache: a 2D grid over the light's rays, fitted to the volume's projection as
//! seen from the light, holding per texel the light that has arrived furthest along its ray.
//!
//! A texel stands for the bundle of light rays through it: parallel rays on a plane
//! perpendicular to a directional light; for a point light, the directions from the light
//! through a plane (a gnomonic map, when the box lies within [`MAX_PLANAR_DEG`] of the
//! direction to its centre) or over the whole sphere (an octahedral map, for a light inside or
//! beside the box). Along a ray, `s` measures how far light has travelled: the distance along
//! a sun's direction, or from a lamp.
//!
//! An entry is the optical depth `tau` the light has crossed to a point (its transmittance is
//! exp(-tau)) together with that point's `s`. Entries pack into one u64 ordered by `s` first and
//! `tau` second, so that merging
//! the writes of one line keeps the furthest entry by `max`, in any order: the result does not
//! depend on how threads interleave.

use crate::lights::Light;
use glam::{UVec2, Vec2, Vec3};

/// Largest angle between a corner of the box and the direction to its centre for which a point
/// light uses the planar map; past it the plane's texels would stretch by 1 / cos^2 and the
/// octahedral map wastes less.
pub const MAX_PLANAR_DEG: f32 = 60.0;

/// How positions map to the cache.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Map {
    /// Parallel rays along `travel`: texel coordinates from the plane coordinates (e1, e2).
    Parallel {
        travel: Vec3,
        e1: Vec3,
        e2: Vec3,
        origin: Vec2,
        texel: f32,
    },
    /// Rays from `light` through the plane at unit distance along `axis`.
    Planar {
        light: Vec3,
        axis: Vec3,
        e1: Vec3,
        e2: Vec3,
        origin: Vec2,
        texel: f32,
    },
    /// Rays from `light` in every direction, through the octahedral map.
    Sphere { light: Vec3 },
}

/// Where a point lies in the cache: the four light rays (texel centres) around it with their
/// bilinear weights, and how far the light has travelled to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Place {
    pub corners: [u32; 4],
    pub weights: [f32; 4],
    pub s: f32,
}

/// How fine the cache is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Resolution {
    /// Texels along the longer side.
    Texels(u32),
    /// Texels about this wide (world units) near the box's centre, for the map's size.
    Footprint(f32),
}

impl Resolution {
    /// `texels` when given; else texels half as wide as a pixel at the volume's centre, or a
    /// voxel wide if that is smaller, and never narrower than half a voxel: a camera inside the
    /// box, or with the box's centre at depth ~0, sees pixels of width ~0 there, which would ask
    /// for the largest map for nothing (texels finer than half a voxel resolve no more of the
    /// data, and `MAX_AUTO_SIZE`^2 texels took minutes in half-angle slicing). Light is interpolated between the grid's rays, and where
    /// it grazes a dense body it changes within a pixel: on the CT phantom lit from behind
    /// (64^2, a pixel about a voxel) texels of a pixel erred by 0.30 relative RMSE, of half a
    /// pixel by 0.06. Finer texels than the view rays' spacing cost time and little accuracy:
    /// a line's rays then miss most texels, and the next line integrates from older entries
    /// (at 128^2, texels of half a voxel instead of this made the tooth 2.5 times slower for
    /// the same error).
    pub fn for_view(
        texels: Option<u32>,
        volume: &crate::volume::Volume,
        camera: &crate::camera::Camera,
    ) -> Self {
        match texels {
            Some(texels) => Resolution::Texels(texels),
            None => {
                let (lo, hi) = volume.bounds();
                let pixel = camera.pixel_footprint(0.5 * (lo + hi));
                let voxel = volume.spacing().min_element();
                Resolution::Footprint((0.5 * pixel).clamp(0.5 * voxel, voxel))
            }
        }
    }
}

/// Most texels per side an automatic resolution picks (4096^2 entries are 128 MiB).
pub const MAX_AUTO_SIZE: u32 = 4096;

/// The cache's geometry for one light and one box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheMap {
    map: Map,
    pub size: UVec2,
}

impl CacheMap {
    /// The map for `light` over the box [lo, hi].
    pub fn new(light: &Light, lo: Vec3, hi: Vec3, resolution: Resolution) -> Option<Self> {
        let corners: Vec<Vec3> = (0..8)
            .map(|c| Vec3::select(glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0), hi, lo))
            .collect();
        let centre = 0.5 * (lo + hi);
        // A light's typical distance to the box: to its centre, at least half its diagonal (a
        // lamp inside the box).
        let reach = |light: Vec3| (centre - light).length().max(0.5 * (hi - lo).length());
        // Texels along the longer side for an extent (in the map's units) and the world length
        // of one map unit at the box.
        let texels = |extent: f32, unit: f32| match resolution {
            Resolution::Texels(n) => n,
            Resolution::Footprint(width) => (extent * unit / width)
                .ceil()
                .clamp(1.0, MAX_AUTO_SIZE as f32)
                as u32,
        };
        let fitted = |coords: &[Vec2], unit: f32| {
            let min = coords.iter().copied().fold(Vec2::MAX, Vec2::min);
            let max = coords.iter().copied().fold(Vec2::MIN, Vec2::max);
            let extent = (max - min).max(Vec2::splat(1e-12));
            let size = texels(extent.max_element(), unit);
            let texel = extent.max_element() / size as f32;
            let size = (extent / texel)
                .ceil()
                .as_uvec2()
                .clamp(UVec2::ONE, UVec2::splat(size));
            (min, texel, size)
        };
        match *light {
            Light::Ambient { .. } => None,
            Light::Directional { to_light, .. } => {
                let travel = -to_light;
                let (e1, e2) = travel.any_orthonormal_pair();
                let coords: Vec<Vec2> = corners
                    .iter()
                    .map(|c| Vec2::new(c.dot(e1), c.dot(e2)))
                    .collect();
                let (origin, texel, size) = fitted(&coords, 1.0);
                Some(Self {
                    map: Map::Parallel {
                        travel,
                        e1,
                        e2,
                        origin,
                        texel,
                    },
                    size,
                })
            }
            Light::Point { position, .. } => {
                let axis = (0.5 * (lo + hi) - position).normalize_or_zero();
                let cos_max = MAX_PLANAR_DEG.to_radians().cos();
                let planar = axis != Vec3::ZERO
                    && corners
                        .iter()
                        .all(|c| (*c - position).normalize_or_zero().dot(axis) >= cos_max);
                if !planar {
                    // The octahedral map is near equal-area: a texel spans sqrt(4 pi) / n.
                    let side = texels(1.0, reach(position) * (4.0 * std::f32::consts::PI).sqrt());
                    return Some(Self {
                        map: Map::Sphere { light: position },
                        size: UVec2::splat(side),
                    });
                }
                let (e1, e2) = axis.any_orthonormal_pair();
                let coords: Vec<Vec2> = corners
                    .iter()
                    .map(|c| {
                        let d = *c - position;
                        Vec2::new(d.dot(e1), d.dot(e2)) / d.dot(axis)
                    })
                    .collect();
                let (origin, texel, size) = fitted(&coords, reach(position));
                Some(Self {
                    map: Map::Planar {
                        light: position,
                        axis,
                        e1,
                        e2,
                        origin,
                        texel,
                    },
                    size,
                })
            }
        }
    }

    /// How positions map to the cache (the GPU twin uploads it).
    pub(super) fn map(&self) -> Map {
        self.map
    }

    /// Texels in the cache (at least one).
    pub fn texels(&self) -> usize {
        (self.size.x * self.size.y) as usize
    }

    /// The four light rays of the cache around `p`, with bilinear weights, and the light's
    /// travel to `p`.
    #[inline]
    pub fn place(&self, p: Vec3) -> Place {
        let (uv, s) = match self.map {
            Map::Parallel {
                travel,
                e1,
                e2,
                origin,
                texel,
            } => (
                (Vec2::new(p.dot(e1), p.dot(e2)) - origin) / texel,
                p.dot(travel),
            ),
            Map::Planar {
                light,
                axis,
                e1,
                e2,
                origin,
                texel,
            } => {
                let d = p - light;
                let z = d.dot(axis).max(f32::MIN_POSITIVE);
                (
                    (Vec2::new(d.dot(e1), d.dot(e2)) / z - origin) / texel,
                    d.length(),
                )
            }
            Map::Sphere { light } => {
                let d = p - light;
                let s = d.length();
                let dir = if s > 0.0 { d / s } else { Vec3::Z };
                (
                    (crate::octahedral::encode(dir) + 1.0) * 0.5 * self.size.as_vec2(),
                    s,
                )
            }
        };
        // Texel centres sit at half-integers; clamped at the edges (on the octahedral map's
        // folds the neighbours across the fold are not used: a seam of one texel).
        let last = (self.size - 1).as_vec2();
        let c = (uv - 0.5).clamp(Vec2::ZERO, last);
        let lo = c.as_uvec2();
        let f = c - lo.as_vec2();
        let hi = (lo + 1).min(self.size - 1);
        let at = |x: u32, y: u32| x + self.size.x * y;
        Place {
            corners: [
                at(lo.x, lo.y),
                at(hi.x, lo.y),
                at(lo.x, hi.y),
                at(hi.x, hi.y),
            ],
            weights: [
                (1.0 - f.x) * (1.0 - f.y),
                f.x * (1.0 - f.y),
                (1.0 - f.x) * f.y,
                f.x * f.y,
            ],
            s,
        }
    }

    /// The point at travel `s` on the light ray through the centre of `texel`.
    #[inline]
    pub fn ray_point(&self, texel: u32, s: f32) -> Vec3 {
        let (origin, dir) = self.ray(texel);
        origin + dir * s
    }

    /// The light ray through the centre of `texel`: its point at travel 0 (on the plane s = 0
    /// through the world's origin for a sun, the lamp itself) and the unit direction the light
    /// travels along it. Taken apart rather than as the difference of two [`Self::ray_point`]s,
    /// which loses the direction's precision when the ray starts far off (a distant lamp).
    #[inline]
    pub fn ray(&self, texel: u32) -> (Vec3, Vec3) {
        let centre = Vec2::new((texel % self.size.x) as f32, (texel / self.size.x) as f32) + 0.5;
        match self.map {
            Map::Parallel {
                travel,
                e1,
                e2,
                origin,
                texel,
            } => {
                let uv = origin + centre * texel;
                (e1 * uv.x + e2 * uv.y, travel)
            }
            Map::Planar {
                light,
                axis,
                e1,
                e2,
                origin,
                texel,
            } => {
                let ab = origin + centre * texel;
                (light, (axis + e1 * ab.x + e2 * ab.y).normalize())
            }
            Map::Sphere { light } => {
                let uv = centre / self.size.as_vec2() * 2.0 - 1.0;
                (light, crate::octahedral::decode(uv))
            }
        }
    }

    /// The unit direction from `p` towards the light and how far the light is (infinite for a
    /// sun).
    #[inline]
    pub fn towards_light(&self, p: Vec3) -> (Vec3, f32) {
        match self.map {
            Map::Parallel { travel, .. } => (-travel, f32::INFINITY),
            Map::Planar { light, .. } | Map::Sphere { light } => {
                let d = light - p;
                let r = d.length();
                (if r > 0.0 { d / r } else { Vec3::Z }, r)
            }
        }
    }
}

/// An entry: the optical depth `tau` the light has crossed when it reaches the point `s` along
/// its ray. Depths, not transmittances, because that is what samples interpolate and add to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    pub s: f32,
    pub tau: f32,
}

/// No entry yet: below every packed entry.
pub const EMPTY: u64 = 0;

impl Entry {
    /// Packs into a u64 ordered by `s`, then `tau` (both finite; `tau` >= 0).
    #[inline]
    pub fn pack(self) -> u64 {
        // The sign-magnitude float made monotonic as an unsigned integer.
        let bits = self.s.to_bits();
        let ordered = if bits >> 31 == 1 {
            !bits
        } else {
            bits | 1 << 31
        };
        ((ordered as u64) << 32) | self.tau.max(0.0).to_bits() as u64
    }

    /// The entry `packed` holds, None for [`EMPTY`].
    #[inline]
    pub fn unpack(packed: u64) -> Option<Self> {
        if packed == EMPTY {
            return None;
        }
        let ordered = (packed >> 32) as u32;
        let bits = if ordered >> 31 == 1 {
            ordered & !(1 << 31)
        } else {
            !ordered
        };
        Some(Self {
            s: f32::from_bits(bits),
            tau: f32::from_bits(packed as u32),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_entries_order_by_travel_then_depth() {
        let entries = [
            (-3.5, 0.2),
            (-3.5, 0.9),
            (-0.0, 1.0),
            (0.0, 0.5),
            (0.25, 0.0),
            (7.0, 69.0),
        ]
        .map(|(s, tau)| Entry { s, tau });
        for pair in entries.windows(2) {
            assert!(pair[0].pack() <= pair[1].pack(), "{pair:?}");
        }
        for e in entries {
            assert!(e.pack() > EMPTY);
            let back = Entry::unpack(e.pack()).unwrap();
            assert_eq!((back.s.abs(), back.tau), (e.s.abs(), e.tau));
        }
        assert_eq!(Entry::unpack(EMPTY), None);
    }

    #[test]
    fn every_point_of_the_box_has_a_texel_and_travel_grows_away_from_the_light() {
        let (lo, hi) = (Vec3::new(-1.0, -0.5, -0.3), Vec3::new(1.0, 0.5, 0.3));
        let lights = [
            Light::Directional {
                to_light: Vec3::new(0.3, -1.0, 1.2).normalize(),
                irradiance: Vec3::ONE,
            },
            Light::Point {
                position: Vec3::new(0.5, -6.0, 2.0),
                intensity: Vec3::ONE,
            },
            Light::Point {
                position: Vec3::new(0.1, 0.0, 0.0),
                intensity: Vec3::ONE,
            },
        ];
        for light in lights {
            let map = CacheMap::new(&light, lo, hi, Resolution::Texels(64)).unwrap();
            assert!(map.size.max_element() == 64, "{light:?}: {:?}", map.size);
            let mut used = vec![false; map.texels()];
            for k in 0..20 {
                for j in 0..20 {
                    for i in 0..20 {
                        let f = Vec3::new(i as f32, j as f32, k as f32) / 19.0;
                        let p = lo + (hi - lo) * f;
                        let place = map.place(p);
                        for (corner, weight) in place.corners.iter().zip(place.weights) {
                            used[*corner as usize] |= weight > 0.0;
                            // The corner's ray passes within a texel or so of p at p's travel.
                            let q = map.ray_point(*corner, place.s);
                            assert!((q - p).length() < 0.2, "{light:?}: {p} vs {q}");
                        }
                        assert!((place.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5);
                        let (to_light, _) = map.towards_light(p);
                        let nearer = map.place(p + 0.01 * to_light);
                        assert!(nearer.s < place.s, "{light:?} at {p}");
                    }
                }
            }
            let share = used.iter().filter(|u| **u).count() as f32 / map.texels() as f32;
            assert!(
                share > 0.1,
                "{light:?}: the box covers {share} of the cache"
            );
        }
    }
}
