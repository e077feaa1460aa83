// Empty-space skipping shared by the ray-casting kernels: the occupancy grid of
// src/optics/occupancy.rs, `cells` cells of `side` voxels each. Its flags live in a storage
// array the kernel binds (a function cannot take it), so `occupied` stays with each kernel.

// The occupancy cell holding index coordinate c (Occupancy::cell_of).
fn occupancy_cell(c: vec3<f32>, cells: vec3<u32>, side: u32) -> vec3<u32> {
    let cell = floor(max(c, vec3<f32>(0.0)) / f32(side));
    return vec3<u32>(min(cell, vec3<f32>(cells) - 1.0));
}

// Where the ray (index coordinates c0 + t dc) leaves the cell; outermost cells are unbounded
// (Occupancy::exit).
fn occupancy_exit(
    cell: vec3<u32>,
    c0: vec3<f32>,
    dc: vec3<f32>,
    cells: vec3<u32>,
    side: u32,
) -> f32 {
    var t = 3.0e38;
    for (var a = 0u; a < 3u; a = a + 1u) {
        if (dc[a] > 0.0 && cell[a] + 1u < cells[a]) {
            t = min(t, (f32(cell[a] + 1u) * f32(side) - c0[a]) / dc[a]);
        } else if (dc[a] < 0.0 && cell[a] > 0u) {
            t = min(t, (f32(cell[a]) * f32(side) - c0[a]) / dc[a]);
        }
    }
    return t;
}
