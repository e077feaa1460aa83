// What the discrete-ordinates sweeps share (visibility.wgsl, scattering.wgsl): one dispatch per
// plane of a sweep order, an invocation per voxel of the plane, looping over the order's
// directions; each direction keeps two padded planes (padding 1: nothing outside the grid), the
// upwind one in slot `slot` and the one swept now in the other. The includer binds `params`, a
// uniform whose member `sweep` is the OrdinatesPlane, and `sigma`, the extinction per voxel.

// Mirrored by transport::gpu::OrdinatesPlane.
struct OrdinatesPlane {
    // Voxels of a plane along its two axes, the plane's index, and the upwind plane's (k + sign:
    // -1 or the plane count when it lies outside the grid).
    lateral: vec2<u32>,
    plane: u32,
    upwind_plane: i32,
    // The grid's strides of the plane's two axes and of the axis, and the planes across it.
    strides: vec3<u32>,
    planes: u32,
    // The order's directions in the includer's table, which slot is upwind, and values per
    // padded plane.
    first: u32,
    count: u32,
    slot: u32,
    padded_len: u32,
};

// Whether invocation `id` stands for a voxel of the plane.
fn in_plane(id: vec3<u32>) -> bool {
    return id.x < params.sweep.lateral.x && id.y < params.sweep.lateral.y;
}

// The grid index of the plane's voxel `id`.
fn plane_voxel(id: vec3<u32>) -> u32 {
    let s = params.sweep.strides;
    return params.sweep.plane * s.z + id.x * s.x + id.y * s.y;
}

// The index of voxel `id` in a padded plane.
fn padded_at(id: vec3<u32>) -> u32 {
    return (id.x + 1u) + (params.sweep.lateral.x + 2u) * (id.y + 1u);
}

// Ordinate::upwind_weights: the bilinear weights of the four voxels around the upwind point.
fn upwind_weights(f: vec2<f32>) -> vec4<f32> {
    return vec4<f32>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
}

// The extinction at lateral voxel (b, c) of the upwind plane; 0 outside the grid.
fn upwind_sigma(b: i32, c: i32) -> f32 {
    let sweep = params.sweep;
    let n = vec2<i32>(sweep.lateral);
    let k = sweep.upwind_plane;
    if k < 0 || k >= i32(sweep.planes) || b < 0 || c < 0 || b >= n.x || c >= n.y {
        return 0.0;
    }
    let s = sweep.strides;
    return sigma[u32(k) * s.z + u32(b) * s.x + u32(c) * s.y];
}

// The extinction at the upwind point of voxel `id` for a direction whose point lies at corner
// offset `floor` with weights `w`, in the CPU's order.
fn upwind_extinction(id: vec3<u32>, floor: vec2<i32>, w: vec4<f32>) -> f32 {
    let b = i32(id.x) + floor.x;
    let c = i32(id.y) + floor.y;
    return w.x * upwind_sigma(b, c) + w.y * upwind_sigma(b + 1, c)
        + w.z * upwind_sigma(b, c + 1) + w.w * upwind_sigma(b + 1, c + 1);
}

// Direction i of the order (0-based): where its upwind plane and its swept plane start, and the
// padded indices of the four upwind corners of the voxel at padded index `at`.
struct Slots {
    swept: u32,
    corners: vec4<u32>,
};

fn slots(i: u32, at: u32, floor: vec2<i32>) -> Slots {
    let sweep = params.sweep;
    let row = sweep.lateral.x + 2u;
    let upwind = (sweep.slot * sweep.count + i) * sweep.padded_len;
    let swept = ((1u - sweep.slot) * sweep.count + i) * sweep.padded_len;
    let p = upwind + u32(i32(at) + floor.x + i32(row) * floor.y);
    return Slots(swept, vec4<u32>(p, p + 1u, p + row, p + row + 1u));
}
