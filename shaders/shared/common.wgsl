// Helpers shared by the kernels; a kernel pulls them in with the line //#include "common.wgsl".
// They mirror src/volume/mod.rs (sampling) and src/render/steps.rs (a view ray's steps) so that
// GPU and CPU twins agree.

const PI: f32 = 3.14159265358979;

// Trilinear sample at continuous index coordinates c (voxel centres at integers), clamped to the
// edge voxels: Volume::sample_index, operation for operation. The eight voxels are loaded and
// interpolated here in f32 rather than by a sampler: hardware filtering computes its weights in
// low precision (8 fractional bits on many GPUs), which puts steps of 1/256 of a voxel into
// every sample, and would need FLOAT32_FILTERABLE, which many adapters lack, for r32float.
// Clamping c first keeps far-away (or infinite) coordinates out of the integer conversion.
fn sample_volume(tex: texture_3d<f32>, c: vec3<f32>, dims: vec3<f32>) -> f32 {
    let clamped = clamp(c, vec3<f32>(0.0), dims - 1.0);
    // clamped >= 0, so the conversion truncates to the floor, as the CPU's does.
    let i0 = vec3<u32>(clamped);
    let f = clamped - vec3<f32>(i0);
    let i1 = min(i0 + 1u, vec3<u32>(dims) - 1u);
    let c00 = along_x(tex, i0.x, i1.x, i0.y, i0.z, f.x);
    let c10 = along_x(tex, i0.x, i1.x, i1.y, i0.z, f.x);
    let c01 = along_x(tex, i0.x, i1.x, i0.y, i1.z, f.x);
    let c11 = along_x(tex, i0.x, i1.x, i1.y, i1.z, f.x);
    return lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z);
}

// The value between voxels (x0, y, z) and (x1, y, z) at fraction t.
fn along_x(tex: texture_3d<f32>, x0: u32, x1: u32, y: u32, z: u32, t: f32) -> f32 {
    return lerp(
        textureLoad(tex, vec3<u32>(x0, y, z), 0).r,
        textureLoad(tex, vec3<u32>(x1, y, z), 0).r,
        t,
    );
}

// a + (b - a) t, the CPU's lerp (WGSL's mix may be computed as a (1 - t) + b t).
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + (b - a) * t;
}

// Gradient in world units at index coordinates c: central differences of samples one voxel
// apart along each axis, divided by 2 * spacing (Volume::gradient).
fn volume_gradient(
    tex: texture_3d<f32>,
    c: vec3<f32>,
    dims: vec3<f32>,
    spacing: vec3<f32>,
) -> vec3<f32> {
    let dx = sample_volume(tex, c + vec3<f32>(1.0, 0.0, 0.0), dims)
        - sample_volume(tex, c - vec3<f32>(1.0, 0.0, 0.0), dims);
    let dy = sample_volume(tex, c + vec3<f32>(0.0, 1.0, 0.0), dims)
        - sample_volume(tex, c - vec3<f32>(0.0, 1.0, 0.0), dims);
    let dz = sample_volume(tex, c + vec3<f32>(0.0, 0.0, 1.0), dims)
        - sample_volume(tex, c - vec3<f32>(0.0, 0.0, 1.0), dims);
    return vec3<f32>(dx, dy, dz) / (2.0 * spacing);
}

// PCG's state step and output permutation of one u32 (steps::pcg); u32 arithmetic wraps.
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The fraction of a step, in [0, 1), by which the view ray through `pixel` shifts its steps,
// bit for bit steps::step_offset (see there why): 24 bits of a hash times 2^-24, exact in f32.
fn step_offset(pixel: vec2<u32>) -> f32 {
    return f32(pcg_hash(pixel.x + pcg_hash(pixel.y)) >> 8u) * 5.9604644775390625e-8;
}

// A view ray's steps between `near` and `far` (steps::ViewSteps): the lattice of steps of
// `step` starting `offset * step` before `near`, clipped to [near, far].
struct ViewSteps {
    near: f32,
    far: f32,
    start: f32,
    step: f32,
    count: u32,
};

// ViewSteps::new for the box span (near, far).
fn view_steps(span: vec2<f32>, step: f32, offset: f32) -> ViewSteps {
    let start = span.x - offset * step;
    return ViewSteps(span.x, span.y, start, step, u32(ceil((span.y - start) / step)));
}

// ViewSteps::segment: step k's start and length; sampled at its midpoint.
fn step_segment(s: ViewSteps, k: u32) -> vec2<f32> {
    let a = max(s.start + f32(k) * s.step, s.near);
    var b = s.far;
    if (k + 1u < s.count) {
        b = min(s.start + f32(k + 1u) * s.step, s.far);
    }
    return vec2<f32>(a, max(b - a, 0.0));
}
