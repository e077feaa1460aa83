// The classification table's lookup and the emission integral, shared by the kernels; they
// mirror src/classify/lut.rs and src/render/raycast/cpu.rs. The including kernel declares
// `lut: array<vec4<f32>>` (two vec4s per entry: (sigma_t, albedo) and (emission, unused)).

// The table's axes; src/gpu/lut_shape.rs's LutShapeUniform mirrors it field for field.
struct LutShape {
    value_min: f32,
    value_max: f32,
    // 0: a 1D table (value only).
    gradient_max: f32,
    value_entries: u32,
    gradient_entries: u32,
    // To 32 bytes: a struct member of a uniform is followed by a multiple of 16 bytes.
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

struct Optical {
    sigma_t: f32,
    albedo: vec3<f32>,
    emission: vec3<f32>,
};

// Linear coordinate along a table axis of n entries: (i0, i1, fraction), as Lut::coord.
fn lut_coord(x: f32, lo: f32, hi: f32, n: f32) -> vec3<f32> {
    let u = clamp((x - lo) / (hi - lo) * (n - 1.0), 0.0, n - 1.0);
    let i0 = floor(u);
    let i1 = min(i0 + 1.0, n - 1.0);
    return vec3<f32>(i0, i1, u - i0);
}

// Entry (i, j) of a table with nv entries along the value axis: one half of it.
fn lut_entry(i: f32, j: f32, nv: f32, half: u32) -> vec4<f32> {
    return lut[(u32(i) + u32(nv) * u32(j)) * 2u + half];
}

// Bilinear blend of one half of the four neighbouring entries (a 1D table has j0 = j1 = 0).
fn lut_blend(cv: vec3<f32>, cg: vec3<f32>, nv: f32, half: u32) -> vec4<f32> {
    let row0 = mix(lut_entry(cv.x, cg.x, nv, half), lut_entry(cv.y, cg.x, nv, half), cv.z);
    if (cg.z == 0.0) {
        return row0;
    }
    let row1 = mix(lut_entry(cv.x, cg.y, nv, half), lut_entry(cv.y, cg.y, nv, half), cv.z);
    return mix(row0, row1, cg.z);
}

// Lut::lookup of value v and gradient magnitude g.
fn lut_lookup(v: f32, g: f32, shape: LutShape) -> Optical {
    let nv = f32(shape.value_entries);
    let cv = lut_coord(v, shape.value_min, shape.value_max, nv);
    var cg = vec3<f32>(0.0, 0.0, 0.0);
    if (shape.gradient_max > 0.0) {
        cg = lut_coord(g, 0.0, shape.gradient_max, f32(shape.gradient_entries));
    }
    let a = lut_blend(cv, cg, nv, 0u);
    let b = lut_blend(cv, cg, nv, 1u);
    return Optical(a.x, a.yzw, b.xyz);
}

// Emission integrated over a step of opacity alpha and length dt.
fn emitted(o: Optical, alpha: f32, dt: f32) -> vec3<f32> {
    if (o.sigma_t > 1e-6) {
        return o.emission * (alpha / o.sigma_t);
    }
    return o.emission * dt;
}
