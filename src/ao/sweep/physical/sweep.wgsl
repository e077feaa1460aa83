// Occlusion sweeping on the GPU (src/ao/sweep/gpu.rs): the physical mode's visibility (twin of
// src/ao/sweep/cpu.rs) and the geometric mode's octants and shading (twin of the octant part
// of src/ao/sweep/geometric.rs; its signed distance and surface terms come from the CPU).
//
// Grids are padded with one voxel of empty space on every side, x fastest, as on the CPU:
// padded voxel (i + 1, j + 1, k + 1) holds voxel (i, j, k). Four kernels, in this order:
// - sweep_half_steps: exp(-sigma_t |n| / 2) per voxel for one step length (1 in the padding),
//   once per distinct step length;
// - sweep_fill: a group of octant visibility grids set to 1 (the padding keeps it: V = 1
//   outside the grid);
// - sweep_plane: one anti-diagonal plane of every octant of the group. For the octant of signs
//   s, d_a counts voxel index a from the side the light comes from (d_a = n_a - 1 - i_a where
//   s_a > 0, else i_a); V_s(x) reads only neighbours x + n whose d_x + d_y + d_z is 1, 2 or 3
//   smaller, so the voxels of plane t = d_x + d_y + d_z are independent given planes < t, and
//   planes run one dispatch each, in order;
// - sweep_average: the group's octants added into the sum, which the last group divides by 8
//   and clamps to [0, 1].
// The geometric mode (`geometric` = 1) binds the padded transmittance from distance as every
// half-step grid, weighs the three faces 1/3 and the rest 0, and takes each term as
// w * tau(x + n) * V(x + n) (the paper's Eq. 6: the light that crossed the neighbour); then
// - sweep_shade: the group's octants, each read one voxel out along the normal (the cell's
//   step) and weighed by its intensity and its geometry term (bilinear in the table), added
//   into the sum; the last group clamps it to [0, 1] and raises it to 1 / gamma.

//#include "plane.wgsl"

// Mirrored by ao::sweep::gpu::Params.
struct Params {
    // Voxels along x, y, z (unpadded).
    dims: vec3<u32>,
    // sweep_plane: the axis whose d is solved from the plane (the others are enumerated).
    solved_axis: u32,
    // Stencil weights of the steps: faces x, y, z (STEPS 0..3) ...
    face_weights: vec3<f32>,
    // ... the corner (STEPS 6) ...
    corner_weight: f32,
    // ... edges xy, xz, yz (STEPS 3..6).
    edge_weights: vec3<f32>,
    // sweep_half_steps: the world length of the step.
    step_length: f32,
    // The group's first octant (octant o has signs 1 - 2 * ((o >> a) & 1) along axis a).
    first_octant: u32,
    // Octants in the group (at most 8), one padded grid each in `visibility`.
    octants: u32,
    // Voxels of one padded grid.
    padded_voxels: u32,
    // sweep_plane: t, the plane's sweep index.
    plane: u32,
    // Invocations per row of a 1D kernel's 2D dispatch grid.
    row_width: u32,
    // 1: the geometric mode (terms w * tau(x + n) * V(x + n)); 0: the physical mode.
    geometric: u32,
    // sweep_shade: 1 / gamma.
    inverse_gamma: f32,
    // sweep_shade: the intensities of octants 0..3 and 4..7.
    intensities_low: vec4<f32>,
    intensities_high: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
// sweep_half_steps.
@group(0) @binding(1) var<storage, read> extinction: array<f32>;
@group(0) @binding(2) var<storage, read_write> half_step: array<f32>;
// sweep_fill, sweep_plane, sweep_average: the group's octant grids, one after the other.
@group(0) @binding(3) var<storage, read_write> visibility: array<f32>;
// sweep_plane: the half-step transmittances of STEPS 0..7 (steps of one length share a grid).
@group(0) @binding(4) var<storage, read> half0: array<f32>;
@group(0) @binding(5) var<storage, read> half1: array<f32>;
@group(0) @binding(6) var<storage, read> half2: array<f32>;
@group(0) @binding(7) var<storage, read> half3: array<f32>;
@group(0) @binding(8) var<storage, read> half4: array<f32>;
@group(0) @binding(9) var<storage, read> half5: array<f32>;
@group(0) @binding(10) var<storage, read> half6: array<f32>;
// sweep_average, sweep_shade: the running sum, then the visibility or AO (unpadded).
@group(0) @binding(11) var<storage, read_write> sum: array<f32>;
// sweep_shade: per voxel its surface terms, three words: the table texel, the bilinear
// fractions (two u16 in 1/65535, the first in the low half), the padded index step to the
// voxel the octants are read at (i32); and the geometry table, eight terms per texel.
@group(0) @binding(12) var<storage, read> cells: array<u32>;
@group(0) @binding(13) var<storage, read> geometry: array<f32>;

// Texels per side of the geometry table (ao::sweep::geometric::TABLE_SIDE).
const TABLE_SIDE: u32 = 65u;
// A cell without a normal: each octant takes 1/8.
const NO_NORMAL: u32 = 0xffffffffu;

fn padded_dims() -> vec3<u32> {
    return params.dims + vec3<u32>(2u);
}

// Padded index of unpadded voxel v.
fn padded_index(v: vec3<u32>) -> u32 {
    let p = padded_dims();
    return (v.x + 1u) + p.x * ((v.y + 1u) + p.y * (v.z + 1u));
}

// Index of a 1D kernel's invocation.
fn item(id: vec3<u32>) -> u32 {
    return id.x + id.y * params.row_width;
}

@compute @workgroup_size(64, 1, 1)
fn sweep_half_steps(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = item(id);
    if (index >= params.padded_voxels) {
        return;
    }
    let p = padded_dims();
    let c = vec3<u32>(index % p.x, (index / p.x) % p.y, index / (p.x * p.y));
    if (any(c == vec3<u32>(0u)) || any(c == p - 1u)) {
        half_step[index] = 1.0;
        return;
    }
    let v = c - 1u;
    let sigma = extinction[v.x + params.dims.x * (v.y + params.dims.y * v.z)];
    // As the CPU: (-0.5 * sigma) * length.
    half_step[index] = exp(-0.5 * sigma * params.step_length);
}

@compute @workgroup_size(64, 1, 1)
fn sweep_fill(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = item(id);
    if (index < params.octants * params.padded_voxels) {
        visibility[index] = 1.0;
    }
}

// One term w * h_n(x) * h_n(x + n) * V(x + n), multiplied in the CPU's order; in the
// geometric mode w * tau(x + n) * V(x + n).
fn term(weight: f32, here: f32, there: f32, seen: f32) -> f32 {
    if (params.geometric == 1u) {
        return weight * there * seen;
    }
    return weight * here * there * seen;
}

@compute @workgroup_size(8, 8, 1)
fn sweep_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = vec3<i32>(params.dims);
    let position = plane_position(id.xy, i32(params.plane), n, params.solved_axis);
    if (position.w == 0 || id.z >= params.octants) {
        return;
    }
    let d = position.xyz;
    let octant = params.first_octant + id.z;
    let signs = vec3<i32>(1) - 2 * vec3<i32>(
        i32(octant & 1u),
        i32((octant >> 1u) & 1u),
        i32((octant >> 2u) & 1u),
    );
    let voxel = select(d, n - 1 - d, signs > vec3<i32>(0));
    let x = padded_index(vec3<u32>(voxel));
    let p = vec3<i32>(padded_dims());
    // Index offsets of the signed steps: along x, y, z (one padded row, one padded slice).
    let sx = signs.x;
    let sy = signs.y * p.x;
    let sz = signs.z * p.x * p.y;
    let base = id.z * params.padded_voxels;
    let fw = params.face_weights;
    let ew = params.edge_weights;
    // STEPS 1..7 in order, as the CPU's row accumulator; then step 0, the CPU's recurrence.
    var off = 0.0;
    var y = u32(i32(x) + sy);
    off = off + term(fw.y, half1[x], half1[y], visibility[base + y]);
    y = u32(i32(x) + sz);
    off = off + term(fw.z, half2[x], half2[y], visibility[base + y]);
    y = u32(i32(x) + sx + sy);
    off = off + term(ew.x, half3[x], half3[y], visibility[base + y]);
    y = u32(i32(x) + sx + sz);
    off = off + term(ew.y, half4[x], half4[y], visibility[base + y]);
    y = u32(i32(x) + sy + sz);
    off = off + term(ew.z, half5[x], half5[y], visibility[base + y]);
    y = u32(i32(x) + sx + sy + sz);
    off = off + term(params.corner_weight, half6[x], half6[y], visibility[base + y]);
    y = u32(i32(x) + sx);
    var along = fw.x * half0[x] * half0[y];
    if (params.geometric == 1u) {
        along = fw.x * half0[y];
    }
    visibility[base + x] = off + along * visibility[base + y];
}

@compute @workgroup_size(64, 1, 1)
fn sweep_average(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = item(id);
    let dims = params.dims;
    if (index >= dims.x * dims.y * dims.z) {
        return;
    }
    let v = vec3<u32>(index % dims.x, (index / dims.x) % dims.y, index / (dims.x * dims.y));
    let x = padded_index(v);
    var acc = 0.0;
    if (params.first_octant > 0u) {
        acc = sum[index];
    }
    for (var o = 0u; o < params.octants; o = o + 1u) {
        acc = acc + visibility[o * params.padded_voxels + x];
    }
    if (params.first_octant + params.octants == 8u) {
        acc = clamp(acc / 8.0, 0.0, 1.0);
    }
    sum[index] = acc;
}

// G_s of octant s at a voxel's cell, as GeometryTable::share.
fn geometry_share(texel: u32, fractions: u32, s: u32) -> f32 {
    if (texel == NO_NORMAL) {
        return 0.125;
    }
    let fx = f32(fractions & 0xffffu) / 65535.0;
    let fy = f32(fractions >> 16u) / 65535.0;
    let a = geometry[texel * 8u + s];
    let b = geometry[(texel + 1u) * 8u + s];
    let c = geometry[(texel + TABLE_SIDE) * 8u + s];
    let d = geometry[(texel + TABLE_SIDE + 1u) * 8u + s];
    let bottom = a + (b - a) * fx;
    let top = c + (d - c) * fx;
    return bottom + (top - bottom) * fy;
}

@compute @workgroup_size(64, 1, 1)
fn sweep_shade(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = item(id);
    let dims = params.dims;
    if (index >= dims.x * dims.y * dims.z) {
        return;
    }
    let v = vec3<u32>(index % dims.x, (index / dims.x) % dims.y, index / (dims.x * dims.y));
    let texel = cells[3u * index];
    let fractions = cells[3u * index + 1u];
    let at = u32(i32(padded_index(v)) + bitcast<i32>(cells[3u * index + 2u]));
    var acc = 0.0;
    if (params.first_octant > 0u) {
        acc = sum[index];
    }
    for (var o = 0u; o < params.octants; o = o + 1u) {
        let s = params.first_octant + o;
        var intensity = params.intensities_low[s & 3u];
        if (s >= 4u) {
            intensity = params.intensities_high[s & 3u];
        }
        let seen = visibility[o * params.padded_voxels + at];
        acc = acc + intensity * geometry_share(texel, fractions, s) * seen;
    }
    if (params.first_octant + params.octants == 8u) {
        acc = pow(clamp(acc, 0.0, 1.0), params.inverse_gamma);
    }
    sum[index] = acc;
}
