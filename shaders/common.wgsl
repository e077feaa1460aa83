// Helpers shared by the kernels; a kernel pulls them in with the line //#include "common.wgsl".
// They mirror src/volume/mod.rs so that GPU and CPU twins agree.

// Trilinear sample at continuous index coordinates c (voxel centres at integers), clamped to the
// edge voxels: Volume::sample_index. Voxel i's centre sits at texture coordinate (i + 0.5) / n,
// so the texture's linear, clamp-to-edge sampler does the interpolation. Clamping c first, as the
// CPU does, keeps far-away (or infinite) coordinates out of the filter.
fn sample_volume(tex: texture_3d<f32>, samp: sampler, c: vec3<f32>, dims: vec3<f32>) -> f32 {
    let clamped = clamp(c, vec3<f32>(0.0), dims - 1.0);
    return textureSampleLevel(tex, samp, (clamped + 0.5) / dims, 0.0).r;
}

// Gradient in world units at index coordinates c: central differences of samples one voxel
// apart along each axis, divided by 2 * spacing (Volume::gradient).
fn volume_gradient(
    tex: texture_3d<f32>,
    samp: sampler,
    c: vec3<f32>,
    dims: vec3<f32>,
    spacing: vec3<f32>,
) -> vec3<f32> {
    let dx = sample_volume(tex, samp, c + vec3<f32>(1.0, 0.0, 0.0), dims)
        - sample_volume(tex, samp, c - vec3<f32>(1.0, 0.0, 0.0), dims);
    let dy = sample_volume(tex, samp, c + vec3<f32>(0.0, 1.0, 0.0), dims)
        - sample_volume(tex, samp, c - vec3<f32>(0.0, 1.0, 0.0), dims);
    let dz = sample_volume(tex, samp, c + vec3<f32>(0.0, 0.0, 1.0), dims)
        - sample_volume(tex, samp, c - vec3<f32>(0.0, 0.0, 1.0), dims);
    return vec3<f32>(dx, dy, dz) / (2.0 * spacing);
}
