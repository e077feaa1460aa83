//! The same input gives the same bytes on the CPU whatever the number of threads: every
//! registered method at each of its chart settings (and every ambient-occlusion method inside
//! `method = "ao"`), and every Monte Carlo estimator, rendered in rayon pools of one, two and
//! three threads. Work is split by rows, lines, teams and per-pixel random streams, never by
//! the thread count, and sums are taken in a fixed order; this holds it to the bit.

use occlux::gpu::Compute;
use occlux::method::{MethodSpec, ParamKind};
use occlux::progress::NoProgress;
use occlux::registry::{find, METHODS};
use occlux::render::reference::{self, Estimator, ReferenceInput, ReferenceParams};
use occlux::render::{MethodInput, Rendered};
use occlux::scene::{Method, Scene};
use occlux::volume::Volume;
use std::path::Path;

/// The CT phantom (24^3) under an ambient light, a sun and a lamp, seen at 20 x 20 pixels.
fn scene() -> Scene {
    Scene::parse(
        "[volume]\nphantom = \"ct\"\nsize = 24\nfit = 2.0\ncentre = [0, 0, 0]\n\n\
         [classification]\npreset = \"ct-bone\"\n\n\
         [camera]\nposition = [2.4, -2.6, 1.4]\ntarget = [0, 0, 0]\nfov_deg = 40\nwidth = 20\n\
         height = 20\n\n\
         [[lights]]\ntype = \"ambient\"\nradiance = 0.6\n\n\
         [[lights]]\ntype = \"directional\"\ndirection = [-0.3, -1.0, 1.2]\nirradiance = 3.0\n\n\
         [[lights]]\ntype = \"point\"\nposition = [-1.5, -2.5, 2.0]\nintensity = 30.0\n",
        Path::new("."),
    )
    .unwrap()
}

/// Runs `work` in a pool of `threads` threads.
fn with_threads<T: Send>(threads: usize, work: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(work)
}

/// Every float a render produced, as bits, in a fixed order: image, depth, factor, grids.
fn bits(rendered: &Rendered) -> Vec<u32> {
    let image = &rendered.image;
    image
        .rgba
        .iter()
        .flatten()
        .chain(&image.depth)
        .chain(image.factor.iter().flat_map(|f| f.values.as_flattened()))
        .chain(rendered.grids.iter().flat_map(|g| g.volume.values()))
        .map(|v| v.to_bits())
        .collect()
}

fn render(scene: &Scene, spec: &MethodSpec, method: &Method, volume: &Volume) -> Rendered {
    let lut = scene.classification.bake(volume);
    method
        .render(&MethodInput {
            volume,
            classification: &scene.classification,
            lut: &lut,
            camera: &scene.camera,
            lighting: &spec.lights_of(&scene.lighting),
            compute: &Compute::Cpu,
            progress: &NoProgress,
        })
        .unwrap()
}

/// Each registered method at its chart settings, and `ao` with every `ao_method` choice.
fn methods() -> Vec<(String, &'static MethodSpec, Method)> {
    let mut methods = vec![];
    for spec in METHODS {
        for setting in spec.chart {
            methods.push((
                format!("{} [{setting}]", spec.name),
                *spec,
                spec.at_setting(setting).unwrap(),
            ));
        }
    }
    let ao = find("ao").unwrap();
    let choices = ao
        .params
        .iter()
        .find(|p| p.key == "ao_method")
        .map(|p| match p.kind {
            ParamKind::Choice { options } => options.iter().map(|c| c.name).collect(),
            _ => vec![],
        })
        .unwrap();
    for choice in choices {
        let setting = format!("ao_method = \"{choice}\"");
        methods.push((
            format!("ao [{setting}]"),
            ao,
            ao.at_setting(&setting).unwrap(),
        ));
    }
    methods
}

#[test]
fn every_method_gives_the_same_bytes_on_one_two_and_three_threads() {
    let scene = scene();
    let volume = scene.load_volume().unwrap();
    let mut differing = vec![];
    for (name, spec, method) in methods() {
        let one = with_threads(1, || bits(&render(&scene, spec, &method, &volume)));
        assert!(!one.is_empty(), "{name}: nothing rendered");
        for threads in [2, 3] {
            let many = with_threads(threads, || bits(&render(&scene, spec, &method, &volume)));
            let differ = one.iter().zip(&many).filter(|(a, b)| a != b).count();
            if differ > 0 || one.len() != many.len() {
                differing.push(format!(
                    "{name} on {threads} threads: {differ} values differ"
                ));
            }
        }
        println!("{name}: {} values the same", one.len());
    }
    assert!(differing.is_empty(), "{differing:#?}");
}

#[test]
fn every_monte_carlo_estimator_gives_the_same_bytes_on_one_two_and_three_threads() {
    let scene = scene();
    let volume = scene.load_volume().unwrap();
    let lut = scene.classification.bake(&volume);
    for estimator in [
        Estimator::Ambient,
        Estimator::Cone { aperture: 0.5 },
        Estimator::Single,
        Estimator::Multiple { bounces: 3 },
    ] {
        let params = ReferenceParams {
            estimator,
            spp: 4,
            seed: 5,
            g: 0.3,
        };
        let input = ReferenceInput {
            volume: &volume,
            lut: &lut,
            camera: &scene.camera,
            lighting: &scene.lighting,
            params: &params,
        };
        let run = |threads| {
            with_threads(threads, || {
                let image = reference::render(&input, &NoProgress).unwrap();
                image
                    .mean
                    .iter()
                    .flatten()
                    .chain(image.stderr.iter().flatten())
                    .map(|v| v.to_bits())
                    .collect::<Vec<u32>>()
            })
        };
        let one = run(1);
        for threads in [2, 3] {
            assert_eq!(one, run(threads), "{estimator:?} on {threads} threads");
        }
    }
}
