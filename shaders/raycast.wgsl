// The baseline ray caster's GPU twin: one invocation per pixel. It mirrors
// src/render/raycast/cpu.rs step for step (see src/render/raycast/mod.rs for the model).

//#include "common.wgsl"
//#include "classify.wgsl"

const PI: f32 = 3.14159265358979;
const BACKGROUND_DEPTH: f32 = 1.0e10;
const MAX_LIGHTS: u32 = 8u;

struct Light {
    // x: 1 directional, 2 point (ambient lights are summed into `ambient`).
    kind: vec4<f32>,
    // Directional: unit direction towards the light; point: position.
    vector: vec4<f32>,
    // Irradiance (directional) or intensity (point).
    colour: vec4<f32>,
};

struct Params {
    cam_position: vec4<f32>,   // w: 1 perspective, 0 orthographic
    cam_forward: vec4<f32>,
    cam_right: vec4<f32>,
    cam_up: vec4<f32>,
    image: vec4<f32>,          // half extent x, half extent y, width, height
    box_lo: vec4<f32>,
    box_hi: vec4<f32>,
    vol_origin: vec4<f32>,
    vol_spacing: vec4<f32>,
    vol_dims: vec4<f32>,
    ambient: vec4<f32>,
    background: vec4<f32>,
    lut_range: vec4<f32>,      // value min, value max, gradient max (0: 1D table), unused
    lut_size: vec4<f32>,       // entries along value, along gradient
    march: vec4<f32>,          // step, ERT threshold, normal threshold, shading (0 unshaded, 1 gradient, 2 AO, 3 AO + gradient)
    phong: vec4<f32>,          // specular, shininess, light count, opacity modulation (1)
    band: vec4<f32>,           // first row of this dispatch, rows in it
    cells: vec4<f32>,          // occupancy cells along x, y, z; voxels per cell
    lights: array<Light, 8>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var volume_sampler: sampler;
@group(0) @binding(3) var<storage, read> lut: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> out_rgba: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> out_depth: array<f32>;
@group(0) @binding(6) var<storage, read> occupancy: array<u32>;
// AO shading: openness and the opacity modulation factor on the volume's grid (one-voxel
// stand-ins otherwise), sampled with the volume's sampler.
@group(0) @binding(7) var ao_openness: texture_3d<f32>;
@group(0) @binding(8) var ao_opacity: texture_3d<f32>;

// The occupancy cell holding index coordinate c (Occupancy::cell_of).
fn cell_of(c: vec3<f32>) -> vec3<u32> {
    let cell = floor(max(c, vec3<f32>(0.0)) / params.cells.w);
    return vec3<u32>(min(cell, params.cells.xyz - 1.0));
}

fn occupied(cell: vec3<u32>) -> bool {
    let n = vec3<u32>(params.cells.xyz);
    return occupancy[cell.x + n.x * (cell.y + n.y * cell.z)] != 0u;
}

// Where the ray (index coordinates c0 + t dc) leaves the cell; outermost cells are unbounded
// (Occupancy::exit).
fn cell_exit(cell: vec3<u32>, c0: vec3<f32>, dc: vec3<f32>) -> f32 {
    let n = vec3<u32>(params.cells.xyz);
    var t = 3.0e38;
    for (var a = 0u; a < 3u; a = a + 1u) {
        if (dc[a] > 0.0 && cell[a] + 1u < n[a]) {
            t = min(t, (f32(cell[a] + 1u) * params.cells.w - c0[a]) / dc[a]);
        } else if (dc[a] < 0.0 && cell[a] > 0u) {
            t = min(t, (f32(cell[a]) * params.cells.w - c0[a]) / dc[a]);
        }
    }
    return t;
}

fn sample_at(p: vec3<f32>) -> f32 {
    let c = (p - params.vol_origin.xyz) / params.vol_spacing.xyz;
    return sample_volume(volume, volume_sampler, c, params.vol_dims.xyz);
}

fn ao_at(tex: texture_3d<f32>, p: vec3<f32>) -> f32 {
    let c = (p - params.vol_origin.xyz) / params.vol_spacing.xyz;
    return sample_volume(tex, volume_sampler, c, params.vol_dims.xyz);
}

fn gradient_at(p: vec3<f32>) -> vec3<f32> {
    let c = (p - params.vol_origin.xyz) / params.vol_spacing.xyz;
    return volume_gradient(volume, volume_sampler, c, params.vol_dims.xyz, params.vol_spacing.xyz);
}

fn lookup(v: f32, g: f32) -> Optical {
    return lut_lookup(v, g, params.lut_range, params.lut_size);
}

// Unit direction towards light l and the irradiance it delivers at p (as lights::incident).
fn incident(l: u32, p: vec3<f32>, to_light: ptr<function, vec3<f32>>) -> vec3<f32> {
    let light = params.lights[l];
    if (light.kind.x == 1.0) {
        *to_light = light.vector.xyz;
        return light.colour.xyz;
    }
    let d = light.vector.xyz - p;
    let r2 = max(dot(d, d), 1e-12);
    *to_light = d / sqrt(r2);
    return light.colour.xyz / r2;
}

fn in_scattered(o: Optical, p: vec3<f32>, grad: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let count = u32(params.phong.z);
    let shading = params.march.w;
    var ambient = params.ambient.xyz;
    if (shading >= 2.0) {
        ambient = ambient * ao_at(ao_openness, p);
    }
    var l = vec3<f32>(0.0);
    if (shading == 0.0) {
        var direct = vec3<f32>(0.0);
        for (var i = 0u; i < count; i = i + 1u) {
            direct = direct + incident(i, p, &l);
        }
        return o.albedo * (ambient + direct / (4.0 * PI));
    }
    if (shading == 2.0) {
        return o.albedo * ambient;
    }
    let gm = length(grad);
    let w = min(gm / params.march.z, 1.0);
    var n = vec3<f32>(0.0);
    if (gm > 0.0) {
        n = -grad / gm;
    }
    if (dot(n, dir) > 0.0) {
        n = -n;
    }
    let to_eye = -dir;
    let shininess = params.phong.y;
    var diffuse = ambient;
    var specular = vec3<f32>(0.0);
    for (var i = 0u; i < count; i = i + 1u) {
        let e = incident(i, p, &l);
        diffuse = diffuse + e * (w * max(dot(n, l), 0.0) / PI + (1.0 - w) / (4.0 * PI));
        let hv = l + to_eye;
        var h = vec3<f32>(0.0);
        if (dot(hv, hv) > 0.0) {
            h = normalize(hv);
        }
        let lobe = pow(max(dot(n, h), 0.0), shininess) * (shininess + 8.0) / (8.0 * PI);
        specular = specular + e * (w * params.phong.x * lobe);
    }
    return o.albedo * diffuse + specular;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = u32(params.image.z);
    let row = id.y + u32(params.band.x);
    if (id.x >= width || id.y >= u32(params.band.y)) {
        return;
    }
    let out_index = id.x + width * id.y;
    let ray = camera_ray(
        vec2<u32>(id.x, row),
        params.cam_position,
        params.cam_forward.xyz,
        params.cam_right.xyz,
        params.cam_up.xyz,
        params.image,
    );
    let origin = ray.origin;
    let dir = ray.dir;
    let background = params.background.xyz;
    let span = box_span(origin, dir, params.box_lo.xyz, params.box_hi.xyz);
    if (!(span.y > span.x)) {
        out_rgba[out_index] = vec4<f32>(background, 0.0);
        out_depth[out_index] = BACKGROUND_DEPTH;
        return;
    }
    let step = params.march.x;
    let ert = params.march.y;
    // A 2D table needs the gradient to classify; shading needs it only where there is matter.
    let table_2d = params.lut_range.z > 0.0;
    let shaded = params.march.w == 1.0 || params.march.w == 3.0;
    let steps = u32(ceil((span.y - span.x) / step));
    var radiance = vec3<f32>(0.0);
    var transmittance = 1.0;
    var depth = BACKGROUND_DEPTH;
    let index_origin = (origin - params.vol_origin.xyz) / params.vol_spacing.xyz;
    let index_dir = dir / params.vol_spacing.xyz;
    var k = 0u;
    loop {
        if (k >= steps) {
            break;
        }
        let ta = span.x + f32(k) * step;
        let dt = min(span.y - ta, step);
        let p = origin + (ta + 0.5 * dt) * dir;
        let cell = cell_of((p - params.vol_origin.xyz) / params.vol_spacing.xyz);
        if (!occupied(cell)) {
            // Resume at the first step whose midpoint lies at or beyond the cell's exit.
            let next = ceil((cell_exit(cell, index_origin, index_dir) - span.x) / step - 0.5);
            if (!(next < f32(steps))) {
                break;
            }
            k = max(u32(next), k + 1u);
            continue;
        }
        k = k + 1u;
        let value = sample_at(p);
        var grad = vec3<f32>(0.0);
        if (table_2d) {
            grad = gradient_at(p);
        }
        var o = lookup(value, length(grad));
        if (params.phong.w == 1.0) {
            o.sigma_t = o.sigma_t * ao_at(ao_opacity, p);
        }
        if (o.sigma_t <= 0.0 && all(o.emission == vec3<f32>(0.0))) {
            continue;
        }
        if (shaded && !table_2d) {
            grad = gradient_at(p);
        }
        let alpha = 1.0 - exp(-o.sigma_t * dt);
        let light_in = in_scattered(o, p, grad, dir);
        radiance = radiance + transmittance * (alpha * light_in + emitted(o, alpha, dt));
        let next = transmittance * (1.0 - alpha);
        if (transmittance > 0.5 && next <= 0.5) {
            depth = ta + log(2.0 * transmittance) / o.sigma_t;
        }
        transmittance = next;
        if (transmittance < ert) {
            break;
        }
    }
    out_rgba[out_index] = vec4<f32>(radiance + transmittance * background, 1.0 - transmittance);
    out_depth[out_index] = depth;
}
