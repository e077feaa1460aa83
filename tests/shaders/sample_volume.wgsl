// Test kernel for the volume texture (tests/gpu_volume.rs): value and gradient at a list of
// index coordinates, to be compared with Volume::sample_index and Volume::gradient on the CPU.

//#include "common.wgsl"

struct Params {
    // Voxels per axis.
    dims: vec3<u32>,
    // Points to sample.
    count: u32,
    // World units per voxel.
    spacing: vec3<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var<storage, read> points: array<vec4<f32>>;
// xyz: gradient, w: value.
@group(0) @binding(3) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.count) {
        return;
    }
    let c = points[i].xyz;
    let dims = vec3<f32>(params.dims);
    let value = sample_volume(volume, c, dims);
    let gradient = volume_gradient(volume, c, dims, params.spacing);
    results[i] = vec4<f32>(gradient, value);
}
