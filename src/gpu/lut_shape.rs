//! The classification table's axes as the renderers' uniforms hold them
//! (shaders/classify.wgsl's `LutShape`, read by `lut_lookup`).

use bytemuck::{Pod, Zeroable};

use crate::classify::Lut;

/// shaders/classify.wgsl's `LutShape`, field for field.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LutShapeUniform {
    value_min: f32,
    value_max: f32,
    /// 0: a 1D table (value only).
    gradient_max: f32,
    value_entries: u32,
    gradient_entries: u32,
    _pad: [u32; 3],
}

impl LutShapeUniform {
    pub fn new(lut: &Lut) -> Self {
        let [value_min, value_max] = lut.value_range();
        let [nv, ng] = lut.size();
        Self {
            value_min,
            value_max,
            gradient_max: lut.gradient_max().unwrap_or(0.0),
            value_entries: nv as u32,
            gradient_entries: ng as u32,
            _pad: [0; 3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors;

    #[test]
    fn lut_shape_matches_the_shader() {
        assert_mirrors!(
            LutShapeUniform,
            // classify.wgsl reads its includer's `lut` binding: parsed within a kernel.
            "raycast.wgsl",
            "LutShape",
            [
                value_min,
                value_max,
                gradient_max,
                value_entries,
                gradient_entries
            ]
        );
    }
}
