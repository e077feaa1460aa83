// The Henyey-Greenstein phase and the basis of its bands through 2, shared by the kernels that
// scatter light (the transport solve, IPSVI).
//#include "common.wgsl"

// optics::phase::henyey_greenstein.
fn henyey_greenstein(g: f32, cos_theta: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(denom));
}

// bands::basis: the nine basis functions of bands 0 to 2 at unit direction w.
fn band_basis(w: vec3<f32>) -> array<f32, 9> {
    return array<f32, 9>(
        1.0, w.x, w.y, w.z,
        w.x * w.x - w.z * w.z, w.y * w.y - w.z * w.z,
        2.0 * w.x * w.y, 2.0 * w.x * w.z, 2.0 * w.y * w.z,
    );
}
