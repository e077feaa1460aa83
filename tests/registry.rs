//! The method registry is what the methods are: each entry's parameters are exactly its serde
//! struct's fields, its ranges are enforced with errors naming `render.KEY`, its choices parse,
//! its shaders exist, and what it says reaches the EXR header and `occlux methods --json`.

use occlux::export::exr::read_exr;
use occlux::gpu::Compute;
use occlux::method::{MethodSpec, ParamKind};
use occlux::pipeline::{self, OutputOptions, Settled};
use occlux::progress::NoProgress;
use occlux::registry::{self, Method, METHODS};
use occlux::scene::Scene;
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn table(method: &str, extra: Value) -> Map<String, Value> {
    let mut table = Map::new();
    table.insert("method".into(), json!(method));
    if let Value::Object(extra) = extra {
        table.extend(extra);
    }
    table
}

fn parse(method: &str, extra: Value) -> occlux::Result<Method> {
    Method::from_table(table(method, extra))
}

fn keys(spec: &MethodSpec) -> BTreeSet<String> {
    spec.params.iter().map(|p| p.key.to_owned()).collect()
}

#[test]
fn each_entry_lists_exactly_its_structs_fields() {
    let names: BTreeSet<&str> = METHODS.iter().map(|m| m.name).collect();
    assert_eq!(names.len(), METHODS.len(), "names are unique");
    for spec in METHODS {
        let method = parse(spec.name, json!({})).unwrap();
        assert_eq!(method.spec().name, spec.name);
        let Value::Object(mut fields) = method.to_json() else {
            panic!("{}: not an object", spec.name)
        };
        assert_eq!(fields.remove("method"), Some(json!(spec.name)));
        let fields: BTreeSet<String> = fields.keys().cloned().collect();
        assert_eq!(fields, keys(spec), "{}", spec.name);
        // The JSON form reads back as the same method (EXR headers are data).
        let back: Method = serde_json::from_value(method.to_json()).unwrap();
        assert_eq!(back, method);
    }
}

#[test]
fn every_choice_parses_and_is_written_back() {
    for spec in METHODS {
        for param in spec.params {
            let ParamKind::Choice { options } = &param.kind else {
                continue;
            };
            for option in *options {
                let mut table = companions(param.key);
                table[param.key] = json!(option.name);
                let method = parse(spec.name, table)
                    .unwrap_or_else(|e| panic!("{} {}={}: {e}", spec.name, param.key, option.name));
                assert_eq!(method.to_json()[param.key], json!(option.name));
            }
            let mut table = companions(param.key);
            table[param.key] = json!("no-such-option");
            let err = parse(spec.name, table).unwrap_err().to_string();
            assert!(err.contains(&format!("render.{}", param.key)), "{err}");
        }
    }
}

/// Parameters whose acceptance depends on another one: what must be set with them.
fn companions(key: &str) -> Value {
    match key {
        // VAO's keys (the default AO method, the discrete ordinates, computes the visibility).
        "variance_max" => json!({ "opacity_modulation": true, "ao_method": "cdf" }),
        "ao_radius" | "ao_field" | "ao_variance" | "opacity_modulation" | "ao_convention" => {
            json!({ "ao_method": "cdf" })
        }
        "ao_iso" | "ao_gamma" | "ao_alpha" | "ao_light" => json!({ "ao_method": "sweep" }),
        _ => json!({}),
    }
}

/// `key = value` (a whole number for integer parameters) with its companions.
fn with(key: &str, value: f64, is_int: bool) -> Value {
    let mut extra = companions(key);
    extra[key] = if is_int {
        json!(value as i64)
    } else {
        json!(value)
    };
    extra
}

#[test]
fn ranges_are_enforced_at_their_bounds_with_the_key_named() {
    let mut checked = 0;
    for spec in METHODS {
        for param in spec.params {
            let range = match &param.kind {
                ParamKind::Float { range, .. } | ParamKind::Int { range, .. } => range,
                _ => continue,
            };
            let is_int = matches!(param.kind, ParamKind::Int { .. });
            let step = if is_int { 1.0 } else { 1e-3 };
            let bounds = [
                (range.min, range.min_inclusive, -step),
                (range.max, range.max_inclusive, step),
            ];
            for (bound, inclusive, outward) in bounds {
                if !bound.is_finite() {
                    continue;
                }
                let at = parse(spec.name, with(param.key, bound, is_int));
                assert_eq!(
                    at.is_ok(),
                    inclusive,
                    "{} {} = {bound}: {at:?}",
                    spec.name,
                    param.key
                );
                let outside = parse(spec.name, with(param.key, bound + outward, is_int))
                    .unwrap_err()
                    .to_string();
                assert!(
                    outside.contains(&format!("render.{}", param.key)),
                    "{outside}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 10, "{checked} bounds checked");
}

#[test]
fn type_errors_and_foreign_keys_name_the_key() {
    for (method, extra, key) in [
        ("dos", json!({ "theta_deg": "wide" }), "render.theta_deg"),
        ("dos", json!({ "grid": 2.5 }), "render.grid"),
        (
            "dos",
            json!({ "clip_planes": [{ "point": [0, 0] }] }),
            "render.clip_planes",
        ),
        ("ao", json!({ "direct": "yes" }), "render.direct"),
        ("gradient", json!({ "ao_radius": 4 }), "render.ao_radius"),
        ("unshaded", json!({ "colour": 4 }), "render.colour"),
    ] {
        let err = parse(method, extra.clone()).unwrap_err().to_string();
        assert!(err.contains(key), "{method} {extra}: {err}");
    }
    let err = parse("gradient", json!({ "theta_deg": 30 }))
        .unwrap_err()
        .to_string();
    assert!(err.contains("only for method = \"dos\""), "{err}");
    let err = parse("magic", json!({})).unwrap_err().to_string();
    assert!(err.contains("render.method") && err.contains("unshaded, gradient, ao, dos"));
}

#[test]
fn each_method_names_shaders_that_exist_and_every_shader_belongs_to_one() {
    // A method's kernels lie beside the CPU and GPU twins that run them (src/render/dos/dos.wgsl,
    // src/ao/vao/vao_stats.wgsl); the helpers any kernel may include, in shaders/shared/.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let shared = root.join("shaders/shared");
    let mut on_disk: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut folders = vec![root.join("src"), shared.clone()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                let name = path.file_name().unwrap().to_string_lossy().into_owned();
                assert!(on_disk.insert(name.clone(), path).is_none(), "two {name}");
            }
        }
    }
    // What the registered methods use: their kernels and, transitively, their includes, each
    // found beside its includer or among the shared helpers.
    let mut used: BTreeSet<String> = BTreeSet::new();
    let mut todo: Vec<String> = METHODS
        .iter()
        .flat_map(|m| m.shaders.iter().map(|s| s.to_string()))
        .collect();
    while let Some(name) = todo.pop() {
        let path = on_disk
            .get(&name)
            .unwrap_or_else(|| panic!("{name} is nowhere"));
        if !used.insert(name.clone()) {
            continue;
        }
        let text = std::fs::read_to_string(path).unwrap();
        for include in text
            .lines()
            .filter_map(|l| l.trim().strip_prefix("//#include"))
            .map(|rest| rest.trim().trim_matches('"').to_owned())
        {
            let found = &on_disk[&include];
            assert!(
                found.parent() == path.parent() || found.parent() == Some(shared.as_path()),
                "{name} includes {include}, neither beside it nor shared"
            );
            todo.push(include);
        }
        // A kernel (a file with an entry point) lies beside the CPU and GPU twins that run it.
        let folder = path.parent().unwrap();
        if text.contains("@compute") {
            assert!(
                folder.join("cpu.rs").is_file() && folder.join("gpu.rs").is_file(),
                "{name}: no cpu.rs and gpu.rs beside it in {}",
                folder.display()
            );
        }
    }
    let strays: Vec<&String> = on_disk.keys().filter(|n| !used.contains(*n)).collect();
    assert!(strays.is_empty(), "shaders no method uses: {strays:?}");
}

#[test]
fn dos_takes_only_the_lights_its_entry_lists() {
    let spec = registry::find("dos").unwrap();
    let text = r#"
[volume]
phantom = "sphere"
size = 8
[camera]
position = [0, -4, 0]
width = 4
height = 4
[[lights]]
type = "ambient"
radiance = 1
[[lights]]
type = "directional"
direction = [0, 0, 1]
irradiance = 1
[render]
method = "gradient"
"#;
    // The scene is refused as it is read...
    let dos = text.replace("\"gradient\"", "\"dos\"");
    let err = Scene::parse(&dos, Path::new(".")).unwrap_err().to_string();
    assert!(
        err.contains("lights[1]") && err.contains("ambient"),
        "{err}"
    );
    // ...and a scene whose method is changed afterwards, when it renders.
    let mut scene = Scene::parse(text, Path::new(".")).unwrap();
    let direct = spec.check_lights(&scene.lighting).unwrap_err().to_string();
    assert!(err.contains(&direct), "{err} / {direct}");
    scene.method = Method::Dos(Default::default());
    let volume = scene.load_volume().unwrap();
    let render = pipeline::render(&Settled::named(&scene), &volume, &Compute::Cpu, &NoProgress);
    assert_eq!(render.err().map(|e| e.to_string()), Some(direct));
}

#[test]
fn the_exr_header_carries_the_method_lights_and_camera_as_json() {
    let text = r#"
background = [0.1, 0.2, 0.3]
[volume]
phantom = "sphere"
size = 8
[camera]
position = [0, -4, 0]
width = 6
height = 4
[[lights]]
type = "ambient"
radiance = [1.0, 0.9, 0.8]
[render]
method = "dos"
theta_deg = 30
grid = 3
distance = "approximate"
"#;
    let scene = Scene::parse(text, Path::new(".")).unwrap();
    let volume = scene.load_volume().unwrap();
    let rendered =
        pipeline::render(&Settled::named(&scene), &volume, &Compute::Cpu, &NoProgress).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let written = pipeline::write_render(
        &rendered.image,
        &Settled::named(&scene),
        dir.path(),
        "s",
        &OutputOptions::default(),
    )
    .unwrap();
    let exr = read_exr(&written[0]).unwrap();
    let header = |key: &str| -> Value { serde_json::from_str(&exr.metadata[key]).unwrap() };
    let method: Method = serde_json::from_value(header("occlux/method")).unwrap();
    assert_eq!(method, scene.method);
    assert_eq!(header("occlux/method")["theta_deg"], json!(30.0));
    let lighting = header("occlux/lighting");
    assert_eq!(
        lighting["lights"],
        json!([{ "type": "ambient", "radiance": [1.0, 0.9, 0.8] }])
    );
    assert_eq!(lighting["background"], json!([0.1, 0.2, 0.3]));
    let camera = header("occlux/camera");
    assert_eq!(camera["width"], json!(6));
    assert_eq!(camera["projection"]["type"], json!("perspective"));
    let fov = camera["projection"]["fov_y"].as_f64().unwrap();
    assert!((fov - 40f64.to_radians()).abs() < 1e-6, "{fov}");
}
