// One bounce of the source iteration on the GPU (src/transport/scattering/gpu.rs, twin of
// src/transport/scattering/cpu.rs), in the planes and slots of ordinates.wgsl. Per padded
// voxel of a direction's plane two vec4: the radiance carried and the source, rgb.

//#include "ordinates.wgsl"
//#include "phase.wgsl"

// Mirrored by transport::scattering::gpu::Params.
struct Params {
    sweep: OrdinatesPlane,
    // Band coefficients per colour channel (1 or 9), whether the source is the light's first
    // scattering (1: `direct`) or the previous bounce's field (0: `previous`), and the
    // Henyey-Greenstein asymmetry.
    per_channel: u32,
    first_bounce: u32,
    g: f32,
    _pad: u32,
};

// Mirrored by transport::scattering::gpu::GpuOrdinate: the upwind point's corner and bilinear
// fraction, the direction towards the light it carries, the segment's length, and what its
// radiance adds to each band coefficient (bands::gathering).
struct Ordinate {
    floor: vec2<i32>,
    fraction: vec2<f32>,
    towards: vec3<f32>,
    length: f32,
    gather: array<f32, 9>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> sigma: array<f32>;
@group(0) @binding(2) var<storage, read> ordinates: array<Ordinate>;
@group(0) @binding(3) var<storage, read_write> planes: array<vec4<f32>>;
// Per cell the direction towards the light and sigma_s E T over the ordinates' phase sum.
@group(0) @binding(4) var<storage, read> direct: array<vec4<f32>>;
// Per cell sigma_s, rgb.
@group(0) @binding(5) var<storage, read> scattering: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> previous: array<f32>;
@group(0) @binding(7) var<storage, read_write> field: array<f32>;

// cpu::Reading::at: the radiance source at `cell` for light leaving along `leaving`.
fn source_at(cell: u32, leaving: vec3<f32>) -> vec3<f32> {
    if params.first_bounce == 1u {
        let towards = direct[2u * cell].xyz;
        return direct[2u * cell + 1u].xyz * henyey_greenstein(params.g, -dot(towards, leaving));
    }
    var basis = band_basis(leaving);
    let n = params.per_channel;
    let base = 3u * n * cell;
    var j = vec3<f32>(0.0);
    for (var k = 0u; k < n; k++) {
        j = j + basis[k] * vec3<f32>(previous[base + k], previous[base + n + k],
            previous[base + 2u * n + k]);
    }
    return scattering[cell].xyz * max(j, vec3<f32>(0.0));
}

// cpu::segment_weights: E1 and E2 of a segment of optical depth tau, by their series below 1/2.
fn segment_weights(tau: f32) -> vec2<f32> {
    if tau < 0.5 {
        let t = -tau;
        let e1 = 1.0 + t * (1.0 / 2.0 + t * (1.0 / 6.0 + t * (1.0 / 24.0 + t * (1.0 / 120.0
            + t * (1.0 / 720.0 + t / 5040.0)))));
        let e2 = 0.5 + t * (2.0 / 6.0 + t * (3.0 / 24.0 + t * (4.0 / 120.0 + t * (5.0 / 720.0
            + t * (6.0 / 5040.0 + t * 7.0 / 40320.0)))));
        return vec2<f32>(e1, e2);
    }
    let e = exp(-tau);
    return vec2<f32>((1.0 - e) / tau, (1.0 - e * (1.0 + tau)) / (tau * tau));
}

@compute @workgroup_size(8, 8, 1)
fn scatter_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    if !in_plane(id) {
        return;
    }
    let cell = plane_voxel(id);
    let here = sigma[cell];
    let at = padded_at(id);
    let n = params.per_channel;
    let base = 3u * n * cell;
    var bands: array<f32, 27>;
    for (var k = 0u; k < 3u * n; k++) {
        bands[k] = field[base + k];
    }
    for (var i = 0u; i < params.sweep.count; i++) {
        let o = ordinates[params.sweep.first + i];
        let q = source_at(cell, -o.towards);
        let w = upwind_weights(o.fraction);
        let sigma_p = upwind_extinction(id, o.floor, w);
        let slot = slots(i, at, o.floor);
        var l_up = vec3<f32>(0.0);
        var q_up = vec3<f32>(0.0);
        for (var corner = 0u; corner < 4u; corner++) {
            l_up = l_up + w[corner] * planes[2u * slot.corners[corner]].xyz;
            q_up = q_up + w[corner] * planes[2u * slot.corners[corner] + 1u].xyz;
        }
        let tau = 0.5 * o.length * (here + sigma_p);
        let e = segment_weights(tau);
        let l = l_up * exp(-tau) + o.length * (q * (e.x - e.y) + q_up * e.y);
        planes[2u * (slot.swept + at)] = vec4<f32>(l, 0.0);
        planes[2u * (slot.swept + at) + 1u] = vec4<f32>(q, 0.0);
        for (var k = 0u; k < n; k++) {
            bands[k] = bands[k] + l.x * o.gather[k];
            bands[n + k] = bands[n + k] + l.y * o.gather[k];
            bands[2u * n + k] = bands[2u * n + k] + l.z * o.gather[k];
        }
    }
    for (var k = 0u; k < 3u * n; k++) {
        field[base + k] = bands[k];
    }
}
