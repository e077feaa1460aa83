// What the plane-by-plane sweeps share (sweep.wgsl, sweep_sdf.wgsl): the voxel an invocation
// of an anti-diagonal plane's dispatch stands for.
//
// Plane t holds the voxels whose sweep indices d (each axis counted in the sweep's direction)
// sum to t. The dispatch enumerates the two axes other than `solved` from where the plane
// enters them (as the host sizes it, ao::sweep::planes::Plan::plane_workgroups); d along
// `solved` follows from t. Returns d and, in w, 1 when it lies in the grid of `n` voxels.
fn plane_position(id: vec2<u32>, t: i32, n: vec3<i32>, solved: u32) -> vec4<i32> {
    let axis_a = (solved + 1u) % 3u;
    let axis_b = (solved + 2u) % 3u;
    let lo_a = max(0, t - (n[axis_b] - 1) - (n[solved] - 1));
    let lo_b = max(0, t - (n[axis_a] - 1) - (n[solved] - 1));
    let a = lo_a + i32(id.x);
    let b = lo_b + i32(id.y);
    let c = t - a - b;
    var d = vec3<i32>(0);
    d[axis_a] = a;
    d[axis_b] = b;
    d[solved] = c;
    let inside = a < n[axis_a] && b < n[axis_b] && c >= 0 && c < n[solved];
    return vec4<i32>(d, select(0, 1, inside));
}
