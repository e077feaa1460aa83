//! From a raw scan to a figure without guessing (issue 18): every shared volume under every
//! preset, with the defaults a new user gets (no camera position, `fit = "auto"`), gives an
//! image that is neither empty nor an opaque block, with the content framed inside its margin;
//! robust windows against outliers and wrapped values on real data; content framing for
//! perspective and orthographic cameras; the optical-depth notice.

mod common;

use common::scivis_dir;
use glam::Vec3;
use occlux::classify::presets::PRESETS;
use occlux::framing::{self, content};
use occlux::gpu::Compute;
use occlux::pipeline::Settled;
use occlux::progress::NoProgress;
use occlux::render::RenderImage;
use occlux::scene::Scene;
use occlux::volume::{self, LoadOptions, Volume};
use std::path::{Path, PathBuf};

const SIDE: u32 = 48;

fn shared_volumes() -> Vec<(String, PathBuf)> {
    let mut names: Vec<(String, PathBuf)> = std::fs::read_dir(scivis_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "nrrd"))
        .map(|p| (p.file_stem().unwrap().to_string_lossy().into_owned(), p))
        .collect();
    names.sort();
    assert!(names.len() >= 15, "{names:?}");
    names
}

/// A new user's scene: a preset, `fit = "auto"`, a camera with only an image size.
fn default_scene(path: &Path, classification: &str, camera: &str) -> Scene {
    let text = format!(
        "[volume]\npath = {path:?}\nfit = \"auto\"\n[classification]\n{classification}\n\
         [camera]\nwidth = {SIDE}\nheight = {SIDE}\n{camera}\n\
         [[lights]]\ntype = \"ambient\"\nradiance = 1.0\n[render]\nmethod = \"unshaded\"\n"
    );
    Scene::parse(&text, Path::new(".")).unwrap()
}

/// `volume` placed as `fit = "auto"` places it.
fn fitted(volume: &Volume) -> Volume {
    let (lo, hi) = volume.bounds();
    let scale = 2.0 / (hi - lo).max_element();
    Volume::new(
        volume.dims(),
        volume.spacing() * scale,
        volume.origin() * scale,
        volume.values().to_vec(),
    )
    .unwrap()
}

fn render(scene: &Scene, volume: &Volume) -> RenderImage {
    occlux::pipeline::render(&Settled::named(scene), volume, &Compute::Cpu, &NoProgress)
        .unwrap()
        .image
}

/// The share of pixels whose alpha is above `a`.
fn share_above(image: &RenderImage, a: f32) -> f64 {
    image.rgba.iter().filter(|p| p[3] > a).count() as f64 / image.rgba.len() as f64
}

/// The pixel box (x0, y0, x1, y1) of pixels with alpha above 0.05.
fn covered_box(image: &RenderImage) -> Option<[u32; 4]> {
    let (w, h) = (image.width, image.height);
    let mut b: Option<[u32; 4]> = None;
    for y in 0..h {
        for x in 0..w {
            if image.rgba[(y * w + x) as usize][3] > 0.05 {
                b = Some(match b {
                    None => [x, y, x, y],
                    Some([x0, y0, x1, y1]) => [x0.min(x), y0.min(y), x1.max(x), y1.max(y)],
                });
            }
        }
    }
    b
}

/// Every shared volume under every preset, framed by default: at least 3 % of the pixels
/// show the volume (alpha > 0.05), at most half are opaque (alpha > 0.95: a box filled with
/// opaque air or fill seen from the default direction covers about two thirds; the shared
/// volumes measure 0.35 at most), the covered pixels span at least half of the frame's width
/// or height (the content fills the frame), and the outermost ring of pixels stays clear of
/// solid content (alpha < 0.5: the content lies inside its margin). The background value's
/// optical depth across the box is printed: clear (0) wherever the volume has empty space;
/// fields that fill their box (Marschner-Lobb, Rayleigh-Taylor) have no empty background.
#[test]
fn every_shared_volume_under_every_preset_gives_a_framed_visible_figure() {
    let mut failures = Vec::new();
    let mut rows = Vec::new();
    for (name, path) in shared_volumes() {
        let volume = fitted(&volume::load(&path, &LoadOptions::default()).unwrap());
        for preset in PRESETS {
            let scene = default_scene(&path, &format!("preset = \"{preset}\""), "");
            let loaded = framing::settle(&scene, volume.clone(), None).unwrap();
            let image = render(&loaded.scene, &loaded.volume);
            let covered = share_above(&image, 0.05);
            let opaque = share_above(&image, 0.95);
            let report = occlux::classify::Window::robust(&loaded.volume);
            let lut = loaded.scene.classification.bake(&loaded.volume);
            let (lo, hi) = loaded.volume.bounds();
            let background_depth = lut.sigma_t(report.background, 0.0) * (hi - lo).max_element();
            let span = covered_box(&image).map_or(0, |[x0, y0, x1, y1]| (x1 - x0).max(y1 - y0) + 1);
            let ring = (0..SIDE)
                .flat_map(|i| [(i, 0), (i, SIDE - 1), (0, i), (SIDE - 1, i)])
                .map(|(x, y)| image.rgba[(y * SIDE + x) as usize][3])
                .fold(0.0f32, f32::max);
            rows.push(format!(
                "{name:15} {preset:15} covered {covered:.3} opaque {opaque:.3} air depth \
                 {background_depth:.3} span {span}/{SIDE} ring {ring:.3}"
            ));
            let problems: Vec<&str> = [
                (covered < 0.03, "empty"),
                (opaque > 0.5, "an opaque block"),
                (span * 2 < SIDE, "content does not fill the frame"),
                (ring >= 0.5, "content outside its margin"),
            ]
            .into_iter()
            .filter_map(|(bad, what)| bad.then_some(what))
            .collect();
            if !problems.is_empty() {
                failures.push(format!("{name} / {preset}: {}", problems.join(", ")));
            }
        }
    }
    println!("{}", rows.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The stag beetle is uint16 with values to 4095 but its data below about 2200: normalised on
/// the full range, ct-bone's bone (0.55 and up) lies above nearly every voxel; on the robust
/// window it shows the beetle. The same data with one outlier voxel at 50 times the maximum
/// gives the same window and image.
#[test]
fn an_outlier_voxel_does_not_change_a_real_volume_s_figure() {
    let path = scivis_dir().join("stag_beetle.nrrd");
    let volume = fitted(&volume::load(&path, &LoadOptions::default()).unwrap());
    let scene = default_scene(&path, "preset = \"ct-bone\"", "");
    let plain = framing::settle(&scene, volume.clone(), None).unwrap();
    let mut values = volume.values().to_vec();
    let max = volume.value_range().1;
    let middle = values.len() / 3;
    values[middle] = 50.0 * max;
    let spiked = Volume::new(volume.dims(), volume.spacing(), volume.origin(), values).unwrap();
    let with_outlier = framing::settle(&scene, spiked.clone(), None).unwrap();
    assert_eq!(
        plain.scene.classification.range, with_outlier.scene.classification.range,
        "the window moved"
    );
    let (a, b) = (
        render(&plain.scene, &plain.volume),
        render(&with_outlier.scene, &with_outlier.volume),
    );
    let differing = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .filter(|(p, q)| (p[3] - q[3]).abs() > 1e-3)
        .count();
    // The outlier voxel itself may show in a pixel or two.
    assert!(differing <= 4, "{differing} pixels differ");
    // On the full range, as before the robust window, the outlier moves the window 50-fold.
    let full = default_scene(&path, "preset = \"ct-bone\"\nrange = \"full\"", "");
    let full = framing::settle(&full, spiked, None).unwrap();
    match full.scene.classification.range {
        occlux::classify::ValueRange::Window(w) => assert_eq!(w.hi, 50.0 * max),
        other => panic!("{other:?}"),
    }
    assert!(share_above(&b, 0.05) > 0.05);
}

/// Negative values wrapped into uint16 (the engine shifted to CT-like numbers with its air
/// outside a cylinder at 64512, as a scanner's out-of-field fill read unsigned): the fill is
/// cut away, so the render matches the same data with the fill set to air.
#[test]
fn wrapped_fill_outside_the_field_of_view_is_not_an_opaque_block() {
    let path = scivis_dir().join("engine.nrrd");
    let volume = fitted(&volume::load(&path, &LoadOptions::default()).unwrap());
    let [nx, ny, _] = volume.dims();
    let outside = |n: usize| {
        let (x, y) = (
            (n % nx) as f32 / nx as f32 - 0.5,
            ((n / nx) % ny) as f32 / ny as f32 - 0.5,
        );
        x * x + y * y > 0.25
    };
    let with = |fill: f32| {
        let values = volume
            .values()
            .iter()
            .enumerate()
            .map(|(n, v)| if outside(n) { fill } else { v * 10.0 })
            .collect();
        Volume::new(volume.dims(), volume.spacing(), volume.origin(), values).unwrap()
    };
    let scene = default_scene(&path, "preset = \"ct-bone\"", "position = [3.2, -3.2, 2.6]");
    let wrapped = framing::settle(&scene, with(64_512.0), None).unwrap();
    let air = framing::settle(&scene, with(0.0), None).unwrap();
    let cut = match wrapped.scene.classification.range {
        occlux::classify::ValueRange::Window(w) => w.cut,
        other => panic!("{other:?}"),
    };
    let top = volume.value_range().1 * 10.0;
    assert_eq!(cut, Some(top));
    let (a, b) = (
        render(&wrapped.scene, &wrapped.volume),
        render(&air.scene, &air.volume),
    );
    // Only pixels along the cylinder's wall may differ: there the fill interpolates with the
    // data above the cut (clear) where air interpolates through the ramp.
    let differing = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .filter(|(p, q)| (p[3] - q[3]).abs() > 0.05)
        .count() as f64
        / a.rgba.len() as f64;
    assert!(differing < 0.03, "{differing} of the pixels differ");
    assert!(share_above(&a, 0.95) < 0.5);
}

/// Framing for both projections and several directions and image shapes: every corner of the
/// content box projects inside the frame less its margin, and at least one touches it.
#[test]
fn a_framed_camera_fits_the_content_box_within_its_margin() {
    let path = scivis_dir().join("tooth.nrrd");
    let volume = fitted(&volume::load(&path, &LoadOptions::default()).unwrap());
    for (projection, size) in [
        ("", "width = 64\nheight = 48"),
        ("projection = \"orthographic\"", "width = 40\nheight = 64"),
        ("fov_deg = 20", "width = 64\nheight = 64"),
    ] {
        for direction in ["[1, -1, 0.8]", "[0, 0, 1]", "[-2, 0.5, -0.3]"] {
            let text = format!(
                "[volume]\npath = {path:?}\nfit = \"auto\"\ncentre = \"content\"\n\
                 [classification]\npreset = \"ct-soft-tissue\"\n[camera]\n{projection}\n{size}\n\
                 direction = {direction}\nmargin = 0.1\nup = [0, 1, 0.01]\n[[lights]]\n\
                 type = \"ambient\"\nradiance = 1\n"
            );
            let scene = Scene::parse(&text, Path::new(".")).unwrap();
            let loaded = framing::settle(&scene, volume.clone(), None).unwrap();
            let c = content(&loaded.volume, &loaded.scene.classification).unwrap();
            // centre = "content" put the content's centre at the origin.
            assert!((0.5 * (c.lo + c.hi)).length() < 1e-3, "{c:?}");
            let camera = loaded.scene.camera;
            let (fx, fy) = camera.half_extent();
            let mut largest: f32 = 0.0;
            for n in 0..8 {
                let pick = |bit: usize, a: f32, b: f32| if n & bit == 0 { a } else { b };
                let p = Vec3::new(
                    pick(1, c.lo.x, c.hi.x),
                    pick(2, c.lo.y, c.hi.y),
                    pick(4, c.lo.z, c.hi.z),
                );
                let q = p - camera.position;
                let depth = q.dot(camera.forward);
                let (x, y) = if camera.is_perspective() {
                    assert!(depth > 0.0);
                    (q.dot(camera.right) / depth, q.dot(camera.up) / depth)
                } else {
                    (q.dot(camera.right), q.dot(camera.up))
                };
                let used = (x.abs() / fx).max(y.abs() / fy);
                largest = largest.max(used);
            }
            assert!(
                (largest - 0.9).abs() < 1e-3,
                "{projection} {direction}: the box reaches {largest} of the half frame"
            );
        }
    }
}

/// A volume in physical units far from the presets' 2 world units gets a notice naming the
/// fit or density_scale that shows it; `fit = "auto"` silences it.
#[test]
fn a_volume_too_small_or_too_large_for_its_extinction_gets_a_notice() {
    let path = scivis_dir().join("tooth.nrrd");
    let raw = volume::load(&path, &LoadOptions::default()).unwrap();
    let scaled = |s: f32| {
        Volume::new(
            raw.dims(),
            raw.spacing() * s,
            raw.origin() * s,
            raw.values().to_vec(),
        )
        .unwrap()
    };
    let text = |fit: &str| {
        format!(
            "[volume]\npath = {path:?}\n{fit}\n[classification]\npreset = \"ct-soft-tissue\"\n\
             [camera]\nwidth = 32\nheight = 32\n[[lights]]\ntype = \"ambient\"\nradiance = 1\n"
        )
    };
    let plain = Scene::parse(&text(""), Path::new(".")).unwrap();
    // A 2 cm specimen in metres: 0.02 units across.
    let small = framing::settle(&plain, scaled(0.02 / 161.0), None).unwrap();
    let notice = small
        .notices
        .iter()
        .find(|n| n.starts_with("notice:"))
        .expect("a notice");
    assert!(
        notice.contains("nearly transparent") && notice.contains("fit = \"auto\""),
        "{notice}"
    );
    // The same in micrometres: each voxel opaque.
    let large = framing::settle(&plain, scaled(20_000.0 / 161.0), None).unwrap();
    let notice = large
        .notices
        .iter()
        .find(|n| n.starts_with("notice:"))
        .expect("a notice");
    assert!(notice.contains("each voxel opaque"), "{notice}");
    // The suggested density_scale is what fit = "auto" amounts to: the same image.
    let scale: f32 = notice
        .split("density_scale = ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    let mut suggested = large.scene.clone();
    suggested.classification.density_scale = scale;
    let auto = Scene::parse(&text("fit = \"auto\""), Path::new(".")).unwrap();
    let auto = framing::settle(&auto, fitted(&raw), None).unwrap();
    assert!(
        !auto.notices.iter().any(|n| n.starts_with("notice:")),
        "{:?}",
        auto.notices
    );
    let a = share_above(&render(&suggested, &large.volume), 0.05);
    let b = share_above(&render(&auto.scene, &auto.volume), 0.05);
    assert!((a - b).abs() < 0.01, "{a} vs {b}");
}

/// An example of examples/ as `occlux render` loads it (framed, window resolved), with its
/// method's lines replaced by `method` when given, at a test's image size: a square image's
/// framing does not depend on its size.
fn example(name: &str, method: Option<(&str, &str)>) -> (Scene, Volume) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
    if let Some((lines, replacement)) = method {
        assert!(text.contains(lines), "{name}: {lines}");
        text = text.replace(lines, replacement);
    }
    let loaded = Scene::parse(&text, &dir).unwrap().load().unwrap();
    let mut scene = loaded.scene;
    (scene.camera.width, scene.camera.height) = (96, 96);
    (scene, loaded.volume)
}

/// Luminance summed over an image, the background's included (it is the same in both images
/// compared, so differences are the volume's).
fn light(image: &RenderImage) -> f64 {
    image
        .rgba
        .iter()
        .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum()
}

#[test]
fn the_bonsai_examples_show_what_each_method_is_for() {
    // Ambient occlusion under a sky: the same scene with gradient shading is the unoccluded
    // sky, so AO can only darken it, pixel by pixel, and on this scene it must darken the
    // content by a fifth at least (with the sky drowned by a sun, as the old examples had it,
    // the two differed by a few percent).
    let ao = (
        "method = \"ao\"\nao_method = \"ordinates\"",
        "method = \"gradient\"",
    );
    let (scene, volume) = example("bonsai-ao", None);
    let occluded = render(&scene, &volume);
    let (scene, volume) = example("bonsai-ao", Some(ao));
    let open = render(&scene, &volume);
    for (o, u) in occluded.rgba.iter().zip(&open.rgba) {
        assert!((o[3] - u[3]).abs() < 1e-5, "{o:?} {u:?}");
        for c in 0..3 {
            assert!(o[c] <= u[c] * (1.0 + 1e-4) + 1e-6, "{o:?} {u:?}");
        }
    }
    let ratio = light(&occluded) / light(&open);
    assert!(ratio < 0.8, "AO keeps {ratio} of the sky's light");

    // Directional occlusion under the same sky darkens it as much, and by varying amounts
    // across the content (a uniform factor would show no structure).
    let dos_lines = ("method = \"dos\"\ntheta_deg = 60", "method = \"gradient\"");
    let (scene, volume) = example("bonsai-dos", None);
    let dos = render(&scene, &volume);
    let (scene, volume) = example("bonsai-dos", Some(dos_lines));
    let open = render(&scene, &volume);
    let ratio = light(&dos) / light(&open);
    // The occlusion of what each pixel shows: the layer's P / A.
    let mut visible: Vec<f32> = dos
        .factor("occlusion")
        .unwrap()
        .unpremultiplied()
        .into_iter()
        .zip(&dos.rgba)
        .filter(|(_, p)| p[3] > 0.5)
        .map(|(f, _)| f)
        .collect();
    visible.sort_by(f32::total_cmp);
    let spread = visible[visible.len() * 9 / 10] - visible[visible.len() / 10];
    assert!(ratio < 0.8, "DOS keeps {ratio} of the sky's light");
    assert!(
        spread > 0.2,
        "DOS's occlusion spans {spread} between its deciles"
    );

    // The key light's shadows: of the visible content, a good share lies in shadow and a good
    // share in light (a sun along the view would light it all, one behind it shadow it all).
    let (scene, volume) = example("bonsai-sun", None);
    let lit = render(&scene, &volume);
    let shadow = lit.factor("shadow").unwrap().unpremultiplied();
    let visible: Vec<f32> = shadow
        .into_iter()
        .zip(&lit.rgba)
        .filter(|(_, p)| p[3] > 0.5)
        .map(|(f, _)| f)
        .collect();
    let dark = visible.iter().filter(|&&f| f < 0.5).count() as f64 / visible.len() as f64;
    assert!(
        (0.15..0.85).contains(&dark),
        "{dark} of the content in shadow"
    );
}

/// Finite values near the f32 limit: the table over the full range would span more than an
/// f32 holds and classify every voxel as clear (issue 38: an empty image, no word). The full
/// range and raw units are refused by name; the robust window is that of the other voxels.
#[test]
fn a_value_range_wider_than_f32_is_refused_where_the_table_would_span_it() {
    // A slab of 2s in 1s, and one voxel at each extreme.
    let mut values = vec![1.0f32; 16 * 16 * 16];
    values[0] = -3e38;
    values[1] = 3e38;
    for v in &mut values[16 * 16 * 6..16 * 16 * 10] {
        *v = 2.0;
    }
    let volume = Volume::new([16; 3], Vec3::splat(0.125), Vec3::splat(-0.9375), values).unwrap();
    let scene = |classification: &str| {
        Scene::parse(
            &format!(
                "[volume]\nphantom = \"sphere\"\nsize = 8\n[classification]\n{classification}\n\
                 [camera]\nposition = [0, -4, 0]\nwidth = 8\nheight = 8\n"
            ),
            Path::new("."),
        )
        .unwrap()
    };
    for classification in [
        "range = \"full\"",
        "units = \"raw\"\npoints = [{ value = 1, sigma_t = 0 }, { value = 2, sigma_t = 5 }]",
    ] {
        let err = framing::settle(&scene(classification), volume.clone(), None)
            .err()
            .unwrap_or_else(|| panic!("{classification}: settled"))
            .to_string();
        assert!(
            err.contains("classification.range") && err.contains("3e38"),
            "{err}"
        );
    }
    // The robust window leaves the two extremes out (its quantiles, interpolated in f64, no
    // longer overflow to an infinite top).
    let robust = framing::settle(&scene(""), volume, None).unwrap();
    match robust.scene.classification.range {
        occlux::classify::ValueRange::Window(w) => assert_eq!((w.lo, w.hi), (1.0, 2.0)),
        other => panic!("{other:?}"),
    }
}

/// Issue 38: a camera looking away, or a volume fitted to 1e-30 units, rendered a blank image
/// with no word, and `step = 1e9` rendered one sample per ray; now a notice names the view, and
/// the step is refused.
#[test]
fn a_view_that_misses_the_volume_is_noticed_and_a_step_past_it_refused() {
    let scene = |extra: &str, camera: &str| {
        Scene::parse(
            &format!(
                "[volume]\nphantom = \"sphere\"\nsize = 8\n{extra}\n[camera]\n{camera}\n\
                 width = 16\nheight = 16\n"
            ),
            Path::new("."),
        )
        .unwrap()
    };
    let towards = "position = [0, -4, 0]\ntarget = [0, 0, 0]";
    let missed = |loaded: &occlux::scene::Loaded| {
        loaded
            .notices
            .iter()
            .any(|n| n.contains("no pixel sees the volume"))
    };
    assert!(!missed(&scene("", towards).load().unwrap()));
    let away = scene("", "position = [0, -4, 0]\ntarget = [0, -8, 0]");
    assert!(missed(&away.load().unwrap()));
    let tiny = scene("fit = 1e-30", towards);
    assert!(missed(&tiny.load().unwrap()));
    let err = scene("[render]\nmethod = \"unshaded\"\nstep = 1e9", towards)
        .load()
        .err()
        .expect("refused")
        .to_string();
    assert!(
        err.contains("render.step") && err.contains("diagonal"),
        "{err}"
    );
    assert!(
        scene("[render]\nmethod = \"unshaded\"\nstep = 0.5", towards)
            .load()
            .is_ok()
    );
}
