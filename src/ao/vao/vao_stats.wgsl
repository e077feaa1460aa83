// One 1D pass of the VAO statistics, one invocation per line of the volume along the pass's
// axis. It mirrors src/ao/vao/stats.rs operation for operation: a running mean of deviations
// from a local offset, recomputed every w = 2R + 1 steps, van Herk/Gil-Werman extremes through the prefix and suffix buffers,
// and the outside value beyond the ends of the line.

// Params.reduce (vao::stats::Reduce::shader_code).
const REDUCE_MEAN: u32 = 0u;
const REDUCE_MIN: u32 = 1u;
const REDUCE_MAX: u32 = 2u;

// Mirrored by vao::gpu::PassParams.
struct Params {
    // Voxels along x, y, z.
    dims: vec3<u32>,
    // The axis of the lines: 0 x, 1 y, 2 z.
    axis: u32,
    radius: u32,
    reduce: u32,
    // 1: the input is squared after the map (the second moment's first pass).
    square: u32,
    // Lines per row of the dispatch grid.
    lines_per_row: u32,
    // The value beyond the grid (mapped, and squared for the second moment).
    outside: f32,
    // Scale and offset of the map to [0, 1] applied to values read (first pass; 1 and 0 after).
    scale: f32,
    offset: f32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> src: array<f32>;
@group(0) @binding(2) var<storage, read_write> dst: array<f32>;
@group(0) @binding(3) var<storage, read_write> prefix: array<f32>;
@group(0) @binding(4) var<storage, read_write> suffix: array<f32>;

var<private> start: u32;
var<private> stride: u32;
var<private> n: i32;

fn at(i: i32) -> u32 {
    return start + u32(i) * stride;
}

fn input(j: i32) -> f32 {
    if (j < 0 || j >= n) {
        return params.outside;
    }
    let v = src[at(j)] * params.scale + params.offset;
    if (params.square == 1u) {
        return v * v;
    }
    return v;
}

fn reduce2(a: f32, b: f32) -> f32 {
    if (params.reduce == REDUCE_MIN) {
        return min(a, b);
    }
    return max(a, b);
}

fn running_mean(r: i32, w: i32) {
    let wf = f32(w);
    // The sum of deviations from a local offset, as in stats.rs (why: see there).
    var acc = 0.0;
    var offset = 0.0;
    for (var i = 0; i < n; i = i + 1) {
        if (i % w == 0) {
            offset = input(i);
            acc = 0.0;
            for (var j = i - r; j <= i + r; j = j + 1) {
                acc = acc + (input(j) - offset);
            }
        }
        dst[at(i)] = offset + acc / wf;
        acc = acc + (input(i + r + 1) - input(i - r));
    }
}

fn van_herk(r: i32, w: i32) {
    var run = 0.0;
    for (var i = 0; i < n; i = i + 1) {
        let x = input(i);
        if (i % w == 0) {
            run = x;
        } else {
            run = reduce2(run, x);
        }
        prefix[at(i)] = run;
    }
    for (var i = n - 1; i >= 0; i = i - 1) {
        let x = input(i);
        if (i % w == w - 1 || i == n - 1) {
            run = x;
        } else {
            run = reduce2(run, x);
        }
        suffix[at(i)] = run;
    }
    for (var i = 0; i < n; i = i + 1) {
        let lo = max(i - r, 0);
        let hi = min(i + r, n - 1);
        var v: f32;
        if (lo / w == hi / w) {
            if (lo % w == 0) {
                v = prefix[at(hi)];
            } else {
                v = suffix[at(lo)];
            }
        } else {
            v = reduce2(suffix[at(lo)], prefix[at(hi)]);
        }
        if (i < r || i + r >= n) {
            v = reduce2(v, params.outside);
        }
        dst[at(i)] = v;
    }
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let nx = params.dims.x;
    let ny = params.dims.y;
    let nz = params.dims.z;
    let line = id.x + id.y * params.lines_per_row;
    switch params.axis {
        case 0u: {
            if (line >= ny * nz) {
                return;
            }
            start = line * nx;
            stride = 1u;
            n = i32(nx);
        }
        case 1u: {
            if (line >= nx * nz) {
                return;
            }
            start = line % nx + (line / nx) * nx * ny;
            stride = nx;
            n = i32(ny);
        }
        default: {
            if (line >= nx * ny) {
                return;
            }
            start = line;
            stride = nx * ny;
            n = i32(nz);
        }
    }
    let r = i32(params.radius);
    let w = 2 * r + 1;
    if (params.reduce == REDUCE_MEAN) {
        running_mean(r, w);
    } else {
        van_herk(r, w);
    }
}
