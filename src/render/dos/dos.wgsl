// Directional occlusion shading's GPU twin: one dispatch per slab, one invocation per pixel.
// It mirrors src/render/dos/cpu.rs step for step (see src/render/dos/mod.rs for the model).

//#include "common.wgsl"
//#include "view.wgsl"
//#include "classify.wgsl"
//#include "occupancy.wgsl"

const BACKGROUND_DEPTH: f32 = 1.0e10;
const MAX_CLIP_PLANES: u32 = 6u;

// Material on the side the normal points to is removed (dos::ClipPlane).
struct ClipPlane {
    point: vec3<f32>,
    normal: vec3<f32>,
};

// Mirrored by dos::gpu::Params.
struct Params {
    view: View,
    lut: LutShape,
    ambient: vec3<f32>,
    // Slab thickness d, and slab 0's depth along the forward axis (along the rays, lock-step).
    slice_distance: f32,
    first_depth: f32,
    // Cone samples, and clipping planes in use.
    sample_count: u32,
    clip_count: u32,
    // 1: slabs are lock-step distances along each ray; 0: view-aligned slices.
    lock_step_rays: u32,
    // Planes of the occlusion buffers: one per path length through the previous slab.
    planes: u32,
    // 1: a sample's light is attenuated through the front half of its own segment.
    self_occlusion: u32,
    // The occupancy grid: cells per axis, voxels per cell side.
    cells: vec3<u32>,
    cell_voxels: u32,
    clip_planes: array<ClipPlane, MAX_CLIP_PLANES>,
};

// One cone sample (dos::gpu::ConeSample).
struct ConeSample {
    // On the unit disc.
    offset: vec2<f32>,
    // The occlusion buffer's plane (its ring).
    plane: u32,
};

// What changes from slab to slab (dos::gpu::Slab).
struct Slab {
    index: u32,
    // The cone base's radius in pixels on the previous slab.
    radius_px: f32,
    // To the 16 bytes of each slab's slice of the uniform buffer.
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var<storage, read> lut: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> samples: array<ConeSample>;
// Occlusion buffers W, one plane per ring, laid out (row, plane, column): the previous slab's,
// read; this slab's, written.
@group(0) @binding(4) var<storage, read> previous: array<f32>;
@group(0) @binding(5) var<storage, read_write> next: array<f32>;
// Eye buffer: radiance and transmittance; depth and the occlusion layer's P (the light each
// sample receives weighted by its contribution, summed).
@group(0) @binding(6) var<storage, read_write> eye: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> eye_depth: array<vec2<f32>>;
@group(0) @binding(8) var<uniform> slab: Slab;
// Path length through the previous slab per plane.
@group(0) @binding(9) var<storage, read> ring_lengths: array<f32>;
// Occupancy flags (src/optics/occupancy.rs): slabs whose sample lies in an empty cell pass the
// light on unchanged, with no sample taken, as on the CPU.
@group(0) @binding(10) var<storage, read> occupancy: array<u32>;

// Whether the occupancy cell may hold matter (Occupancy::occupied).
fn occupied(cell: vec3<u32>) -> bool {
    let n = params.cells;
    return occupancy[cell.x + n.x * (cell.y + n.y * cell.z)] != 0u;
}

// Index of plane p's texel (i, j) in the occlusion buffers.
fn texel(p: u32, i: i32, j: i32) -> u32 {
    return (u32(j) * params.planes + p) * params.view.size.x + u32(i);
}

// V_k at a pixel: the average over the cone's samples of the previous buffer read bilinearly,
// with indices clamped to the image (dos::cpu::cone_average, blended rows first).
fn visibility(pixel: vec2<u32>) -> f32 {
    let count = params.sample_count;
    let last = vec2<i32>(params.view.size) - 1;
    var sum = 0.0;
    for (var s = 0u; s < count; s = s + 1u) {
        let q = samples[s];
        let o = vec2<f32>(q.offset.x, -q.offset.y) * slab.radius_px;
        let whole = floor(o);
        let f = o - whole;
        let at = vec2<i32>(pixel) + vec2<i32>(whole);
        let i0 = clamp(at.x, 0, last.x);
        let i1 = clamp(at.x + 1, 0, last.x);
        let j0 = clamp(at.y, 0, last.y);
        let j1 = clamp(at.y + 1, 0, last.y);
        let p = q.plane;
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
    for (var i = 0u; i < params.clip_count; i = i + 1u) {
        let plane = params.clip_planes[i];
        if (dot(p - plane.point, plane.normal) > 0.0) {
            return Optical(0.0, vec3<f32>(0.0), vec3<f32>(0.0));
        }
    }
    let view = params.view;
    let c = index_of(view, p);
    let dims = volume_dims(view);
    var g = 0.0;
    if (params.lut.gradient_max > 0.0) {
        g = length(volume_gradient(volume, c, dims, view.spacing));
    }
    let v = sample_volume(volume, c, dims);
    return lut_lookup(v, g, params.lut);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = params.view.size.x;
    if (id.x >= width || id.y >= params.view.size.y) {
        return;
    }
    let index = id.x + width * id.y;
    var v = 1.0;
    if (slab.index > 0u) {
        v = visibility(id.xy);
    }
    let ray = camera_ray(params.view, id.xy);
    let span = box_span(params.view, ray);
    let rate = select(dot(ray.dir, params.view.forward), 1.0, params.lock_step_rays == 1u);
    let d = params.slice_distance;
    let z0 = params.first_depth + f32(slab.index) * d;
    let ta = max(z0 / rate, span.x);
    let tb = min((z0 + d) / rate, span.y);
    var tau = 0.0;
    if (tb > ta) {
        let dt = tb - ta;
        let p = ray.origin + (0.5 * (ta + tb)) * ray.dir;
        let cell = occupancy_cell(index_of(params.view, p), params.cells, params.cell_voxels);
        var o = Optical(0.0, vec3<f32>(0.0), vec3<f32>(0.0));
        if (occupied(cell)) {
            o = material(p);
        }
        if (o.sigma_t > 0.0 || any(o.emission != vec3<f32>(0.0))) {
            var e = eye[index];
            let alpha = 1.0 - exp(-o.sigma_t * dt);
            var lit = v;
            if (params.self_occlusion == 1u) {
                lit = v * exp(-0.5 * o.sigma_t * dt);
            }
            let light = alpha * o.albedo * params.ambient * lit + emitted(o, alpha, dt);
            let transmittance = e.w * (1.0 - alpha);
            var at = eye_depth[index];
            if (e.w > 0.5 && transmittance <= 0.5) {
                at.x = ta + log(2.0 * e.w) / o.sigma_t;
            }
            at.y = at.y + e.w * alpha * lit;
            eye_depth[index] = at;
            eye[index] = vec4<f32>(e.xyz + e.w * light, transmittance);
            tau = o.sigma_t * dt * rate / d;
        }
    }
    for (var p = 0u; p < params.planes; p = p + 1u) {
        next[texel(p, i32(id.x), i32(id.y))] = v * exp(-tau * ring_lengths[p]);
    }
}
