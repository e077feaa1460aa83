// The ordinates sweep of the ambient visibility on the GPU (src/transport/gpu.rs, twin of
// src/transport/cpu.rs): one dispatch per plane of a sweep order, an invocation per voxel of
// the plane, looping over the order's directions in the set's order. Each direction keeps two
// padded planes of T (padding 1: no matter outside the grid) in `planes`, the upwind one in
// slot `slot` and the one swept now in the other.

// Mirrored by transport::gpu::Params.
struct Params {
    // Voxels of a plane along its two axes, the plane's index, and the upwind plane's (k + sign:
    // -1 or the plane count when it lies outside the grid).
    lateral: vec2<u32>,
    plane: u32,
    upwind_plane: i32,
    // The grid's strides of the plane's two axes and of the axis, and the planes across it.
    strides: vec3<u32>,
    planes: u32,
    // The order's directions in `ordinates`, and which slot of `planes` is upwind.
    first: u32,
    count: u32,
    slot: u32,
    // Values per padded plane.
    padded_len: u32,
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

// The extinction at lateral voxel (b, c) of the upwind plane; 0 outside the grid.
fn upwind_sigma(b: i32, c: i32) -> f32 {
    let n = vec2<i32>(params.lateral);
    let k = params.upwind_plane;
    if k < 0 || k >= i32(params.planes) || b < 0 || c < 0 || b >= n.x || c >= n.y {
        return 0.0;
    }
    let s = params.strides;
    return sigma[u32(k) * s.z + u32(b) * s.x + u32(c) * s.y];
}

@compute @workgroup_size(8, 8, 1)
fn sweep_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.lateral.x || id.y >= params.lateral.y {
        return;
    }
    let s = params.strides;
    let voxel = params.plane * s.z + id.x * s.x + id.y * s.y;
    let here = sigma[voxel];
    let row = params.lateral.x + 2u;
    let at = (id.x + 1u) + row * (id.y + 1u);
    var lit = visibility[voxel];
    for (var i = 0u; i < params.count; i++) {
        let o = ordinates[params.first + i];
        let f = o.fraction;
        let w = vec4<f32>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
        let b = i32(id.x) + o.floor.x;
        let c = i32(id.y) + o.floor.y;
        let sigma_p = w.x * upwind_sigma(b, c) + w.y * upwind_sigma(b + 1, c)
            + w.z * upwind_sigma(b, c + 1) + w.w * upwind_sigma(b + 1, c + 1);
        let upwind = (params.slot * params.count + i) * params.padded_len;
        let swept = ((1u - params.slot) * params.count + i) * params.padded_len;
        let p = upwind + u32(i32(at) + o.floor.x + i32(row) * o.floor.y);
        let t_p = w.x * planes[p] + w.y * planes[p + 1u] + w.z * planes[p + row]
            + w.w * planes[p + row + 1u];
        let t = t_p * exp(-(o.half_length * (here + sigma_p)));
        planes[swept + at] = t;
        lit += o.weight * t;
    }
    visibility[voxel] = lit;
}
