// Directional occlusion shading's GPU twin: one dispatch per slab, one invocation per pixel.
// It mirrors src/render/dos/cpu.rs step for step (see src/render/dos/mod.rs for the model).

//#include "common.wgsl"
//#include "classify.wgsl"

const BACKGROUND_DEPTH: f32 = 1.0e10;
const MAX_CLIP_PLANES: u32 = 6u;

struct Params {
    // The view: camera and volume placement (raycast::gpu::ViewUniform).
    cam_position: vec4<f32>,   // w: 1 perspective, 0 orthographic
    cam_forward: vec4<f32>,
    cam_right: vec4<f32>,
    cam_up: vec4<f32>,
    image: vec4<f32>,          // half extent x, half extent y, width, height
    box_lo: vec4<f32>,
    box_hi: vec4<f32>,
    vol_origin: vec4<f32>,
    vol_spacing: vec4<f32>,
    vol_dims: vec4<f32>,
    lut_range: vec4<f32>,      // value min, value max, gradient max (0: 1D table), unused
    lut_size: vec4<f32>,       // entries along value, along gradient
    ambient: vec4<f32>,
    slabs: vec4<f32>,          // slice distance, depth of slice 0, cone samples, clip planes
    march: vec4<f32>,          // x: 1 lock-step rays (t = depth), 0 view-aligned slices; y: planes
    clip_point: array<vec4<f32>, MAX_CLIP_PLANES>,
    clip_normal: array<vec4<f32>, MAX_CLIP_PLANES>,
};

// What changes from slab to slab.
struct Slab {
    index: u32,
    // The cone base's radius in pixels on the previous slab.
    radius_px: f32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var volume_sampler: sampler;
@group(0) @binding(3) var<storage, read> lut: array<vec4<f32>>;
// Unit-disc offset (xy) and ring, the occlusion buffer's plane (z), per cone sample.
@group(0) @binding(4) var<storage, read> samples: array<vec4<f32>>;
// Occlusion buffers W, one plane per ring, laid out (row, plane, column): the previous slab's,
// read; this slab's, written.
@group(0) @binding(5) var<storage, read> previous: array<f32>;
@group(0) @binding(6) var<storage, read_write> next: array<f32>;
// Eye buffer: radiance and transmittance; depth and the occlusion factor there.
@group(0) @binding(7) var<storage, read_write> eye: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> eye_depth: array<vec2<f32>>;
@group(0) @binding(9) var<uniform> slab: Slab;
// Path length through the previous slab per plane.
@group(0) @binding(10) var<storage, read> ring_lengths: array<f32>;

// Index of plane p's texel (i, j) in the occlusion buffers.
fn texel(p: u32, i: i32, j: i32) -> u32 {
    return (u32(j) * u32(params.march.y) + p) * u32(params.image.z) + u32(i);
}

// V_k at a pixel: the average over the cone's samples of the previous buffer read bilinearly,
// with indices clamped to the image (dos::cpu::cone_average, blended rows first).
fn visibility(pixel: vec2<u32>) -> f32 {
    let count = u32(params.slabs.z);
    let last = vec2<i32>(params.image.zw) - 1;
    var sum = 0.0;
    for (var s = 0u; s < count; s = s + 1u) {
        let q = samples[s];
        let o = vec2<f32>(q.x, -q.y) * slab.radius_px;
        let whole = floor(o);
        let f = o - whole;
        let at = vec2<i32>(pixel) + vec2<i32>(whole);
        let i0 = clamp(at.x, 0, last.x);
        let i1 = clamp(at.x + 1, 0, last.x);
        let j0 = clamp(at.y, 0, last.y);
        let j1 = clamp(at.y + 1, 0, last.y);
        let p = u32(q.z);
        let t0 = previous[texel(p, i0, j0)];
        let t1 = previous[texel(p, i1, j0)];
        let m0 = t0 + (previous[texel(p, i0, j1)] - t0) * f.y;
        let m1 = t1 + (previous[texel(p, i1, j1)] - t1) * f.y;
        sum = sum + (m0 + (m1 - m0) * f.x);
    }
    return sum / f32(count);
}

// Optical properties at p with clipped material removed (dos::material).
fn material(p: vec3<f32>) -> Optical {
    for (var i = 0u; i < u32(params.slabs.w); i = i + 1u) {
        if (dot(p - params.clip_point[i].xyz, params.clip_normal[i].xyz) > 0.0) {
            return Optical(0.0, vec3<f32>(0.0), vec3<f32>(0.0));
        }
    }
    let c = (p - params.vol_origin.xyz) / params.vol_spacing.xyz;
    var g = 0.0;
    if (params.lut_range.z > 0.0) {
        g = length(volume_gradient(volume, volume_sampler, c, params.vol_dims.xyz, params.vol_spacing.xyz));
    }
    let v = sample_volume(volume, volume_sampler, c, params.vol_dims.xyz);
    return lut_lookup(v, g, params.lut_range, params.lut_size);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = u32(params.image.z);
    if (id.x >= width || id.y >= u32(params.image.w)) {
        return;
    }
    let index = id.x + width * id.y;
    var v = 1.0;
    if (slab.index > 0u) {
        v = visibility(id.xy);
    }
    let ray = camera_ray(
        id.xy,
        params.cam_position,
        params.cam_forward.xyz,
        params.cam_right.xyz,
        params.cam_up.xyz,
        params.image,
    );
    let span = box_span(ray.origin, ray.dir, params.box_lo.xyz, params.box_hi.xyz);
    let rate = select(dot(ray.dir, params.cam_forward.xyz), 1.0, params.march.x == 1.0);
    let d = params.slabs.x;
    let z0 = params.slabs.y + f32(slab.index) * d;
    let ta = max(z0 / rate, span.x);
    let tb = min((z0 + d) / rate, span.y);
    var tau = 0.0;
    if (tb > ta) {
        let dt = tb - ta;
        let o = material(ray.origin + (0.5 * (ta + tb)) * ray.dir);
        if (o.sigma_t > 0.0 || any(o.emission != vec3<f32>(0.0))) {
            var e = eye[index];
            let alpha = 1.0 - exp(-o.sigma_t * dt);
            let light = alpha * o.albedo * params.ambient.xyz * v + emitted(o, alpha, dt);
            let transmittance = e.w * (1.0 - alpha);
            if (e.w > 0.5 && transmittance <= 0.5) {
                eye_depth[index] = vec2<f32>(ta + log(2.0 * e.w) / o.sigma_t, v);
            }
            eye[index] = vec4<f32>(e.xyz + e.w * light, transmittance);
            tau = o.sigma_t * dt * rate / d;
        }
    }
    for (var p = 0u; p < u32(params.march.y); p = p + 1u) {
        next[texel(p, i32(id.x), i32(id.y))] = v * exp(-tau * ring_lengths[p]);
    }
}
