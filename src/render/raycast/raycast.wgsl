// The baseline ray caster's GPU twin: one invocation per pixel. It mirrors
// src/render/raycast/cpu.rs step for step (see src/render/raycast/mod.rs for the model).

//#include "common.wgsl"
//#include "view.wgsl"
//#include "classify.wgsl"
//#include "occupancy.wgsl"

const BACKGROUND_DEPTH: f32 = 1.0e10;
const MAX_LIGHTS: u32 = 8u;

// Params.shading (raycast::gpu's SHADING_*).
const SHADING_UNSHADED: u32 = 0u;
const SHADING_GRADIENT: u32 = 1u;
const SHADING_AO: u32 = 2u;
// AO for the ambient light, gradient shading for the others.
const SHADING_AO_GRADIENT: u32 = 3u;

// Light.kind (raycast::gpu's LIGHT_*); ambient lights are summed into Params.ambient.
const LIGHT_DIRECTIONAL: u32 = 1u;
const LIGHT_POINT: u32 = 2u;

struct Light {
    // Directional: unit direction towards the light; point: position.
    vector: vec3<f32>,
    kind: u32,
    // Irradiance (directional) or intensity (point).
    colour: vec3<f32>,
};

// Mirrored by raycast::gpu::Params.
struct Params {
    view: View,
    lut: LutShape,
    ambient: vec3<f32>,
    // Ray-marching step in world units.
    step: f32,
    background: vec3<f32>,
    // Early ray termination below this transmittance.
    ert_threshold: f32,
    // Gradient magnitude from which a sample is fully surface-shaded.
    normal_threshold: f32,
    shading: u32,
    // Phong lobe: weight and exponent.
    specular: f32,
    shininess: f32,
    light_count: u32,
    // 1: extinction scaled by ao_opacity.
    opacity_modulation: u32,
    // The band of rows this dispatch renders.
    first_row: u32,
    rows: u32,
    // Occupancy cells along each axis, and voxels along each side of a cell.
    cells: vec3<u32>,
    cell_voxels: u32,
    lights: array<Light, MAX_LIGHTS>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var<storage, read> lut: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> out_rgba: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> out_depth: array<f32>;
@group(0) @binding(5) var<storage, read> occupancy: array<u32>;
// AO shading: openness and the opacity modulation factor on the volume's grid (one-voxel
// stand-ins otherwise), interpolated as the volume is (sample_volume).
@group(0) @binding(6) var ao_openness: texture_3d<f32>;
@group(0) @binding(7) var ao_opacity: texture_3d<f32>;

// Whether the occupancy cell may hold matter (Occupancy::occupied).
fn occupied(cell: vec3<u32>) -> bool {
    let n = params.cells;
    return occupancy[cell.x + n.x * (cell.y + n.y * cell.z)] != 0u;
}

fn sample_at(p: vec3<f32>) -> f32 {
    return sample_volume(volume, index_of(params.view, p), volume_dims(params.view));
}

fn ao_at(tex: texture_3d<f32>, p: vec3<f32>) -> f32 {
    return sample_volume(tex, index_of(params.view, p), volume_dims(params.view));
}

fn gradient_at(p: vec3<f32>) -> vec3<f32> {
    let view = params.view;
    return volume_gradient(volume, index_of(view, p), volume_dims(view), view.spacing);
}

fn lookup(v: f32, g: f32) -> Optical {
    return lut_lookup(v, g, params.lut);
}

// Unit direction towards light l and the irradiance it delivers at p (as lights::incident).
fn incident(l: u32, p: vec3<f32>, to_light: ptr<function, vec3<f32>>) -> vec3<f32> {
    let light = params.lights[l];
    if (light.kind == LIGHT_DIRECTIONAL) {
        *to_light = light.vector;
        return light.colour;
    }
    let d = light.vector - p;
    let r2 = max(dot(d, d), 1e-12);
    *to_light = d / sqrt(r2);
    return light.colour / r2;
}

fn in_scattered(o: Optical, p: vec3<f32>, grad: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let count = params.light_count;
    let shading = params.shading;
    var ambient = params.ambient;
    if (shading == SHADING_AO || shading == SHADING_AO_GRADIENT) {
        ambient = ambient * ao_at(ao_openness, p);
    }
    var l = vec3<f32>(0.0);
    if (shading == SHADING_UNSHADED) {
        var direct = vec3<f32>(0.0);
        for (var i = 0u; i < count; i = i + 1u) {
            direct = direct + incident(i, p, &l);
        }
        return o.albedo * (ambient + direct / (4.0 * PI));
    }
    if (shading == SHADING_AO) {
        return o.albedo * ambient;
    }
    let gm = length(grad);
    let w = min(gm / params.normal_threshold, 1.0);
    var n = vec3<f32>(0.0);
    if (gm > 0.0) {
        n = -grad / gm;
    }
    if (dot(n, dir) > 0.0) {
        n = -n;
    }
    let to_eye = -dir;
    let shininess = params.shininess;
    var diffuse = ambient;
    var specular = vec3<f32>(0.0);
    for (var i = 0u; i < count; i = i + 1u) {
        let e = incident(i, p, &l);
        let facing = max(dot(n, l), 0.0);
        diffuse = diffuse + e * (w * facing / PI + (1.0 - w) / (4.0 * PI));
        let hv = l + to_eye;
        var h = vec3<f32>(0.0);
        if (dot(hv, hv) > 0.0) {
            h = normalize(hv);
        }
        let lobe = pow(max(dot(n, h), 0.0), shininess) * (shininess + 8.0) / (8.0 * PI);
        // Times the irradiance's cosine (cpu::in_scattered): no highlight facing away.
        specular = specular + e * (w * params.specular * lobe * facing);
    }
    return o.albedo * diffuse + specular;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = params.view.size.x;
    let row = id.y + params.first_row;
    if (id.x >= width || id.y >= params.rows) {
        return;
    }
    let out_index = id.x + width * id.y;
    let ray = camera_ray(params.view, vec2<u32>(id.x, row));
    let origin = ray.origin;
    let dir = ray.dir;
    let background = params.background;
    let span = box_span(params.view, ray);
    if (!(span.y > span.x)) {
        out_rgba[out_index] = vec4<f32>(background, 0.0);
        out_depth[out_index] = BACKGROUND_DEPTH;
        return;
    }
    let steps = view_steps(span, params.step, step_offset(vec2<u32>(id.x, row)));
    let ert = params.ert_threshold;
    // A 2D table needs the gradient to classify; shading needs it only where there is matter.
    let table_2d = params.lut.gradient_max > 0.0;
    let shaded = params.shading == SHADING_GRADIENT || params.shading == SHADING_AO_GRADIENT;
    var radiance = vec3<f32>(0.0);
    var transmittance = 1.0;
    var depth = BACKGROUND_DEPTH;
    let index_origin = index_of(params.view, origin);
    let index_dir = dir / params.view.spacing;
    var k = 0u;
    loop {
        if (k >= steps.count) {
            break;
        }
        let segment = step_segment(steps, k);
        let ta = segment.x;
        let dt = segment.y;
        let p = origin + (ta + 0.5 * dt) * dir;
        let cell = occupancy_cell(index_of(params.view, p), params.cells, params.cell_voxels);
        if (!occupied(cell)) {
            // Resume at the first step whose midpoint lies at or beyond the cell's exit.
            let leave = occupancy_exit(cell, index_origin, index_dir, params.cells, params.cell_voxels);
            let next = ceil((leave - steps.start) / steps.step - 0.5);
            if (!(next < f32(steps.count))) {
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
        if (params.opacity_modulation == 1u) {
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
