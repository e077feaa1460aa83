//! The octahedral map between unit vectors and the square [-1, 1]^2: every direction gets a
//! place with nearly uniform area, so a square table covers the sphere without poles.

use glam::{Vec2, Vec3};

/// The octahedral map of a unit vector onto [-1, 1]^2 (the lower hemisphere folded outwards).
pub fn encode(n: Vec3) -> Vec2 {
    let p = Vec2::new(n.x, n.y) / n.abs().element_sum();
    if n.z >= 0.0 {
        p
    } else {
        (Vec2::ONE - Vec2::new(p.y, p.x).abs()) * Vec2::new(sign(p.x), sign(p.y))
    }
}

/// The unit vector that [`encode`] maps to `uv`.
pub fn decode(uv: Vec2) -> Vec3 {
    let z = 1.0 - uv.x.abs() - uv.y.abs();
    let xy = if z >= 0.0 {
        uv
    } else {
        (Vec2::ONE - Vec2::new(uv.y, uv.x).abs()) * Vec2::new(sign(uv.x), sign(uv.y))
    };
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// +1 or -1 (+1 at zero, so the fold is continuous on the axes).
fn sign(x: f32) -> f32 {
    if x >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Directions for tests: a spiral over the sphere plus the axes and the diagonals, where the map
/// folds.
#[cfg(test)]
pub(crate) fn test_directions() -> Vec<Vec3> {
    let mut directions: Vec<Vec3> = (0..400)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 400.0;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    for x in [-1.0, 0.0, 1.0] {
        for y in [-1.0, 0.0, 1.0] {
            for z in [-1.0, 0.0, 1.0] {
                let d = Vec3::new(x, y, z);
                if d != Vec3::ZERO {
                    directions.push(d.normalize());
                }
            }
        }
    }
    directions
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for n in test_directions() {
            let back = decode(encode(n));
            assert!((back - n).length() < 1e-5, "{n} -> {back}");
        }
    }
}
