// IPSVI's GPU twin, the trace: one invocation per pixel of a line (or of a piece of a long
// line), the pixels in sweep order from `order`. It mirrors Tracer::trace of
// src/render/ipsvi/cpu.rs step for step (see src/render/ipsvi/mod.rs for the model): it reads
// the cache as the previous lines left it and hands its writes to the merge
// (ipsvi_cache.wgsl, ipsvi_merge.wgsl).
//
// With multiple scattering, `chord_depths` (one invocation per cache texel, cpu::chord_depths)
// first writes each cache ray's optical depth through the whole box to `chords`, once per
// light before its sweep; the trace interpolates it at a sample's four cache rays to find
// where the light's slab ends (diffusion::fluence's `ahead`).

//#include "common.wgsl"
//#include "view.wgsl"
//#include "classify.wgsl"
//#include "occupancy.wgsl"
//#include "ipsvi_cache.wgsl"
//#include "phase.wgsl"

const BACKGROUND_DEPTH: f32 = 1.0e10;
// Stands for the CPU's infinite lengths (no anchor, a sun's distance): longer than any path
// through a box, so every min it enters picks the other operand as the CPU's infinity does.
const FAR: f32 = 3.0e38;
// cpu::DARK_DEPTH: the optical depth taken as no light at all (exp(-69) = 1e-30).
const DARK_DEPTH: f32 = 69.0;
// f32::MIN_POSITIVE.
const MIN_POSITIVE: f32 = 1.17549435e-38;
// std::f32::consts::FRAC_1_PI.
const FRAC_1_PI: f32 = 0.318309886183791;
// Invocations per workgroup of `main` and `chord_depths` (ipsvi::gpu's TRACE_WORKGROUP).
const WORKGROUP: u32 = 64u;
// diffusion::MAX_DEPTH and diffusion::MAX_ALBEDO.
const MAX_DEPTH: f32 = 1e4;
const MAX_ALBEDO: f32 = 0.999;

// CacheMap.kind (ipsvi::gpu's MAP_*).
const MAP_PARALLEL: u32 = 0u;
const MAP_PLANAR: u32 = 1u;
const MAP_SPHERE: u32 = 2u;

// Params.light_kind (ipsvi::gpu's LIGHT_*).
const LIGHT_DIRECTIONAL: u32 = 1u;
const LIGHT_POINT: u32 = 2u;

// cache::CacheMap (ipsvi::gpu::GpuCacheMap): how positions map to the cache's texels.
struct CacheMap {
    kind: u32,
    // A texel's side in plane coordinates (parallel: world units; planar: at unit distance).
    texel: f32,
    // Texels along each side.
    size: vec2<u32>,
    // A lamp's position (planar, sphere).
    light: vec3<f32>,
    // Parallel: the light's direction of travel; planar: the plane's axis.
    axis: vec3<f32>,
    // The plane's axes (parallel, planar) and where its texel (0, 0) begins.
    e1: vec3<f32>,
    e2: vec3<f32>,
    origin: vec2<f32>,
};

// Mirrored by ipsvi::gpu::Params; one per light.
struct Params {
    view: View,
    lut: LutShape,
    map: CacheMap,
    // Directional: unit direction towards the light; point: its position.
    light: vec3<f32>,
    light_kind: u32,
    // Irradiance (directional) or intensity (point).
    colour: vec3<f32>,
    // Henyey-Greenstein asymmetry.
    g: f32,
    // Occupancy cells along each axis, and voxels along each side of a cell.
    cells: vec3<u32>,
    cell_voxels: u32,
    // Steps along view rays and along light paths (twice the view's).
    step: f32,
    light_step: f32,
    // Early ray termination below this transmittance.
    ert_threshold: f32,
    // 1: piecewise integration along the light's path; 0: the paper's basic scheme.
    piecewise: u32,
    // 1 in the first light's pass, which also records emission, transmittance and depth.
    first_pass: u32,
    // 1: add the diffuse light of multiple scattering (diffusion::fluence); 2: add the
    // transport field's light (in_scattered).
    multiple: u32,
    // The transport field's grid: its first cell's centre, spacing and cells.
    field_origin: vec3<f32>,
    field_spacing: vec3<f32>,
    field_dims: vec3<u32>,
    // Its coefficients per colour channel (transport::scattering::bands).
    field_coefficients: u32,
};

// What one view ray gathers under one light (cpu::PixelOut).
struct PixelOut {
    scattered: vec3<f32>,
    emitted: vec3<f32>,
    transmittance: f32,
    depth: f32,
    // The light's transmittance and the grey irradiance at each sample, weighted by the
    // sample's contribution, summed (cpu::PixelOut's lit and irradiance).
    lit: f32,
    irradiance: f32,
};

// Where a point lies in the cache (cache::Place): the four texels around it with their
// bilinear weights, and how far the light travelled to it.
struct Place {
    corners: vec4<u32>,
    weights: vec4<f32>,
    s: f32,
};

// A cache ray the view ray holds (cpu::Held): its latest entry there (s, tau), unpacked, and
// the entry it will write when it moves away.
struct Held {
    used: bool,
    texel: u32,
    s: f32,
    tau: f32,
    write: vec2<u32>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(3) var<storage, read> lut: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> occupancy: array<u32>;
// The pixels (x + width * y) of this dispatch, in sweep order.
@group(0) @binding(5) var<storage, read> order: array<u32>;
// Per pixel, summed over the lights: scattered light (rgb) and the shadow layer's W_l P_l (a;
// ipsvi::Gathered's lit).
@group(0) @binding(6) var<storage, read_write> scattered_out: array<vec4<f32>>;
// Per pixel, from the first pass: emission (rgb) and the view's transmittance (a).
@group(0) @binding(7) var<storage, read_write> view_out: array<vec4<f32>>;
// Per pixel: the depth (first pass) and the shadow layer's W_l summed over the lights
// (ipsvi::Gathered's irradiance).
@group(0) @binding(8) var<storage, read_write> depth_out: array<vec2<f32>>;
// Per cache texel, with multiple scattering: the optical depth of its light ray through the
// whole box (written by `chord_depths`, read by the trace; one element when unused); with
// `multiple` 2 the transport field instead (in_scattered).
@group(0) @binding(9) var<storage, read_write> chords: array<f32>;

// Whether the occupancy cell may hold matter (Occupancy::occupied).
fn occupied(cell: vec3<u32>) -> bool {
    let n = params.cells;
    return occupancy[cell.x + n.x * (cell.y + n.y * cell.z)] != 0u;
}

// Optical properties at p (Medium::optical): the trilinear value, then the table (with the
// gradient's magnitude for a 2D table).
fn optical_at(p: vec3<f32>) -> Optical {
    let view = params.view;
    let c = index_of(view, p);
    let dims = volume_dims(view);
    var g = 0.0;
    if (params.lut.gradient_max > 0.0) {
        g = length(volume_gradient(volume, c, dims, view.spacing));
    }
    return lut_lookup(sample_volume(volume, c, dims), g, params.lut);
}

// v / |v| as glam's normalize computes it: v times the reciprocal of the length.
fn unit(v: vec3<f32>) -> vec3<f32> {
    return v * (1.0 / sqrt(dot(v, v)));
}

// +1 or -1 per component, +1 at zero (octahedral::sign).
fn sign_of(v: vec2<f32>) -> vec2<f32> {
    return select(vec2<f32>(-1.0), vec2<f32>(1.0), v >= vec2<f32>(0.0));
}

// octahedral::encode of a unit vector.
fn octahedral_encode(n: vec3<f32>) -> vec2<f32> {
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if (n.z >= 0.0) {
        return p;
    }
    return (1.0 - abs(p.yx)) * sign_of(p);
}

// octahedral::decode of a point of [-1, 1]^2.
fn octahedral_decode(uv: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - abs(uv.x) - abs(uv.y);
    var xy = uv;
    if (z < 0.0) {
        xy = (1.0 - abs(uv.yx)) * sign_of(uv);
    }
    return unit(vec3<f32>(xy, z));
}

// CacheMap::place: the four cache rays around p with bilinear weights, and the light's
// travel to p.
fn place_of(p: vec3<f32>) -> Place {
    let map = params.map;
    var uv: vec2<f32>;
    var s: f32;
    if (map.kind == MAP_PARALLEL) {
        uv = (vec2<f32>(dot(p, map.e1), dot(p, map.e2)) - map.origin) / map.texel;
        s = dot(p, map.axis);
    } else if (map.kind == MAP_PLANAR) {
        let d = p - map.light;
        let z = max(dot(d, map.axis), MIN_POSITIVE);
        uv = (vec2<f32>(dot(d, map.e1), dot(d, map.e2)) / z - map.origin) / map.texel;
        s = sqrt(dot(d, d));
    } else {
        let d = p - map.light;
        s = sqrt(dot(d, d));
        var dir = vec3<f32>(0.0, 0.0, 1.0);
        if (s > 0.0) {
            dir = d / s;
        }
        uv = (octahedral_encode(dir) + 1.0) * 0.5 * vec2<f32>(map.size);
    }
    let c = clamp(uv - 0.5, vec2<f32>(0.0), vec2<f32>(map.size - 1u));
    let lo = vec2<u32>(c);
    let f = c - vec2<f32>(lo);
    let hi = min(lo + 1u, map.size - 1u);
    let w = map.size.x;
    return Place(
        vec4<u32>(lo.x + w * lo.y, hi.x + w * lo.y, lo.x + w * hi.y, hi.x + w * hi.y),
        vec4<f32>(
            (1.0 - f.x) * (1.0 - f.y),
            f.x * (1.0 - f.y),
            (1.0 - f.x) * f.y,
            f.x * f.y,
        ),
        s,
    );
}

// CacheMap::ray_point: the point at travel s on the light ray through the centre of texel.
fn ray_point(texel: u32, s: f32) -> vec3<f32> {
    let map = params.map;
    let centre = vec2<f32>(f32(texel % map.size.x), f32(texel / map.size.x)) + 0.5;
    if (map.kind == MAP_PARALLEL) {
        let uv = map.origin + centre * map.texel;
        return map.e1 * uv.x + map.e2 * uv.y + map.axis * s;
    }
    if (map.kind == MAP_PLANAR) {
        let ab = map.origin + centre * map.texel;
        return map.light + unit(map.axis + map.e1 * ab.x + map.e2 * ab.y) * s;
    }
    let uv = centre / vec2<f32>(map.size) * 2.0 - 1.0;
    return map.light + octahedral_decode(uv) * s;
}

// CacheMap::towards_light: the unit direction from p towards the light (xyz) and how far it
// is (w; FAR for a sun).
fn towards_light(p: vec3<f32>) -> vec4<f32> {
    let map = params.map;
    if (map.kind == MAP_PARALLEL) {
        return vec4<f32>(-map.axis, FAR);
    }
    let d = map.light - p;
    let r = sqrt(dot(d, d));
    var dir = vec3<f32>(0.0, 0.0, 1.0);
    if (r > 0.0) {
        dir = d / r;
    }
    return vec4<f32>(dir, r);
}

// Tracer::optical_depth: from x towards the light over at most `limit`, within the box and
// short of the light.
fn optical_depth(x0: vec3<f32>, limit: f32) -> f32 {
    let towards = towards_light(x0);
    return optical_depth_along(x0, towards.xyz, min(limit, towards.w));
}

// Tracer::optical_depth_along: from x0 along the unit `dir` over at most `limit` (FAR for the
// CPU's infinity) within the box, by the midpoint rule in equal steps of at most light_step,
// skipping the steps in empty occupancy cells.
fn optical_depth_along(x0: vec3<f32>, dir: vec3<f32>, limit: f32) -> f32 {
    let span = box_span(params.view, CameraRay(x0, dir));
    if (!(span.y > span.x)) {
        return 0.0;
    }
    let along = min(limit, span.y) - span.x;
    if (along <= 0.0) {
        return 0.0;
    }
    let x = x0 + span.x * dir;
    let n = u32(max(ceil(along / params.light_step), 1.0));
    let h = along / f32(n);
    let index_origin = index_of(params.view, x);
    let index_dir = dir / params.view.spacing;
    var tau = 0.0;
    var i = 0u;
    loop {
        if (i >= n) {
            break;
        }
        let t = (f32(i) + 0.5) * h;
        let at = index_origin + t * index_dir;
        let cell = occupancy_cell(at, params.cells, params.cell_voxels);
        if (!occupied(cell)) {
            let leave = occupancy_exit(cell, index_origin, index_dir, params.cells, params.cell_voxels);
            let next = ceil(leave / h - 0.5);
            if (!(next < f32(n))) {
                break;
            }
            i = max(u32(next), i + 1u);
            continue;
        }
        tau = tau + optical_at(x + t * dir).sigma_t;
        i = i + 1u;
    }
    return tau * h;
}

// The held slot of `texel`, -1 if none (HeldRays::get).
fn find_held(held: ptr<function, array<Held, 4>>, texel: u32) -> i32 {
    for (var i = 0; i < 4; i = i + 1) {
        if ((*held)[i].used && (*held)[i].texel == texel) {
            return i;
        }
    }
    return -1;
}

// Starts holding `texel` in the first free slot (HeldRays::hold of a new ray).
fn hold_new(held: ptr<function, array<Held, 4>>, texel: u32, s: f32, tau: f32, write: vec2<u32>) {
    for (var i = 0; i < 4; i = i + 1) {
        if (!(*held)[i].used) {
            (*held)[i] = Held(true, texel, s, tau, write);
            return;
        }
    }
}

// Writes and forgets the held rays whose texel is not in `keep` (HeldRays::release); with
// `keep_any` false, all of them.
fn release(held: ptr<function, array<Held, 4>>, keep: vec4<u32>, keep_any: bool) {
    for (var i = 0; i < 4; i = i + 1) {
        let h = (*held)[i];
        if (h.used && !(keep_any && any(keep == vec4<u32>(h.texel)))) {
            record_write(h.texel, h.write);
            (*held)[i].used = false;
        }
    }
}

// Tracer::light_piecewise: per cache ray around the sample, the depth continued from the
// furthest entry behind it (the ray's own or the cache's) along that cache ray; the four
// depths bilinearly weighted. Returns the depth of the sample's light.
fn light_piecewise(place: Place, held: ptr<function, array<Held, 4>>) -> f32 {
    release(held, place.corners, true);
    var depth = 0.0;
    for (var i = 0u; i < 4u; i = i + 1u) {
        let texel = place.corners[i];
        let weight = place.weights[i];
        if (weight <= 0.0) {
            continue;
        }
        let own = find_held(held, texel);
        var found = false;
        var anchor = vec2<f32>(0.0);
        if (own >= 0 && (*held)[own].s <= place.s) {
            found = true;
            anchor = vec2<f32>((*held)[own].s, (*held)[own].tau);
        }
        let read = cache[texel];
        if (!is_empty(read)) {
            let e = unpack_entry(read);
            if (e.x <= place.s && !(found && anchor.x >= e.x)) {
                found = true;
                anchor = e;
            }
        }
        var start = 0.0;
        var limit = FAR;
        if (found) {
            start = anchor.y;
            limit = place.s - anchor.x;
        }
        // Behind an entry already dark, nothing is left to integrate.
        var tau = DARK_DEPTH;
        if (start < DARK_DEPTH) {
            tau = min(start + optical_depth(ray_point(texel, place.s), limit), DARK_DEPTH);
        }
        depth = depth + weight * tau;
        // Written: the entry nearest the light, where every later sample can start.
        let entry = pack_entry(place.s, tau);
        if (own >= 0) {
            (*held)[own].s = place.s;
            (*held)[own].tau = tau;
            if (entry_less(entry, (*held)[own].write)) {
                (*held)[own].write = entry;
            }
        } else {
            hold_new(held, texel, place.s, tau, entry);
        }
    }
    return depth;
}

// Tracer::light_basic: the light's depth read from the nearest cache ray (this view ray's own
// entry while it stays there); what the sample lets through (its depth along the view ray
// added) is passed on, written where the run of samples on that cache ray began.
fn light_basic(place: Place, view_depth: f32, held: ptr<function, array<Held, 4>>) -> f32 {
    // The last of the heaviest corners, as Iterator::max_by.
    var best = 0u;
    for (var i = 1u; i < 4u; i = i + 1u) {
        if (place.weights[i] >= place.weights[best]) {
            best = i;
        }
    }
    let nearest = place.corners[best];
    release(held, vec4<u32>(nearest), true);
    let own = find_held(held, nearest);
    var tau = 0.0;
    if (own >= 0) {
        tau = (*held)[own].tau;
    } else if (!is_empty(cache[nearest])) {
        tau = unpack_entry(cache[nearest]).y;
    }
    let through = min(tau + view_depth, DARK_DEPTH);
    if (own >= 0) {
        let start = min(unpack_entry((*held)[own].write).x, place.s);
        (*held)[own].s = place.s;
        (*held)[own].tau = through;
        (*held)[own].write = pack_entry(start, through);
    } else {
        hold_new(held, nearest, place.s, through, pack_entry(place.s, through));
    }
    return tau;
}

// Unit direction towards the light (xyz) and the irradiance it delivers at p (lights::incident).
fn incident(p: vec3<f32>, to_light: ptr<function, vec3<f32>>) -> vec3<f32> {
    if (params.light_kind == LIGHT_DIRECTIONAL) {
        *to_light = params.light;
        return params.colour;
    }
    let d = params.light - p;
    let r2 = max(dot(d, d), 1e-12);
    *to_light = d / sqrt(r2);
    return params.colour / r2;
}

// diffusion::lateral_escape: B^2 of the two directions across the light for a body as wide
// as the slab (L deep) is.
fn lateral_escape(l: f32, d: f32) -> f32 {
    let w = PI / (l + 4.0 * d);
    return 2.0 * w * w;
}

// diffusion::spread: exp(-t) t h((1 - mu) t) with h(x) = expm1(x) / x, finite for mu near 1
// and for large t, in the same branches. WGSL has no expm1: for 1e-4 <= |x| < 1e-2 its series
// to x^4 is exact in f32 (the next term is x^5 / 120), and beyond exp(x) - 1 loses about
// 1e-7 / |x| <= 1e-5 of itself to cancellation. Only the branch taken is evaluated, so
// exp never overflows (x < 50) and no inf meets a 0.
fn spread(t: f32, mu: f32) -> f32 {
    let x = (1.0 - mu) * t;
    if (abs(x) < 1e-4) {
        return exp(-t) * t * (1.0 + 0.5 * x);
    }
    if (abs(x) < 1e-2) {
        let expm1 = x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))));
        return exp(-t) * expm1 / (1.0 - mu);
    }
    if (x < 50.0) {
        return exp(-t) * (exp(x) - 1.0) / (1.0 - mu);
    }
    // = (exp(-mu t) - exp(-t)) / (1 - mu), which cannot overflow.
    return (exp(-mu * t) - exp(-t)) / (1.0 - mu);
}

// diffusion::fluence of one colour channel: the diffuse fluence per unit irradiance at
// optical depth tau along a light ray, in a slab tau + ahead deep (with sideways escape), for
// albedo a and asymmetry g; the same clamps (a to MAX_ALBEDO, tau and L to MAX_DEPTH: no
// infinite depth, no inf * 0) and the same cancellation-free form.
fn fluence_channel(tau_in: f32, ahead: f32, a_in: f32, g: f32) -> f32 {
    if (a_in <= 0.0) {
        return 0.0;
    }
    let a = min(a_in, MAX_ALBEDO);
    let tau = min(tau_in, MAX_DEPTH);
    let l = min(tau + max(ahead, 0.0), MAX_DEPTH);
    let d = 1.0 / (3.0 * (1.0 - a * g));
    let mu = sqrt(3.0 * (1.0 - a) * (1.0 - a * g) + lateral_escape(l, d));
    let f = a * (1.0 + 3.0 * d * g) / (d * (mu + 1.0));
    let moment = 6.0 * d * g * a;
    let p = 1.0 + 2.0 * d * mu;
    let m = 1.0 - 2.0 * d * mu;
    let far = exp(-mu * l);
    let beam_out = exp(-l);
    let spread_l = spread(l, mu);
    let det = p * p - m * m * far * far;
    let near_face = (-p * moment - m * far * moment * beam_out
        + f * (2.0 * d * p + m * far * (m * spread_l + 2.0 * d * beam_out))) / det;
    let far_face = (p * moment * beam_out + m * far * moment
        - f * (4.0 * d * beam_out + m * (1.0 + 2.0 * d) * spread_l)) / det;
    let phi = f * spread(tau, mu) + near_face * exp(-mu * tau) + far_face * exp(-mu * (l - tau));
    return max(phi, 0.0);
}

// InScattered::at: the transport field (binding 9: per cell the red, green and blue channels'
// field_coefficients band coefficients, bands::Bands) at world point p towards `leaving`,
// trilinear over the eight cells around p (clamped to the edge cells) in the CPU's order,
// never negative.
fn in_scattered(p: vec3<f32>, leaving: vec3<f32>) -> vec3<f32> {
    let n = params.field_dims;
    let top = vec3<f32>(n - vec3<u32>(1u));
    let c = clamp((p - params.field_origin) / params.field_spacing, vec3<f32>(0.0), top);
    let i0 = vec3<u32>(c);
    let f = c - vec3<f32>(i0);
    let i1 = min(i0 + vec3<u32>(1u), n - vec3<u32>(1u));
    var basis = band_basis(leaving);
    let k = params.field_coefficients;
    var j = vec3<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner = corner + 1u) {
        let high = vec3<bool>((corner & 1u) != 0u, (corner & 2u) != 0u, (corner & 4u) != 0u);
        let i = select(i0, i1, high);
        let w3 = select(vec3<f32>(1.0) - f, f, high);
        let w = w3.x * w3.y * w3.z;
        let base = 3u * k * (i.x + n.x * (i.y + n.y * i.z));
        var cell = vec3<f32>(0.0);
        for (var b = 0u; b < k; b = b + 1u) {
            cell = cell + basis[b] * vec3<f32>(
                chords[base + b], chords[base + k + b], chords[base + 2u * k + b]);
        }
        j = j + w * cell;
    }
    return max(j, vec3<f32>(0.0));
}

// diffusion::fluence per colour channel of the albedo a.
fn fluence(tau: f32, ahead: f32, a: vec3<f32>, g: f32) -> vec3<f32> {
    return vec3<f32>(
        fluence_channel(tau, ahead, a.x, g),
        fluence_channel(tau, ahead, a.y, g),
        fluence_channel(tau, ahead, a.z, g),
    );
}

// Tracer::trace: marches the view ray through pixel `xy` front to back.
fn trace(xy: vec2<u32>) -> PixelOut {
    var out = PixelOut(vec3<f32>(0.0), vec3<f32>(0.0), 1.0, BACKGROUND_DEPTH, 0.0, 0.0);
    let view = params.view;
    let ray = camera_ray(view, xy);
    let span = box_span(view, ray);
    if (!(span.y > span.x)) {
        return out;
    }
    let steps = view_steps(span, params.step, step_offset(xy));
    let index_origin = index_of(view, ray.origin);
    let index_dir = ray.dir / view.spacing;
    var held: array<Held, 4>;
    var k = 0u;
    loop {
        if (k >= steps.count) {
            break;
        }
        let segment = step_segment(steps, k);
        let ta = segment.x;
        let dt = segment.y;
        let x = ray.origin + (ta + 0.5 * dt) * ray.dir;
        let cell = occupancy_cell(index_of(view, x), params.cells, params.cell_voxels);
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
        let o = optical_at(x);
        if (o.sigma_t <= 0.0 && all(o.emission == vec3<f32>(0.0))) {
            continue;
        }
        let alpha = 1.0 - exp(-o.sigma_t * dt);
        let place = place_of(x);
        var light_depth: f32;
        if (params.piecewise == 1u) {
            light_depth = light_piecewise(place, &held);
        } else {
            light_depth = light_basic(place, o.sigma_t * dt, &held);
        }
        let light_t = exp(-light_depth);
        var to_light: vec3<f32>;
        let e = incident(x, &to_light);
        // Light travels along -to_light and leaves along -dir: cos = to_light . dir.
        var per_irradiance = vec3<f32>(henyey_greenstein(params.g, dot(to_light, ray.dir)) * light_t);
        if (params.multiple == 1u) {
            let tau = light_depth;
            // The slab's far face: where the light ray leaves the box, from the chords of the
            // cache rays around the sample (summed in the CPU's order).
            var chord = 0.0;
            for (var i = 0u; i < 4u; i = i + 1u) {
                chord = chord + place.weights[i] * chords[place.corners[i]];
            }
            let phi = fluence(tau, chord - tau, o.albedo, params.g);
            per_irradiance = per_irradiance + phi * FRAC_1_PI * 0.25;
        }
        var scattered = per_irradiance * e;
        if (params.multiple == 2u) {
            // Leaving towards the eye: along -dir.
            scattered = scattered + in_scattered(x, -ray.dir);
        }
        out.scattered = out.scattered + out.transmittance * alpha * (o.albedo * scattered);
        out.emitted = out.emitted + out.transmittance * emitted(o, alpha, dt);
        // The shadow layer: the sample's light and irradiance with its contribution weight.
        let weight = out.transmittance * alpha;
        out.lit = out.lit + weight * light_t;
        out.irradiance = out.irradiance + weight * ((e.x + e.y + e.z) / 3.0);
        let next = out.transmittance * (1.0 - alpha);
        if (out.transmittance > 0.5 && next <= 0.5) {
            out.depth = ta + log(2.0 * out.transmittance) / o.sigma_t;
        }
        out.transmittance = next;
        if (out.transmittance < params.ert_threshold) {
            break;
        }
    }
    release(&held, vec4<u32>(0u), false);
    return out;
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&order)) {
        return;
    }
    let pixel = order[id.x];
    let width = params.view.size.x;
    let out = trace(vec2<u32>(pixel % width, pixel / width));
    let light = scattered_out[pixel];
    scattered_out[pixel] = vec4<f32>(light.xyz + out.scattered, light.w + out.irradiance * out.lit);
    let at_depth = depth_out[pixel];
    var depth = at_depth.x;
    if (params.first_pass == 1u) {
        view_out[pixel] = vec4<f32>(out.emitted, out.transmittance);
        depth = out.depth;
    }
    depth_out[pixel] = vec2<f32>(depth, at_depth.y + out.irradiance);
}

// cpu::chord_depths: the optical depth of texel's cache ray through the whole box, from the
// light (a lamp's maps) or from behind every point of the box (a sun's rays, lines through
// the plane s = 0 at the world's origin). One invocation per texel, in a 2D grid of
// workgroups (rows of groups.x * WORKGROUP texels) when there are more than one dimension
// holds.
@compute @workgroup_size(64, 1, 1)
fn chord_depths(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let map = params.map;
    let texel = id.x + id.y * groups.x * WORKGROUP;
    if (texel >= map.size.x * map.size.y) {
        return;
    }
    var start = 0.0;
    if (map.kind == MAP_PARALLEL) {
        let lo = params.view.box_lo;
        let hi = params.view.box_hi;
        start = -(max(sqrt(dot(lo, lo)), sqrt(dot(hi, hi))) + 1.0);
    }
    let origin = ray_point(texel, start);
    let d = ray_point(texel, start + 1.0) - origin;
    // glam's normalize_or_zero; a zero direction (never, for a valid map) crosses nothing.
    let len2 = dot(d, d);
    var chord = 0.0;
    if (len2 > 0.0) {
        chord = optical_depth_along(origin, unit(d), FAR);
    }
    chords[texel] = chord;
}
