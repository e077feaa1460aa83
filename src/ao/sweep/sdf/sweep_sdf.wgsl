// Fast sweeping signed distance on the GPU (src/ao/sweep/sdf_gpu.rs, GPU twin of
// src/ao/sweep/sdf.rs): Zhao's Gauss-Seidel sweeps in the eight diagonal orders, each order
// swept plane by plane over the anti-diagonal planes d_x + d_y + d_z = t (d_a counts voxel
// index a in the order's direction). A voxel's face neighbours lie on the planes t - 1 and
// t + 1, never on its own, so the voxels of one plane update in parallel, each reading the
// neighbours before it already updated in this sweep and those after it not yet (the
// hyperplane ordering of Detrixhe, Gibou and Min 2013); the sweeps reach the same fixed point.
//
// Distances are on a grid padded by one voxel, x fastest; unset voxels hold UNSET, a finite
// stand-in for the CPU's infinity (shaders may assume no infinities): UNSET + h rounds back to
// UNSET, so an unset neighbour never lowers a value, as infinity does not.

//#include "plane.wgsl"

// Mirrored by ao::sweep::sdf_gpu::Params.
struct Params {
    // Voxels along x, y, z (unpadded).
    dims: vec3<u32>,
    // The axis whose d is solved from the plane (the others are enumerated).
    solved_axis: u32,
    // Spacing per axis, and 1 / spacing^2.
    spacing: vec3<f32>,
    // The plane's index t.
    plane: u32,
    weights: vec3<f32>,
    // Bit a set: axis a is swept descending (the CPU's order bits).
    order: u32,
};

const UNSET: f32 = 1.0e30;

@group(0) @binding(0) var<uniform> params: Params;
// Padded unsigned distances.
@group(0) @binding(1) var<storage, read_write> distance: array<f32>;
// Padded: 1 where the voxel is next to the surface (fixed).
@group(0) @binding(2) var<storage, read> fixed: array<u32>;
// The largest decrease in this round, as the bits of a non-negative f32 (which order as u32).
@group(0) @binding(3) var<storage, read_write> change: atomic<u32>;

// Zhao's update from the smaller neighbour along each axis, as ao::sweep::sdf::solve.
fn solve(a_in: vec3<f32>) -> f32 {
    var a = array<f32, 3>(a_in.x, a_in.y, a_in.z);
    var h = array<f32, 3>(params.spacing.x, params.spacing.y, params.spacing.z);
    var w = array<f32, 3>(params.weights.x, params.weights.y, params.weights.z);
    // Sort the three (a, h, w) by a, with the CPU's three compare-and-swaps.
    for (var step = 0u; step < 3u; step = step + 1u) {
        let i = select(0u, 1u, step == 1u);
        if (a[i] > a[i + 1u]) {
            let ta = a[i];
            a[i] = a[i + 1u];
            a[i + 1u] = ta;
            let th = h[i];
            h[i] = h[i + 1u];
            h[i + 1u] = th;
            let tw = w[i];
            w[i] = w[i + 1u];
            w[i + 1u] = tw;
        }
    }
    // 1D.
    var u = a[0] + h[0];
    if (u <= a[1]) {
        return u;
    }
    // 2D.
    let b1 = a[1] - a[0];
    var s = w[0] + w[1];
    var disc = s - w[0] * w[1] * b1 * b1;
    u = a[0] + (w[1] * b1 + sqrt(max(disc, 0.0))) / s;
    if (u <= a[2]) {
        return u;
    }
    // 3D.
    let b2 = a[2] - a[0];
    s = w[0] + w[1] + w[2];
    let d12 = b2 - b1;
    disc = s - (w[0] * w[1] * b1 * b1 + w[0] * w[2] * b2 * b2 + w[1] * w[2] * d12 * d12);
    return a[0] + (w[1] * b1 + w[2] * b2 + sqrt(max(disc, 0.0))) / s;
}

@compute @workgroup_size(8, 8, 1)
fn sdf_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = vec3<i32>(params.dims);
    let position = plane_position(id.xy, i32(params.plane), n, params.solved_axis);
    if (position.w == 0) {
        return;
    }
    let d = position.xyz;
    let descending = vec3<bool>(
        (params.order & 1u) != 0u,
        (params.order & 2u) != 0u,
        (params.order & 4u) != 0u,
    );
    let v = select(d, n - 1 - d, descending);
    let p = n + 2;
    let x = (v.x + 1) + p.x * ((v.y + 1) + p.y * (v.z + 1));
    if (fixed[x] != 0u) {
        return;
    }
    let sy = p.x;
    let sz = p.x * p.y;
    let ax = min(distance[x - 1], distance[x + 1]);
    let ay = min(distance[x - sy], distance[x + sy]);
    let az = min(distance[x - sz], distance[x + sz]);
    let new_value = solve(vec3<f32>(ax, ay, az));
    let old = distance[x];
    if (new_value < old) {
        distance[x] = new_value;
        atomicMax(&change, bitcast<u32>(old - new_value));
    }
}
