#![no_main]
//! Every registered method on the CPU, at random parameters within the registry's ranges, on
//! a random volume of 4^3 to 8^3 voxels with a random classification, lights and camera, at
//! 8 x 8 pixels. Every pixel (colour, depth, shading factor) and every grid a method computes
//! must be finite. A method may refuse a combination of parameters, naming the key, or data it
//! cannot use (the volume never crosses `ao_iso`, a classification that leaves nothing to
//! occlude); any other error, a panic or a non-finite output is a finding.
//!
//! Values are drawn to keep an execution to milliseconds: lengths (steps, slice distances) from
//! an eighth of a voxel up, whole numbers (grids, radii, cache sizes) within 15 of their least.

use glam::Vec3;
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use occlux::camera::{Camera, Projection};
use occlux::classify::{
    presets, Classification, ControlPoint, TransferFunction, TransferFunction1D,
    TransferFunction2D, ValueRange, ValueUnits, Widget, WidgetShape, Window, DEFAULT_LUT_SIZE,
};
use occlux::gpu::Compute;
use occlux::lights::{Light, Lighting};
use occlux::method::{ParamKind, ParamSpec, Range};
use occlux::progress::NoProgress;
use occlux::registry::{Method, METHODS};
use occlux::render::{MethodInput, Rendered};
use occlux::volume::Volume;
use occlux::Error;
use serde_json::{json, Map, Value};

/// The image's side in pixels.
const SIDE: u32 = 8;

fuzz_target!(init: occlux_fuzz::one_thread(), |data: &[u8]| {
    let _ = render_all(&mut Unstructured::new(data));
});

/// A number in [0, 1] in 256 steps.
fn fraction(u: &mut Unstructured) -> Result<f32> {
    Ok(u.int_in_range(0u8..=255)? as f32 / 255.0)
}

fn between(u: &mut Unstructured, lo: f32, hi: f32) -> Result<f32> {
    Ok(lo + (hi - lo) * fraction(u)?)
}

fn rgb(u: &mut Unstructured, hi: f32) -> Result<[f32; 3]> {
    Ok([
        between(u, 0.0, hi)?,
        between(u, 0.0, hi)?,
        between(u, 0.0, hi)?,
    ])
}

/// A vector with components in [-1, 1]; may be zero.
fn vector(u: &mut Unstructured) -> Result<Vec3> {
    Ok(Vec3::new(
        between(u, -1.0, 1.0)?,
        between(u, -1.0, 1.0)?,
        between(u, -1.0, 1.0)?,
    ))
}

fn unit(u: &mut Unstructured) -> Result<Vec3> {
    Ok(vector(u)?.try_normalize().unwrap_or(Vec3::Z))
}

fn volume(u: &mut Unstructured) -> Result<Option<Volume>> {
    let mut dims = [0; 3];
    for d in &mut dims {
        *d = u.int_in_range(4..=8)?;
    }
    let mut spacing = Vec3::ZERO;
    for s in spacing.as_mut() {
        *s = 2f32.powi(u.int_in_range(-3..=3)?);
    }
    let origin = 4.0 * vector(u)?;
    // Values as a CT's, as normalised ones, as a simulation's tiny or huge ones.
    let scale = *u.choose(&[1.0, 255.0, 4096.0, 1e-6, 1e30])?;
    let offset = *u.choose(&[0.0, -1024.0, 1e6])?;
    let values = (0..dims.iter().product())
        .map(|_| Ok(offset + scale * fraction(u)?))
        .collect::<Result<_>>()?;
    Ok(Volume::new(dims, spacing, origin, values).ok())
}

/// A value on the classification's axis: normalised, or within (and a little beyond) the
/// volume's values.
fn position(u: &mut Unstructured, units: ValueUnits, volume: &Volume) -> Result<f32> {
    let (lo, hi) = match units {
        ValueUnits::Normalized => (0.0, 1.0),
        _ => volume.value_range(),
    };
    Ok(lo + (hi - lo) * between(u, -0.25, 1.25)?)
}

fn sigma_t(u: &mut Unstructured) -> Result<f32> {
    Ok(between(u, 0.0, 1.0)? * *u.choose(&[0.0, 1.0, 50.0, 1e4])?)
}

/// No emission, or some.
fn emission(u: &mut Unstructured) -> Result<[f32; 3]> {
    let most = *u.choose(&[0.0, 4.0])?;
    rgb(u, most)
}

fn classification(u: &mut Unstructured, volume: &Volume) -> Result<Option<Classification>> {
    let units = *u.choose(&[ValueUnits::Normalized, ValueUnits::Raw, ValueUnits::Hu])?;
    let tf = match u.int_in_range(0..=2)? {
        0 => return Ok(presets::preset_in(u.choose(presets::PRESETS)?, units).ok()),
        1 => {
            let mut points = Vec::new();
            for _ in 0..u.int_in_range(1..=4)? {
                points.push(ControlPoint::new(
                    position(u, units, volume)?,
                    sigma_t(u)?,
                    rgb(u, 1.0)?,
                    emission(u)?,
                ));
            }
            TransferFunction1D::new(points).map(TransferFunction::OneD)
        }
        _ => {
            let mut widgets = Vec::new();
            for _ in 0..u.int_in_range(1..=3)? {
                let g0 = between(u, 0.0, 0.9)?;
                widgets.push(Widget {
                    shape: *u.choose(&[WidgetShape::Box, WidgetShape::Trapezoid])?,
                    value: position(u, units, volume)?,
                    width_bottom: between(u, 0.0, 1.0)?,
                    width_top: if u.arbitrary()? {
                        Some(between(u, 0.01, 1.0)?)
                    } else {
                        None
                    },
                    gradient: [g0, between(u, g0 + 0.05, 1.0)?],
                    sigma_t: sigma_t(u)?,
                    albedo: rgb(u, 1.0)?,
                    emission: emission(u)?,
                });
            }
            TransferFunction2D::new(widgets).map(TransferFunction::TwoD)
        }
    };
    let Ok(tf) = tf else {
        return Ok(None);
    };
    let range = match u.int_in_range(0..=2)? {
        _ if units != ValueUnits::Normalized => ValueRange::default(),
        0 => ValueRange::Robust,
        1 => ValueRange::Full,
        _ => {
            let (lo, hi) = (
                position(u, ValueUnits::Raw, volume)?,
                position(u, ValueUnits::Raw, volume)?,
            );
            ValueRange::Window(Window {
                lo: lo.min(hi),
                hi: lo.max(hi),
                cut: None,
            })
        }
    };
    let c = Classification {
        tf,
        units,
        density_scale: between(u, 0.0, 4.0)?,
        // The default now and then only: a 2D table of its size is a million entries, and the
        // baking would outweigh the rendering many times.
        lut_size: *u.choose(&[2, 3, 17, 256, 256, 256, DEFAULT_LUT_SIZE])?,
        range,
    };
    Ok(c.validate().is_ok().then_some(c))
}

/// Suns, lamps (inside the box too) and ambient light, as a scene may hold them.
fn lighting(u: &mut Unstructured, centre: Vec3, extent: f32) -> Result<Lighting> {
    let mut lights = Vec::new();
    for _ in 0..u.int_in_range(0..=4)? {
        lights.push(match u.int_in_range(0..=2)? {
            0 => Light::Ambient {
                radiance: Vec3::from(rgb(u, 2.0)?),
            },
            1 => Light::Directional {
                to_light: unit(u)?,
                irradiance: Vec3::from(rgb(u, 4.0)?),
            },
            _ => Light::Point {
                position: centre + 2.0 * extent * vector(u)?,
                intensity: Vec3::from(rgb(u, 20.0)?) * extent * extent,
            },
        });
    }
    let lighting = Lighting {
        lights,
        background: Vec3::from(rgb(u, 1.0)?),
    };
    lighting.validate().expect("the target makes valid lights");
    Ok(lighting)
}

/// A camera looking at the box from outside, from its surface or from inside it.
fn camera(u: &mut Unstructured, centre: Vec3, extent: f32) -> Result<Option<Camera>> {
    let distance = extent * *u.choose(&[0.1, 0.5, 1.0, 2.0, 4.0, 100.0])?;
    let position = centre + distance * unit(u)?;
    let target = centre + 0.25 * extent * vector(u)?;
    let up = if u.arbitrary()? { Vec3::Z } else { unit(u)? };
    let projection = if u.arbitrary()? {
        Projection::Perspective {
            fov_y: between(u, 1.0, 150.0)?.to_radians(),
        }
    } else {
        Projection::Orthographic {
            scale: extent * between(u, 0.1, 4.0)?,
        }
    };
    Ok(Camera::look_at(position, target, up, projection, SIDE, SIDE).ok())
}

/// A value of `range`: its bounds (or the nearest f32 inside an open one) as often as not,
/// else within it; `length` scales unbounded ranges (a voxel's side).
fn float_in(u: &mut Unstructured, range: &Range, length: f32, volume: &Volume) -> Result<f32> {
    let (lo, hi) = (range.min as f32, range.max as f32);
    Ok(match (lo.is_finite(), hi.is_finite()) {
        (true, true) if u.ratio(1, 2)? => {
            if u.arbitrary()? {
                if range.min_inclusive {
                    lo
                } else {
                    lo.next_up()
                }
            } else if range.max_inclusive {
                hi
            } else {
                hi.next_down()
            }
        }
        (true, true) => between(u, lo, hi)?,
        // Lengths: from an eighth of a voxel (shorter would only be slower) to far beyond the
        // box, where a single step crosses it.
        (true, false) if u.ratio(1, 16)? => lo.max(0.0) + 1e30,
        (true, false) => lo.max(0.0) + length * 2f32.powi(u.int_in_range(-3..=6)?),
        (false, true) => hi.min(0.0) - length * 2f32.powi(u.int_in_range(-3..=6)?),
        // Values in the data's units: around the volume's, or any finite f32.
        (false, false) => {
            let any = f32::from_bits(u.arbitrary()?);
            if any.is_finite() && u.ratio(1, 4)? {
                any
            } else {
                position(u, ValueUnits::Raw, volume)?
            }
        }
    })
}

/// A value for `param`, as a scene's `[render]` table holds it.
fn value(u: &mut Unstructured, param: &ParamSpec, volume: &Volume) -> Result<Value> {
    let (lo, hi) = volume.bounds();
    Ok(match &param.kind {
        ParamKind::Float { range, .. } => {
            let length = volume.spacing().min_element();
            json!(float_in(u, range, length, volume)? as f64)
        }
        ParamKind::Int { range, .. } => {
            // The registry's whole numbers all have closed ranges.
            let (least, most) = (range.min.ceil(), range.max.floor());
            json!(u.int_in_range(least as i64..=most.min(least + 15.0) as i64)?)
        }
        ParamKind::Bool => json!(u.arbitrary::<bool>()?),
        ParamKind::Choice { options } => json!(u.choose(options)?.name),
        ParamKind::Planes { max } => {
            let mut planes = Vec::new();
            for _ in 0..u.int_in_range(0..=*max)? {
                let point = lo + (hi - lo) * (0.5 + 0.75 * vector(u)?);
                // Whole components, so that the zero normal (refused) comes up too.
                let normal = (2.0 * vector(u)?).round();
                planes.push(json!({ "point": point.to_array(), "normal": normal.to_array() }));
            }
            Value::Array(planes)
        }
    })
}

/// An error a render may end in: a parameter named by its key, or data it cannot use.
fn acceptable(e: &Error, method: &str) {
    match e {
        Error::Param { key, message } => {
            assert!(!key.is_empty() && !message.is_empty(), "{method}: {e:?}")
        }
        Error::Volume(message) => assert!(!message.is_empty(), "{method}: {e:?}"),
        other => panic!("{method}: neither a parameter nor the data at fault: {other}"),
    }
}

/// The first non-finite output of a render, if any: a pixel's colour, depth or shading factor,
/// or a grid's voxel (`occlux export` writes the grids as VDB, which refuses such values).
fn non_finite(rendered: &Rendered) -> Option<String> {
    let image = &rendered.image;
    let finite = |v: &[f32]| v.iter().all(|c| c.is_finite());
    if let Some(p) = image.rgba.iter().position(|rgba| !finite(rgba)) {
        return Some(format!("pixel {p} is {:?}", image.rgba[p]));
    }
    if let Some(p) = image.depth.iter().position(|d| !d.is_finite()) {
        return Some(format!("depth at pixel {p} is {}", image.depth[p]));
    }
    if let Some(factor) = &image.factor {
        if let Some(p) = factor.values.iter().position(|v| !finite(v)) {
            return Some(format!(
                "{} at pixel {p} is {:?}",
                factor.name, factor.values[p]
            ));
        }
    }
    rendered.grids.iter().find_map(|grid| {
        let v = grid.volume.values().iter().find(|v| !v.is_finite())?;
        Some(format!("grid {} holds {v}", grid.name))
    })
}

fn render_all(u: &mut Unstructured) -> Result<()> {
    let Some(volume) = volume(u)? else {
        return Ok(());
    };
    let Some(classification) = classification(u, &volume)? else {
        return Ok(());
    };
    let (lo, hi) = volume.bounds();
    let (centre, extent) = (0.5 * (lo + hi), (hi - lo).max_element());
    let lighting = lighting(u, centre, extent)?;
    let Some(camera) = camera(u, centre, extent)? else {
        return Ok(());
    };
    let lut = classification.bake(&volume);
    for spec in METHODS {
        let mut table = Map::new();
        table.insert("method".into(), json!(spec.name));
        for param in spec.params {
            // Absent (the default) unless the input says otherwise, so that a short input
            // renders every method at its defaults.
            if u.arbitrary()? {
                table.insert(param.key.into(), value(u, param, &volume)?);
            }
        }
        let method = match Method::from_table(table) {
            Ok(method) => method,
            Err(e) => {
                acceptable(&e, spec.name);
                continue;
            }
        };
        // A scene is refused the lights its method does not render; here they are left out.
        let lighting = spec.lights_of(&lighting);
        let input = MethodInput {
            volume: &volume,
            classification: &classification,
            lut: &lut,
            camera: &camera,
            lighting: &lighting,
            compute: &Compute::Cpu,
            progress: &NoProgress,
        };
        let rendered = match method.render(&input) {
            Ok(rendered) => rendered,
            Err(e) => {
                acceptable(&e, spec.name);
                continue;
            }
        };
        let pixels = (SIDE * SIDE) as usize;
        let image = &rendered.image;
        assert_eq!((image.rgba.len(), image.depth.len()), (pixels, pixels));
        if let Some(what) = non_finite(&rendered) {
            // Everything a regression test needs to reproduce it through the library's API.
            let (dims, spacing, origin) = (volume.dims(), volume.spacing(), volume.origin());
            panic!(
                "{}: {what}\n{method:?}\n{lighting:?}\n{camera:?}\n{classification:?}\n\
                 volume {dims:?} spacing {spacing} origin {origin} values {:?}",
                spec.name,
                volume.values()
            );
        }
    }
    Ok(())
}
