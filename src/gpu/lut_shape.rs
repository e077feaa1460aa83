//! The classification table's axes as the renderers' uniforms hold them
//! (shaders/shared/classify.wgsl's `LutShape`, read by `lut_lookup`).

use bytemuck::{Pod, Zeroable};

use crate::classify::Lut;

/// shaders/shared/classify.wgsl's `LutShape`, field for field.
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
    use crate::gpu::shader::Wgsl;

    /// The least kernel that includes classify.wgsl: the `lut` binding it reads, and an entry
    /// point that uses `LutShape`.
    const PROBE: Wgsl = Wgsl {
        name: "lut_shape_probe.wgsl",
        text: "@group(0) @binding(0) var<storage, read> lut: array<vec4<f32>>;\n\
               @group(0) @binding(1) var<uniform> shape: LutShape;\n\
               //#include \"common.wgsl\"\n//#include \"classify.wgsl\"\n\
               @compute @workgroup_size(1) fn main() { let o = lut_lookup(0.5, 0.0, shape); }\n",
        includes: &[],
    };

    #[test]
    fn lut_shape_matches_the_shader() {
        assert_mirrors!(
            LutShapeUniform,
            // classify.wgsl reads its includer's `lut` binding: parsed within a kernel.
            PROBE,
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
