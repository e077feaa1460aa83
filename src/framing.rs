//! What a scene decides from its data once the volume is loaded ([`crate::scene::Scene::load`]):
//! Hounsfield presets when the file says its values are HU, the classification's window, the
//! visible content's centre and the camera framing it, and a notice when the volume's size
//! makes its optical depth too small or too large to show.
//!
//! The visible content is the voxels whose extinction would make a slab as deep as the box
//! [`CONTENT_DEPTH`] deep in optical depth (about 10 % opaque), bounded per axis without the
//! outermost [`TRIM`] of them, so that a few noisy voxels in empty space do not widen it.

use crate::classify::{presets, Classification, ValueRange, ValueUnits, Window};
use crate::error::{Error, Result};
use crate::scene::{Centre, Loaded, Scene, AUTO_FIT};
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;

/// Optical depth across the box that makes a voxel's extinction visible content.
const CONTENT_DEPTH: f32 = 0.1;
/// Share of the content voxels left out at each end of each axis.
const TRIM: f64 = 0.001;
/// Optical depth through the content below which it is nearly transparent.
const FAINT_DEPTH: f32 = 1.0;
/// Optical depth of one voxel of typical content above which each voxel is opaque on its own
/// (95 %), so the render shows blocky voxels rather than a lit medium.
const SATURATED_VOXEL_DEPTH: f32 = 3.0;
/// Voxels whose extinctions the typical one is read from, at most.
const SAMPLE: usize = 1 << 20;

/// The visible content of a classified volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Content {
    /// World-space box of the content's cells.
    pub lo: Vec3,
    pub hi: Vec3,
    /// The median extinction of the voxels with any.
    pub typical_sigma_t: f32,
}

/// Settles a scene's data-dependent choices for its loaded and placed `volume`; `hounsfield`
/// says why the file's values are HU, when it says so.
pub fn settle(scene: &Scene, mut volume: Volume, hounsfield: Option<&str>) -> Result<Loaded> {
    let mut scene = scene.clone();
    let mut notices = Vec::new();
    settle_units(&mut scene, hounsfield, &mut notices)?;
    settle_window(&mut scene.classification, &volume, &mut notices)?;
    let wants_content = scene.volume.centre == Some(Centre::Content) || scene.framing.is_some();
    // A pass over every voxel (a tenth of a second per 8 million): only when something uses it.
    let content = if wants_content || scene.volume.fit.is_none() {
        content(&volume, &scene.classification)
    } else {
        None
    };
    if scene.volume.fit.is_none() {
        notices.extend(depth_notice(&volume, &scene.classification, content));
    }
    if wants_content && content.is_none() {
        notices.push(
            "content: no voxel is visible under this classification; the whole box is framed \
             and centred instead"
                .into(),
        );
    }
    let (lo, hi) = content.map_or_else(|| volume.bounds(), |c| (c.lo, c.hi));
    let (lo, hi) = if scene.volume.centre == Some(Centre::Content) {
        let shift = -0.5 * (lo + hi);
        let (box_lo, box_hi) = volume.bounds();
        volume = volume.with_centre(0.5 * (box_lo + box_hi) + shift);
        notices.push(format!(
            "volume: the visible content's centre moved to the origin (by {})",
            fmt_vec(shift)
        ));
        (lo + shift, hi + shift)
    } else {
        (lo, hi)
    };
    if let Some(framing) = scene.framing {
        scene.camera = scene.camera.framing(lo, hi, framing.margin)?;
        notices.push(format!(
            "camera: frames the visible content {} .. {} from {} ({} % margin)",
            fmt_vec(lo),
            fmt_vec(hi),
            fmt_vec(scene.camera.position),
            100.0 * framing.margin
        ));
    }
    check_step(&scene, &volume)?;
    notices.extend(view_notice(&scene.camera, &volume));
    Ok(Loaded {
        scene,
        volume,
        notices,
    })
}

/// Refuses a ray-marching step longer than the volume's diagonal: every ray would take at
/// most one sample of the whole crossing (`step = 1e9` rendered one sample per ray, and too
/// bright, without a word).
fn check_step(scene: &Scene, volume: &Volume) -> Result<()> {
    let (lo, hi) = volume.bounds();
    let diagonal = (hi - lo).length();
    match scene.method.step() {
        Some(step) if step > diagonal => Err(Error::param(
            "render.step",
            format!(
                "{step} is longer than the volume's diagonal ({diagonal}): a ray would take at \
                 most one sample; leave it out for half a voxel ({})",
                0.5 * volume.spacing().min_element()
            ),
        )),
        _ => Ok(()),
    }
}

/// Most view rays tried for [`view_notice`]: every pixel's up to about a megapixel, a grid
/// of them beyond (a volume narrower than that grid's spacing is then missed, and noticed).
const VIEW_RAYS: u64 = 1 << 20;

/// A notice when no pixel's ray meets the volume's box: the image would be the background
/// alone (a camera looking away, a `fit` of 1e-30), which rendered with no word.
fn view_notice(camera: &crate::camera::Camera, volume: &Volume) -> Option<String> {
    let (lo, hi) = volume.bounds();
    let pixels = camera.width as u64 * camera.height as u64;
    let stride = ((pixels as f64 / VIEW_RAYS as f64).sqrt().ceil() as u32).max(1);
    let rows = (0..camera.height).step_by(stride as usize);
    let seen = rows.into_iter().any(|y| {
        (0..camera.width)
            .step_by(stride as usize)
            .any(|x| crate::camera::intersect_box(&camera.ray(x, y), lo, hi).is_some())
    });
    (!seen).then(|| {
        format!(
            "camera: no pixel sees the volume's box {} .. {} from {} looking along {}: the image \
             will be the background alone (check camera.position and target, or volume.fit)",
            fmt_vec(lo),
            fmt_vec(hi),
            fmt_vec(camera.position),
            fmt_vec(camera.forward)
        )
    })
}

/// A preset without units becomes its Hounsfield form when the file says its values are HU.
fn settle_units(
    scene: &mut Scene,
    hounsfield: Option<&str>,
    notices: &mut Vec<String>,
) -> Result<()> {
    let c = &mut scene.classification;
    match (&scene.units_from_data, hounsfield) {
        (Some(name), Some(why)) => {
            *c = Classification {
                density_scale: c.density_scale,
                lut_size: c.lut_size,
                ..presets::preset_in(name, ValueUnits::Hu)?
            };
            notices.push(format!(
                "classification: {name} in Hounsfield units, as the file says ({why})"
            ));
        }
        (_, Some(why)) if c.units == ValueUnits::Normalized => notices.push(format!(
            "classification: the file's values are Hounsfield units ({why}); units = \"hu\" \
             places CT presets on them"
        )),
        _ => {}
    }
    Ok(())
}

/// Resolves the normalised window, saying which values it spans. The classification's table
/// spans the window (a little past it), or the volume's whole value range for `range = "full"`
/// and for raw and HU units: a range wider than an f32 holds (finite values near +-3.4e38)
/// would divide every lookup by infinity and classify every voxel as clear, so it is refused.
fn settle_window(c: &mut Classification, volume: &Volume, notices: &mut Vec<String>) -> Result<()> {
    let spans_values = c.units != ValueUnits::Normalized || c.range == ValueRange::Full;
    if spans_values {
        let (lo, hi) = volume.value_range();
        if !(hi - lo).is_finite() {
            return Err(Error::param(
                "classification.range",
                format!(
                    "the values span {lo:e} .. {hi:e}, a range wider than 32-bit floats hold \
                     ({:e}): classify on the robust window (the default, range = \"robust\") or \
                     on a window [lo, hi]",
                    f32::MAX
                ),
            ));
        }
    }
    let how = match c.units {
        ValueUnits::Normalized => match c.range {
            ValueRange::Robust => {
                let report = Window::robust(volume);
                c.range = ValueRange::Window(report.window);
                format!("normalised 0..1 on values {report}")
            }
            ValueRange::Full => {
                let window = c.range.window(volume);
                c.range = ValueRange::Window(window);
                format!("normalised 0..1 on values {window} (range = \"full\")")
            }
            ValueRange::Window(w) => format!("normalised 0..1 on values {w} (as given)"),
        },
        ValueUnits::Raw => "on raw values".into(),
        ValueUnits::Hu => "in Hounsfield units".into(),
    };
    notices.push(format!("classification: {how}"));
    Ok(())
}

/// The visible content of `volume` under `classification` (its window resolved or not); None
/// when no voxel is visible.
pub fn content(volume: &Volume, classification: &Classification) -> Option<Content> {
    let lut = classification.bake(volume);
    let (box_lo, box_hi) = volume.bounds();
    let threshold = CONTENT_DEPTH / (box_hi - box_lo).max_element();
    let [nx, ny, nz] = volume.dims();
    let sigma_at = |i: usize, j: usize, k: usize| {
        let g = if classification.uses_gradient() {
            let p = volume.origin() + Vec3::new(i as f32, j as f32, k as f32) * volume.spacing();
            volume.gradient(p).length()
        } else {
            0.0
        };
        lut.sigma_t(volume.at(i, j, k), g)
    };
    // Content voxels per index along each axis, summed over slabs in parallel.
    let counts = (0..nz)
        .into_par_iter()
        .map(|k| {
            let mut c = [vec![0u64; nx], vec![0u64; ny], vec![0u64; nz]];
            for j in 0..ny {
                for i in 0..nx {
                    if sigma_at(i, j, k) >= threshold {
                        c[0][i] += 1;
                        c[1][j] += 1;
                        c[2][k] += 1;
                    }
                }
            }
            c
        })
        .reduce(
            || [vec![0u64; nx], vec![0u64; ny], vec![0u64; nz]],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.iter_mut().zip(y).for_each(|(x, y)| *x += y);
                }
                a
            },
        );
    let total: u64 = counts[0].iter().sum();
    if total == 0 {
        return None;
    }
    let extent = |axis: &[u64]| {
        let skip = (TRIM * total as f64) as u64;
        let first = index_past(axis.iter(), skip);
        let last = axis.len() - 1 - index_past(axis.iter().rev(), skip);
        (first as f32, last.max(first) as f32)
    };
    let [(i0, i1), (j0, j1), (k0, k1)] = [0, 1, 2].map(|a| extent(&counts[a]));
    let half = 0.5 * volume.spacing();
    let at = |i: f32, j: f32, k: f32| volume.origin() + Vec3::new(i, j, k) * volume.spacing();
    let values = volume.values();
    let stride = (values.len() / SAMPLE).max(1) | 1;
    let mut sigmas: Vec<f32> = (0..values.len())
        .step_by(stride)
        .map(|n| sigma_at(n % nx, (n / nx) % ny, n / (nx * ny)))
        .filter(|s| *s > 0.0)
        .collect();
    sigmas.sort_unstable_by(f32::total_cmp);
    Some(Content {
        lo: at(i0, j0, k0) - half,
        hi: at(i1, j1, k1) + half,
        typical_sigma_t: sigmas.get(sigmas.len() / 2).copied().unwrap_or(threshold),
    })
}

/// The first index whose running count exceeds `skip`.
fn index_past<'a>(counts: impl Iterator<Item = &'a u64>, skip: u64) -> usize {
    let mut seen = 0;
    for (i, c) in counts.enumerate() {
        seen += c;
        if seen > skip {
            return i;
        }
    }
    0
}

/// A notice when the content's optical depth is far from showing: nearly transparent, or so
/// deep that every voxel is opaque on its own; with the `fit` or `density_scale` that would
/// give the depth the presets are made for (a volume [`AUTO_FIT`] units across).
fn depth_notice(
    volume: &Volume,
    classification: &Classification,
    content: Option<Content>,
) -> Option<String> {
    let (lo, hi) = volume.bounds();
    let across = (hi - lo).max_element();
    let (depth, voxel_depth, what) = match content {
        Some(c) => (
            c.typical_sigma_t * (c.hi - c.lo).max_element(),
            c.typical_sigma_t * volume.spacing().min_element(),
            "its content",
        ),
        None => {
            // Nothing reaches the content threshold: the densest voxel across the box.
            let sigma = classification.bake(volume).max_sigma_t();
            (sigma * across, 0.0, "the box at its densest")
        }
    };
    let state = if depth < FAINT_DEPTH {
        "nearly transparent"
    } else if voxel_depth > SATURATED_VOXEL_DEPTH {
        "each voxel opaque on its own"
    } else {
        return None;
    };
    let scale = classification.density_scale * AUTO_FIT / across;
    Some(format!(
        "notice: the volume is {across:.3e} world units across, so the optical depth through \
         {what} is about {depth:.2e}: {state}. Extinction is per world unit; fit = \"auto\" \
         (longest side {AUTO_FIT} units) or density_scale = {scale:.3e} shows it as the presets \
         intend."
    ))
}

fn fmt_vec(v: Vec3) -> String {
    format!("[{:.3}, {:.3}, {:.3}]", v.x, v.y, v.z)
}
