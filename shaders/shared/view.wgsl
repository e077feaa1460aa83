// The view the renderers share: the camera, the image and the volume's placement, with the
// helpers that read it. A kernel pulls it in with the line //#include "view.wgsl" and makes a
// `View` part of its uniform; src/gpu/view.rs's ViewUniform mirrors it field for field.

struct View {
    // The eye (perspective) or the image plane's centre (orthographic).
    position: vec3<f32>,
    // 1 perspective, 0 orthographic.
    perspective: u32,
    // The camera's unit axes.
    forward: vec3<f32>,
    right: vec3<f32>,
    up: vec3<f32>,
    // Half the image plane along right and up: tangents of the half angles (perspective) or
    // world units (orthographic), as Camera::half_extent.
    half_extent: vec2<f32>,
    // Width and height in pixels.
    size: vec2<u32>,
    // The volume's bounding box.
    box_lo: vec3<f32>,
    box_hi: vec3<f32>,
    // Voxel centres sit at origin + index * spacing; dims voxels along each axis.
    origin: vec3<f32>,
    spacing: vec3<f32>,
    dims: vec3<u32>,
};

struct CameraRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
};

// The ray through the centre of pixel (i, j), row 0 at the top (Camera::ray).
fn camera_ray(view: View, pixel: vec2<u32>) -> CameraRay {
    let size = vec2<f32>(view.size);
    let sx = ((f32(pixel.x) + 0.5) / size.x * 2.0 - 1.0) * view.half_extent.x;
    let sy = (1.0 - (f32(pixel.y) + 0.5) / size.y * 2.0) * view.half_extent.y;
    if (view.perspective == 1u) {
        return CameraRay(view.position, normalize(view.forward + sx * view.right + sy * view.up));
    }
    return CameraRay(view.position + sx * view.right + sy * view.up, view.forward);
}

// Entry and exit distances of the ray in the volume's box, entry clamped to 0; x >= y when it
// misses (camera::intersect_box).
fn box_span(view: View, ray: CameraRay) -> vec2<f32> {
    let inv = 1.0 / ray.dir;
    let t0 = (view.box_lo - ray.origin) * inv;
    let t1 = (view.box_hi - ray.origin) * inv;
    let near = max(max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z)), 0.0);
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z));
    return vec2<f32>(near, far);
}

// Continuous index coordinates of world position p, voxel centres at integers
// (Volume::to_index).
fn index_of(view: View, p: vec3<f32>) -> vec3<f32> {
    return (p - view.origin) / view.spacing;
}

// Voxels along each axis, as common.wgsl's sampling helpers take them.
fn volume_dims(view: View) -> vec3<f32> {
    return vec3<f32>(view.dims);
}
