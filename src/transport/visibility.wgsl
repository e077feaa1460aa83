// The ordinates sweep of the ambient visibility on the GPU (src/transport/gpu.rs, twin of
// src/transport/cpu.rs), in the planes and slots of ordinates.wgsl. Each direction's planes
// hold T.

//#include "ordinates.wgsl"

// Mirrored by transport::gpu::Params.
struct Params {
    sweep: OrdinatesPlane,
};

// Mirrored by transport::gpu::GpuOrdinate.
struct Ordinate {
    floor: vec2<i32>,
    fraction: vec2<f32>,
    half_length: f32,
    weight: f32,
    _pad: vec2<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> sigma: array<f32>;
@group(0) @binding(2) var<storage, read> ordinates: array<Ordinate>;
@group(0) @binding(3) var<storage, read_write> planes: array<f32>;
@group(0) @binding(4) var<storage, read_write> visibility: array<f32>;

@compute @workgroup_size(8, 8, 1)
fn sweep_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    if !in_plane(id) {
        return;
    }
    let voxel = plane_voxel(id);
    let here = sigma[voxel];
    let at = padded_at(id);
    var lit = visibility[voxel];
    for (var i = 0u; i < params.sweep.count; i++) {
        let o = ordinates[params.sweep.first + i];
        let w = upwind_weights(o.fraction);
        let sigma_p = upwind_extinction(id, o.floor, w);
        let slot = slots(i, at, o.floor);
        let p = slot.corners;
        let t_p = w.x * planes[p.x] + w.y * planes[p.y] + w.z * planes[p.z] + w.w * planes[p.w];
        let t = t_p * exp(-(o.half_length * (here + sigma_p)));
        planes[slot.swept + at] = t;
        lit += o.weight * t;
    }
    visibility[voxel] = lit;
}
