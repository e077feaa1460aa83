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

// Entry and exit distances of a ray in the box [lo, hi], entry clamped to 0; x >= y when it
// misses (camera::intersect_box).
fn box_span(origin: vec3<f32>, dir: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let inv = 1.0 / dir;
    let t0 = (lo - origin) * inv;
    let t1 = (hi - origin) * inv;
    let near = max(max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z)), 0.0);
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z));
    return vec2<f32>(near, far);
}

struct CameraRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
};

// The ray through the centre of pixel (i, j), row 0 at the top (Camera::ray). position.w: 1
// perspective, 0 orthographic; image: half extent x, half extent y, width, height.
fn camera_ray(
    pixel: vec2<u32>,
    position: vec4<f32>,
    forward: vec3<f32>,
    right: vec3<f32>,
    up: vec3<f32>,
    image: vec4<f32>,
) -> CameraRay {
    let sx = ((f32(pixel.x) + 0.5) / image.z * 2.0 - 1.0) * image.x;
    let sy = (1.0 - (f32(pixel.y) + 0.5) / image.w * 2.0) * image.y;
    if (position.w == 1.0) {
        return CameraRay(position.xyz, normalize(forward + sx * right + sy * up));
    }
    return CameraRay(position.xyz + sx * right + sy * up, forward);
}
